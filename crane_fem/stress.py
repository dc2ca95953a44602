"""Von Mises stress of a displacement field, cell by cell (linear elasticity; P1 strains are
constant in a tetrahedron), and its peak over a group of cells."""

from __future__ import annotations

import dolfinx
import numpy as np
import numpy.typing as npt
import ufl
from mpi4py import MPI

__all__ = ["VonMises"]

FloatArray = npt.NDArray[np.float64]


class VonMises:
    """σ_vm = √(3/2 s:s) of the displacement ``u`` on ``V`` (a vector P1 space), in DG0.

    Collective over the mesh communicator (:meth:`evaluate` scatters the ghosts).
    """

    def __init__(
        self,
        V: dolfinx.fem.FunctionSpace,
        E: float | dolfinx.fem.Function,
        nu: float | dolfinx.fem.Function,
    ) -> None:
        mu = E / (2.0 * (1.0 + nu))
        lmbda = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))
        self.u = dolfinx.fem.Function(V, name="displacement")
        eps = ufl.sym(ufl.grad(self.u))
        sigma = 2.0 * mu * eps + lmbda * ufl.tr(eps) * ufl.Identity(len(self.u))
        dev = sigma - ufl.tr(sigma) / 3.0 * ufl.Identity(len(self.u))
        W = dolfinx.fem.functionspace(V.mesh, ("DG", 0))
        self.field = dolfinx.fem.Function(W, name="von_mises")
        self._expr = dolfinx.fem.Expression(
            ufl.sqrt(1.5 * ufl.inner(dev, dev)), W.element.interpolation_points
        )
        self._n = V.dofmap.index_map.size_local * V.dofmap.index_map_bs
        self.n_cells = V.mesh.topology.index_map(V.mesh.topology.dim).size_local

    def evaluate(self, u: FloatArray | None = None) -> FloatArray:
        """σ_vm (Pa) of the owned cells, for the owned-DOF displacement ``u`` (or the one
        already in ``self.u``) (collective)."""
        if u is not None:
            self.u.x.array[: self._n] = u
            self.u.x.scatter_forward()
        self.field.interpolate(self._expr)
        return np.asarray(self.field.x.array[: self.n_cells])

    def peak(self, u: FloatArray, cells: npt.NDArray[np.int32], comm: MPI.Comm) -> float:
        """The largest σ_vm over the owned ``cells`` of all ranks (collective)."""
        local = float(np.max(self.evaluate(u)[cells], initial=0.0))
        return float(comm.allreduce(local, op=MPI.MAX))

    def peak_at(
        self, u: FloatArray, cells: npt.NDArray[np.int32], comm: MPI.Comm
    ) -> tuple[float, FloatArray]:
        """The largest σ_vm over the owned ``cells`` of all ranks and the centre of its cell
        (m; the lowest rank's on a tie) (collective)."""
        labels = np.zeros(cells.size, dtype=np.int64)
        values, where = self.peaks_by(u, cells, labels, 1, comm)
        return float(values[0]), where[0]

    def peaks_by(
        self,
        u: FloatArray,
        cells: npt.NDArray[np.int32],
        labels: npt.NDArray[np.int64],
        n_labels: int,
        comm: MPI.Comm,
    ) -> tuple[FloatArray, FloatArray]:
        """Per label 0..``n_labels`` − 1 of the owned ``cells``, the largest σ_vm of all ranks
        and the centre of its cell ((n_labels,), (n_labels, 3); the lowest rank's on a tie;
        0 and the origin for a label without cells) (collective: one evaluation, one
        gather)."""
        vm = self.evaluate(u)[cells]
        local = np.zeros(n_labels)
        where = np.zeros((n_labels, 3))
        mesh = self.field.function_space.mesh
        for k in range(n_labels):
            sel = np.flatnonzero(labels == k)
            if sel.size == 0:
                continue
            j = sel[int(np.argmax(vm[sel]))]
            local[k] = vm[j]
            mid = dolfinx.mesh.compute_midpoints(mesh, mesh.topology.dim, cells[j : j + 1])
            where[k, : mid.shape[1]] = mid[0]
        gathered = comm.allgather((local, where))
        values = np.zeros(n_labels)
        at = np.zeros((n_labels, 3))
        for k in range(n_labels):
            # The largest value, the lowest rank on a tie (ranks in order: strict >).
            for vals, wh in gathered:
                if vals[k] > values[k]:
                    values[k], at[k] = vals[k], wh[k]
        return values, at
