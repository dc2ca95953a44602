"""Stability: bounded energy over 10⁵ steps at 0.95 Δt_crit; diagnosis above Δt_crit."""

import json
import math

import numpy as np
import pytest
from conftest import COMM, make_scenario, run

from crane_fem.errors import UnstableRunError
from crane_fem.io import read_history


@pytest.mark.serial
def test_cd_lagrange_long_run_bounded_energy(shared_tmp) -> None:
    """10⁵ steps of the clamped bar bouncing on its obstacle (an impact every 3 s)."""
    ne = 20
    h = 1.0 / ne
    steps = 100_000
    # c = 1: Δt_crit ≈ h/c (a little above with the clamp); 2 % margin gives ≥ 10⁵ steps.
    dt_upper = 0.95 * h * 1.02
    sc = make_scenario(
        model={"elements": ne, "clamp": "right"},
        initial={"velocity": 0.0, "displacement": [0.5, 0.0]},
        contact=[{"type": "wall", "gap": 0.0}],
        time={"end": steps * dt_upper, "dt_factor": 0.95},
        output={"every": 100, "xdmf": False},
    )
    res = run(sc, shared_tmp)
    s, hist = res.summary, res.history
    assert s["steps_done"] >= steps
    assert s["dt_over_dt_critical"] == pytest.approx(0.95)
    e0 = 0.125  # ½ ∫ (u0')² dx with u0' = −½
    # Bounded: the physical energy never exceeds the initial one (contact only dissipates),
    # and the balance closes over the whole run.
    energy = hist["kinetic"] + hist["internal"]
    assert np.all(np.isfinite(energy))
    assert np.max(energy) <= e0 * 1.01  # shadow energy differs from E0 by O(Δt²) ≈ 0.3 %
    assert s["energy_balance_error"] <= 1e-10
    assert s["contact_intervals"] >= 1000  # ~ steps Δt / 3 impacts, none skipped


def test_above_critical_step_stops_with_diagnosis(shared_tmp) -> None:
    sc = make_scenario(time={"dt_factor": 1.05})
    with pytest.warns(RuntimeWarning, match="exceeds the critical explicit step"):
        with pytest.raises(UnstableRunError) as info:
            run(sc, shared_tmp)
    msg = str(info.value)
    assert "\n" not in msg
    for part in ("subdomain 'bar'", "cd-lagrange", "at step", "1.050× the critical step"):
        assert part in msg
    COMM.barrier()
    # Files written so far stay valid: the summary names the diagnosis, the history parses
    # and holds only finite values (the monitor stops before any NaN is written).
    summary = json.loads((shared_tmp / "summary.json").read_text())
    assert summary["status"] == "unstable" and summary["diagnosis"] == msg
    hist = read_history(shared_tmp / "history.csv")
    assert 0 < hist["t"].size < summary["steps"]
    assert all(np.all(np.isfinite(v)) for v in hist.values())


def test_rayleigh_damping_reduces_the_step_and_dissipates(shared_tmp) -> None:
    alpha, beta = 0.5, 1e-3
    sc = make_scenario(material={"rayleigh": [alpha, beta]})
    res = run(sc, shared_tmp)
    s, h = res.summary, res.history
    w = s["omega_max"]
    a = alpha + beta * w * w
    assert s["dt_critical"] == pytest.approx((-a + math.sqrt(a * a + 4 * w * w)) / (w * w))
    assert s["dt_critical"] < 2.0 / w
    assert h["damping_dissipated"][-1] > 0.0
    assert np.all(np.diff(h["damping_dissipated"]) >= -1e-15)
    assert s["energy_balance_error"] <= 1e-10


def test_critical_step_is_h_over_c_with_clamp_and_two_bars(shared_tmp) -> None:
    # Two bars of different meshes: the finer one (h = 1/150) sets the limit.
    sc = make_scenario(
        model={"elements": 100, "second_bar": {"length": 1.0, "elements": 150}},
        contact=[{"type": "bars", "gap": 0.1}],
        time={"end": 0.05},
    )
    s = run(sc, shared_tmp).summary
    assert s["dt_critical"] == pytest.approx(1.0 / 150, rel=1e-9)
