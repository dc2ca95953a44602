"""The Pareto suite's measures: the non-dominated set, the exact contact end, the bar's error
of a CD-Lagrange run against the d'Alembert solution, the crane's accuracy window."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from crane_fem.bench.common import run_case
from crane_fem.bench.pareto import (
    Point,
    Spec,
    accuracy_window,
    bar_errors,
    bar_specs,
    cheapest_within,
    contact_end_exact,
    pareto_front,
    wheel_peaks,
)
from crane_fem.exact import WallImpact


def test_front_of_hand_made_points() -> None:
    cost = np.array([1.0, 2.0, 3.0, 4.0, 2.5, np.nan, 0.5, 4.0])
    err = np.array([5.0, 3.0, 4.0, 1.0, 3.0, 0.1, np.inf, 1.0])
    # (3, 4) and (2.5, 3) are dominated by (2, 3); non-finite points are left out; the two
    # equal points (4, 1) dominate each other in neither coordinate: both stay.
    assert pareto_front(cost, err).tolist() == [0, 1, 3, 7]
    assert pareto_front(np.array([1.0]), np.array([2.0])).tolist() == [0]


def _point(cost: float, err: float, status: str = "completed", ref: bool = False) -> Point:
    spec = Spec("crane", "gc", f"p{cost}", Path("x.toml"), {}, {"m": 10}, ref)
    return Point(spec, status, cost, "time loop", {"pair_l2": err})


def test_cheapest_within_skips_unstable_and_reference() -> None:
    pts = [
        _point(1.0, 0.0, ref=True),
        _point(2.0, 0.01, status="unstable"),
        _point(5.0, 0.015),
        _point(3.0, 0.019),
        _point(2.5, 0.03),
    ]
    best = cheapest_within(pts, "pair_l2", 0.02)
    assert best is not None and best.cost == 3.0
    assert cheapest_within(pts, "pair_l2", 0.001) is None


def test_contact_end_matches_wall_impact() -> None:
    exact = WallImpact(1.0, 1.0, -1.0, 0.1)
    t = np.linspace(0.0, 3.0, 301)
    ref = np.array([exact.displacement(np.array([0.0]), float(s))[0] for s in t])
    np.testing.assert_allclose(contact_end_exact(exact, t), ref, atol=1e-14)


def test_bar_error_of_cd_lagrange(shared_tmp: Path) -> None:
    """CD-Lagrange at Δt = 0.9 Δt_crit on the split bar's bar (200 elements): the contact end
    within 6 % in L2 (the floor of the mesh: the release 2h/c late, the one-step
    penetration), the peak force within 10 % of ρ c |v0| A, the contact duration within
    0.5 %, energy to round-off; Moreau–Jean θ = 1 at 3 Δt_crit is far off (> 20 %)."""
    specs, exact, force = bar_specs()
    cd = next(s for s in specs if s.label == "bar_cd_dt0.9")
    o = run_case(cd.label, cd.scenario, cd.settings, shared_tmp / cd.label)
    assert o.stable
    err = bar_errors(o.history, o.summary, exact, force)
    assert 0.0 < err["u_end_l2"] < 0.06
    assert err["peak_force"] < 0.10
    assert err["contact_duration"] < 0.005
    assert err["energy_balance"] < 1e-10
    mj = next(s for s in specs if s.label == "bar_mj1_dt3")
    o = run_case(mj.label, mj.scenario, mj.settings, shared_tmp / mj.label)
    assert bar_errors(o.history, o.summary, exact, force)["u_end_l2"] > 0.2


def test_accuracy_window_and_wheel_peaks() -> None:
    t = np.linspace(0.0, 1.0, 1001)
    flight = (t > 0.1) & (t < 0.4)
    hist = {"t": t}
    for k in range(1, 5):
        late = (t > 0.5 + 0.01 * k) & (t < 0.6)
        hist[f"gap_wheel_{k}"] = np.where(((t > 0.1) & (t < 0.4)) | late, 1e-3, 0.0)
        hist[f"force_wheel_{k}"] = np.where(flight, 0.0, 10.0 * k)
    t_acc, how = accuracy_window(hist)
    assert math.isclose(t_acc, 0.541, abs_tol=1e-9) and "second take-off" in how
    one = {"t": t, "gap_wheel_1": np.where((t > 0.1) & (t < 0.4), 1e-3, 0.0)}
    assert accuracy_window(one)[0] == 1.0
    np.testing.assert_allclose(wheel_peaks({}, hist), [10.0, 20.0, 30.0, 40.0])
    summary = {"wheels": {str(k): {"peak_force_N": 100.0 * k} for k in range(1, 5)}}
    np.testing.assert_allclose(wheel_peaks(summary, hist), [100.0, 200.0, 300.0, 400.0])
