"""Exact solution of the small velocity-level LCP 0 ≤ Λ ⟂ q + W Λ ≥ 0 (W symmetric positive)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import numpy.typing as npt
import scipy.linalg

__all__ = ["solve_lcp", "solve_mixed_lcp", "solve_mixed_lcp_blocks"]

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
    from scipy.optimize import nnls  # (here: a quarter of a second at start-up, rarely used)

    sol, _ = nnls(R, b)
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
    if n_eq == 0:
        z = np.zeros_like(q)
        c = np.flatnonzero(active)
        if c.size == 0:  # every point open: nothing to solve
            return z
        sub = A[np.ix_(c, c)]
        diag = bool(np.all(sub == np.diag(np.diag(sub))))
        z[c] = solve_lcp(sub, q[c], np.ones(c.size, dtype=bool), diag)
        return z
    if solve_eq is None:
        factor = scipy.linalg.cho_factor(A[:n_eq, :n_eq])

        def solve_eq(x: FloatArray) -> FloatArray:
            return np.asarray(scipy.linalg.cho_solve(factor, x))

    z_e, z_c = solve_mixed_lcp_blocks(
        solve_eq, A[:n_eq, n_eq:], A[n_eq:, n_eq:], q[:n_eq], q[n_eq:], active
    )
    return np.concatenate([z_e, z_c])


def solve_mixed_lcp_blocks(
    solve_eq: Callable[[FloatArray], FloatArray],
    A_ec: FloatArray,
    A_cc: FloatArray,
    q_e: FloatArray,
    q_c: FloatArray,
    active: npt.NDArray[np.bool_],
    cc_diagonal: bool | None = None,
    ec_zero: bool = False,
) -> tuple[FloatArray, FloatArray]:
    """:func:`solve_mixed_lcp` given by blocks, the equality block only through ``solve_eq``.

    Only the active columns of ``A_ec`` that are not zero are passed to ``solve_eq`` (a
    contact point sharing no DOF with the equality rows costs nothing), so n_e × n_e work is
    done once per call plus once per coupled active contact. ``cc_diagonal`` may tell that
    ``A_cc`` is diagonal (checked otherwise), ``ec_zero`` that ``A_ec`` is zero (no contact
    shares a DOF with an equality row: two independent problems). Not collective.

    Returns:
        ``(z_e, z_c)``.
    """
    z_c = np.zeros_like(q_c)
    z_e = -solve_eq(q_e)
    c = np.flatnonzero(active)
    if c.size == 0:
        return z_e, z_c
    if ec_zero and cc_diagonal:
        z_c[c] = np.maximum(0.0, -q_c[c] / np.diagonal(A_cc)[c])
        return z_e, z_c
    Aec = A_ec[:, c]
    coupled = np.flatnonzero(np.any(Aec != 0.0, axis=0))
    S = A_cc[np.ix_(c, c)]
    qs = q_c[c] + Aec.T @ z_e
    if coupled.size:
        Y = solve_eq(Aec[:, coupled])
        S = S.copy()
        S[:, coupled] -= Aec.T @ Y
        S = 0.5 * (S + S.T)
        diag = False
    elif cc_diagonal is not None:
        diag = cc_diagonal
    else:
        diag = bool(np.all(S == np.diag(np.diag(S))))
    z_c[c] = solve_lcp(S, qs, np.ones(c.size, dtype=bool), diag)
    if coupled.size:
        z_e -= solve_eq(Aec @ z_c[c])
    return z_e, z_c
