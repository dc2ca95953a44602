"""Coulomb friction at velocity level: the frictional contact problem of one CD-Lagrange step
(THEORY.md §7), in NumPy — the reference of the compiled solver
(:mod:`crane_fem.kernels.friction`) and of the tests.

The problem, over closed contact points a with local rows (n, t₁[, t₂]) (the point's normal
row first): impulses r, local velocities u = W r + q (W the Delassus operator of the rows,
q the free velocities), and at every point

    r_n ≥ 0, u_n ≥ 0, r_n u_n = 0                           (Signorini, velocity level)
    ‖r_t‖ ≤ μ r_n;  u_t = 0 (stick)  or  r_t = −μ r_n u_t/‖u_t‖ (slide)         (Coulomb)

(μ = 0: no tangential row). Its Alart–Curnier form, with ρ_a = 1/W_nn of point a:

    Φ_n = r_n − max(0, r_n − ρ u_n)
    Φ_t = r_t − P_{B(μ max(0, r_n − ρ u_n))}(r_t − ρ u_t)                          (7.1)

(P_B(τ) the projection on the disc of radius τ); Φ(r) = 0 exactly when r solves the problem.
With W = w I on a point (lumped mass, orthonormal rows on its own DOFs: w = 1/m node to
plane), ρ = 1/w makes (7.1) explicit, the closed form of :func:`coulomb_point`. One point
with any W: the exact enumeration of :func:`solve_point` (separation, stick, then the slip
directions, roots of a quartic). Points that share DOFs: a semismooth Newton method on (7.1)
with an Armijo line search on ½‖Φ‖², and where it stalls (large μ with strongly coupled
rows) nonsmooth Gauss–Seidel sweeps with :func:`solve_point` at each point, both stopped at
round-off (:func:`solve_coulomb`).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["alart_curnier", "coulomb_point", "coulomb_residual", "solve_coulomb", "solve_point"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

#: Newton stops when ‖Φ‖∞ ≤ TOL × the impulse scale max |q_i| ρ_a (round-off of u = W r + q).
TOL = 1e-13
MAX_ITER = 200
#: Gauss–Seidel sweeps after a stalled Newton method.
MAX_SWEEPS = 2000


def coulomb_point(q: FloatArray, w: float, mu: float) -> FloatArray:
    """The exact impulse (r_n, r_t) of one point whose Delassus block is w I (closed form).

    Trial r = −q / w. Separation (r_n ≤ 0): r = 0. Otherwise r_n = −q_n / w (u_n = 0), and the
    trial tangential impulse is kept if ‖r_t‖ ≤ μ r_n (stick, u_t = 0), else radially
    returned onto the disc ‖r_t‖ = μ r_n (slide: r_t = −μ r_n q_t/‖q_t‖, u_t ∥ q_t). The
    normal impulse is not changed by the return: this is Coulomb's law, not the orthogonal
    projection of the trial onto the cone (the associated law, which would lift the point).
    Not collective."""
    r = np.zeros_like(q)
    rn = max(0.0, -q[0] / w)
    if rn <= 0.0:
        return r
    r[0] = rn
    rt = -q[1:] / w
    s = float(np.sqrt(rt @ rt))
    lim = mu * rn
    r[1:] = rt if s <= lim else rt * (lim / s)
    return r


def _slip_angles(W: FloatArray, q: FloatArray, mu: float) -> list[float]:
    """The slip directions d = (cos φ, sin φ) of a point with two tangential rows at which
    u_t = r_n b(d) + q_t is parallel to d, with r_n = −q_n / a(d), a = W_nn − μ W_nt d and
    b = W_tn − μ W_tt d: the roots of f(φ) = −q_n b × d + a q_t × d, a trigonometric
    polynomial of degree 2 (a quartic in tan φ/2), polished by Newton's method on f."""
    Wnn, w, A = W[0, 0], W[1:, 0], W[1:, 1:]
    qn, qt = q[0], q[1:]
    # f = a1 c + a2 s + b11 c² + b12 c s + b22 s² (c = cos φ, s = sin φ).
    a1 = qn * w[1] - Wnn * qt[1]
    a2 = -qn * w[0] + Wnn * qt[0]
    b11 = -qn * mu * A[0, 1] + mu * w[0] * qt[1]
    b22 = qn * mu * A[0, 1] - mu * w[1] * qt[0]
    b12 = qn * mu * (A[0, 0] - A[1, 1]) - mu * w[0] * qt[0] + mu * w[1] * qt[1]

    def f(ph: float) -> tuple[float, float]:
        c, s = np.cos(ph), np.sin(ph)
        val = a1 * c + a2 * s + b11 * c * c + b12 * c * s + b22 * s * s
        der = -a1 * s + a2 * c - 2 * b11 * c * s + b12 * (c * c - s * s) + 2 * b22 * s * c
        return float(val), float(der)

    # t = tan φ/2: (1 + t²)² f = p4 t⁴ + p3 t³ + p2 t² + p1 t + p0 (φ = π apart).
    poly = [b11 - a1, 2 * (a2 - b12), 4 * b22 - 2 * b11, 2 * (a2 + b12), a1 + b11]
    phis = [float(np.pi)]
    if any(poly):
        for t in np.roots(poly):
            if abs(t.imag) <= 1e-6 * max(1.0, abs(t)):
                phis.append(2.0 * float(np.arctan(t.real)))
    out = []
    for ph in phis:
        for _ in range(8):
            val, der = f(ph)
            if der == 0.0:
                break
            ph -= val / der
        out.append(ph)
    return out


def solve_point(W: FloatArray, q: FloatArray, mu: float) -> tuple[FloatArray, bool]:
    """The exact impulse of one point with any Delassus block W (1 + k rows, k = 0, 1, 2):
    separation (q_n ≥ 0: r = 0), else stick (r = −W⁻¹ q inside the cone), else the slip
    candidates r = r_n (1, −μ d) with u_n = 0 and u_t = α d, α ≥ 0 (d = ±1 for one
    tangential row; for two, the slip angles of :func:`_slip_angles`), the one with the
    smallest :func:`coulomb_residual`. Returns (r, found). Not collective."""
    m = q.size
    r = np.zeros(m)
    if q[0] >= 0.0:
        return r, True
    if m == 1 or mu == 0.0:
        r[0] = -q[0] / W[0, 0]
        return r, True
    stick = -np.linalg.solve(W, q)
    if stick[0] > 0.0 and float(np.sqrt(stick[1:] @ stick[1:])) <= mu * stick[0]:
        return stick, True
    if m == 2:
        dirs = [np.array([1.0]), np.array([-1.0])]
    else:
        dirs = [np.array([np.cos(ph), np.sin(ph)]) for ph in _slip_angles(W, q, mu)]
    best, best_res = r, np.inf
    ptr, mus = np.array([0, m]), np.array([mu])
    for d in dirs:
        a = W[0, 0] - mu * float(W[0, 1:] @ d)
        if a == 0.0:
            continue
        rn = -q[0] / a
        if rn <= 0.0:
            continue
        cand = np.r_[rn, -mu * rn * d]
        res = coulomb_residual(W, q, ptr, mus, cand)
        if res < best_res:
            best, best_res = cand, res
    return best, bool(best_res <= 10 * TOL)


def _blocks(ptr: IntArray) -> list[tuple[int, int]]:
    return [(int(ptr[a]), int(ptr[a + 1])) for a in range(ptr.size - 1)]


def alart_curnier(
    W: FloatArray, q: FloatArray, ptr: IntArray, mu: FloatArray, r: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Φ(r) of (7.1) and an element of its generalized Jacobian (not collective).

    Args:
        W, q: the Delassus operator (m × m) and free velocities (m) of the rows.
        ptr: (na + 1) the rows of point a are ptr[a]:ptr[a+1], its normal row first.
        mu: (na) friction coefficients.
        r: (m) impulses.
    """
    u = W @ r + q
    m = q.size
    phi = np.zeros(m)
    J = np.zeros((m, m))
    for a, (i0, i1) in enumerate(_blocks(ptr)):
        rho = 1.0 / W[i0, i0]
        an = r[i0] - rho * u[i0]
        if an > 0.0:
            phi[i0] = r[i0] - an
            J[i0] = rho * W[i0]
        else:
            phi[i0] = r[i0]
            J[i0, i0] = 1.0
        if i1 - i0 == 1:
            continue
        t = slice(i0 + 1, i1)
        tau = mu[a] * max(0.0, an)
        z = r[t] - rho * u[t]
        nz = float(np.sqrt(z @ z))
        if tau > 0.0 and nz <= tau:  # stick: Φ_t = ρ u_t
            phi[t] = rho * u[t]
            J[t] = rho * W[t]
            continue
        k = i1 - i0 - 1
        Et = np.zeros((k, m))
        Et[:, i0 + 1 : i1] = np.eye(k)
        if tau <= 0.0:  # open or no normal impulse: Φ_t = r_t
            phi[t] = r[t]
            J[t] = Et
            continue
        zh = z / nz
        phi[t] = r[t] - tau * zh
        dz = Et - rho * W[t]
        en = np.zeros(m)
        en[i0] = 1.0
        dtau = mu[a] * (en - rho * W[i0])
        J[t] = Et - (tau / nz) * (dz - np.outer(zh, zh @ dz)) - np.outer(zh, dtau)
    return phi, J


def _start(W: FloatArray, q: FloatArray, ptr: IntArray, mu: FloatArray) -> FloatArray:
    """Each point alone with its block taken as W_nn I: the closed form (the solution when the
    points do not couple and their blocks are isotropic)."""
    r = np.zeros_like(q)
    for a, (i0, i1) in enumerate(_blocks(ptr)):
        r[i0:i1] = coulomb_point(q[i0:i1], float(W[i0, i0]), float(mu[a]))
    return r


def _scale(W: FloatArray, q: FloatArray, ptr: IntArray) -> float:
    s = 0.0
    for i0, i1 in _blocks(ptr):
        s = max(s, float(np.max(np.abs(q[i0:i1]))) / W[i0, i0])
    return s


def solve_coulomb(
    W: FloatArray, q: FloatArray, ptr: IntArray, mu: FloatArray
) -> tuple[FloatArray, float, int]:
    """The impulses of the frictional contact problem (7.1): semismooth Newton, then
    Gauss–Seidel sweeps with the exact point solutions if Newton stalls.

    Not collective. Returns ``(r, residual, worst)``: the residual ‖Φ‖∞ relative to the
    impulse scale (≤ :data:`TOL` when converged) and the point where it is largest."""
    scale = _scale(W, q, ptr)
    r = _start(W, q, ptr, mu)
    if scale == 0.0:
        return r, 0.0, 0
    phi, J = alart_curnier(W, q, ptr, mu, r)
    for _ in range(MAX_ITER):
        if np.max(np.abs(phi)) <= TOL * scale:
            break
        try:
            d = np.linalg.solve(J, -phi)
        except np.linalg.LinAlgError:
            d = np.linalg.lstsq(J, -phi, rcond=None)[0]
        merit = 0.5 * float(phi @ phi)
        step = 1.0
        for _ls in range(40):
            trial = r + step * d
            phi_t, J_t = alart_curnier(W, q, ptr, mu, trial)
            if 0.5 * float(phi_t @ phi_t) <= (1.0 - 2e-4 * step) * merit:
                break
            step *= 0.5
        r, phi, J = trial, phi_t, J_t
    blocks = _blocks(ptr)
    for _ in range(MAX_SWEEPS if np.max(np.abs(phi)) > TOL * scale else 0):
        for a, (i0, i1) in enumerate(blocks):
            q_a = q[i0:i1] + W[i0:i1] @ r - W[i0:i1, i0:i1] @ r[i0:i1]
            r[i0:i1] = solve_point(W[i0:i1, i0:i1], q_a, float(mu[a]))[0]
        phi, _ = alart_curnier(W, q, ptr, mu, r)
        if np.max(np.abs(phi)) <= TOL * scale:
            break
    res = np.abs(phi) / scale
    worst = int(np.searchsorted(ptr, int(np.argmax(res)), side="right") - 1)
    return r, float(np.max(res)), worst


def coulomb_residual(
    W: FloatArray, q: FloatArray, ptr: IntArray, mu: FloatArray, r: FloatArray
) -> float:
    """How far ``r`` is from solving the problem, relative to the impulse scale, in De Saxcé's
    natural-map form (independent of (7.1)): ‖r − P_K(r − ρ (u + μ‖u_t‖ n))‖∞ with K the
    cone ‖r_t‖ ≤ μ r_n (μ = 0: the half-line r_n ≥ 0). Not collective."""
    u = W @ r + q
    err = 0.0
    for a, (i0, i1) in enumerate(_blocks(ptr)):
        rho = 1.0 / W[i0, i0]
        ut = u[i0 + 1 : i1]
        s = r[i0:i1].copy()
        s[0] -= rho * (u[i0] + mu[a] * float(np.sqrt(ut @ ut)))
        s[1:] -= rho * ut
        proj = _project_cone(s, float(mu[a]))
        err = max(err, float(np.max(np.abs(r[i0:i1] - proj))))
    scale = _scale(W, q, ptr)
    return err / scale if scale > 0.0 else err


def _project_cone(x: FloatArray, mu: float) -> FloatArray:
    """Orthogonal projection on K = {‖x_t‖ ≤ μ x_n}."""
    out = np.zeros_like(x)
    if x.size == 1 or mu == 0.0:
        out[0] = max(0.0, x[0])
        return out
    xn, xt = x[0], x[1:]
    nt = float(np.sqrt(xt @ xt))
    if nt <= mu * xn:
        return x.copy()
    if mu * nt <= -xn:
        return out
    a = (xn + mu * nt) / (1.0 + mu * mu)
    out[0] = a
    out[1:] = mu * a * xt / nt
    return out
