"""Gap relations g = g0 + L u of unilateral contact points, distributed over MPI ranks."""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
from mpi4py import MPI

__all__ = ["ContactSet"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


@dataclass
class ContactSet:
    """p contact points with gaps ``g = g0 + L u`` (``L = ∇g``), rows of L split by DOF owner.

    Each rank holds the terms of L whose DOF it owns: ``rows[k]`` (contact point),
    ``dofs[k]`` (owned local DOF index) and ``coeffs[k]``. Point-wise results (gaps, relative
    velocities, the Delassus operator) are reduced over ``comm`` so every rank holds the same
    global p-vectors.

    Attributes:
        comm: communicator of the mesh.
        g0: initial gaps (p,), m, identical on all ranks.
        group: index into ``group_names`` of each point (for per-contact output).
        group_names: one name per ``[[contact]]`` entry.
        tol: gap below which a point counts as closed, m (0: g ≤ 0).
    """

    comm: MPI.Comm
    g0: FloatArray
    rows: IntArray
    dofs: IntArray
    coeffs: FloatArray
    group: IntArray
    group_names: list[str]
    tol: float = 0.0
    _buf: FloatArray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self._buf = np.zeros(2 * self.p)

    def subset(self, keep: npt.NDArray[np.bool_]) -> ContactSet:
        """The points where ``keep`` (p,) is True, renumbered in order (not collective)."""
        new_index = np.cumsum(keep) - 1
        terms = keep[self.rows]
        return ContactSet(
            self.comm,
            self.g0[keep],
            new_index[self.rows[terms]],
            self.dofs[terms],
            self.coeffs[terms],
            self.group[keep],
            self.group_names,
            self.tol,
        )

    def closed(self, gaps: FloatArray) -> npt.NDArray[np.bool_]:
        """Points whose gap is closed: ``g ≤ tol`` (``tol`` absorbs the round-off of a gap
        held at zero by a persistent contact, which would otherwise open it for a step)."""
        return gaps <= self.tol

    @property
    def p(self) -> int:
        return int(self.g0.size)

    def _local(self, x: FloatArray) -> FloatArray:
        # float64 also when this rank holds no term (bincount of nothing is int64), so the
        # buffers of the reductions match on every rank.
        out = np.bincount(self.rows, weights=self.coeffs * x[self.dofs], minlength=self.p)
        return out.astype(np.float64, copy=False)

    def apply(self, x: FloatArray) -> FloatArray:
        """``L x`` for an owned-DOF array ``x`` (collective)."""
        local = self._local(x)
        if self.comm.size == 1:
            return local
        out = np.empty_like(local)
        self.comm.Allreduce(local, out, op=MPI.SUM)
        return out

    def gaps_and_velocities(self, u: FloatArray, v: FloatArray) -> tuple[FloatArray, FloatArray]:
        """``(g0 + L u, L v)`` in one reduction (collective)."""
        p = self.p
        self._buf[:p] = self._local(u)
        self._buf[p:] = self._local(v)
        if self.comm.size == 1:
            out = self._buf.copy()
        else:
            out = np.empty_like(self._buf)
            self.comm.Allreduce(self._buf, out, op=MPI.SUM)
        return self.g0 + out[:p], out[p:]

    def add_transpose(self, lam: FloatArray, out: FloatArray, scale: FloatArray | float) -> None:
        """``out += scale * Lᵀ lam`` on owned DOFs (not collective); ``scale`` may be per DOF."""
        out += scale * self.transpose(lam, out.size)

    def transpose(self, lam: FloatArray, n_owned: int) -> FloatArray:
        """``Lᵀ lam`` as a new owned-DOF array (not collective)."""
        out = np.bincount(self.dofs, weights=self.coeffs * lam[self.rows], minlength=n_owned)
        return out.astype(np.float64, copy=False)

    def delassus(self, minv: FloatArray) -> FloatArray:
        """``W = L M⁻¹ Lᵀ`` (p × p, dense) for a diagonal M⁻¹ given on owned DOFs (collective)."""
        p = self.p
        W = np.zeros((p, p))
        # Terms sharing a DOF couple their rows; group terms by DOF on this rank.
        order = np.argsort(self.dofs, kind="stable")
        dofs, rows, coeffs = self.dofs[order], self.rows[order], self.coeffs[order]
        starts = np.flatnonzero(np.r_[True, dofs[1:] != dofs[:-1]]) if dofs.size else np.zeros(0)
        bounds = [*(int(i) for i in starts), int(dofs.size)]
        for a, b in itertools.pairwise(bounds):
            r, c = rows[a:b], coeffs[a:b]
            W[np.ix_(r, r)] += minv[dofs[a]] * np.outer(c, c)
        return self.comm.allreduce(W, op=MPI.SUM)

    def group_sums(self, values: FloatArray) -> FloatArray:
        """Sum of a point-wise p-vector over each contact group (not collective)."""
        return np.bincount(self.group, weights=values, minlength=len(self.group_names))

    def group_mins(self, values: FloatArray) -> FloatArray:
        """Minimum of a point-wise p-vector over each contact group (not collective)."""
        out = np.full(len(self.group_names), np.inf)
        np.minimum.at(out, self.group, values)
        return out

    @classmethod
    def empty(cls, comm: MPI.Comm) -> ContactSet:
        z = np.zeros(0, dtype=np.int64)
        return cls(comm, np.zeros(0), z, z.copy(), np.zeros(0), z.copy(), [])

    @classmethod
    def stack(cls, first: ContactSet, second: ContactSet) -> ContactSet:
        """Rows of ``first`` then rows of ``second`` (same communicator)."""
        return cls(
            first.comm,
            np.concatenate([first.g0, second.g0]),
            np.concatenate([first.rows, second.rows + first.p]),
            np.concatenate([first.dofs, second.dofs]),
            np.concatenate([first.coeffs, second.coeffs]),
            np.concatenate([first.group, second.group + len(first.group_names)]),
            [*first.group_names, *second.group_names],
            max(first.tol, second.tol),
        )
