"""Coulomb friction in the explicit kernel: the frictional contact impulses of a micro step,
compiled (the NumPy reference is :mod:`crane_fem.contact.friction`, whose docstring states the
problem and its Alart–Curnier form (7.1)).

Points that share no DOF with another point (the Delassus operator of the normal and
tangential rows is block diagonal by point) are solved one by one: in closed form when the
point's block is isotropic, w I (lumped mass, orthonormal rows on the point's own DOFs: every
node-to-plane point), else exactly by enumeration (separation, stick, slip directions from a
quartic). Points that share DOFs are solved together: semismooth Newton on the Alart–Curnier
function, then, if it stalls, Gauss–Seidel sweeps with the exact point solutions, to
round-off; a problem neither solves is flagged (``FRICTION_ERROR``) with the point and
residual in ``ZoneState.fric_info``, and the zone's owner refuses the step.
"""

from __future__ import annotations

import numba
import numpy as np
import numpy.typing as npt

from crane_fem.kernels.zone import FRICTION_ERROR, Zone, ZoneState

__all__ = ["TOL", "contacts_friction", "solve_coulomb", "solve_point"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]

#: Newton stops when ‖Φ‖∞ ≤ TOL × the impulse scale max |q_i| ρ_a (crane_fem.contact.friction).
TOL = 1e-13
MAX_ITER = 200
#: Gauss–Seidel sweeps after a stalled Newton method.
MAX_SWEEPS = 2000


@numba.njit(cache=True)
def _w_times(W: FloatArray, r: FloatArray, q: FloatArray) -> FloatArray:
    """W r + q by rows (no BLAS call: the problems are a few rows)."""
    m = q.size
    u = np.empty(m)
    for i in range(m):
        s = 0.0
        for j in range(m):
            s += W[i, j] * r[j]
        u[i] = s + q[i]
    return u


@numba.njit(cache=True)
def _alart_curnier(
    W: FloatArray,
    q: FloatArray,
    ptr: IntArray,
    mu: FloatArray,
    r: FloatArray,
    phi: FloatArray,
    J: FloatArray,
) -> float:
    """Φ(r) of (7.1) into ``phi``, a generalized Jacobian into ``J``; returns ½‖Φ‖²."""
    m = q.size
    u = _w_times(W, r, q)
    J[:, :] = 0.0
    for a in range(ptr.size - 1):
        i0, i1 = ptr[a], ptr[a + 1]
        rho = 1.0 / W[i0, i0]
        an = r[i0] - rho * u[i0]
        if an > 0.0:
            phi[i0] = r[i0] - an
            for j in range(m):
                J[i0, j] = rho * W[i0, j]
        else:
            phi[i0] = r[i0]
            J[i0, i0] = 1.0
        k = i1 - i0 - 1
        if k == 0:
            continue
        tau = mu[a] * max(0.0, an)
        z = np.empty(k)
        nz2 = 0.0
        for b in range(k):
            z[b] = r[i0 + 1 + b] - rho * u[i0 + 1 + b]
            nz2 += z[b] * z[b]
        nz = np.sqrt(nz2)
        if tau > 0.0 and nz <= tau:  # stick: Φ_t = ρ u_t
            for b in range(k):
                phi[i0 + 1 + b] = rho * u[i0 + 1 + b]
                for j in range(m):
                    J[i0 + 1 + b, j] = rho * W[i0 + 1 + b, j]
            continue
        if tau <= 0.0:  # open, or no normal impulse: Φ_t = r_t
            for b in range(k):
                phi[i0 + 1 + b] = r[i0 + 1 + b]
                J[i0 + 1 + b, i0 + 1 + b] = 1.0
            continue
        # Slide: Φ_t = r_t − τ ẑ; dΦ_t = E_t − (τ/‖z‖)(I − ẑẑᵀ) dz − ẑ dτ.
        zh = z / nz
        c = tau / nz
        dz = np.zeros((k, m))
        for b in range(k):
            dz[b, i0 + 1 + b] = 1.0
            for j in range(m):
                dz[b, j] -= rho * W[i0 + 1 + b, j]
        proj = zh @ dz  # ẑᵀ dz
        for b in range(k):
            phi[i0 + 1 + b] = r[i0 + 1 + b] - tau * zh[b]
            J[i0 + 1 + b, i0 + 1 + b] += 1.0
            for j in range(m):
                dtau = -mu[a] * rho * W[i0, j]
                if j == i0:
                    dtau += mu[a]
                J[i0 + 1 + b, j] -= c * (dz[b, j] - zh[b] * proj[j]) + zh[b] * dtau
    merit = 0.0
    for i in range(m):
        merit += phi[i] * phi[i]
    return 0.5 * merit


@numba.njit(cache=True)
def _point_closed_form(q: FloatArray, w: float, mu: float, r: FloatArray) -> None:
    """(crane_fem.contact.friction.coulomb_point) r of one point with block w I."""
    for i in range(q.size):
        r[i] = 0.0
    rn = max(0.0, -q[0] / w)
    if rn <= 0.0:
        return
    r[0] = rn
    s2 = 0.0
    for i in range(1, q.size):
        s2 += (-q[i] / w) * (-q[i] / w)
    s = np.sqrt(s2)
    lim = mu * rn
    f = 1.0 if s <= lim else lim / s
    for i in range(1, q.size):
        r[i] = (-q[i] / w) * f


@numba.njit(cache=True)
def _residual_point(W: FloatArray, q: FloatArray, mu: float, r: FloatArray) -> float:
    """(crane_fem.contact.friction.coulomb_residual) De Saxcé's natural-map residual of one
    point, relative to its impulse scale."""
    m = q.size
    rho = 1.0 / W[0, 0]
    u = _w_times(W, r, q)
    ut2 = 0.0
    for i in range(1, m):
        ut2 += u[i] * u[i]
    x = np.empty(m)
    x[0] = r[0] - rho * (u[0] + mu * np.sqrt(ut2))
    for i in range(1, m):
        x[i] = r[i] - rho * u[i]
    p = np.zeros(m)  # projection of x on the cone ‖p_t‖ ≤ μ p_n
    if m == 1 or mu == 0.0:
        p[0] = max(0.0, x[0])
    else:
        nt2 = 0.0
        for i in range(1, m):
            nt2 += x[i] * x[i]
        nt = np.sqrt(nt2)
        if nt <= mu * x[0]:
            p[:] = x
        elif mu * nt > -x[0]:
            a = (x[0] + mu * nt) / (1.0 + mu * mu)
            p[0] = a
            for i in range(1, m):
                p[i] = mu * a * x[i] / nt
    err = 0.0
    scale = 0.0
    for i in range(m):
        err = max(err, abs(r[i] - p[i]))
        scale = max(scale, abs(q[i]) * rho)
    return err / scale if scale > 0.0 else err


@numba.njit(cache=True)
def _slip_coefficients(W: FloatArray, q: FloatArray, mu: float) -> FloatArray:
    """The coefficients (a1, a2, b11, b12, b22) of the slip angle's equation
    f(φ) = a1 c + a2 s + b11 c² + b12 c s + b22 s² = 0 (c = cos φ, s = sin φ) of a point
    with two tangential rows."""
    Wnn = W[0, 0]
    w0, w1 = W[1, 0], W[2, 0]
    A00, A01, A11 = W[1, 1], W[1, 2], W[2, 2]
    qn, qt0, qt1 = q[0], q[1], q[2]
    out = np.empty(5)
    out[0] = qn * w1 - Wnn * qt1
    out[1] = -qn * w0 + Wnn * qt0
    out[2] = -qn * mu * A01 + mu * w0 * qt1
    out[3] = qn * mu * (A00 - A11) - mu * w0 * qt0 + mu * w1 * qt1
    out[4] = qn * mu * A01 - mu * w1 * qt0
    return out


@numba.njit(cache=True)
def _polish(f: FloatArray, ph: float) -> float:
    """A slip angle polished by 8 Newton steps on f(φ) (:func:`_slip_coefficients`)."""
    a1, a2, b11, b12, b22 = f[0], f[1], f[2], f[3], f[4]
    for _ in range(8):
        c, s = np.cos(ph), np.sin(ph)
        val = a1 * c + a2 * s + b11 * c * c + b12 * c * s + b22 * s * s
        der = -a1 * s + a2 * c - 2 * b11 * c * s + b12 * (c * c - s * s) + 2 * b22 * s * c
        if der == 0.0:
            break
        ph -= val / der
    return ph


@numba.njit(cache=True)
def _slip_angles(W: FloatArray, q: FloatArray, mu: float) -> FloatArray:
    """(crane_fem.contact.friction._slip_angles) the slip angles φ of a point with two
    tangential rows: roots of a quartic in tan φ/2, and π, polished by Newton on f(φ)."""
    f = _slip_coefficients(W, q, mu)
    a1, a2, b11, b12, b22 = f[0], f[1], f[2], f[3], f[4]
    poly = np.array([b11 - a1, 2 * (a2 - b12), 4 * b22 - 2 * b11, 2 * (a2 + b12), a1 + b11])
    phis = np.empty(5)
    n = 1
    phis[0] = np.pi
    if np.any(poly != 0.0):
        for t in np.roots(poly.astype(np.complex128)):
            if abs(t.imag) <= 1e-6 * max(1.0, abs(t)):
                phis[n] = 2.0 * np.arctan(t.real)
                n += 1
    for k in range(n):
        phis[k] = _polish(f, phis[k])
    return phis[:n]


Block3 = tuple[float, float, float, float, float, float, float, float, float]
Vec3 = tuple[float, float, float]


@numba.njit(cache=True)
def _residual3(W: Block3, q: Vec3, mu: float, r0: float, r1: float, r2: float) -> float:
    """:func:`_residual_point` of a point with two tangential rows, on scalars (``W`` its
    3 × 3 block row by row)."""
    w00, w01, w02, w10, w11, w12, w20, w21, w22 = W
    rho = 1.0 / w00
    u0 = (w00 * r0 + w01 * r1 + w02 * r2) + q[0]
    u1 = (w10 * r0 + w11 * r1 + w12 * r2) + q[1]
    u2 = (w20 * r0 + w21 * r1 + w22 * r2) + q[2]
    x0 = r0 - rho * (u0 + mu * np.sqrt(u1 * u1 + u2 * u2))
    x1 = r1 - rho * u1
    x2 = r2 - rho * u2
    p0 = p1 = p2 = 0.0
    if mu == 0.0:
        p0 = max(0.0, x0)
    else:
        nt = np.sqrt(x1 * x1 + x2 * x2)
        if nt <= mu * x0:
            p0, p1, p2 = x0, x1, x2
        elif mu * nt > -x0:
            a = (x0 + mu * nt) / (1.0 + mu * mu)
            p0 = a
            p1 = mu * a * x1 / nt
            p2 = mu * a * x2 / nt
    err = max(abs(r0 - p0), max(abs(r1 - p1), abs(r2 - p2)))
    scale = max(abs(q[0]) * rho, max(abs(q[1]) * rho, abs(q[2]) * rho))
    return err / scale if scale > 0.0 else err


@numba.njit(cache=True)
def _solve_point3(W: Block3, q: Vec3, mu: float) -> tuple[bool, float, float, float]:
    """:func:`solve_point`'s first candidates for a 3 × 3 block ``W`` (row by row; q_n < 0,
    μ > 0) on scalars, without an allocation: stick by Cramer's rule, else the slip angle
    polished from the stick impulse's direction (:func:`_slip_coefficients`,
    :func:`_polish`). Returns (solved to round-off, r); not solved: the caller enumerates."""
    a, b, c, d, e, f, g, h, i = W
    A, B, C = e * i - f * h, f * g - d * i, d * h - e * g
    det = a * A + b * B + c * C
    s0 = -(A * q[0] + (c * h - b * i) * q[1] + (b * f - c * e) * q[2]) / det
    s1 = -(B * q[0] + (a * i - c * g) * q[1] + (c * d - a * f) * q[2]) / det
    s2 = -(C * q[0] + (b * g - a * h) * q[1] + (a * e - b * d) * q[2]) / det
    st2 = s1 * s1 + s2 * s2
    if s0 > 0.0 and np.sqrt(st2) <= mu * s0:
        return True, s0, s1, s2
    if st2 <= 0.0:
        return False, 0.0, 0.0, 0.0
    qn, qt0, qt1 = q
    a1 = qn * g - a * qt1
    a2 = -qn * d + a * qt0
    b11 = -qn * mu * f + mu * d * qt1
    b12 = qn * mu * (e - i) - mu * d * qt0 + mu * g * qt1
    b22 = qn * mu * f - mu * g * qt0
    ph = np.arctan2(-s2, -s1)
    for _ in range(8):
        co, si = np.cos(ph), np.sin(ph)
        val = a1 * co + a2 * si + b11 * co * co + b12 * co * si + b22 * si * si
        der = -a1 * si + a2 * co - 2 * b11 * co * si + b12 * (co * co - si * si) + 2 * b22 * si * co
        if der == 0.0:
            break
        ph -= val / der
    co, si = np.cos(ph), np.sin(ph)
    an = a - mu * (b * co + c * si)
    if an == 0.0 or -qn / an <= 0.0:
        return False, 0.0, 0.0, 0.0
    rn = -qn / an
    c0, c1, c2 = rn, -mu * rn * co, -mu * rn * si
    if _residual3(W, q, mu, c0, c1, c2) <= 10 * TOL:
        return True, c0, c1, c2
    return False, 0.0, 0.0, 0.0


@numba.njit(cache=True)
def solve_point(
    W: FloatArray, q: FloatArray, mu: float, r: FloatArray, small: bool = False
) -> bool:
    """(crane_fem.contact.friction.solve_point) the exact impulse r of one point with any
    Delassus block W: separation, stick, or the slip candidate of smallest residual.
    Returns whether it solves the problem to round-off. ``small``: a 3 × 3 block's stick
    impulse by Cramer's rule, then first the slip angle nearest the stick impulse's
    direction (:func:`_solve_point3`; a beam's wheel: LAPACK's call costs more than the
    solve, the quartic's roots a complex eigenvalue problem, ten times the rest of the
    step)."""
    m = q.size
    for i in range(m):
        r[i] = 0.0
    if q[0] >= 0.0:
        return True
    if m == 1 or mu == 0.0:
        r[0] = -q[0] / W[0, 0]
        return True
    if small and m == 3:
        W9 = (W[0, 0], W[0, 1], W[0, 2], W[1, 0], W[1, 1], W[1, 2], W[2, 0], W[2, 1], W[2, 2])
        ok, r[0], r[1], r[2] = _solve_point3(W9, (q[0], q[1], q[2]), mu)
        if ok:
            return True
    else:
        stick = -np.linalg.solve(W, q)
        st2 = 0.0
        for i in range(1, m):
            st2 += stick[i] * stick[i]
        if stick[0] > 0.0 and np.sqrt(st2) <= mu * stick[0]:
            r[:] = stick
            return True
    if m == 2:
        dirs = np.array([[1.0, 0.0], [-1.0, 0.0]])
    else:
        phis = _slip_angles(W, q, mu)
        dirs = np.empty((phis.size, 2))
        for k in range(phis.size):
            dirs[k, 0] = np.cos(phis[k])
            dirs[k, 1] = np.sin(phis[k])
    best = np.inf
    cand = np.empty(m)
    for k in range(dirs.shape[0]):
        a = W[0, 0]
        for i in range(1, m):
            a -= mu * W[0, i] * dirs[k, i - 1]
        if a == 0.0:
            continue
        rn = -q[0] / a
        if rn <= 0.0:
            continue
        cand[0] = rn
        for i in range(1, m):
            cand[i] = -mu * rn * dirs[k, i - 1]
        res = _residual_point(W, q, mu, cand)
        if res < best:
            best = res
            r[:] = cand
    return best <= 10 * TOL


@numba.njit(cache=True)
def _newton_direction(J: FloatArray, phi: FloatArray) -> FloatArray:
    """d solving J d = −Φ: by LU (20× cheaper than the least-squares SVD on a 111-row
    problem, a cabinet's 37 feet on a floor), by least squares where J is singular (a
    degenerate point: zero normal and tangential free velocity)."""
    try:
        d = np.linalg.solve(J, -phi)
    except Exception:  # singular J: numba raises LinAlgError
        return np.linalg.lstsq(J, -phi)[0]
    for i in range(d.size):
        if not np.isfinite(d[i]):
            return np.linalg.lstsq(J, -phi)[0]
    return d


@numba.njit(cache=True)
def solve_coulomb(
    W: FloatArray, q: FloatArray, ptr: IntArray, mu: FloatArray, r: FloatArray
) -> tuple[float, int]:
    """r solving (7.1) by semismooth Newton with an Armijo line search on ½‖Φ‖², from each
    point's closed form with its block taken as W_nn I, then Gauss–Seidel sweeps with
    :func:`solve_point` if Newton stalls. Returns (‖Φ‖∞ relative to the impulse scale, the
    point where it is largest); converged when ≤ :data:`TOL`.
    Not collective: every rank holds the same W and q and gets the same answer."""
    m = q.size
    na = ptr.size - 1
    scale = 0.0
    for a in range(na):
        i0, i1 = ptr[a], ptr[a + 1]
        _point_closed_form(q[i0:i1], W[i0, i0], mu[a], r[i0:i1])
        for i in range(i0, i1):
            scale = max(scale, abs(q[i]) / W[i0, i0])
    if scale == 0.0:
        return 0.0, 0
    phi = np.empty(m)
    J = np.empty((m, m))
    phi_t = np.empty(m)
    J_t = np.empty((m, m))
    merit = _alart_curnier(W, q, ptr, mu, r, phi, J)
    for _ in range(MAX_ITER):
        res = 0.0
        for i in range(m):
            res = max(res, abs(phi[i]))
        if res <= TOL * scale:
            break
        d = _newton_direction(J, phi)
        step = 1.0
        trial = r + d
        merit_t = merit
        for _ls in range(40):
            trial = r + step * d
            merit_t = _alart_curnier(W, q, ptr, mu, trial, phi_t, J_t)
            if merit_t <= (1.0 - 2e-4 * step) * merit:
                break
            step *= 0.5
        r[:] = trial
        phi[:] = phi_t
        J[:, :] = J_t
        merit = merit_t
    res = 0.0
    for i in range(m):
        res = max(res, abs(phi[i]))
    if res > TOL * scale:
        # The general path's flag as a boolean value: a literal False is a type of its own,
        # for which numba would compile solve_point (and its callees) a second time.
        general = m < 0
        for _ in range(MAX_SWEEPS):
            for a in range(na):
                i0, i1 = ptr[a], ptr[a + 1]
                qa = q[i0:i1].copy()
                for i in range(i0, i1):
                    for j in range(m):
                        if j < i0 or j >= i1:
                            qa[i - i0] += W[i, j] * r[j]
                solve_point(np.ascontiguousarray(W[i0:i1, i0:i1]), qa, mu[a], r[i0:i1], general)
            _alart_curnier(W, q, ptr, mu, r, phi, J)
            res = 0.0
            for i in range(m):
                res = max(res, abs(phi[i]))
            if res <= TOL * scale:
                break
    res = 0.0
    worst = 0
    for a in range(na):
        for i in range(ptr[a], ptr[a + 1]):
            if abs(phi[i]) / scale > res:
                res = abs(phi[i]) / scale
                worst = a
    return res, worst


@numba.njit(cache=True)
def _fail(st: ZoneState, flags: IntArray, point: int, res: float) -> None:
    if flags[FRICTION_ERROR] == 0 or res > st.fric_info[1]:
        st.fric_info[0] = point
        st.fric_info[1] = res
    flags[FRICTION_ERROR] = 1


@numba.njit(cache=True)
def contacts_friction(
    z: Zone, st: ZoneState, closed: BoolArray, lam_c: FloatArray, flags: IntArray
) -> None:
    """Normal impulses ``lam_c`` and tangential impulses ``st.lam_t`` of the closed points
    (zero on open points) from the frictional contact problem; the free velocities are
    ``st.qc`` (normal rows) and ``st.qt`` (tangential rows). Not collective."""
    pc = closed.size
    lam_t = st.lam_t
    for c in range(pc):
        lam_c[c] = 0.0
    for k in range(lam_t.size):
        lam_t[k] = 0.0
    any_closed = False
    for c in range(pc):
        any_closed = any_closed or closed[c]
    if not any_closed:  # (in flight: nothing to solve)
        return
    if z.fric_local:
        for c in range(pc):
            if closed[c]:
                _single(z, st, c, lam_c, flags)
        return
    # Points coupled through shared DOFs: one problem over the closed points of each
    # component of the coupling (the problems of two components are independent).
    for k in range(z.fric_ptr.size - 1):
        comp = z.fric_order[z.fric_ptr[k] : z.fric_ptr[k + 1]]
        n_closed = 0
        for c in comp:
            if closed[c]:
                n_closed += 1
        if n_closed == 0:
            continue
        if n_closed == 1:
            # One closed point in its component (a beam's wheel with its flanges open, a
            # solid wheel's point on its own rail triangle): its own problem.
            for c in comp:
                if closed[c]:
                    _single(z, st, c, lam_c, flags)
            continue
        idx = np.empty(n_closed, dtype=np.int64)
        n_closed = 0
        for c in comp:
            if closed[c]:
                idx[n_closed] = c
                n_closed += 1
        _coupled(z, st, idx, lam_c, flags)


@numba.njit(cache=True)
def _single(z: Zone, st: ZoneState, c: int, lam_c: FloatArray, flags: IntArray) -> None:
    """The frictional problem of the one closed point ``c`` (its own rows only): the closed
    form where its block is isotropic, else :func:`solve_point`. Not collective."""
    lam_t, qc, qt = st.lam_t, st.qc, st.qt
    nk = z.t_count[c]
    if nk == 0:  # frictionless: the normal law's closed form
        lam_c[c] = max(0.0, -qc[c] / z.W_cc[c, c])
        return
    k0 = z.t_first[c]
    w = z.W_cc[c, c]
    if z.iso[c]:
        rn = max(0.0, -qc[c] / w)
        lam_c[c] = rn
        if rn > 0.0:
            s2 = 0.0
            for k in range(nk):
                s2 += (-qt[k0 + k] / w) * (-qt[k0 + k] / w)
            s = np.sqrt(s2)
            lim = z.mu[c] * rn
            f = 1.0 if s <= lim else lim / s
            for k in range(nk):
                lam_t[k0 + k] = (-qt[k0 + k] / w) * f
        return
    if nk == 2 and qc[c] < 0.0 and z.mu[c] != 0.0:
        # A point with two tangential rows: its 3 × 3 problem on scalars (no allocation),
        # the general path only where its first candidates fail.
        t0, t1 = k0, k0 + 1
        wn0, wn1 = z.W_nt[c, t0], z.W_nt[c, t1]
        W9 = (w, wn0, wn1, wn0, z.W_tt[t0, t0], z.W_tt[t0, t1], wn1, z.W_tt[t1, t0], z.W_tt[t1, t1])
        ok, r0, r1, r2 = _solve_point3(W9, (qc[c], qt[t0], qt[t1]), z.mu[c])
        if ok:
            lam_c[c], lam_t[t0], lam_t[t1] = r0, r1, r2
            return
    Wl = np.empty((nk + 1, nk + 1))
    ql = np.empty(nk + 1)
    Wl[0, 0] = w
    ql[0] = qc[c]
    for a in range(nk):
        ql[1 + a] = qt[k0 + a]
        Wl[0, 1 + a] = z.W_nt[c, k0 + a]
        Wl[1 + a, 0] = z.W_nt[c, k0 + a]
        for b in range(nk):
            Wl[1 + a, 1 + b] = z.W_tt[k0 + a, k0 + b]
    rl = np.empty(nk + 1)
    if not solve_point(Wl, ql, z.mu[c], rl, z.bs == 6):
        _fail(st, flags, c, _residual_point(Wl, ql, z.mu[c], rl))
    lam_c[c] = rl[0]
    for a in range(nk):
        lam_t[k0 + a] = rl[1 + a]


@numba.njit(cache=True)
def _coupled(z: Zone, st: ZoneState, idx: IntArray, lam_c: FloatArray, flags: IntArray) -> None:
    """The frictional problem of the closed points ``idx``, coupled through shared DOFs, as
    one problem (:func:`solve_coulomb`). Not collective."""
    pc = lam_c.size
    lam_t, qc, qt = st.lam_t, st.qc, st.qt
    na = idx.size
    ptr = np.zeros(na + 1, dtype=np.int64)
    for a in range(na):
        ptr[a + 1] = ptr[a] + 1 + z.t_count[idx[a]]
    m = ptr[na]
    rows = np.empty(m, dtype=np.int64)  # full-row index: c (normal) or pc + k (tangent)
    mus = np.empty(na)
    for a in range(na):
        c = idx[a]
        mus[a] = z.mu[c]
        rows[ptr[a]] = c
        for b in range(z.t_count[c]):
            rows[ptr[a] + 1 + b] = pc + z.t_first[c] + b
    Wl = np.empty((m, m))
    ql = np.empty(m)
    for i in range(m):
        ri = rows[i]
        ql[i] = qc[ri] if ri < pc else qt[ri - pc]
        for j in range(m):
            rj = rows[j]
            if ri < pc and rj < pc:
                Wl[i, j] = z.W_cc[ri, rj]
            elif ri < pc:
                Wl[i, j] = z.W_nt[ri, rj - pc]
            elif rj < pc:
                Wl[i, j] = z.W_nt[rj, ri - pc]
            else:
                Wl[i, j] = z.W_tt[ri - pc, rj - pc]
    rl = np.empty(m)
    res, worst = solve_coulomb(Wl, ql, ptr, mus, rl)
    if res > TOL:
        _fail(st, flags, idx[worst], res)
    for i in range(m):
        ri = rows[i]
        if ri < pc:
            lam_c[ri] = rl[i]
        else:
            lam_t[ri - pc] = rl[i]
