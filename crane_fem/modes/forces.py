"""Forces of a displacement of the closed structure: each support face's reaction (and, for
beams, its moment) and each wheel's normal contact force, and the static solve that gives the
displacements."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from mpi4py import MPI
from petsc4py import PETSc
from scipy.spatial import cKDTree

from crane_fem.errors import CraneFemError
from crane_fem.modes.operators import ClosedStructure
from crane_fem.reactions import face_labels

__all__ = ["ForceRecovery", "Forces", "StiffnessSolver"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


@dataclass(frozen=True, eq=False)
class Forces:
    """Forces of ``m`` displacement fields (global, identical on every rank).

    Attributes:
        support: (m, faces, 3) force of each support face on the structure, N (faces
            numbered as the runs' ``supports``: a gmsh model's or a frame's ``[[support]]``
            entries in order, else by y, then x, of their points).
        wheel: (m, wheels) normal contact force of each wheel, the sum over its pairs of
            k_p (u_rail − u_wheel)·e_z, N (positive in compression); (m, 0) without pairs.
        moment: (m, faces, 3) moment of each support face on the structure about the face's
            centre, N·m: its nodes' moments (a beam's rotational reactions) plus the arms'
            moments of their forces; (m, faces, 0) for a structure without rotational DOFs.
    """

    support: FloatArray
    wheel: FloatArray
    moment: FloatArray


class ForceRecovery:
    """Maps displacements of the free DOFs to :class:`Forces` (collective; built once).

    The face reaction is K_cf u_f (the rows of the unconstrained stiffness at the clamped
    DOFs; the clamped DOFs do not move), the force that keeps the face at rest against the
    elastic forces; with a body load f the static reaction is K_cf u_f − f_c. The face's force
    sums its translation DOFs' rows (a pinned beam node has only those); a beam's face moment
    sums its rotation DOFs' rows and the moments of its nodes' forces about its centre.
    """

    def __init__(self, st: ClosedStructure) -> None:
        self.st = st
        comm = st.comm
        bs, n_t = st.bs, st.translations
        xyz = st.V.tabulate_dof_coordinates()
        block = st.clamped // bs
        self._comp = st.clamped % bs
        self._trans = self._comp < n_t
        if st.faces:  # a gmsh model's or frame's [[support]] groups (a vertex in two: the first)
            vertex = st.block_vertex[block]
            labels = np.full(vertex.size, len(st.faces), dtype=np.int64)
            for k in reversed(range(len(st.faces))):
                labels[np.isin(vertex, st.faces[k])] = k
            # A P2 edge DOF (no vertex) takes the face of the nearest clamped vertex.
            pos = xyz[block]
            known = labels < len(st.faces)
            got = comm.allgather((pos[known], labels[known]))
            ref_xyz = np.concatenate([g[0] for g in got])
            ref_lab = np.concatenate([g[1] for g in got])
            if np.any(~known) and ref_lab.size:
                _, near = cKDTree(ref_xyz).query(pos[~known])
                labels[~known] = ref_lab[near]
            # The centre of a face's nodes, each counted once per translation DOF (clamped
            # and pinned nodes alike).
            t = self._trans
            sums = np.zeros((len(st.faces), 4))
            np.add.at(sums[:, :3], labels[t], xyz[block[t]])
            np.add.at(sums[:, 3], labels[t], 1.0)
            sums = comm.allreduce(sums, op=MPI.SUM)
            self.centres = sums[:, :3] / np.maximum(sums[:, 3:], 1.0)
        else:
            labels, self.centres = face_labels(xyz[block], comm)
        self.labels = labels
        self.n_faces = int(self.centres.shape[0])
        self.n_wheels = int(st.wheel.max(initial=0))
        #: Whether the faces have moments (a beam's rotational DOFs: θx, θy, θz).
        self.has_moments = bs > n_t
        self._arm = xyz[block] - self.centres[labels] if self.has_moments else np.zeros((0, 3))
        # Position, in the owned free DOFs, of the z DOF of each pair's wheel and rail vertex
        # that this rank owns (a clamped vertex has none: it does not move).
        z_pos = np.flatnonzero(st.free % bs == 2)
        z_vertex = st.block_vertex[st.free[z_pos] // bs]
        position = dict(zip(z_vertex.tolist(), z_pos.tolist(), strict=True))
        self._ends: list[tuple[IntArray, IntArray]] = []
        for side in (0, 1):
            at = np.array([position.get(v, -1) for v in st.pairs[:, side].tolist()], np.int64)
            which = np.flatnonzero(at >= 0)
            self._ends.append((at[which], which.astype(np.int64)))
        self._x = st.K_cf.createVecRight()
        self._r = st.K_cf.createVecLeft()

    def __call__(self, U: FloatArray, body: FloatArray | None = None) -> Forces:
        """The forces of the owned free-DOF displacements ``U`` (m, owned free DOFs), with
        ``body`` (owned clamped DOFs, N) the body load at the clamped DOFs, subtracted from
        every reaction (collective)."""
        st = self.st
        U = np.atleast_2d(U)
        m = U.shape[0]
        local = np.zeros((m, self.n_faces, 3))
        moment = np.zeros((m, self.n_faces, 3 if self.has_moments else 0))
        t, comp, labels = self._trans, self._comp, self.labels
        for k in range(m):
            self._x.array[:] = U[k]
            st.K_cf.mult(self._x, self._r)
            r = np.array(self._r.array_r, dtype=np.float64)
            if body is not None:
                r -= body
            np.add.at(local[k], (labels[t], comp[t]), r[t])
            if self.has_moments:
                force = np.zeros((int(t.sum()), 3))
                force[np.arange(force.shape[0]), comp[t]] = r[t]
                np.add.at(moment[k], labels[t], np.cross(self._arm[t], force))
                rot = ~t
                np.add.at(moment[k], (labels[rot], comp[rot] - st.translations), r[rot])
        support = np.asarray(st.comm.allreduce(local, op=MPI.SUM), dtype=np.float64)
        moment = np.asarray(st.comm.allreduce(moment, op=MPI.SUM), dtype=np.float64)
        p = st.pairs.shape[0]
        uz = np.zeros((2, m, p))
        for side, (pos, which) in enumerate(self._ends):
            uz[side][:, which] = U[:, pos]
        uz = np.asarray(st.comm.allreduce(uz, op=MPI.SUM), dtype=np.float64)
        pair_force = st.k_p * (uz[1] - uz[0])  # compressive on the wheel
        wheel = np.zeros((m, self.n_wheels))
        for w in range(self.n_wheels):
            wheel[:, w] = pair_force[:, st.wheel == w + 1].sum(axis=1)
        return Forces(support, wheel, moment)

    def destroy(self) -> None:
        """Destroy the work vectors (collective)."""
        self._x.destroy()
        self._r.destroy()


class StiffnessSolver:
    """K_ff u = f by one MUMPS factorisation, reused (collective; options prefix
    ``crane_fem_modes_static_``). Owns its KSP: :meth:`destroy`."""

    def __init__(self, st: ClosedStructure) -> None:
        self.comm = st.comm
        self.ksp = PETSc.KSP().create(st.K.getComm())
        self.ksp.setOptionsPrefix("crane_fem_modes_static_")
        self.ksp.setOperators(st.K)
        self.ksp.setType(PETSc.KSP.Type.PREONLY)
        pc = self.ksp.getPC()
        pc.setType(PETSc.PC.Type.LU)
        pc.setFactorSolverType("mumps")
        self.ksp.setFromOptions()
        self._b = st.K.createVecLeft()
        self._x = st.K.createVecRight()

    def solve(self, f: FloatArray) -> FloatArray:
        """u (owned free DOFs, m) for the load ``f`` (owned free DOFs, N) (collective)."""
        self._b.array[:] = f
        self.ksp.solve(self._b, self._x)
        ok = self.comm.allreduce(bool(np.all(np.isfinite(self._x.array_r))), op=MPI.LAND)
        if self.ksp.is_diverged or not ok:
            raise CraneFemError(
                f"modes: the static MUMPS solve failed (KSP reason {self.ksp.getConvergedReason()})"
            )
        return np.array(self._x.array_r, dtype=np.float64)

    def destroy(self) -> None:
        """Destroy the KSP and its vectors (collective)."""
        for obj in (self.ksp, self._b, self._x):
            obj.destroy()
