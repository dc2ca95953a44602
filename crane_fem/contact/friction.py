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
plane), ρ = 1/w makes (7.1) explicit, the closed form of :func:`coulomb_point`. Otherwise a
semismooth Newton method on (7.1) with an Armijo line search on ½‖Φ‖², stopped at round-off
(:func:`solve_coulomb`).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["alart_curnier", "coulomb_point", "coulomb_residual", "solve_coulomb"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

#: Newton stops when ‖Φ‖∞ ≤ TOL × the impulse scale max |q_i| ρ_a (round-off of u = W r + q).
TOL = 1e-13
MAX_ITER = 200


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
    """The impulses of the frictional contact problem (7.1) by semismooth Newton.

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
        s = r[i0 : i1].copy()
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
