"""Exact solution of the small velocity-level LCP 0 ≤ Λ ⟂ q + W Λ ≥ 0 (W symmetric positive)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import numpy.typing as npt
import scipy.linalg
import scipy.optimize

__all__ = ["solve_lcp", "solve_mixed_lcp"]

FloatArray = npt.NDArray[np.float64]


def solve_lcp(
    W: FloatArray, q: FloatArray, active: npt.NDArray[np.bool_], diagonal: bool
) -> FloatArray:
    """Impulses Λ with 0 ≤ Λ ⟂ q + W Λ ≥ 0 on ``active`` points and Λ = 0 elsewhere.

    Not collective: every rank holds the same ``W`` and ``q`` and gets the same answer.

    Args:
        W: Delassus operator (p × p, symmetric positive definite on the active set).
        q: free relative normal velocities (p,).
        active: points whose gap is closed (g ≤ 0).
        diagonal: ``W`` is diagonal (contact points share no DOF): closed form, point by point.

    Returns:
        Λ (p,), the impulses (N·s).
    """
    lam = np.zeros_like(q)
    idx = np.flatnonzero(active)
    if idx.size == 0:
        return lam
    if diagonal:
        lam[idx] = np.maximum(0.0, -q[idx] / W[idx, idx])
        return lam
    # With W = Rᵀ R, the LCP is the optimality system of min ½ΛᵀWΛ + qᵀΛ over Λ ≥ 0,
    # i.e. the non-negative least-squares problem min |R Λ + R⁻ᵀ q|²; Lawson–Hanson's
    # active-set NNLS terminates finitely with the exact solution (up to round-off).
    Waa = W[np.ix_(idx, idx)]
    try:
        R = scipy.linalg.cholesky(Waa, lower=False)
    except np.linalg.LinAlgError:
        raise ValueError(
            "contact Delassus operator is singular: two active constraints are redundant"
        ) from None
    b = -scipy.linalg.solve_triangular(R, q[idx], trans="T", lower=False)
    sol, _ = scipy.optimize.nnls(R, b)
    lam[idx] = sol
    return lam


def solve_mixed_lcp(
    A: FloatArray,
    q: FloatArray,
    n_eq: int,
    active: npt.NDArray[np.bool_],
    solve_eq: Callable[[FloatArray], FloatArray] | None = None,
) -> FloatArray:
    """Solve A z + q = 0 on the first ``n_eq`` rows (z free) and 0 ≤ z ⟂ A z + q ≥ 0 on the
    ``active`` remaining rows (z = 0 on inactive ones), A symmetric positive definite.

    The free block is eliminated exactly (Cholesky, or ``solve_eq`` = its inverse applied to a
    vector or matrix when the caller has it pre-factored); the Schur complement, symmetric
    positive definite, gives a plain LCP solved by :func:`solve_lcp`. Not collective.
    """
    z = np.zeros_like(q)
    c = n_eq + np.flatnonzero(active)
    if n_eq == 0:
        sub = A[np.ix_(c, c)]
        diag = bool(np.all(sub == np.diag(np.diag(sub))))
        z[c] = solve_lcp(sub, q[c], np.ones(c.size, dtype=bool), diag)
        return z
    e = np.arange(n_eq)
    if solve_eq is None:
        factor = scipy.linalg.cho_factor(A[np.ix_(e, e)])

        def solve_eq(x: FloatArray) -> FloatArray:
            return np.asarray(scipy.linalg.cho_solve(factor, x))

    if c.size:
        Aec = A[np.ix_(e, c)]
        Y = solve_eq(Aec)
        S = A[np.ix_(c, c)] - Aec.T @ Y
        S = 0.5 * (S + S.T)
        qs = q[c] - Y.T @ q[e]
        z[c] = solve_lcp(S, qs, np.ones(c.size, dtype=bool), diagonal=False)
        z[e] = -solve_eq(q[e] + Aec @ z[c])
    else:
        z[e] = -solve_eq(q[e])
    return z
