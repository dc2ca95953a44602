"""Support reactions: the force each clamped face applies to the structure, from the rows of
the unconstrained operators at its DOFs.

The clamped DOFs carry no equation in the run (their rows are identities). Their reaction is
the residual of the unconstrained rows, R = K_f u + C_f v + M_f (a + ι a_g − g): the
structure's internal, damping and inertia forces at the face minus its body load (self-weight
and the relative formulation's −M ι a_g), which is the force the support applies. The rows
K_f and M_f (a few hundred on a crane) are assembled once; an evaluation is two small products. The
acceleration a is the mean over the last interval between evaluations, Δv / Δt: the inertia of
the half elements next to a face is small against their elastic force.

The peaks are taken on a finer interval than the sampling's (:meth:`SupportReactions.track`,
at every state the run holds between its sampling instants: a coupled run's macro steps, a
monolithic reference's pieces of the scene's fine macro step). After a landing a face's force
rings at 1–4 kHz, at and above the Nyquist frequency of the 0.13–0.16 ms sampling: its peak
sampled there depends on where the sampling instants fall in the ringing (an explicit run's
support peak moves by −20 % / +0 % over the phases of its own sampling grid), and a coupled
run, whose Δt (the explicit zone's) differs from the reference's (the whole mesh's), samples
another grid. The faces' forces need only the few field values their rows couple
(:attr:`SupportReactions.columns`): cheap at every macro step, on a reduced side too.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt
from mpi4py import MPI
from petsc4py import PETSc

from crane_fem.model import assemble_operators
from crane_fem.subdomains import Subdomain

__all__ = ["SupportReactions", "face_labels"]

FloatArray = npt.NDArray[np.float64]


def face_labels(xy: FloatArray, comm: MPI.Comm) -> tuple[npt.NDArray[np.int64], FloatArray]:
    """Label clamped points by face: the clusters of their (x, y) positions taken in order of
    y then x (a crane's four end-carriage ends: 1, 2 at y = 0, then 3, 4), with the centre of
    each face (collective; ``xy`` the owned points' coordinates, (n, 3))."""
    allxy = np.concatenate(comm.allgather(np.asarray(xy, dtype=np.float64).reshape(-1, 3)))
    if allxy.shape[0] == 0:
        return np.zeros(0, dtype=np.int64), np.zeros((0, 3))
    span = float(np.ptp(allxy[:, :2], axis=0).max()) or 1.0
    # Faces are planes far apart against their size: cluster by x and y separately.
    keys = []
    for axis in (1, 0):
        vals = np.sort(np.unique(np.round(allxy[:, axis] / (1e-3 * span))))
        breaks = vals[1:][np.diff(vals) > 50]  # gaps of more than 5 % of the extent
        keys.append(breaks)
    by, bx = keys

    def label(p: FloatArray) -> npt.NDArray[np.int64]:
        iy = np.searchsorted(by, np.round(p[:, 1] / (1e-3 * span)), side="right")
        ix = np.searchsorted(bx, np.round(p[:, 0] / (1e-3 * span)), side="right")
        return np.asarray(iy * (bx.size + 1) + ix, dtype=np.int64)

    all_lab = label(allxy)
    used, dense = np.unique(all_lab, return_inverse=True)
    centres = np.array([allxy[dense == k].mean(axis=0) for k in range(used.size)])
    mine = np.searchsorted(used, label(np.asarray(xy, dtype=np.float64).reshape(-1, 3)))
    return mine.astype(np.int64), centres


#: The per-face peaks :class:`SupportReactions` keeps.
_PEAKS = ("peak", "t_peak", "peak_vertical", "t_vertical")


class SupportReactions:
    """The force of each clamped face on the structure, for the fields of the subdomain
    ``sub`` that holds the clamped DOFs (collective over its mesh communicator). Owns two
    PETSc matrices of face rows: :meth:`destroy` them.

    Args:
        sub: the subdomain (its ``model.fixed`` marks the clamped owned DOFs).
        rayleigh: (α, β) of C = α M + β K.
        gravity: the gravity vector (m/s²).
        faces: the global parent vertex ids of each face (a gmsh model's ``[[support]]``
            groups, in order; a vertex in two takes the first), or None: the faces found by
            :func:`face_labels` (a crane's four end-carriage ends).
    """

    def __init__(
        self,
        sub: Subdomain,
        rayleigh: tuple[float, float],
        gravity: FloatArray | list[float],
        faces: list[npt.NDArray[np.int64]] | None = None,
    ) -> None:
        V, bs = sub.V, sub.bs
        self.subdomain = sub.name
        self.comm = sub.submesh.comm
        self.bs = bs
        self.alpha, self.beta = rayleigh
        self.translations = sub.formulation.translations
        self.gravity = np.asarray(gravity, dtype=np.float64)[: self.translations]
        n_own = sub.model.n_owned
        start = V.dofmap.index_map.local_range[0] * bs
        self.rows = np.flatnonzero(sub.model.fixed).astype(np.int32)
        if faces is not None:  # the faces' rows only (not a rope end's held rotations)
            on_face = np.isin(sub.parent_vertex[self.rows // bs], np.concatenate(faces))
            self.rows = self.rows[on_face]
        none = np.zeros(0, dtype=np.int64)
        K, _, M = assemble_operators(sub.formulation, V, sub.fields, none, True)
        assert M is not None
        isrow = PETSc.IS().createGeneral(self.rows + start, comm=self.comm)
        iscol = PETSc.IS().createStride(n_own, first=start, step=1, comm=self.comm)
        self.K = K.createSubMatrix(isrow, iscol)
        self.M = M.createSubMatrix(isrow, iscol)
        for obj in (K, M, isrow, iscol):
            obj.destroy()
        self._x = self.K.createVecRight()
        self._r = self.K.createVecLeft()
        xyz = V.tabulate_dof_coordinates()[: sub.n_owned_blocks]
        # Each fixed row's block and component (a beam's pinned block fixes 3 of its 6).
        self._row_block = self.rows // bs
        self._row_comp = self.rows % bs
        blocks = np.unique(self._row_block)
        if faces is None:
            labels, self.centres = face_labels(xyz[blocks], self.comm)
        else:
            vertex = sub.parent_vertex[blocks]
            labels = np.full(blocks.size, len(faces), dtype=np.int64)
            for k in reversed(range(len(faces))):
                labels[np.isin(vertex, faces[k])] = k
            sums = np.zeros((len(faces), 4))
            np.add.at(sums[:, :3], labels, xyz[blocks])
            np.add.at(sums[:, 3], labels, 1.0)
            sums = self.comm.allreduce(sums, op=MPI.SUM)
            self.centres = sums[:, :3] / np.maximum(sums[:, 3:], 1.0)
        self.n_faces = self.centres.shape[0]
        self.labels = labels[np.searchsorted(blocks, self._row_block)]
        self.peak = np.zeros(self.n_faces)
        self.t_peak = np.zeros(self.n_faces)
        self.peak_vertical = np.zeros(self.n_faces)
        self.t_vertical = np.zeros(self.n_faces)
        self.initial: FloatArray | None = None
        self.static: FloatArray | None = None
        self._v_prev: FloatArray | None = None
        self._t_prev = 0.0
        # The owned DOFs the face rows couple (local indices): all the forces need.
        cols = [np.zeros(0, dtype=np.int64)]
        for A in (self.K, self.M):
            _, aj, _ = A.getValuesCSR()
            cols.append(np.asarray(aj, dtype=np.int64) - start)
        self.columns = np.unique(np.concatenate(cols))
        self.n_owned = n_own
        # The finer observations' own previous velocity (their mean acceleration).
        self._track_v: FloatArray | None = None
        self._track_t = 0.0

    def _apply(self, A: PETSc.Mat, x: FloatArray) -> FloatArray:
        self._x.array[:] = x
        A.mult(self._x, self._r)
        return np.array(self._r.array, dtype=np.float64)

    def forces(self, t: float, u: FloatArray, v: FloatArray, ground: FloatArray) -> FloatArray:
        """The force of each face on the structure at time ``t`` (n_faces, bs), N, for the
        owned fields ``u``, ``v`` and the ground acceleration vector ``ground`` (collective).
        Successive calls give the mean acceleration between them."""
        if self._v_prev is None or t <= self._t_prev:
            a = np.zeros_like(v)
        else:
            a = (v - self._v_prev) / (t - self._t_prev)
        self._v_prev, self._t_prev = v.copy(), t
        return self._residual(u, v, a, ground)

    def _residual(
        self, u: FloatArray, v: FloatArray, a: FloatArray, ground: FloatArray
    ) -> FloatArray:
        """R = K_f u + C_f v + M_f (a + ι a_g − g) summed per face (n_faces, bs) (collective)."""
        bs = self.bs
        body = np.zeros((v.size // bs, bs))
        n_t = self.translations
        body[:, :n_t] = np.asarray(ground, dtype=np.float64)[:n_t] - self.gravity
        r = self._apply(self.K, u + self.beta * v) + self._apply(
            self.M, a + body.ravel() + self.alpha * v
        )
        local = np.zeros((self.n_faces, bs))
        np.add.at(local, (self.labels, self._row_comp), r)
        return np.asarray(self.comm.allreduce(local, op=MPI.SUM), dtype=np.float64)

    def update(self, t: float, u: FloatArray, v: FloatArray, ground: FloatArray) -> FloatArray:
        """Evaluate the faces' forces at ``t``; return them (n_faces, bs), N (collective).
        Their peaks are kept here at the first call and in a run not observed between its
        sampling instants; an observed run keeps them at every observation (:meth:`track`,
        whose states include the sampling instants), so that they do not depend on the
        sampling interval."""
        f = self.forces(t, u, v, ground)
        if self.initial is None:
            # The first forces without the ground's acceleration on the clamped nodes' mass
            # (M_f ι a_g): in a run from its preload, the reaction to the self-weight alone.
            self.initial = f
            self.static = self._residual(u, v, np.zeros_like(v), np.zeros(3))
            self._keep_peaks(t, f)
        elif self._track_v is None:  # not observed between the sampling instants
            self._keep_peaks(t, f)
        return f

    def _keep_peaks(self, t: float, f: FloatArray) -> None:
        n_t = self.translations
        norm = np.linalg.norm(f[:, :n_t], axis=1)
        better = norm > self.peak
        self.peak[better], self.t_peak[better] = norm[better], t
        vert = np.abs(f[:, n_t - 1])
        better = vert > self.peak_vertical
        self.peak_vertical[better], self.t_vertical[better] = vert[better], t

    def track(self, t: float, u: FloatArray, v: FloatArray, ground: FloatArray) -> None:
        """Keep the faces' peaks at ``t`` between the sampling instants (collective): ``u``,
        ``v`` owned fields, whose values at :attr:`columns` only are read (the others may be
        zero). The mean acceleration is over the interval since the last :meth:`track`; the
        sampled forces (:meth:`update`) are not changed."""
        if self._track_v is None or t <= self._track_t:
            a = np.zeros_like(v)
        else:
            a = (v - self._track_v) / (t - self._track_t)
        self._track_v, self._track_t = v.copy(), t
        if self.initial is None:
            return  # the first forces are the sampled ones (update)
        self._keep_peaks(t, self._residual(u, v, a, ground))

    def state_dict(self) -> dict[str, Any]:
        """The peaks, the first forces and the last velocities (a checkpoint; the velocities
        are this rank's owned values)."""
        out: dict[str, Any] = {k: getattr(self, k).copy() for k in _PEAKS}
        out["t_prev"] = self._t_prev
        if self.initial is not None:
            out["initial"] = self.initial.copy()
        if self.static is not None:
            out["static"] = self.static.copy()
        if self._v_prev is not None:
            out["v_prev"] = self._v_prev.copy()
        if self._track_v is not None:
            out["track_v"] = self._track_v.copy()
            out["track_t"] = self._track_t
        return out

    def load_state_dict(self, state: dict[str, Any]) -> None:
        for k in _PEAKS:
            setattr(self, k, np.array(state[k], dtype=np.float64))
        self._t_prev = float(state["t_prev"])
        init, v = state.get("initial"), state.get("v_prev")
        self.initial = None if init is None else np.array(init, dtype=np.float64)
        static = state.get("static")
        self.static = None if static is None else np.array(static, dtype=np.float64)
        self._v_prev = None if v is None else np.array(v, dtype=np.float64)
        tv = state.get("track_v")
        self._track_v = None if tv is None else np.array(tv, dtype=np.float64)
        self._track_t = float(state.get("track_t", 0.0))

    def table(self) -> dict[str, dict[str, Any]]:
        """Per face (numbered from 1): its centre, the peak of the force's magnitude and of its
        vertical component with their times, the force at the first evaluation and its static
        part (without the ground's acceleration on the clamped nodes' own mass) (N; a beam's
        support also its moment, N·m)."""
        init = self.initial if self.initial is not None else np.zeros((self.n_faces, self.bs))
        static = self.static if self.static is not None else init
        n_t = self.translations
        out: dict[str, dict[str, Any]] = {}
        for k in range(self.n_faces):
            row: dict[str, Any] = {
                "centre_m": [float(c) for c in self.centres[k]],
                "peak_force_N": float(self.peak[k]),
                "peak_force_time_s": float(self.t_peak[k]),
                "peak_vertical_N": float(self.peak_vertical[k]),
                "peak_vertical_time_s": float(self.t_vertical[k]),
                "initial_force_N": [float(x) for x in init[k, :n_t]],
                "static_force_N": [float(x) for x in static[k, :n_t]],
            }
            if self.bs > n_t:
                row["initial_moment_Nm"] = [float(x) for x in init[k, n_t:]]
                row["static_moment_Nm"] = [float(x) for x in static[k, n_t:]]
            out[str(k + 1)] = row
        return out

    def destroy(self) -> None:
        for obj in (self.K, self.M, self._x, self._r):
            obj.destroy()
