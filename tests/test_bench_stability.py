"""The stability map's classification (crane_fem.bench.stability): a few tiny points of the
bar on a wall through the suite's own point runner, and the class of an energy history."""

import math

import numpy as np

from crane_fem.bench import stability as st


def test_wall_points_classified(shared_tmp) -> None:
    """CD-Lagrange on a coarse bar (20 elements): stable at 0.9 h/c, unstable at 1.5 h/c;
    penalty k = 100 EA/h at 0.5 h/c, below the CFL limit but above its own 2/ω_p ≈ 0.14 h/c:
    unstable (stopped by the energy-growth monitor)."""
    bar = st.wall_scenario(shared_tmp, elements=20)
    assert math.isclose(bar.h_over_c, 0.05 / math.sqrt(2.1e11 / 7800.0))
    cd = st.cd_lagrange()
    stable = st.wall_point(cd, 0.9, bar, shared_tmp)
    assert stable.cls == st.STABLE, stable.diagnosis
    assert stable.energy_ratio <= 1.0 + 1e-9  # contact only dissipates
    over = st.wall_point(cd, 1.5, bar, shared_tmp)
    assert over.cls == st.UNSTABLE
    assert "unstable run" in over.diagnosis and math.isinf(over.energy_ratio)
    stiff = st.wall_point(st.penalty(100.0, bar), 0.5, bar, shared_tmp)
    assert stiff.cls == st.UNSTABLE, stiff
    assert 0.1 < stiff.limit_ratio < 0.2  # its own limit, springs closed, in units of h/c
    row = stiff.row()
    assert row["class"] == st.UNSTABLE and row["k_EA_over_h"] == 100.0


def test_classify_thresholds() -> None:
    """Completed and bounded: stable; completed past ENERGY_GROWTH × E0: energy growth;
    stopped or non-finite: unstable."""
    flat = np.array([1.0, 0.99, 1.0 + 1e-12])
    assert st.classify("completed", flat) == (st.STABLE, 1.0 + 1e-12)
    bump = np.array([2.0, 2.0 * 1.064, 2.0])  # GC/PH's bounded excursion at m = 1
    assert st.classify("completed", bump)[0] == st.STABLE
    grown = np.array([2.0, 2.1, 2.0 * st.ENERGY_GROWTH * 1.01])
    cls, ratio = st.classify("completed", grown)
    assert cls == st.GROWTH and math.isclose(ratio, st.ENERGY_GROWTH * 1.01)
    assert st.classify("unstable", flat)[0] == st.UNSTABLE
    assert st.classify("completed", np.array([1.0, np.nan]))[0] == st.UNSTABLE
