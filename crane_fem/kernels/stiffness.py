"""The stiffness product of the explicit kernel fused with the free velocity update (THEORY.md
§1, (1.2)) and its energy sums: one pass over the block CSR stiffness per micro step, in
PETSc's summation order (bs = 3 blocks, bs = 1 scalars; any bs with stiffness damping), or,
on a serial zone with bs = 3, over K's upper block triangle only (half the memory traffic;
its blocks in 4-wide vector operations, crane_fem.kernels.vector); beams (bs = 6) over their
scalar nonzeros, on a zone without ghost columns in one loop."""

from __future__ import annotations

import numba
import numpy as np
import numpy.typing as npt

from crane_fem.kernels.vector import upper_row3
from crane_fem.kernels.zone import Zone, ZoneState

__all__ = ["free_rows", "load_at", "stiffness_velocity"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


@numba.njit(cache=True, inline="always")
def load_at(z: Zone, coef: FloatArray, i: int) -> float:
    f = z.load_base[i]
    for k in range(coef.size):
        f = f + coef[k] * z.load_shapes[k, i]
    return f


@numba.njit(cache=True, inline="always")
def _update3(
    i: int,
    s0: float,
    s1: float,
    s2: float,
    vh: FloatArray,
    ku: FloatArray,
    minv: FloatArray,
    mass: FloatArray,
    base: FloatArray,
    shapes: FloatArray,
    coef: FloatArray,
    alpha: float,
    h: float,
) -> tuple[float, float]:
    """The free velocity (1.2) of the three rows from ``i`` whose K U sums are ``s0, s1, s2``
    (written to ``ku``), the load F(t_j) = base + Σ_k coef_k shapes_k written out per
    component; returns their terms of Σ (V_old + V_free)·F and Σ (V_old + V_free)·C V_old.
    Inlined in Numba's IR: the caller's fastmath flags apply."""
    f0 = base[i]
    f1 = base[i + 1]
    f2 = base[i + 2]
    for k in range(coef.size):
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
    ku[i] = s0
    ku[i + 1] = s1
    ku[i + 2] = s2
    ext = ((v0 + w0) * f0 + (v1 + w1) * f1) + (v2 + w2) * f2
    damp = ((v0 + w0) * c0 + (v1 + w1) * c1) + (v2 + w2) * c2
    return ext, damp


@numba.njit(cache=True, inline="always")
def _update1(
    i: int,
    s: float,
    vh: FloatArray,
    ku: FloatArray,
    minv: FloatArray,
    mass: FloatArray,
    base: FloatArray,
    shapes: FloatArray,
    coef: FloatArray,
    alpha: float,
    h: float,
) -> tuple[float, float]:
    """:func:`_update3` for one scalar row (bars, beams)."""
    f = base[i]
    for k in range(coef.size):
        f = f + coef[k] * shapes[k, i]
    v = vh[i]
    cv = alpha * mass[i] * v
    w = v + h * minv[i] * (f - s - cv)
    vh[i] = w
    ku[i] = s
    return (v + w) * f, (v + w) * cv


@numba.njit(cache=True)
def stiffness_velocity(z: Zone, st: ZoneState) -> None:
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
    """:func:`free_rows` for bs = 3 without stiffness damping, on arrays only: one pass over K
    (at the memory bandwidth on the stress-grade crane), the update written out per
    component, the energy sums accumulated per block row."""
    ext = 0.0
    damp = 0.0
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
        e, d = _update3(i, s0, s1, s2, vh, ku_out, minv, mass, base, shapes, coef, alpha, h)
        ext += e
        damp += d
    return ext, damp


@numba.njit(cache=True, fastmath={"contract"})
def _rows3_upper(
    ptr: IntArray,
    idx: npt.NDArray[np.int32],
    dat: FloatArray,
    diag: FloatArray,
    u: FloatArray,
    vh: FloatArray,
    ku: FloatArray,
    minv: FloatArray,
    mass: FloatArray,
    base: FloatArray,
    shapes: FloatArray,
    coef: FloatArray,
    alpha: float,
    h: float,
) -> tuple[float, float]:
    """:func:`_rows3` on every block row of a serial zone from K's upper block triangle
    (crane_fem.kernels.zone.upper_blocks): row r's block (r, c > r) adds A u_c to row r and
    Aᵀ u_r to row c, accumulated in ``ku`` (crane_fem.kernels.vector: 4-wide); rows are
    taken in order, so row r's sum is complete once its own blocks are, and its update
    follows at once. The sums differ from PETSc's order by round-off (fused multiply-adds,
    the vector lanes added at the row's end)."""
    nb = ptr.size - 1
    for i in range(3 * nb):
        ku[i] = 0.0
    ext = 0.0
    damp = 0.0
    for r in range(nb):
        i = 3 * r
        r0 = u[i]
        r1 = u[i + 1]
        r2 = u[i + 2]
        t0, t1, t2 = upper_row3(ptr[r], ptr[r + 1], idx, dat, u, ku, r0, r1, r2)
        g = 9 * r
        s0 = ku[i] + (diag[g] * r0 + diag[g + 1] * r1 + diag[g + 2] * r2) + t0
        s1 = ku[i + 1] + (diag[g + 3] * r0 + diag[g + 4] * r1 + diag[g + 5] * r2) + t1
        s2 = ku[i + 2] + (diag[g + 6] * r0 + diag[g + 7] * r1 + diag[g + 8] * r2) + t2
        e, d = _update3(i, s0, s1, s2, vh, ku, minv, mass, base, shapes, coef, alpha, h)
        ext += e
        damp += d
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
    for rr in range(rows.size):
        i = rows[rr]
        s = 0.0
        for jj in range(indptr[i], indptr[i + 1]):
            s += data[jj, 0, 0] * u[indices[jj]]
        e, d = _update1(i, s, vh, ku_out, minv, mass, base, shapes, coef, alpha, h)
        ext += e
        damp += d
    return ext, damp


@numba.njit(cache=True, fastmath={"reassoc", "contract"})
def _rows6(
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
    """:func:`_rows3` for beams (bs = 6: three translations, three rotations), over the
    scalar rows' nonzeros (``indptr``, ``indices``, ``data``: scalar CSR) of the block
    ``rows``."""
    ext = 0.0
    damp = 0.0
    for rr in range(rows.size):
        r = rows[rr]
        for a in range(6):
            i = 6 * r + a
            s = 0.0
            for jj in range(indptr[i], indptr[i + 1]):
                s += data[jj] * u[indices[jj]]
            e, d = _update1(i, s, vh, ku_out, minv, mass, base, shapes, coef, alpha, h)
            ext += e
            damp += d
    return ext, damp


@numba.njit(cache=True, fastmath={"reassoc", "contract"})
def _rows6_all(
    s_rows: IntArray,
    indices: IntArray,
    data: FloatArray,
    u: FloatArray,
    vh: FloatArray,
    ku: FloatArray,
    load: FloatArray,
    minv: FloatArray,
    mass: FloatArray,
    base: FloatArray,
    shapes: FloatArray,
    coef: FloatArray,
    alpha: float,
    h: float,
) -> tuple[float, float]:
    """:func:`_rows6` on every owned row at once, in three loops LLVM can vectorise or keep
    short: the product over the nonzeros (``s_rows``: each one's row), the load F(t_j) into
    ``load`` one shape at a time, the update. (A frame's rows hold 1–12 nonzeros: a loop per
    row, and the shapes' loop inside the update, cost more than the arithmetic, ×2 on the
    frame crane's step.)"""
    n = ku.size
    for i in range(n):
        ku[i] = 0.0
        load[i] = base[i]
    for jj in range(data.size):
        ku[s_rows[jj]] += data[jj] * u[indices[jj]]
    for k in range(coef.size):
        ck = coef[k]
        for i in range(n):
            load[i] = load[i] + ck * shapes[k, i]
    ext = 0.0
    damp = 0.0
    for i in range(n):
        f = load[i]
        v = vh[i]
        cv = alpha * mass[i] * v
        w = v + h * minv[i] * (f - ku[i] - cv)
        vh[i] = w
        ext += (v + w) * f
        damp += (v + w) * cv
    return ext, damp


@numba.njit(cache=True)
def free_rows(
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
    if z.bs == 3 and z.beta == 0.0 and z.u_indptr.size == rows.size + 1:
        # (a serial zone: ``rows`` are all its block rows, in order)
        return _rows3_upper(
            z.u_indptr,
            z.u_indices,
            z.u_data,
            z.u_diag,
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
    if z.bs == 6 and z.beta == 0.0 and st.load.size > 0 and 6 * rows.size == st.load.size:
        # (every owned row: a zone without ghost columns)
        return _rows6_all(
            z.s_rows,
            z.s_indices,
            z.s_data,
            st.u,
            st.vh,
            st.ku,
            st.load,
            z.minv,
            z.mass,
            z.load_base,
            z.load_shapes,
            coef,
            z.alpha,
            h,
        )
    if z.bs == 6 and z.beta == 0.0 and z.s_indptr.size > 0:
        return _rows6(
            z.s_indptr,
            z.s_indices,
            z.s_data,
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
            for k in range(coef.size):
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
