"""Gap relations g = g0 + L u of unilateral contact points, and the tangential rows of the
frictional ones, distributed over MPI ranks."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
from mpi4py import MPI

__all__ = ["ContactSet", "TangentRows"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


@dataclass(frozen=True)
class TangentRows:
    """The tangential velocity rows v_t = T V of frictional contact points: n_t rows (one or
    two per point, orthonormal to each other and to the point's normal row), terms split by
    DOF owner as :class:`ContactSet`'s.

    Attributes:
        point: (n_t,) the contact point of each row (global numbering, identical on all ranks);
            a point's rows are consecutive.
        rows, dofs, coeffs: this rank's terms: row (0..n_t−1), owned local DOF, coefficient.
    """

    point: IntArray
    rows: IntArray
    dofs: IntArray
    coeffs: FloatArray

    @property
    def n(self) -> int:
        return int(self.point.size)

    def subset(self, keep: npt.NDArray[np.bool_]) -> TangentRows:
        """The rows of the points where ``keep`` (p,) is True, points renumbered in order."""
        new_point = np.cumsum(keep) - 1
        keep_rows = keep[self.point]
        new_row = np.cumsum(keep_rows) - 1
        terms = keep_rows[self.rows]
        return TangentRows(
            new_point[self.point[keep_rows]].astype(np.int64),
            new_row[self.rows[terms]].astype(np.int64),
            self.dofs[terms],
            self.coeffs[terms],
        )

    @classmethod
    def empty(cls) -> TangentRows:
        z = np.zeros(0, dtype=np.int64)
        return cls(z, z.copy(), z.copy(), np.zeros(0))


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
        mu: Coulomb friction coefficient of each point (p,), or None: frictionless.
        tangents: the tangential rows of the points with ``mu > 0`` (None: none).
        spring: per point (p,) the stiffness of the rope whose chord component the row is
            (N/m; a rope's three rows, x, y, z of x_b − x_a, are consecutive), 0 for a
            unilateral row; None: none. ``rest``: the ropes' rest lengths on the same rows
            (m).
    """

    comm: MPI.Comm
    g0: FloatArray
    rows: IntArray
    dofs: IntArray
    coeffs: FloatArray
    group: IntArray
    group_names: list[str]
    tol: float = 0.0
    mu: FloatArray | None = None
    tangents: TangentRows | None = None
    spring: FloatArray | None = None
    rest: FloatArray | None = None
    _buf: FloatArray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self._buf = np.zeros(2 * self.p)

    @property
    def friction(self) -> FloatArray:
        """The friction coefficient of each point (p,), zeros when frictionless."""
        return np.zeros(self.p) if self.mu is None else self.mu

    @property
    def tangent_rows(self) -> TangentRows:
        """The tangential rows (empty when frictionless)."""
        return TangentRows.empty() if self.tangents is None else self.tangents

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
            None if self.mu is None else self.mu[keep],
            None if self.tangents is None else self.tangents.subset(keep),
            None if self.spring is None else self.spring[keep],
            None if self.rest is None else self.rest[keep],
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
        # Terms sharing a DOF couple their rows; group terms by DOF on this rank. Every pair
        # (i, j) of terms of one DOF adds minv c_i c_j to W[row_i, row_j]: all pairs at once,
        # summed by np.bincount in the order of the DOFs (each entry's sum in the same order
        # as a loop over the DOFs would make it: bit-identical to it).
        order = np.argsort(self.dofs, kind="stable")
        dofs, rows, coeffs = self.dofs[order], self.rows[order], self.coeffs[order]
        if dofs.size:
            starts = np.flatnonzero(np.r_[True, dofs[1:] != dofs[:-1]])
            sizes = np.diff(np.r_[starts, dofs.size])
            group = np.repeat(np.arange(starts.size), sizes)  # each term's DOF group
            per = sizes[group]  # each term's partners (its group's terms)
            i = np.repeat(np.arange(dofs.size), per)
            j = starts[group][i] + (np.arange(i.size) - np.repeat(np.cumsum(per) - per, per))
            W = np.bincount(
                rows[i] * p + rows[j],
                weights=minv[dofs[i]] * (coeffs[i] * coeffs[j]),
                minlength=p * p,
            ).reshape(p, p)
        if self.comm.size == 1:
            return W
        out = np.empty_like(W)
        self.comm.Allreduce(W, out, op=MPI.SUM)
        return out

    def rope_values(self, gaps: FloatArray, forces: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Per point (p,) the gaps and forces an engineer reads: a rope's three chord rows
        give its slack L − ℓ on each row and its tension on its first (0 on the other two);
        the other rows as they are (not collective)."""
        if self.spring is None or not np.any(self.spring > 0.0):
            return gaps, forces
        gaps, forces = gaps.copy(), forces.copy()
        first = np.flatnonzero(self.spring > 0.0)[::3]
        rest = self.rest if self.rest is not None else np.zeros(self.p)
        for c in first:
            chord = float(np.linalg.norm(gaps[c : c + 3]))
            gaps[c : c + 3] = rest[c] - chord
            tension = float(np.linalg.norm(forces[c : c + 3]))
            forces[c : c + 3] = 0.0
            forces[c] = tension
        return gaps, forces

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

    def with_tangents(self) -> ContactSet:
        """The normal rows followed by the tangential rows as one row set (p + n_t rows; its
        :meth:`delassus` is the Delassus operator of the frictional problem). Not collective."""
        t = self.tangent_rows
        return ContactSet(
            self.comm,
            np.zeros(self.p + t.n),
            np.concatenate([self.rows, self.p + t.rows]).astype(np.int64),
            np.concatenate([self.dofs, t.dofs]).astype(np.int64),
            np.concatenate([self.coeffs, t.coeffs]),
            np.zeros(self.p + t.n, dtype=np.int64),
            ["rows"],
        )

    @classmethod
    def stack(cls, first: ContactSet, second: ContactSet) -> ContactSet:
        """Rows of ``first`` then rows of ``second`` (same communicator)."""
        mu = None
        if first.mu is not None or second.mu is not None:
            mu = np.concatenate([first.friction, second.friction])
        spring = rest = None
        if first.spring is not None or second.spring is not None:

            def both(a: FloatArray | None, b: FloatArray | None) -> FloatArray:
                return np.concatenate(
                    [np.zeros(first.p) if a is None else a, np.zeros(second.p) if b is None else b]
                )

            spring = both(first.spring, second.spring)
            rest = both(first.rest, second.rest)
        tangents = None
        if first.tangents is not None or second.tangents is not None:
            a, b = first.tangent_rows, second.tangent_rows
            tangents = TangentRows(
                np.concatenate([a.point, b.point + first.p]).astype(np.int64),
                np.concatenate([a.rows, b.rows + a.n]).astype(np.int64),
                np.concatenate([a.dofs, b.dofs]).astype(np.int64),
                np.concatenate([a.coeffs, b.coeffs]),
            )
        return cls(
            first.comm,
            np.concatenate([first.g0, second.g0]),
            np.concatenate([first.rows, second.rows + first.p]),
            np.concatenate([first.dofs, second.dofs]),
            np.concatenate([first.coeffs, second.coeffs]),
            np.concatenate([first.group, second.group + len(first.group_names)]),
            [*first.group_names, *second.group_names],
            max(first.tol, second.tol),
            mu,
            tangents,
            spring,
            rest,
        )
