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


def test_sliding_scene_judges_slip_and_flange_impacts() -> None:
    """On a sliding scene (bench three_component) (b) also judges each wheel's slip across
    and along and its flanges' impacts (both sides counted, the larger peak); the default
    scenes' quantities stay as they were."""

    def run(across: float, impacts: int, peak: float) -> Outcome:
        o = _run(100e3, 3, 20e6, [0.05])
        o.summary["wheels"]["1"] |= {"max_slip_across_m": across, "max_slip_along_m": 0.01}
        flange = {"impacts": [{"t_s": 0.1}] * impacts, "peak_force_N": peak}
        o.summary["flanges"] = {"in_1": flange, "out_1": {"impacts": [], "peak_force_N": 0.0}}
        return o

    members = [run(5.00e-3, 2, 20e3), run(5.02e-3, 3, 30e3), run(5.01e-3, 2, 25e3)]
    b = judge(run(5.03e-3, 2, 12e3), members[0], members, sliding=True)
    assert b["wheel 1 max slip across (mm)"]["ratio"] == pytest.approx(3.0)
    assert b["wheel 1 max slip along (mm)"]["ratio"] == 0.0
    assert b["wheel 1 flange impacts"]["half_range"] == pytest.approx(0.5)
    assert b["wheel 1 flange impacts"]["ratio"] == 0.0
    assert b["wheel 1 flange peak force (kN)"]["ratio"] == pytest.approx(8.0 / 5.0)
    assert "wheel 1 flange impacts" not in judge(members[1], members[0], members)


def test_explicit_member_scales_every_component() -> None:
    """The ensemble's record × 1.005 scales each of a three-component scene's records."""
    s = explicit_settings(demo("crane_3c"), 1.005)
    scales = [s[f"loading.ground_motion.{i}.scale"] for i in range(3)]
    assert scales == pytest.approx([2.5 * 1.005, 2.5 * 1.005, 8.0 * 1.005], rel=1e-15)
    assert s["coupling.method"] == "monolithic"
