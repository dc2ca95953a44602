"""The interface and contact impulses of the explicit kernel: A_k⁻¹ by blocks of eigenvectors
(crane_fem.coupling.operator), the exact contact LCP (closed form or the small LCP), and the
mixed problem of interface rows and contacts through its Schur complement."""

from __future__ import annotations

import numba
import numpy as np
import numpy.typing as npt

from crane_fem.kernels.friction import contacts_friction
from crane_fem.kernels.lcp import lcp_exact
from crane_fem.kernels.zone import LCP_ERROR, InterfaceOp, Zone, ZoneState

__all__ = ["apply_operator", "contacts_exact", "solve_mixed"]

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.int64]


@numba.njit(cache=True, fastmath=True)
def _block_product(
    Q: npt.NDArray[np.floating], y: FloatArray, s: FloatArray, k: float, gamma: float, lowrank: bool
) -> FloatArray:
    """Q f(s) Qᵀ y for one block, Q (n_b × r_b) row-major read once per product: Qᵀ y as
    row axpys, Q c as row dot products (reassociated, vectorised); sums in double precision
    whatever Q's."""
    n_b, r_b = Q.shape
    c = np.zeros(r_b)
    for i in range(n_b):
        yi = y[i]
        for m in range(r_b):
            c[m] += yi * Q[i, m]
    for m in range(r_b):
        scale = 1.0 / (1.0 + 2.0 * k * gamma * s[m])
        c[m] = (scale - 1.0) * c[m] if lowrank else scale * c[m]
    z = np.empty(n_b)
    for i in range(n_b):
        t = 0.0
        for m in range(r_b):
            t += Q[i, m] * c[m]
        z[i] = t
    return z


@numba.njit(cache=True, fastmath=True)
def _dense_product(B: npt.NDArray[np.floating], y: FloatArray) -> FloatArray:
    """B y for one block, B (n_b × n_b) row-major read once (row dot products, vectorised;
    sums in double precision whatever B's)."""
    n_b = B.shape[0]
    z = np.empty(n_b)
    for i in range(n_b):
        t = 0.0
        for j in range(n_b):
            t += B[i, j] * y[j]
        z[i] = t
    return z


@numba.njit(cache=True)
def apply_operator(op: InterfaceOp, k: float, x: FloatArray, out: FloatArray) -> None:
    """``out = A_k⁻¹ x`` (not collective: every rank holds the operator and x). An operator
    built for one k (``k_fixed``) ignores ``k``: the caller checks it."""
    if op.k_fixed > 0.0:
        for b in range(op.ptr.size - 1):
            a0, a1 = op.ptr[b], op.ptr[b + 1]
            n_b = a1 - a0
            y = np.empty(n_b)
            for i in range(n_b):
                y[i] = x[op.idx[a0 + i]]
            q0 = op.qptr[b]
            if op.single:
                zb = _dense_product(op.Q32[q0 : q0 + n_b * n_b].reshape((n_b, n_b)), y)
            else:
                zb = _dense_product(op.Q[q0 : q0 + n_b * n_b].reshape((n_b, n_b)), y)
            for i in range(n_b):
                out[op.idx[a0 + i]] = zb[i]
        return
    for b in range(op.ptr.size - 1):
        a0, a1 = op.ptr[b], op.ptr[b + 1]
        n_b = a1 - a0
        r_b = op.rank[b]
        y = np.empty(n_b)
        for i in range(n_b):
            y[i] = op.dis[a0 + i] * x[op.idx[a0 + i]]
        if r_b == 0:
            for i in range(n_b):
                out[op.idx[a0 + i]] = op.dis[a0 + i] * y[i]
            continue
        q0 = op.qptr[b]
        s = op.s[op.sptr[b] : op.sptr[b + 1]]
        if op.single:
            Q32 = op.Q32[q0 : q0 + n_b * r_b].reshape((n_b, r_b))
            zb = _block_product(Q32, y, s, k, op.gamma, op.lowrank)
        else:
            Q = op.Q[q0 : q0 + n_b * r_b].reshape((n_b, r_b))
            zb = _block_product(Q, y, s, k, op.gamma, op.lowrank)
        for i in range(n_b):
            v = y[i] + zb[i] if op.lowrank else zb[i]
            out[op.idx[a0 + i]] = op.dis[a0 + i] * v


@numba.njit(cache=True)
def contacts_exact(
    z: Zone, st: ZoneState, closed: BoolArray, lam_c: FloatArray, flags: IntArray
) -> None:
    """Λ_c on the closed points from 0 ≤ Λ ⟂ q_c + W_cc Λ ≥ 0 (closed form when W_cc is
    diagonal, the exact small LCP otherwise); Λ_c = 0 on open points. With friction
    (tangential rows), Λ_c and the tangential impulses from the frictional problem
    (crane_fem.kernels.friction)."""
    if z.nt > 0:
        contacts_friction(z, st, closed, lam_c, flags)
        return
    pc = closed.size
    for c in range(pc):
        lam_c[c] = 0.0
    if z.cc_diagonal:
        for c in range(pc):
            if closed[c]:
                lam_c[c] = max(0.0, -st.qc[c] / z.W_cc[c, c])
        return
    idx = np.flatnonzero(closed)
    if idx.size == 0:
        return
    sub = np.empty((idx.size, idx.size))
    qs = np.empty(idx.size)
    for a in range(idx.size):
        qs[a] = st.qc[idx[a]]
        for b in range(idx.size):
            sub[a, b] = z.W_cc[idx[a], idx[b]]
    sol, ok = lcp_exact(sub, qs)
    if not ok:
        flags[LCP_ERROR] = 1
    for a in range(idx.size):
        lam_c[idx[a]] = sol[a]


@numba.njit(cache=True)
def solve_mixed(
    z: Zone, op: InterfaceOp, st: ZoneState, k: float, closed: BoolArray, flags: IntArray
) -> None:
    """Interface rows solved with A_k, contact rows by the LCP of their Schur complement
    (crane_fem.contact.lcp.solve_mixed_lcp_blocks): Λ_Γ = −A_k⁻¹ (q_Γ + W_Γc Λ_c)."""
    n_g, lam = z.n_g, st.lam
    ze = st.work
    apply_operator(op, k, st.qe, ze)
    for i in range(n_g):
        ze[i] = -ze[i]
    lam_c = lam[n_g:]
    pc = z.p - n_g
    for c in range(pc):
        lam_c[c] = 0.0
    idx = np.flatnonzero(closed)
    if idx.size > 0:
        if z.ec_zero:
            contacts_exact(z, st, closed, lam_c, flags)
        else:
            # Schur complement S = W_cc − W_cΓ A⁻¹ W_Γc on the closed points.
            nc = idx.size
            S = np.empty((nc, nc))
            qs = np.empty(nc)
            col = np.empty(n_g)
            y = np.empty(n_g)
            for a in range(nc):
                s = st.qc[idx[a]]
                for i in range(n_g):
                    s += z.W_ec[i, idx[a]] * ze[i]
                qs[a] = s
            for b in range(nc):
                for i in range(n_g):
                    col[i] = z.W_ec[i, idx[b]]
                apply_operator(op, k, col, y)
                for a in range(nc):
                    s = z.W_cc[idx[a], idx[b]]
                    for i in range(n_g):
                        s -= z.W_ec[i, idx[a]] * y[i]
                    S[a, b] = s
            S = 0.5 * (S + S.T)
            sol, ok = lcp_exact(S, qs)
            if not ok:
                flags[LCP_ERROR] = 1
            for a in range(nc):
                lam_c[idx[a]] = sol[a]
            for i in range(n_g):
                col[i] = 0.0
                for a in range(nc):
                    col[i] += z.W_ec[i, idx[a]] * sol[a]
            apply_operator(op, k, col, y)
            for i in range(n_g):
                ze[i] -= y[i]
    for i in range(n_g):
        lam[i] = ze[i]
