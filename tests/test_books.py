"""The energy books' compiled reductions (crane_fem.kernels.books) against NumPy."""

import numpy as np
import pytest

from crane_fem.kernels.books import dot, shadow_energies


def test_serial_reductions_equal_numpy_to_round_off() -> None:
    """On 50 000 entries (above OpenBLAS's threading size) the serial passes equal NumPy's
    dot to round-off: 1e-13 relative, a sum of 5e4 terms in another order."""
    rng = np.random.default_rng(7)
    n = 50_000
    vh, u, ku = rng.standard_normal(n), rng.standard_normal(n), rng.standard_normal(n)
    mass = rng.uniform(0.5, 2.0, n)
    dt = 1.3e-6
    assert dot(u, ku) == pytest.approx(float(np.dot(u, ku)), rel=1e-13)
    kin, internal = shadow_energies(vh, mass, u, ku, dt)
    assert kin == pytest.approx(0.5 * float(np.dot(vh, mass * vh)), rel=1e-13)
    expected = 0.5 * float(np.dot(u, ku)) + 0.5 * dt * float(np.dot(vh, ku))
    assert internal == pytest.approx(expected, rel=1e-13)
    assert dot(np.zeros(0), np.zeros(0)) == 0.0
