"""Support reactions: the force each clamped face applies to the structure, from the rows of
the unconstrained operators at its DOFs.

The clamped DOFs carry no equation in the run (their rows are identities). Their reaction is
the residual of the unconstrained rows, R = K_f u + C_f v + M_f (a + ι a_g − g): the
structure's internal, damping and inertia forces at the face minus its body load (self-weight
and the relative formulation's −M ι a_g), which is the force the support applies. The rows
K_f and M_f (a few hundred on a crane) are assembled once and summed per face into two small
SciPy matrices over the few DOFs they couple (:attr:`SupportReactions.columns`): an evaluation
reads those values only, then one reduction. The acceleration a is the mean over the last
interval between evaluations, Δv / Δt: the inertia of the half elements next to a face is
small against their elastic force.

The peaks are read on a finer interval than the sampling's (:meth:`SupportReactions.track`):
at every record of a coupled run and, in a fully explicit run, every ``output.peak_interval``
(docs/user-guide.md §8). After a landing a face's force rings at 1–4 kHz (median about
3 kHz), at and above the Nyquist frequency of a crane's 0.13–0.16 ms sampling: read at the
sampling instants only, its peak depends on where they fall in the ringing (an explicit run's
support peak moved by −20 % / +0 % over the phases of its own sampling grid), and a coupled
run, whose Δt differs from the reference's, samples another grid.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt
import scipy.sparse
from mpi4py import MPI
from petsc4py import PETSc

from crane_fem.model import assemble_operators
from crane_fem.subdomains import Subdomain

__all__ = ["SupportReactions", "face_labels", "lowpass_limit", "lowpass_peaks"]

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


#: Samples a period of the cut-off a low-passed peak is read from, at least: a component
#: at the cut-off is then read within 1 − cos(π/10) = 5 % of its amplitude.
LOWPASS_SAMPLES = 10


def lowpass_limit(interval: float) -> float:
    """The highest cut-off (Hz) samples every ``interval`` (s) low-pass: :data:`LOWPASS_SAMPLES`
    of them a period."""
    return 1.0 / (LOWPASS_SAMPLES * interval)


def lowpass_peaks(
    times: FloatArray, forces: FloatArray, cutoff: float, translations: int = 3
) -> dict[str, FloatArray]:
    """The faces' peak force magnitude and |vertical force| after a low-pass at ``cutoff``
    (Hz): a 4th-order Butterworth run forward and backward (zero phase, so the peaks keep
    their instants) over ``forces`` (m, n_faces, ≥ translations; N) at the uniformly spaced
    ``times`` (m,). Returns ``peak``, ``t_peak``, ``peak_vertical``, ``t_vertical`` (each
    (n_faces,)). Below 2 samples the forces are read as they are; the filter's edge padding
    (three periods of the cut-off) is shortened to what a short series holds."""
    from scipy.signal import butter, sosfiltfilt  # (2 s to import: only when asked)

    times = np.asarray(times, dtype=np.float64)
    f = np.asarray(forces, dtype=np.float64)[:, :, :translations]
    if times.size >= 2:
        dt = float(np.median(np.diff(times)))
        if cutoff > lowpass_limit(dt) * (1.0 + 1e-9):
            raise ValueError(
                f"a cut-off of {cutoff:g} Hz needs samples every "
                f"{1.0 / (LOWPASS_SAMPLES * cutoff):.4g} s at most (got {dt:.4g} s)"
            )
        sos = butter(4, cutoff, fs=1.0 / dt, output="sos")
        # Padded (odd extension) by three periods of the cut-off, past scipy's default of
        # 3 (2 n_sections + 1) samples: the filter's start-up then dies out before the series.
        pad = max(3 * (2 * sos.shape[0] + 1), math.ceil(3.0 / (cutoff * dt)))
        f = sosfiltfilt(sos, f, axis=0, padlen=min(pad, times.size - 1))
    out: dict[str, FloatArray] = {}
    for key, when, values in (
        ("peak", "t_peak", np.linalg.norm(f, axis=2)),
        ("peak_vertical", "t_vertical", np.abs(f[:, :, translations - 1])),
    ):
        j = np.argmax(values, axis=0)
        out[key], out[when] = values[j, np.arange(values.shape[1])], times[j]
    return out


#: The face operator is held dense up to this many entries (8 MB).
DENSE_FACES = 2**20

#: The per-face peaks :class:`SupportReactions` keeps.
_PEAKS = ("peak", "t_peak", "peak_vertical", "t_vertical")


class SupportReactions:
    """The force of each clamped face on the structure, for the fields of the subdomain
    ``sub`` that holds the clamped DOFs (collective over its mesh communicator). Holds no PETSc
    object after its construction (its face rows are SciPy matrices).

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
        K_face, M_face = self._face_operators(sub, start, n_own)
        #: The owned DOFs (local indices) the face rows couple: all an evaluation reads.
        self.columns = np.unique(np.concatenate([K_face.indices, M_face.indices]))
        self.columns = self.columns.astype(np.int64)
        # M_f's action on the body load (ground − g on each block's translations), per
        # component: the same for every block, so one column per translation.
        comp = np.arange(n_own) % bs
        body = [M_face @ (comp == c).astype(np.float64) for c in range(self.translations)]
        # R = [K_f  M_f  M_f ι] [u + β v;  a + α v;  a_g − g] in one product: (faces × bs)
        # rows by the coupled columns twice and the translations.
        at = self.columns
        op = scipy.sparse.csr_matrix(
            scipy.sparse.hstack(
                [K_face[:, at], M_face[:, at], scipy.sparse.csr_matrix(np.column_stack(body))]
            )
        )
        # Dense while small (a crane's 12 × 603: one BLAS call, 1 µs; SciPy's sparse product
        # costs ~10 µs of overhead, at every observation).
        self._faces: FloatArray | scipy.sparse.csr_matrix = (
            op.toarray() if op.shape[0] * op.shape[1] <= DENSE_FACES else op
        )
        self._x = np.zeros(op.shape[1])
        self.peak = np.zeros(self.n_faces)
        self.t_peak = np.zeros(self.n_faces)
        self.peak_vertical = np.zeros(self.n_faces)
        self.t_vertical = np.zeros(self.n_faces)
        self.initial: FloatArray | None = None
        self.static: FloatArray | None = None
        self._v_prev: FloatArray | None = None
        self._t_prev = 0.0
        # The last observation: its velocity at the columns (the next one's mean
        # acceleration), its time and forces (the sampled forces of that instant).
        self._track_v: FloatArray | None = None
        self._track_t = 0.0
        self._track_f: FloatArray | None = None

    def _face_operators(
        self, sub: Subdomain, start: int, n_own: int
    ) -> tuple[scipy.sparse.csr_matrix, scipy.sparse.csr_matrix]:
        """K_f and M_f summed per face: (n_faces × bs, n_own) CSR over this rank's owned
        columns, so that the faces' forces are a local product and one sum over the ranks
        (collective). The rows are taken by columns (the transposed face rows), which puts
        each on the rank that owns its column, ghosts included."""
        none = np.zeros(0, dtype=np.int64)
        K, _, M = assemble_operators(sub.formulation, sub.V, sub.fields, none, True)
        assert M is not None
        isrow = PETSc.IS().createGeneral((self.rows + start).tolist(), comm=self.comm)
        iscol = PETSc.IS().createStride(n_own, first=start, step=1, comm=self.comm)
        # Each global face row's slot (face × bs + component), the ranks' rows in order.
        slot = np.concatenate(self.comm.allgather(self.labels * self.bs + self._row_comp))
        shape = (self.n_faces * self.bs, n_own)
        out = []
        for A in (K, M):
            A_f = A.createSubMatrix(isrow, iscol)
            A_t = A_f.transpose()  # rows: this rank's owned columns
            ai, aj, av = A_t.getValuesCSR()
            rows = np.repeat(np.arange(n_own), np.diff(ai))
            F = scipy.sparse.coo_matrix((av, (slot[aj], rows)), shape=shape).tocsr()
            F.sum_duplicates()
            out.append(F)
            A_f.destroy()
            A_t.destroy()
        for A in (K, M):
            A.destroy()
        isrow.destroy()
        iscol.destroy()
        return out[0], out[1]

    def forces(self, t: float, u: FloatArray, v: FloatArray, ground: FloatArray) -> FloatArray:
        """The force of each face on the structure at time ``t`` (n_faces, bs), N, for the
        fields' values ``u``, ``v`` at :attr:`columns` and the ground acceleration vector
        ``ground`` (collective). Successive calls give the mean acceleration between them."""
        if self._v_prev is None or t <= self._t_prev:
            a = np.zeros(self.columns.size)
        else:
            a = (v - self._v_prev) / (t - self._t_prev)
        self._v_prev, self._t_prev = np.array(v, dtype=np.float64), t
        return self._residual(u, v, a, ground)

    def _residual(
        self, u: FloatArray, v: FloatArray, a: FloatArray, ground: FloatArray
    ) -> FloatArray:
        """R = K_f u + C_f v + M_f (a + ι a_g − g) summed per face (n_faces, bs), for the
        values ``u``, ``v``, ``a`` at :attr:`columns` (collective)."""
        n_c, n_t = self.columns.size, self.translations
        x = self._x
        x[:n_c] = u + self.beta * v
        x[n_c : 2 * n_c] = a + self.alpha * v
        x[2 * n_c :] = np.asarray(ground, dtype=np.float64)[:n_t] - self.gravity
        r = self._faces @ x
        if self.comm.size > 1:
            total = np.empty_like(r)
            self.comm.Allreduce(r, total)
            r = total
        return r.reshape(self.n_faces, self.bs)

    def update(self, t: float, u: FloatArray, v: FloatArray, ground: FloatArray) -> FloatArray:
        """Evaluate the faces' forces at ``t`` for the fields' values ``u``, ``v`` at
        :attr:`columns` (this rank's); return them (n_faces, bs), N (collective). In a run
        observed between its sampling instants (:meth:`track`, whose instants include them)
        they are the observation's of ``t`` and its peaks are kept there, so that they do not
        depend on the sampling interval; otherwise they are evaluated here (the mean
        acceleration since the last call) and the peaks kept."""
        observed = self._track_f is not None and t == self._track_t
        if observed:
            assert self._track_f is not None
            f = self._track_f.copy()
            self._v_prev, self._t_prev = np.array(v, dtype=np.float64), t
        else:
            f = self.forces(t, u, v, ground)
        if self.initial is None:
            # The first forces without the ground's acceleration on the clamped nodes' mass
            # (M_f ι a_g): in a run from its preload, the reaction to the self-weight alone.
            self.initial = f
            self.static = self._residual(u, v, np.zeros(self.columns.size), np.zeros(3))
            self._keep_peaks(np.array([t]), f[None])
        elif not observed:
            self._keep_peaks(np.array([t]), f[None])
        return f

    def _keep_peaks(self, times: FloatArray, f: FloatArray) -> None:
        """The peak force magnitude and |vertical force| of each face over the forces ``f``
        (m, n_faces, bs) at ``times`` (m,), in order (the first of equal values)."""
        n_t = self.translations
        ft = f[:, :, :n_t]
        for values, peak, when in (
            (np.sqrt(np.einsum("mij,mij->mi", ft, ft)), self.peak, self.t_peak),
            (np.abs(f[:, :, n_t - 1]), self.peak_vertical, self.t_vertical),
        ):
            j = np.argmax(values, axis=0)
            best = values[j, np.arange(self.n_faces)]
            better = best > peak
            peak[better], when[better] = best[better], times[j[better]]

    def track(self, t: float, u: FloatArray, v: FloatArray, ground: FloatArray) -> None:
        """Evaluate the faces' forces at ``t`` and keep their peaks (collective): ``u``, ``v``
        the fields' values at :attr:`columns` (owned, this rank's), the acceleration the mean
        over the interval since the last :meth:`track`. The peaks start at the first
        :meth:`update` (the run's first sampled forces)."""
        g = np.asarray(ground, dtype=np.float64)
        self.track_many(np.array([t], dtype=np.float64), u[None, :], v[None, :], g[None, :])

    def track_many(
        self, times: FloatArray, u: FloatArray, v: FloatArray, ground: FloatArray
    ) -> None:
        """:meth:`track` at each of ``times`` (m,) in order, at once: ``u``, ``v`` (m,
        columns), ``ground`` (m, 3) (collective: one reduction)."""
        m = times.size
        if m == 0:
            return
        a = np.zeros_like(v)
        if self._track_v is not None and times[0] > self._track_t:
            a[0] = (v[0] - self._track_v) / (times[0] - self._track_t)
        if m > 1:
            a[1:] = (v[1:] - v[:-1]) / (times[1:] - times[:-1])[:, None]
        n_c, n_t = self.columns.size, self.translations
        x = np.empty((m, self._x.size))
        x[:, :n_c] = u + self.beta * v
        x[:, n_c : 2 * n_c] = a + self.alpha * v
        x[:, 2 * n_c :] = ground[:, :n_t] - self.gravity
        # (row-major: the reduction sums raw buffers)
        r = np.ascontiguousarray((self._faces @ x.T).T, dtype=np.float64)
        if self.comm.size > 1:
            total = np.empty_like(r)
            self.comm.Allreduce(r, total)
            r = total
        f = r.reshape(m, self.n_faces, self.bs)
        self._track_v, self._track_t = np.array(v[-1], dtype=np.float64), float(times[-1])
        self._track_f = f[-1].copy()
        if self.initial is not None:
            self._keep_peaks(times, f)

    def state_dict(self) -> dict[str, Any]:
        """The peaks, the first forces and the last velocities (a checkpoint; the velocities
        are this rank's values at :attr:`columns`)."""
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
        if self._track_f is not None:
            out["track_f"] = self._track_f.copy()
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
        if self._v_prev is not None and self._v_prev.size != self.columns.size:
            self._v_prev = self._v_prev[self.columns]  # (a checkpoint of the whole field)
        tv = state.get("track_v")
        self._track_v = None if tv is None else np.array(tv, dtype=np.float64)
        self._track_t = float(state.get("track_t", 0.0))
        tf = state.get("track_f")
        self._track_f = None if tf is None else np.array(tf, dtype=np.float64)

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
        """Nothing to free: the PETSc face rows were converted and destroyed at construction
        (kept for the monitors' protocol)."""
