"""The crane scenes' verdicts (bench ensemble): criterion (b) by engineering tolerances,
the explicit ensemble's conditioning, the window of criterion (a), and the members' settings."""

import math
from pathlib import Path

import numpy as np
import pytest

from crane_fem.bench.common import Outcome, demo, explicit_settings
from crane_fem.bench.ensemble import conditioning, judge, second_take_off
from crane_fem.tolerances import Check, judge_runs, worst

pytestmark = pytest.mark.no_kernels


def _run(peak: float, count: int, stress: float, onsets: list[float]) -> Outcome:
    wheel = {
        "lift_offs": {"count": count, "intervals": [[t, t + 0.01] for t in onsets]},
        "max_uplift_m": 2e-3,
        "peak_force_N": peak,
        "peak_force_time_s": 0.1,
        "impacts": [{"impulse_Ns": 40.0, "peak_force_N": 0.9 * peak, "t_s": 0.12}],
    }
    summary = {
        "wheels": {"1": wheel},
        "peak_bridge_von_mises_Pa": stress,
        "peak_bridge_von_mises_part": "girder 1",
        "peak_bridge_von_mises_by_part_Pa": {"girder 1": stress, "girder 2": 0.9 * stress},
        "supports": {"1": {"peak_force_N": 50e3, "peak_vertical_N": 40e3}},
    }
    history = {"t": np.linspace(0.0, 0.2, 11)}
    return Outcome("run", None, Path("."), "completed", summary, history)  # type: ignore[arg-type]


def _checks(run: Outcome, ref: Outcome) -> dict[tuple[str, str], Check]:
    return {(c.quantity, c.where): c for c in judge(run, ref)}


def test_judge_against_the_engineering_tolerances() -> None:
    """A peak force 4 % high is 0.4 of its 10 % tolerance; 12 % high, 1.2 (out); the bridge
    stress 3 % low is 0.6 of its 5 %; the same value gives 0; the uplift's floor of 0.1 mm
    holds a 0.05 mm difference of a 0.5 mm flight; lift-off counts are reported, not judged."""
    ref = _run(100e3, 3, 20e6, [0.05, 0.12])
    c = _checks(_run(104e3, 5, 19.4e6, [0.05]), ref)
    assert c[("peak force", "wheel 1")].ratio == pytest.approx(0.4)
    assert c[("peak force", "wheel 1")].ok
    assert c[("first landing peak force", "wheel 1")].ratio == pytest.approx(0.4)
    assert c[("bridge peak von Mises", "bridge")].ratio == pytest.approx(0.6)
    assert c[("max uplift", "wheel 1")].ratio == 0.0
    assert c[("support peak force", "support 1")].ratio == 0.0
    assert all("lift-off" not in q for q, _ in c)
    high = _checks(_run(112e3, 3, 20e6, [0.05, 0.12]), ref)
    assert high[("peak force", "wheel 1")].ratio == pytest.approx(1.2)
    assert not high[("peak force", "wheel 1")].ok
    w = worst(list(high.values()))
    assert w is not None and w.quantity in ("peak force", "first landing peak force")
    small = _run(100e3, 3, 20e6, [0.05])
    small.summary["wheels"]["1"]["max_uplift_m"] = 0.5e-3
    low = _run(100e3, 3, 20e6, [0.05])
    low.summary["wheels"]["1"]["max_uplift_m"] = 0.55e-3
    assert _checks(low, small)[("max uplift", "wheel 1")].ratio == pytest.approx(0.5)


def test_bridge_part_allows_mirror_ties_and_catches_another_part() -> None:
    """The reference peaks in girder 1: a run peaking in girder 2 at the same value (a mirror
    tie) passes when its girder-1 peak is within 5 %, fails when girder 1 stays low."""
    ref = _run(100e3, 3, 20e6, [0.05])
    tie = _run(100e3, 3, 20e6, [0.05])
    tie.summary["peak_bridge_von_mises_part"] = "girder 2"
    tie.summary["peak_bridge_von_mises_by_part_Pa"] = {"girder 1": 19.9e6, "girder 2": 20e6}
    key = ("bridge peak von Mises in the reference's part", "girder 1")
    assert _checks(tie, ref)[key].ok
    other = _run(100e3, 3, 20e6, [0.05])
    other.summary["peak_bridge_von_mises_by_part_Pa"] = {"girder 1": 15e6, "girder 2": 20e6}
    assert _checks(other, ref)[key].ratio == pytest.approx(5.0)


def test_conditioning_is_the_worst_member() -> None:
    """Members at 98 and 103 kN against 100: the peak force's conditioning is 0.3 of its
    tolerance; a member 20 % off puts it at 2 (the tolerance finer than the scene)."""
    ref = _run(100e3, 3, 20e6, [0.05])
    members = [judge(_run(p, 3, 20e6, [0.05]), ref) for p in (98e3, 103e3)]
    cond = conditioning(members)
    assert cond[("peak force", "wheel 1")] == pytest.approx(0.3)
    members.append(judge(_run(120e3, 3, 20e6, [0.05]), ref))
    assert conditioning(members)[("peak force", "wheel 1")] == pytest.approx(2.0)


def test_spectra_checks_and_their_periods() -> None:
    """The floor spectra: the worst period per measured curve, the input left out; other
    periods (another sampling) are refused."""
    p = np.array([0.01, 0.02, 0.04])
    ref = (p, {"input_z": np.ones(3), "trolley_z": np.array([10.0, 20.0, 5.0])})
    run = (p, {"input_z": np.ones(3), "trolley_z": np.array([10.5, 19.0, 5.6])})
    checks = judge_runs({}, {}, run, ref)
    assert len(checks) == 1
    assert checks[0].where == "trolley z" and checks[0].note == "T = 0.04 s"
    assert checks[0].ratio == pytest.approx(1.2)
    with pytest.raises(ValueError, match="periods"):
        judge_runs({}, {}, (p * 2, run[1]), ref)
    assert not math.isnan(checks[0].tolerance)


def test_second_take_off_is_the_earliest_second_onset() -> None:
    ref = _run(1.0, 3, 1.0, [0.05, 0.13, 0.16])
    ref.summary["wheels"]["2"] = {
        "lift_offs": {"count": 2, "intervals": [[0.05, 0.1], [0.12, 0.2]]}
    }
    assert second_take_off(ref) == 0.12
    single = _run(1.0, 1, 1.0, [0.05])
    assert second_take_off(single) == 0.2  # no second flight: the end of the run


def test_ensemble_members_sample_the_same_instants() -> None:
    """Δt × ½ halves the step and keeps the reference's sampling interval (the same
    instants, the stress every as many samples); the record scale multiplies the scene's; a
    variant's settings ride along."""
    half = explicit_settings(demo("crane"), 1.0, 0.5, 1.3e-4)
    assert half["time.dt_factor"] == pytest.approx(0.45)
    assert half["output.sample_interval"] == 1.3e-4
    assert "output.stress_every" not in half
    assert half["coupling.method"] == "monolithic"
    up = explicit_settings(demo("crane"), 1.005, 1.0, base={"time.end": 0.3})
    assert up["loading.ground_motion.scale"] == pytest.approx(8.0 * 1.005)
    assert up["time.end"] == 0.3
    assert "time.dt_factor" not in up and "output.sample_interval" not in up


def test_explicit_member_scales_every_component() -> None:
    """The ensemble's record × 1.005 scales each of a three-component scene's records."""
    s = explicit_settings(demo("crane_3c"), 1.005)
    scales = [s[f"loading.ground_motion.{i}.scale"] for i in range(3)]
    assert scales == pytest.approx([2.5 * 1.005, 2.5 * 1.005, 8.0 * 1.005], rel=1e-15)
    assert s["coupling.method"] == "monolithic"


def test_the_ensemble_spread_widens_the_allowance() -> None:
    """max(tolerance, spread): a quantity the ensemble moves by more than its tolerance is
    beyond conditioning and judged against the spread; others keep their tolerance."""
    from crane_fem.tolerances import with_spread

    run = [
        Check("peak force", "wheel 1", 130.0, 100.0, "N"),
        Check("peak force", "wheel 2", 108.0, 100.0, "N"),
    ]
    members = [
        [
            Check("peak force", "wheel 1", 75.0, 100.0, "N"),
            Check("peak force", "wheel 2", 103.0, 100.0, "N"),
        ],
        [Check("peak force", "wheel 1", 110.0, 100.0, "N")],
    ]
    assert [c.ok for c in run] == [False, True]
    judged = with_spread(run, members)
    assert [c.spread for c in judged] == [25.0, 3.0]
    assert [c.beyond_conditioning for c in judged] == [True, False]
    assert judged[0].allowance == 25.0 and judged[0].ratio == 30.0 / 25.0
    assert judged[1].allowance == 10.0 and judged[1].ratio == 8.0 / 10.0
    assert "ensemble spread 0.025 kN" in judged[0].rule
