"""The small exact LCP 0 ≤ Λ ⟂ q + W Λ ≥ 0 (W symmetric positive definite), compiled.

The optimality system of min ½ ΛᵀWΛ + qᵀΛ over Λ ≥ 0, solved by the Lawson–Hanson active-set
method written on W itself (crane_fem.contact.lcp solves it as non-negative least squares on
the Cholesky factor of W, with SciPy's NNLS: the same iterates in exact arithmetic). It ends
after finitely many exchanges with the exact solution up to round-off.
"""

from __future__ import annotations

import numba
import numpy as np
import numpy.typing as npt

__all__ = ["lcp_exact"]

FloatArray = npt.NDArray[np.float64]


@numba.njit(cache=True)
def _solve_passive(W: FloatArray, q: FloatArray, passive: npt.NDArray[np.bool_]) -> FloatArray:
    """s with W_PP s_P = −q_P and s = 0 off the passive set P."""
    idx = np.flatnonzero(passive)
    s = np.zeros(q.size)
    if idx.size == 0:
        return s
    A = np.empty((idx.size, idx.size))
    b = np.empty(idx.size)
    for a in range(idx.size):
        b[a] = -q[idx[a]]
        for c in range(idx.size):
            A[a, c] = W[idx[a], idx[c]]
    x = np.linalg.solve(A, b)
    for a in range(idx.size):
        s[idx[a]] = x[a]
    return s


@numba.njit(cache=True)
def lcp_exact(W: FloatArray, q: FloatArray) -> tuple[FloatArray, bool]:
    """Λ with 0 ≤ Λ ⟂ q + WΛ ≥ 0 on every row; returns (Λ, converged).

    Not collective: every rank holds the same W and q and gets the same answer.
    """
    n = q.size
    lam = np.zeros(n)
    passive = np.zeros(n, dtype=np.bool_)
    scale = 0.0
    for i in range(n):
        scale = max(scale, abs(q[i]))
    tol = 1e-13 * scale
    for _ in range(3 * n + 10):
        grad = q + W @ lam
        t = -1
        best = tol
        for i in range(n):
            if not passive[i] and -grad[i] > best:
                best = -grad[i]
                t = i
        if t < 0:
            return lam, True
        passive[t] = True
        for _inner in range(3 * n + 10):
            s = _solve_passive(W, q, passive)
            feasible = True
            for i in range(n):
                if passive[i] and s[i] <= 0.0:
                    feasible = False
            if feasible:
                lam = s
                break
            # Step from Λ towards s until a passive component reaches zero; drop it.
            alpha = 1.0
            for i in range(n):
                if passive[i] and s[i] <= 0.0:
                    alpha = min(alpha, lam[i] / (lam[i] - s[i]))
            lam = lam + alpha * (s - lam)
            for i in range(n):
                if passive[i] and lam[i] <= 1e-300:
                    passive[i] = False
                    lam[i] = 0.0
    return lam, False
