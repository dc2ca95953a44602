"""The wheels' slip on their rails: reported every run, and a run stopped with one line when
a wheel slides beyond what its node-to-node pairs can follow (issue 16: never run on)."""

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import COMM

from crane_fem.driver import run_scenario
from crane_fem.scenario import load_scenario
from crane_fem.slip import SlipError, pair_reach

QUICK = Path(__file__).parent.parent / "demos" / "crane_quick.toml"


def test_pair_reach_is_half_the_smallest_spacing() -> None:
    xy = np.array([[0.0, 0.0], [0.025, 0.0], [0.0, 0.04], [0.025, 0.04]])
    assert pair_reach(xy) == 0.0125


def test_vertical_shaking_slips_little_and_is_reported(shared_tmp) -> None:
    """Vertical shaking: the wheels barely slide (Poisson's lateral strain under the weight,
    tens of micrometres), far inside the reach of the committed mesh's pairs (12.5 mm: its
    rail patch vertices are 25 mm apart)."""
    sc = load_scenario(QUICK, ["time.end=0.005", "output.xdmf=false"])
    s = run_scenario(sc, shared_tmp, COMM, progress=False).summary
    for w in s["wheels"].values():
        assert w["slip_reach_m"] == pytest.approx(0.0125, rel=1e-12)
        assert w["max_pair_slip_m"] < 1e-4
        assert w["max_slip_across_m"] <= w["max_pair_slip_m"] + 1e-15


def test_horizontal_shaking_stops_the_run_at_the_reach(shared_tmp) -> None:
    """Shaken across the rails (x) with frictionless wheels, the trolley stays behind while
    the rails move: the run stops once a wheel has slid 12.5 mm, naming it, and the summary
    says failed with that line."""
    sets = [
        "time.end=0.03",
        "output.xdmf=false",
        "loading.ground_motion.direction=[1.0, 0.0, 0.0]",
        "loading.ground_motion.pga=600.0",
    ]
    sc = load_scenario(QUICK, sets)
    with pytest.raises(SlipError, match=r"wheel \d slid 1\d\.\d\d mm on its rail at t = "):
        run_scenario(sc, shared_tmp, COMM, progress=False)
    s = json.loads((shared_tmp / "summary.json").read_text())
    assert s["status"] == "failed" and "beyond the 12.50 mm" in s["diagnosis"]
    assert 0.0 < s["t_reached_s"] < 0.03
