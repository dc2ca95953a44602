"""The macro step that refines at impacts (coupling.fine_ratio, docs/theory-notes.md §13):
gc-mean's interface energy stays non-negative at every macro step across the changes of ratio,
the run is sampled on one physical interval whatever rungs it took, a closing is never
integrated on the coarse rung, and the refining GC and gc-mean reproduce the fully explicit
quick crane scene within THEORY.md §8's engineering tolerances."""

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import COMM, assert_same_histories, make_scenario, run, run_two_ranks

from crane_fem.cli import main
from crane_fem.io import read_history
from crane_fem.tolerances import judge_dirs, worst

QUICK = Path(__file__).parent.parent / "demos" / "crane_quick.toml"

#: The bar hitting the wall with its left part explicit (the wall's contact there) and its
#: right part implicit: Δt = 4.5e-3 (h = 5e-3, dt_factor 0.9), impact at t = 0.1 s. Undamped:
#: the only losses are the interface's.
SUBS = [
    {"name": "near", "groups": ["left"], "scheme": "cd-lagrange"},
    {"name": "far", "groups": ["right"], "scheme": "newmark"},
]


def _bar(method: str, fine: int | None, end: float = 1.2) -> object:
    coupling: dict[str, object] = {"method": method, "ratio": 8}
    if fine is not None:
        coupling["fine_ratio"] = fine
    return make_scenario(
        model={"elements": 200, "split": 0.4},
        time={"end": end, "dt_factor": 0.9},
        subdomain=SUBS,
        coupling=coupling,
        output={"xdmf": False},
    )


def test_gc_mean_interface_energy_non_negative_across_ratio_changes(shared_tmp) -> None:
    """The refining gc-mean on the bar's impacts: it takes both rungs, refining before or at
    each closing; every macro step's interface energy (booked from the two sides' balances) is
    non-negative to round-off and equals its closed form (§9), so the run never gains energy
    through the interface; the balance closes; the history rows are on one interval."""
    res = run(_bar("gc-mean", 2), shared_tmp / "bar")
    s, h = res.summary, res.history
    ad = s["adaptive"]
    assert ad["coarse_steps"] > 0 and ad["fine_steps"] > 0, ad
    assert ad["coarse_steps_redone"] + ad["refined_by_prediction"] > 0, ad
    assert ad["coarse_steps"] * 8 + ad["fine_steps"] * 2 == s["micro_steps_done"]
    # The energy scale: the bar's initial kinetic energy (½ ρ A L v0² = 0.5 J).
    e0 = float(h["kinetic"][0])
    # Each macro step's interface energy ≥ 0 (a sum of squares), to the round-off of the two
    # sides' balances it is booked from (1e-12 of the energy).
    assert s["interface_energy_gc_min_step"] >= -1e-12 * e0
    assert s["interface_identity_error"] <= 1e-12 * e0
    assert float(h["interface_dissipated"][-1]) > 0.0  # the fine and coarse steps both lose
    assert s["energy_balance_error"] <= 1e-10
    # The run never holds more energy than it started with (no external work).
    assert float(np.max(h["kinetic"] + h["internal"])) <= e0 * (1.0 + 1e-12)
    dt_rows = np.diff(h["t"])
    assert np.allclose(dt_rows, s["sampling_interval_s"], rtol=1e-9, atol=0.0)


def test_refining_gc_runs_the_bar_and_refines_at_the_impact(shared_tmp) -> None:
    """GC's refining step (no energy argument: measured) on the same bar: both rungs, every
    contact interval integrated on the fine rung (the contact's first micro step inside a
    fine macro step: the redone or predicted coarse steps), balance closed."""
    res = run(_bar("gc", 2, end=0.4), shared_tmp / "bar_gc")
    ad = res.summary["adaptive"]
    assert ad["fine_steps"] > 0 and ad["coarse_steps"] > 0, ad
    assert res.summary["energy_balance_error"] <= 1e-10


def test_sampling_is_the_same_in_every_method(shared_tmp) -> None:
    """One physical interval: a fixed-ratio run, a refining one and the fully explicit run of
    the same bar write their rows at the same times (the interval rounded to whole coarse
    steps), whatever macro steps they took; only the last row differs (a coupled run ends on
    a whole coarse step, 0.324 s here, the fully explicit one at its last step of Δt)."""
    times = []
    for name, sc in (
        ("fixed", _bar("gc-mean", None, 0.3)),
        ("refining", _bar("gc-mean", 2, 0.3)),
        ("explicit", _bar("monolithic", None, 0.3)),
    ):
        times.append(run(sc, shared_tmp / name).history["t"])
    assert times[0].size == 10
    for t in times[1:]:
        assert t.shape == times[0].shape
        assert np.max(np.abs(t[:-1] - times[0][:-1])) <= 1e-12


@pytest.fixture(scope="module")
def quick_pair(tmp_path_factory) -> Path:
    """The quick crane scene as written (refining gc-mean) and its fully explicit run, each
    serially (serial only: their two-rank check spawns `mpiexec -n 2`)."""
    if COMM.size > 1:
        pytest.skip("the quick scene pair runs serially")
    root = tmp_path_factory.mktemp("adaptive_quick")
    for name, sets in (("heterogeneous", []), ("explicit", ["coupling.method='monolithic'"])):
        args = ["run", str(QUICK), "-o", str(root / name), "--no-progress"]
        for s in [*sets, "output.xdmf=false"]:
            args += ["--set", s]
        assert main(args) == 0
    return root


@pytest.mark.slow
@pytest.mark.serial
def test_quick_scene_as_written_meets_the_engineering_tolerances(quick_pair) -> None:
    """demos/crane_quick.toml as written (refining gc-mean) against the fully explicit run:
    every quantity of criterion (b) within its tolerance (THEORY.md §8: peak and first
    landing forces 10 %, impulses 5 %, uplift 10 %, bridge stress 5 % and its part, support
    forces 10 %, floor spectra 10 %)."""
    checks = judge_dirs(quick_pair / "heterogeneous", quick_pair / "explicit")
    assert len(checks) >= 40
    bad = [(c.quantity, c.where, round(c.ratio, 2)) for c in checks if not c.ok]
    assert not bad, bad
    w = worst(checks)
    assert w is not None and w.ratio <= 1.0


@pytest.mark.slow
@pytest.mark.serial
@pytest.mark.mpi
def test_quick_scene_as_written_mpiexec_same_as_serial(quick_pair, tmp_path) -> None:
    """The refining step under `mpiexec -n 2` (quick scene as written, through its landing):
    the same rungs on both ranks (every decision is one reduction), the serial histories
    to the crane's serial/parallel tolerance (1e-8: distributed sums in another order), and
    the wheels' table, whose peaks are read from every micro step between the rows: the
    same lift-offs and peak times, the peak forces and uplifts to the same 1e-8 (as the
    quick scene's fixed-ratio runs, test_crane_scene.py). The serial run is the module's
    (quick_pair: the same command on one rank)."""
    serial = quick_pair / "heterogeneous"
    par = run_two_ranks([str(QUICK), "--set", "output.xdmf=false", "--no-progress"], tmp_path)
    s1 = json.loads((serial / "summary.json").read_text())
    s2 = json.loads((par / "summary.json").read_text())
    assert s1["mpi_size"] == 1 and s2["mpi_size"] == 2 and s1["adaptive"]["fine_steps"] > 0
    assert s2["adaptive"] == s1["adaptive"]
    assert sorted(s2["wheels"]) == sorted(s1["wheels"]) == ["1", "2", "3", "4"]
    for k, w in s1["wheels"].items():
        assert w["lift_offs"]["count"] >= 1 and w["impacts"], k  # through the landing
        assert s2["wheels"][k]["lift_offs"]["count"] == w["lift_offs"]["count"], k
        assert s2["wheels"][k]["peak_force_time_s"] == pytest.approx(
            w["peak_force_time_s"], rel=1e-12
        )
        assert s2["wheels"][k]["peak_force_N"] == pytest.approx(w["peak_force_N"], rel=1e-8)
        assert s2["wheels"][k]["max_uplift_m"] == pytest.approx(w["max_uplift_m"], rel=1e-8)
    assert_same_histories(
        read_history(serial / "history.csv"), read_history(par / "history.csv"), 1e-8
    )
