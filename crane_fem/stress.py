"""Peaks of a per-cell stress field: the largest value over groups of cells, and where.

A formulation's stress recovery (crane_fem.formulations: the solid's von Mises stress of its
strains, a beam's von Mises stress at the extreme fibres of its sections) derives from
:class:`CellStress` and gives :meth:`CellStress.evaluate`; the peaks are the same for all."""

from __future__ import annotations

import dolfinx
import numpy as np
import numpy.typing as npt
from mpi4py import MPI

__all__ = ["CellStress"]

FloatArray = npt.NDArray[np.float64]


class CellStress:
    """One stress value per owned cell of a mesh (Pa) and its peaks over cells.

    Subclasses set ``mesh`` and ``n_cells`` and implement :meth:`evaluate`.
    """

    mesh: dolfinx.mesh.Mesh
    n_cells: int

    def evaluate(self, u: FloatArray | None = None) -> FloatArray:
        """The stress of the owned cells for the owned-DOF displacement ``u`` (or the one
        already set) (collective)."""
        raise NotImplementedError

    def peak(self, u: FloatArray, cells: npt.NDArray[np.int32], comm: MPI.Comm) -> float:
        """The largest value over the owned ``cells`` of all ranks (collective)."""
        local = float(np.max(self.evaluate(u)[cells], initial=0.0))
        return float(comm.allreduce(local, op=MPI.MAX))

    def peak_at(
        self, u: FloatArray, cells: npt.NDArray[np.int32], comm: MPI.Comm
    ) -> tuple[float, FloatArray]:
        """The largest value over the owned ``cells`` of all ranks and the centre of its cell
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
        """Per label 0..``n_labels`` − 1 of the owned ``cells``, the largest value of all
        ranks and the centre of its cell ((n_labels,), (n_labels, 3); the lowest rank's on a
        tie; 0 and the origin for a label without cells) (collective: one evaluation, one
        gather)."""
        vm = self.evaluate(u)[cells]
        local = np.zeros(n_labels)
        where = np.zeros((n_labels, 3))
        # Each label's cells in their order (a stable sort), its first largest value.
        order = np.argsort(labels, kind="stable")
        bounds = np.searchsorted(labels[order], np.arange(n_labels + 1)).tolist()
        ks, js = [], []
        for k in range(n_labels):
            a, b = bounds[k], bounds[k + 1]
            if a < b:
                ks.append(k)
                js.append(order[a + int(np.argmax(vm[order[a:b]]))])
        if ks:
            local[ks] = vm[js]
            mesh = self.mesh
            mid = dolfinx.mesh.compute_midpoints(mesh, mesh.topology.dim, cells[js])
            where[ks, : mid.shape[1]] = mid
        gathered = comm.allgather((local, where)) if comm.size > 1 else [(local, where)]
        values = np.zeros(n_labels)
        at = np.zeros((n_labels, 3))
        # The largest value, the lowest rank on a tie (ranks in order: strict >).
        for vals, wh in gathered:
            better = vals > values
            values[better], at[better] = vals[better], wh[better]
        return values, at
