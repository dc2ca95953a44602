"""The energy measure of the Prakash–Hjelmstad coupling (crane_fem.coupling.ph_energy)."""

import numpy as np
import pytest

from crane_fem.coupling.ph_energy import mode_coefficients, refined_eigh

pytestmark = pytest.mark.no_kernels


def _storage(c, x, v, f):
    kappa, c_xx, c_xf, c_ff = c
    return 0.5 * kappa * v * v + 0.5 * c_xx * x * x + c_xf * x * f + 0.5 * c_ff * f * f


def _vint(x, vh, f, w2, dt):
    """½(V_j−½ + V_j+½) from V_j+½ (which includes the force at t_j)."""
    return vh - 0.5 * dt * (f - w2 * x)


@pytest.mark.parametrize("m", [1, 2, 3, 7, 50])
def test_mode_storage_is_lossless_for_the_trapezoidal_supply(m) -> None:
    """One unit-mass mode under central difference, force linear over each macro step
    (f_n → f_n+1, as "ph" applies Λ): brute-force m micro steps from random states and
    check S(n+1) − S(n) = ΔT·½(v_n + v_n+1)·½(f_n + f_n+1), v the integer-step velocity.
    Tolerance 1e-11 of the largest term: round-off of m ≤ 50 steps weighted by κ ≤ ~1e4
    on this grid (the identity is exact in exact arithmetic)."""
    dt = 0.7
    rng = np.random.default_rng(m)
    for theta in [0.0, 1e-3, 0.3, 1.1, 2.0, 2.9]:  # 0: a rigid mode
        w2 = (2.0 * np.sin(theta / 2) / dt) ** 2
        c = [float(a[0]) for a in mode_coefficients(np.array([w2]), dt, m)]
        for _ in range(5):
            x, vh, f0, f1 = rng.standard_normal(4)

            v0 = _vint(x, vh, f0, w2, dt)
            s0 = _storage(c, x, v0, f0)
            for j in range(1, m + 1):
                x = x + dt * vh
                vh = vh + dt * ((1 - j / m) * f0 + (j / m) * f1 - w2 * x)
            v1 = _vint(x, vh, f1, w2, dt)
            s1 = _storage(c, x, v1, f1)
            supply = m * dt * 0.25 * (v0 + v1) * (f0 + f1)
            scale = max(abs(s0), abs(s1), abs(supply))
            assert s1 - s0 == pytest.approx(supply, abs=1e-11 * scale), (theta, m)


def test_mode_weights_limits() -> None:
    """κ = cos²(θ/2) for m = 1 (CD's own energy in integer-step velocity); κ → 1 and
    ω²a → 0 for well-resolved modes; κ ≥ 0 everywhere (the measure is non-negative)."""
    dt = 1.0
    theta = np.linspace(1e-3, 3.1, 200)
    w2 = (2.0 * np.sin(theta / 2) / dt) ** 2
    kappa, c_xx, _, _ = mode_coefficients(w2, dt, 1)
    assert np.allclose(kappa, np.cos(theta / 2) ** 2, rtol=1e-12)
    assert np.allclose(c_xx, kappa * w2 * np.cos(theta / 2) ** 2, rtol=1e-12)
    for m in (2, 10, 100):
        kappa, *_ = mode_coefficients(w2, dt, m)
        assert np.all(kappa >= 0.0)
        small = m * theta < 1e-2
        assert np.allclose(kappa[small], 1.0, atol=1e-4)


def test_refined_eigh_reaches_extended_precision() -> None:
    """The refinement leaves residuals and orthogonality at the float64 rounding of the
    result (≤ 1e-15 relative), with a cluster of equal eigenvalues present."""
    rng = np.random.default_rng(0)
    n = 60
    Q, _ = np.linalg.qr(rng.standard_normal((n, n)))
    lam = np.sort(np.concatenate([rng.uniform(0.0, 4.0, n - 3), [1.5, 1.5, 1.5]]))
    A = (Q * lam) @ Q.T
    A = 0.5 * (A + A.T)
    w, X = refined_eigh(A)
    scale = np.max(np.abs(lam))
    assert np.max(np.abs(w - lam)) <= 1e-14 * scale
    assert np.max(np.abs(X.T @ X - np.eye(n))) <= 1e-15 * n
    assert np.max(np.abs(A @ X - X * w)) <= 1e-14 * scale
