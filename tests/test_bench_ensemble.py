"""The crane ensemble's verdicts: criterion (b)'s ratio and the window of criterion (a)."""

from pathlib import Path

import numpy as np
import pytest

from crane_fem.bench.common import Outcome, demo, explicit_settings
from crane_fem.bench.ensemble import judge, second_take_off


def _run(peak: float, count: int, stress: float, onsets: list[float]) -> Outcome:
    wheel = {
        "lift_offs": {"count": count, "intervals": [[t, t + 0.01] for t in onsets]},
        "max_uplift_m": 2e-3,
        "peak_force_N": peak,
        "peak_force_time_s": 0.1,
    }
    summary = {"wheels": {"1": wheel}, "peak_bridge_von_mises_Pa": stress}
    history = {"t": np.linspace(0.0, 0.2, 11)}
    return Outcome("run", None, Path("."), "completed", summary, history)  # type: ignore[arg-type]


def test_judge_ratio_against_the_half_range() -> None:
    """Ensemble peak forces 100, 98, 103, 101 kN: half-range 2.5 kN; a method at 104 kN is
    1.6 half-ranges from the reference (100), one at 99 kN 0.4; equal counts give 0, a count
    the ensemble agrees on and the method misses gives inf."""
    members = [
        _run(100e3, 3, 20e6, [0.05, 0.12]),
        _run(98e3, 3, 21e6, [0.05, 0.12]),
        _run(103e3, 3, 19e6, [0.05, 0.12]),
        _run(101e3, 3, 20e6, [0.05, 0.12]),
    ]
    far = judge(_run(104e3, 3, 20e6, []), members[0], members)
    assert far["wheel 1 peak force (kN)"]["half_range"] == pytest.approx(2.5)
    assert far["wheel 1 peak force (kN)"]["ratio"] == pytest.approx(1.6)
    assert far["wheel 1 lift-offs"]["ratio"] == 0.0
    assert far["girder peak von Mises (MPa)"]["ratio"] == 0.0
    near = judge(_run(99e3, 4, 21e6, []), members[0], members)
    assert near["wheel 1 peak force (kN)"]["ratio"] == pytest.approx(0.4)
    assert near["wheel 1 lift-offs"]["ratio"] == np.inf
    assert near["girder peak von Mises (MPa)"]["ratio"] == pytest.approx(1.0)


def test_second_take_off_is_the_earliest_second_onset() -> None:
    ref = _run(1.0, 3, 1.0, [0.05, 0.13, 0.16])
    ref.summary["wheels"]["2"] = {
        "lift_offs": {"count": 2, "intervals": [[0.05, 0.1], [0.12, 0.2]]}
    }
    assert second_take_off(ref) == 0.12
    single = _run(1.0, 1, 1.0, [0.05])
    assert second_take_off(single) == 0.2  # no second flight: the end of the run


def test_ensemble_members_keep_the_stress_times() -> None:
    """Δt × ½ halves the step: twice the macro steps between stress evaluations; the record
    scale multiplies the scene's."""
    half = explicit_settings(demo("crane"), 1.0, 0.5)
    assert half["time.dt_factor"] == pytest.approx(0.45)
    assert half["output.stress_every"] == 2
    assert half["coupling.method"] == "monolithic"
    up = explicit_settings(demo("crane"), 1.005, 1.0)
    assert up["loading.ground_motion.scale"] == pytest.approx(8.0 * 1.005)
    assert "time.dt_factor" not in up
