"""The explicit micro steps, compiled: CD-Lagrange on one subdomain with its contact and
interface impulses and its energy terms, any number of micro steps per call.

THEORY.md §1 and §3, docs/theory-notes.md §5. One micro step j (Δt; h = Δt, or Δt/2 at the
start), state (U, V_{j−1/2}) on the owned DOFs and their ghosts:

    U_j       = U_{j−1} + Δt V_{j−1/2}                                            (1.1)
    V_free    = V_{j−1/2} + h M⁻¹ (F(t_j) − K U_j − C V_{j−1/2})                   (1.2)
    stacked rows r = (interface Γ, contacts c): L U_j, L V_{j−1/2}, L V_free  (one reduction)
    Λ         = interface impulses solved (GC, H_j of THEORY §3.2c in its impulse form) or
                imposed (PH, EC), contact impulses from the exact LCP (1.3), a penalty law, or
                bilateral rows (the linear probes of EC and PH)
    V_{j+1/2} = V_free + M⁻¹ Lᵀ Λ                                                  (1.4)

The stiffness product is fused with (1.2) and the energy sums in one pass over K (block CSR,
local columns: owned, then ghost). Under MPI, one halo exchange of U per micro step (of V too
when C has a stiffness part), overlapped with the rows that need no ghost, and one allreduce
of the 3p stacked-row values. Everything here sees arrays only: the owner
(:class:`crane_fem.integrators.explicit_zone.ExplicitZone`) unpacks the PETSc and dolfinx
objects once. :mod:`crane_fem.kernels.reference` is its NumPy twin, for the tests.

The operations keep the order of the Python path they replace (PETSc's 3 × 3 block product,
NumPy's expression order) so that the histories agree to round-off.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numba
import numpy as np
import numpy.typing as npt

from crane_fem.kernels.lcp import lcp_exact
from crane_fem.kernels.mpi import allreduce_sum, halo_finish, halo_start

__all__ = [
    "IMPOSED",
    "LAW_BILATERAL",
    "LAW_LCP",
    "LAW_PENALTY",
    "NONE",
    "SOLVED",
    "InterfaceOp",
    "Steps",
    "StepsOut",
    "Zone",
    "ZoneState",
    "apply_operator",
    "run_steps",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]

#: Interface rows: none (a lone explicit subdomain), solved each micro step, or imposed.
NONE, SOLVED, IMPOSED = 0, 1, 2
#: Contact law: the exact LCP (CD-Lagrange), a penalty spring, or bilateral rows.
LAW_LCP, LAW_PENALTY, LAW_BILATERAL = 0, 1, 2
#: Indices of :attr:`StepsOut.sums`.
EXT, DAMP, CONTACT, LINK, GC_WORK, PHYS_WORK = range(6)
#: Indices of :attr:`StepsOut.flags`.
CHANGED, MPI_ERROR, LCP_ERROR = range(3)


class Zone(NamedTuple):
    """The static arrays of an explicit subdomain (built once)."""

    bs: int
    n_own: int
    dt: float
    #: K in block CSR over the owned block rows; ``data`` is (nnzb, bs, bs) row-major.
    indptr: IntArray
    indices: IntArray
    data: FloatArray
    #: Block rows with owned columns only, and those with a ghost column.
    inner: IntArray
    boundary: IntArray
    mass: FloatArray
    minv: FloatArray
    alpha: float
    beta: float
    #: F(t) = base + Σ_k c_k(t) shapes[k].
    load_base: FloatArray
    load_shapes: FloatArray
    #: Stacked constraint rows: n_g interface rows, then p − n_g contact points; terms
    #: (row, owned DOF, coefficient), and the position of each term's DOF in ``c_dofs``.
    p: int
    n_g: int
    t_row: IntArray
    t_dof: IntArray
    t_coeff: FloatArray
    t_pos: IntArray
    c_dofs: IntArray
    g0: FloatArray
    tol: float
    #: Delassus blocks: diag of W_ΓΓ, W_cc (and its inverse for bilateral rows), W_Γc.
    w_gamma: FloatArray
    W_cc: FloatArray
    W_cc_inv: FloatArray
    W_ec: FloatArray
    cc_diagonal: bool
    ec_zero: bool
    #: MPI: (comm, MPI_DOUBLE, MPI_SUM) handles, size, neighbours, and the halo pattern in
    #: DOFs (values sent from ``send_idx``, received into ``recv_idx``).
    mpi: IntArray
    nranks: int
    neighbours: npt.NDArray[np.int32]
    send_ptr: IntArray
    send_idx: IntArray
    recv_ptr: IntArray
    recv_idx: IntArray


class ZoneState(NamedTuple):
    """The evolving arrays of an explicit subdomain and the kernel's scratch space."""

    u: FloatArray  # U, owned then ghost DOFs
    vh: FloatArray  # V_{j+1/2}, owned then ghost DOFs
    ku: FloatArray  # K U of the last micro step (owned)
    kv: FloatArray  # K V_{j−1/2} (owned; size 0 without stiffness damping)
    v_int: FloatArray  # V_j = ½ (V_{j−1/2} + V_{j+1/2}) of the last micro step (owned)
    lam_prev: FloatArray  # interface impulses Λ̂ of the previous micro step (n_g)
    w_prev: FloatArray  # L_E V at the previous micro step (n_g)
    vold_c: FloatArray  # V_{j−1/2} at the constraint DOFs
    jump: FloatArray  # Lᵀ Λ at the constraint DOFs
    jump_c: FloatArray  # its contact part
    red: FloatArray  # (3p) local L U, L V_{j−1/2}, L V_free
    red_out: FloatArray  # the same, global
    lam: FloatArray  # (p)
    qe: FloatArray  # (n_g) interface right-hand side
    qc: FloatArray  # (p − n_g) contact right-hand side
    work: FloatArray  # (n_g) operator scratch
    send_buf: FloatArray
    recv_buf: FloatArray
    requests: npt.NDArray[Any]


class InterfaceOp(NamedTuple):
    """The micro-step interface operator A_k = W_E,ΓΓ + 2kγ W_I, inverted through blocks
    ``b`` of rows ``idx[ptr[b]:ptr[b+1]]``: A_k⁻¹ = D^-½ Q_b diag(1/(1 + 2kγ s_b)) Q_bᵀ D^-½,
    or with ``lowrank``, D^-½ (I + Q_b diag(1/(1 + 2kγ s_b) − 1) Q_bᵀ) D^-½ with the modes of
    negligible s dropped (crane_fem.coupling.operator)."""

    gamma: float
    idx: IntArray
    ptr: IntArray
    dis: FloatArray  # D^-½ in ``idx`` order
    Q: FloatArray  # per block, n_b × r_b row-major, flattened
    Q32: npt.NDArray[np.float32]  # the same in single precision, when ``single``
    qptr: IntArray
    rank: IntArray
    s: FloatArray
    sptr: IntArray
    lowrank: bool
    single: bool


class Steps(NamedTuple):
    """What one call integrates: ``n`` micro steps; the first with ``h0`` (Δt or Δt/2) and
    moving U or not (the start). Interface: ``mode``; targets w_I,j = tc[j,0] targets[0] +
    tc[j,1] targets[1] and operator step k_op[j] (SOLVED), or impulses Δt (ic[j,0] imposed[0]
    + ic[j,1] imposed[1]) (IMPOSED). ``watch``: the contact points closed at the start (flag
    a change), or empty."""

    n: int
    h0: float
    move0: bool
    coef: FloatArray  # (n, n_shape) load coefficients at t_j
    mode: int
    law: int
    penalty: float
    tc: FloatArray  # (n, 2)
    targets: FloatArray  # (2, n_g)
    k_op: FloatArray  # (n,)
    ic: FloatArray  # (n, 2)
    imposed: FloatArray  # (2, n_g)
    watch: BoolArray
    keep_impulses: bool


class StepsOut(NamedTuple):
    """What a call returns: the last micro step's impulses and gaps (all stacked rows), per
    micro step whether a contact impulse acted, the energy sums (local: external, damping,
    contact and link work; global: the GC-measure and physical interface work), the interface
    impulses summed (trapezoid and plain), each micro step's (``keep_impulses``), L_E V at the
    last micro step, and flags (contact set changed, MPI error, singular LCP)."""

    lam: FloatArray
    gaps: FloatArray
    active: BoolArray
    sums: FloatArray
    impulse_trap: FloatArray
    impulse_sum: FloatArray
    impulses: FloatArray
    w: FloatArray
    flags: IntArray


@numba.njit(cache=True, inline="always")
def _load(z: Zone, coef: FloatArray, i: int) -> float:
    f = z.load_base[i]
    for k in range(coef.size):
        f = f + coef[k] * z.load_shapes[k, i]
    return f


@numba.njit(cache=True)
def _stiffness_velocity(z: Zone, st: ZoneState) -> None:
    """K V_{j−1/2} on the owned rows into ``st.kv`` (stiffness-proportional damping only; V's
    ghosts exchanged before)."""
    bs = z.bs
    for r in range(z.indptr.size - 1):
        for a in range(bs):
            s = 0.0
            for jj in range(z.indptr[r], z.indptr[r + 1]):
                c = bs * z.indices[jj]
                for b in range(bs):
                    s += z.data[jj, a, b] * st.vh[c + b]
            st.kv[bs * r + a] = s


@numba.njit(cache=True)
def _rows3(
    indptr: IntArray,
    indices: IntArray,
    data: FloatArray,
    u: FloatArray,
    vh: FloatArray,
    ku_out: FloatArray,
    minv: FloatArray,
    mass: FloatArray,
    base: FloatArray,
    shapes: FloatArray,
    coef: FloatArray,
    alpha: float,
    h: float,
    rows: IntArray,
) -> tuple[float, float]:
    """:func:`_rows` for bs = 3 without stiffness damping, on arrays only: one pass over K
    (at the memory bandwidth on the stress-grade crane), the update written out per
    component, the energy sums accumulated per block row."""
    ext = 0.0
    damp = 0.0
    n_shape = coef.size
    for rr in range(rows.size):
        r = rows[rr]
        s0 = 0.0
        s1 = 0.0
        s2 = 0.0
        for jj in range(indptr[r], indptr[r + 1]):
            c = 3 * indices[jj]
            x0 = u[c]
            x1 = u[c + 1]
            x2 = u[c + 2]
            # PETSc's MatMult_SeqBAIJ_3 order: sum += (v0 x0 + v1 x1) + v2 x2 per row.
            s0 += data[jj, 0, 0] * x0 + data[jj, 0, 1] * x1 + data[jj, 0, 2] * x2
            s1 += data[jj, 1, 0] * x0 + data[jj, 1, 1] * x1 + data[jj, 1, 2] * x2
            s2 += data[jj, 2, 0] * x0 + data[jj, 2, 1] * x1 + data[jj, 2, 2] * x2
        i = 3 * r
        f0 = base[i]
        f1 = base[i + 1]
        f2 = base[i + 2]
        for k in range(n_shape):
            ck = coef[k]
            f0 = f0 + ck * shapes[k, i]
            f1 = f1 + ck * shapes[k, i + 1]
            f2 = f2 + ck * shapes[k, i + 2]
        v0 = vh[i]
        v1 = vh[i + 1]
        v2 = vh[i + 2]
        c0 = alpha * mass[i] * v0
        c1 = alpha * mass[i + 1] * v1
        c2 = alpha * mass[i + 2] * v2
        w0 = v0 + h * minv[i] * (f0 - s0 - c0)
        w1 = v1 + h * minv[i + 1] * (f1 - s1 - c1)
        w2 = v2 + h * minv[i + 2] * (f2 - s2 - c2)
        vh[i] = w0
        vh[i + 1] = w1
        vh[i + 2] = w2
        ku_out[i] = s0
        ku_out[i + 1] = s1
        ku_out[i + 2] = s2
        ext += ((v0 + w0) * f0 + (v1 + w1) * f1) + (v2 + w2) * f2
        damp += ((v0 + w0) * c0 + (v1 + w1) * c1) + (v2 + w2) * c2
    return ext, damp


@numba.njit(cache=True)
def _rows1(
    indptr: IntArray,
    indices: IntArray,
    data: FloatArray,
    u: FloatArray,
    vh: FloatArray,
    ku_out: FloatArray,
    minv: FloatArray,
    mass: FloatArray,
    base: FloatArray,
    shapes: FloatArray,
    coef: FloatArray,
    alpha: float,
    h: float,
    rows: IntArray,
) -> tuple[float, float]:
    """:func:`_rows3` for bs = 1 (bars): scalar rows, PETSc's AIJ summation order."""
    ext = 0.0
    damp = 0.0
    n_shape = coef.size
    for rr in range(rows.size):
        i = rows[rr]
        s = 0.0
        for jj in range(indptr[i], indptr[i + 1]):
            s += data[jj, 0, 0] * u[indices[jj]]
        f = base[i]
        for k in range(n_shape):
            f = f + coef[k] * shapes[k, i]
        v = vh[i]
        c = alpha * mass[i] * v
        w = v + h * minv[i] * (f - s - c)
        vh[i] = w
        ku_out[i] = s
        ext += (v + w) * f
        damp += (v + w) * c
    return ext, damp


@numba.njit(cache=True)
def _rows(
    z: Zone, st: ZoneState, rows: IntArray, coef: FloatArray, h: float, last: bool
) -> tuple[float, float]:
    """Fused K U, free velocity (1.2) and energy sums over the block ``rows`` (V is updated in
    place: the product reads U only). Returns Σ (V_old + V_free)·F and Σ (V_old + V_free)·C
    V_old over them. (The arrays are taken out of the tuples first: helpers that receive the
    tuples, even inlined, made this loop 50× slower.)"""
    if z.bs == 1 and z.beta == 0.0:
        return _rows1(
            z.indptr,
            z.indices,
            z.data,
            st.u,
            st.vh,
            st.ku,
            z.minv,
            z.mass,
            z.load_base,
            z.load_shapes,
            coef,
            z.alpha,
            h,
            rows,
        )
    if z.bs == 3 and z.beta == 0.0:
        return _rows3(
            z.indptr,
            z.indices,
            z.data,
            st.u,
            st.vh,
            st.ku,
            z.minv,
            z.mass,
            z.load_base,
            z.load_shapes,
            coef,
            z.alpha,
            h,
            rows,
        )
    u, vh, ku_out, kv = st.u, st.vh, st.ku, st.kv
    data, indices, indptr = z.data, z.indices, z.indptr
    mass, minv, base, shapes = z.mass, z.minv, z.load_base, z.load_shapes
    alpha, beta, bs = z.alpha, z.beta, z.bs
    n_shape = coef.size
    ext = 0.0
    damp = 0.0
    ks = np.zeros(bs)
    for rr in range(rows.size):
        r = rows[rr]
        if bs == 3:
            s0 = 0.0
            s1 = 0.0
            s2 = 0.0
            for jj in range(indptr[r], indptr[r + 1]):
                c = 3 * indices[jj]
                x0 = u[c]
                x1 = u[c + 1]
                x2 = u[c + 2]
                # PETSc's MatMult_SeqBAIJ_3 order: sum += (v0 x0 + v1 x1) + v2 x2 per row.
                s0 += data[jj, 0, 0] * x0 + data[jj, 0, 1] * x1 + data[jj, 0, 2] * x2
                s1 += data[jj, 1, 0] * x0 + data[jj, 1, 1] * x1 + data[jj, 1, 2] * x2
                s2 += data[jj, 2, 0] * x0 + data[jj, 2, 1] * x1 + data[jj, 2, 2] * x2
            ks[0] = s0
            ks[1] = s1
            ks[2] = s2
        else:
            for a in range(bs):
                s = 0.0
                for jj in range(indptr[r], indptr[r + 1]):
                    c = bs * indices[jj]
                    t = 0.0
                    for b in range(bs):
                        t += data[jj, a, b] * u[c + b]
                    s += t
                ks[a] = s
        for a in range(bs):
            i = bs * r + a
            ku = ks[a]
            f = base[i]
            for k in range(n_shape):
                f = f + coef[k] * shapes[k, i]
            v_old = vh[i]
            cv = alpha * mass[i] * v_old
            if beta != 0.0:
                cv = cv + beta * kv[i]
            v_free = v_old + h * minv[i] * (f - ku - cv)
            vh[i] = v_free
            if last:
                ku_out[i] = ku
            ext += (v_old + v_free) * f
            damp += (v_old + v_free) * cv
    return ext, damp


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


@numba.njit(cache=True)
def apply_operator(op: InterfaceOp, k: float, x: FloatArray, out: FloatArray) -> None:
    """``out = A_k⁻¹ x`` (not collective: every rank holds the operator and x)."""
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
def _contacts_exact(
    z: Zone, st: ZoneState, closed: BoolArray, lam_c: FloatArray, flags: IntArray
) -> None:
    """Λ_c on the closed points from 0 ≤ Λ ⟂ q_c + W_cc Λ ≥ 0 (closed form when W_cc is
    diagonal, the exact small LCP otherwise); Λ_c = 0 on open points."""
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
def _solve_mixed(
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
            _contacts_exact(z, st, closed, lam_c, flags)
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


@numba.njit(cache=True)
def _micro(
    z: Zone,
    op: InterfaceOp,
    st: ZoneState,
    ctl: Steps,
    out: StepsOut,
    jj: int,
    h: float,
    move: bool,
) -> None:
    n_own, n_g, p = z.n_own, z.n_g, z.p
    u, vh = st.u, st.vh
    last = jj == ctl.n - 1
    if move:
        for i in range(n_own):
            u[i] += z.dt * vh[i]
    for c in range(z.c_dofs.size):
        st.vold_c[c] = vh[z.c_dofs[c]]
    if last:
        for i in range(n_own):
            st.v_int[i] = vh[i]
    halo = z.neighbours.size > 0
    n_nb = z.neighbours.size
    if z.beta != 0.0:  # stiffness damping: K V_{j−1/2} first (its own halo exchange)
        if halo:
            out.flags[MPI_ERROR] |= halo_start(
                vh,
                z.neighbours,
                z.send_ptr,
                z.send_idx,
                z.recv_ptr,
                st.send_buf,
                st.recv_buf,
                st.requests,
                z.mpi,
            )
            out.flags[MPI_ERROR] |= halo_finish(vh, n_nb, z.recv_idx, st.recv_buf, st.requests)
        _stiffness_velocity(z, st)
    if halo:
        out.flags[MPI_ERROR] |= halo_start(
            u,
            z.neighbours,
            z.send_ptr,
            z.send_idx,
            z.recv_ptr,
            st.send_buf,
            st.recv_buf,
            st.requests,
            z.mpi,
        )
    coef = ctl.coef[jj]
    ext, damp = _rows(z, st, z.inner, coef, h, last)
    if halo:
        out.flags[MPI_ERROR] |= halo_finish(u, n_nb, z.recv_idx, st.recv_buf, st.requests)
        e2, d2 = _rows(z, st, z.boundary, coef, h, last)
        ext += e2
        damp += d2
    lam = st.lam
    if p == 0:
        out.sums[EXT] += 0.5 * h * ext
        out.sums[DAMP] += 0.5 * h * damp
        out.active[jj] = False
        if last:
            for i in range(n_own):
                st.v_int[i] = 0.5 * (st.v_int[i] + vh[i])
        return
    # Stacked rows: L U_j, L V_{j−1/2}, L V_free (one reduction).
    red = st.red
    for r in range(3 * p):
        red[r] = 0.0
    for t in range(z.t_row.size):
        r, d, cf = z.t_row[t], z.t_dof[t], z.t_coeff[t]
        red[r] += cf * u[d]
        red[p + r] += cf * st.vold_c[z.t_pos[t]]
        red[2 * p + r] += cf * vh[d]
    g = st.red_out
    if z.nranks > 1:
        out.flags[MPI_ERROR] |= allreduce_sum(red, g, z.mpi)
    else:
        g[:] = red
    gaps = out.gaps
    for r in range(p):
        gaps[r] = z.g0[r] + g[r]
    pc = p - n_g
    closed = np.empty(pc, dtype=np.bool_)
    for c in range(pc):
        closed[c] = gaps[n_g + c] <= z.tol
        st.qc[c] = g[2 * p + n_g + c]
    # Impulses.
    lam_c = lam[n_g:]
    if ctl.mode == SOLVED:
        for i in range(n_g):
            w_i = ctl.tc[jj, 0] * ctl.targets[0, i] + ctl.tc[jj, 1] * ctl.targets[1, i]
            st.qe[i] = (g[p + i] + g[2 * p + i]) + 2.0 * w_i
    elif ctl.mode == IMPOSED:
        for i in range(n_g):
            lam[i] = z.dt * (ctl.ic[jj, 0] * ctl.imposed[0, i] + ctl.ic[jj, 1] * ctl.imposed[1, i])
        if not z.ec_zero:
            for c in range(pc):
                for i in range(n_g):
                    st.qc[c] += z.W_ec[i, c] * lam[i]
    if ctl.law == LAW_PENALTY:  # (a lone explicit subdomain: no interface rows)
        for c in range(pc):
            lam_c[c] = h * (ctl.penalty * max(-gaps[n_g + c], 0.0))
    elif ctl.law == LAW_BILATERAL:  # every row held (the linear probes: interface imposed)
        for c in range(pc):
            s = 0.0
            for b in range(pc):
                s += z.W_cc_inv[c, b] * st.qc[b]
            lam_c[c] = -s
    elif ctl.mode == SOLVED:
        _solve_mixed(z, op, st, ctl.k_op[jj], closed, out.flags)
    else:
        _contacts_exact(z, st, closed, lam_c, out.flags)
    # V_{j+1/2} = V_free + M⁻¹ Lᵀ Λ at the constraint DOFs, and the work of Λ.
    for c in range(z.c_dofs.size):
        st.jump[c] = 0.0
        st.jump_c[c] = 0.0
    for t in range(z.t_row.size):
        r = z.t_row[t]
        st.jump[z.t_pos[t]] += z.t_coeff[t] * lam[r]
        if r >= n_g:
            st.jump_c[z.t_pos[t]] += z.t_coeff[t] * lam[r]
    contact_w = 0.0
    link_w = 0.0
    for c in range(z.c_dofs.size):
        d = z.c_dofs[c]
        dv = z.minv[d] * st.jump[c]
        v_free = vh[d]
        vh[d] = v_free + dv
        v_mid = 0.5 * (st.vold_c[c] + vh[d])
        contact_w += v_mid * st.jump_c[c]
        link_w += v_mid * (st.jump[c] - st.jump_c[c])
        # The sums of _rows took V_free for V_{j+1/2}: add the impulse's part.
        cv = z.alpha * z.mass[d] * st.vold_c[c]
        if z.beta != 0.0:
            cv = cv + z.beta * st.kv[d]
        ext += dv * _load(z, coef, d)
        damp += dv * cv
    out.sums[EXT] += 0.5 * h * ext
    out.sums[DAMP] += 0.5 * h * damp
    out.sums[CONTACT] += contact_w
    out.sums[LINK] += link_w
    active = False
    for c in range(pc):
        if lam_c[c] > 0.0:
            active = True
    out.active[jj] = active
    if ctl.watch.size > 0 and out.flags[CHANGED] == 0:
        for c in range(pc):
            if closed[c] != ctl.watch[c]:
                out.flags[CHANGED] = 1
    # Interface bookkeeping: L_E V_j = ½ (L V_{j−1/2} + L V_{j+1/2}), L V_{j+1/2} = q + W Λ.
    if n_g > 0:
        gc_w = 0.0
        phys_w = 0.0
        for i in range(n_g):
            wl = z.w_gamma[i] * lam[i]
            if not z.ec_zero:
                for c in range(pc):
                    wl += z.W_ec[i, c] * lam_c[c]
            w_i = 0.5 * (g[p + i] + (g[2 * p + i] + wl))
            lbar = 0.5 * (st.lam_prev[i] + lam[i])
            gc_w += lbar * (0.5 * (st.w_prev[i] + w_i))
            phys_w += lbar * g[p + i]  # (Λ̄/Δt)·L(U_j − U_{j−1}), U_j − U_{j−1} = Δt V_{j−1/2}
            out.impulse_trap[i] += 0.5 * (st.lam_prev[i] + lam[i])
            out.impulse_sum[i] += lam[i]
            st.lam_prev[i] = lam[i]
            st.w_prev[i] = w_i
            if ctl.keep_impulses:
                out.impulses[jj, i] = lam[i]
        out.sums[GC_WORK] += gc_w
        out.sums[PHYS_WORK] += phys_w
    if last:
        for i in range(n_own):
            st.v_int[i] = 0.5 * (st.v_int[i] + vh[i])
        for r in range(p):
            out.lam[r] = lam[r]
        for i in range(n_g):
            out.w[i] = st.w_prev[i]


@numba.njit(cache=True)
def run_steps(z: Zone, op: InterfaceOp, st: ZoneState, ctl: Steps, out: StepsOut) -> None:
    """Integrate ``ctl.n`` micro steps of the zone (collective over the zone's communicator:
    one halo exchange and one allreduce per micro step where the zone spans several ranks).

    ``out`` is reset first; ``st`` carries the state from call to call."""
    out.sums[:] = 0.0
    out.impulse_trap[:] = 0.0
    out.impulse_sum[:] = 0.0
    out.flags[:] = 0
    for jj in range(ctl.n):
        if jj == 0:
            _micro(z, op, st, ctl, out, jj, ctl.h0, ctl.move0)
        else:
            _micro(z, op, st, ctl, out, jj, z.dt, True)
