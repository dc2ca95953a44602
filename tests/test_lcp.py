"""The exact LCP solver against brute-force enumeration of complementary bases."""

import itertools

import numpy as np
import pytest

from crane_fem.contact import solve_lcp


def brute_force_lcp(W: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Enumerate the 2^p complementary bases; the LCP with W SPD has exactly one solution."""
    p = q.size
    for mask in itertools.product([False, True], repeat=p):
        idx = np.flatnonzero(mask)
        lam = np.zeros(p)
        if idx.size:
            lam[idx] = np.linalg.solve(W[np.ix_(idx, idx)], -q[idx])
        w = q + W @ lam
        if np.all(lam >= -1e-12) and np.all(w >= -1e-12):
            return lam
    raise AssertionError("no solution")


@pytest.mark.parametrize("seed", range(20))
def test_lcp_matches_enumeration(seed: int) -> None:
    rng = np.random.default_rng(seed)
    p = int(rng.integers(1, 7))
    B = rng.normal(size=(p, p))
    W = B @ B.T + 0.1 * np.eye(p)
    q = rng.normal(size=p)
    lam = solve_lcp(W, q, np.ones(p, dtype=bool), diagonal=False)
    # NNLS is exact up to round-off in the Cholesky factor: 1e-10 on O(1) data.
    np.testing.assert_allclose(lam, brute_force_lcp(W, q), atol=1e-10)
    w = q + W @ lam
    assert np.all(lam >= 0.0) and np.all(w >= -1e-10) and abs(lam @ w) < 1e-10


def test_lcp_diagonal_closed_form_and_inactive_points() -> None:
    W = np.diag([2.0, 4.0, 1.0])
    q = np.array([-1.0, 2.0, -3.0])
    active = np.array([True, True, False])
    lam = solve_lcp(W, q, active, diagonal=True)
    np.testing.assert_array_equal(lam, [0.5, 0.0, 0.0])
