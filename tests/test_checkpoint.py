"""Checkpoint and restart (issue 17 item 5): a run continued from its latest checkpoint ends
as the uninterrupted run does — history (in memory and history.csv), summary and XDMF frames
bit for bit serially, to 1e-10 under mpiexec -n 2 — for every coupling method and the fully
explicit reference, with the full or the reduced implicit side; bad restarts are refused with
one line."""

import json
import math
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import COMM, assert_same_histories, make_scenario

from crane_fem.checkpoint import (
    CHECKPOINT_DIR,
    flatten,
    read_checkpoint,
    scenario_hash,
    unflatten,
    write_checkpoint,
)
from crane_fem.driver import RunResult, run_scenario
from crane_fem.errors import ScenarioError
from crane_fem.io import read_history, read_xdmf
from crane_fem.peaks import ContactPeaks
from crane_fem.scenario import Scenario, load_scenario
from crane_fem.stability import EnergyGrowthMonitor

QUICK = Path(__file__).parent.parent / "demos" / "crane_quick.toml"
#: Serial runs are reproducible to the bit; two-rank runs vary at round-off from one run to
#: the next (distributed reductions), which the crane's impacts amplify.
RTOL = 0.0 if COMM.size == 1 else 1e-10
#: Summary entries that say how the run went rather than what it computed.
VOLATILE = ("wall_time", "restart", "checkpoints")

SUBS = [
    {"name": "near", "groups": ["left"], "scheme": "cd-lagrange"},
    {"name": "far", "groups": ["right"], "scheme": "newmark"},
]
#: The split bar with a cos² pulse crossing the interface (no contact: "ph" and "ec" need the
#: explicit side linear), 400 elements, Δt = h/2, m = 4: 60 macro steps to t = 0.3.
PULSE = {
    "model": {"elements": 400, "split": 0.4},
    "initial": {"velocity": 0.0, "pulse": {"center": 0.2, "width": 0.2, "amplitude": 1e-3}},
    "contact": [],
}


def _subdomains(reduced: bool) -> list[dict[str, Any]]:
    """The split bar's two sides, the implicit one full or reduced (20 modes)."""
    if not reduced:
        return SUBS
    return [SUBS[0], {**SUBS[1], "scheme": "newmark-reduced", "modes": 20}]


def _pulse(
    method: str, end: float, every: int | None = None, reduced: bool = False, **extra: Any
) -> Scenario:
    """The split bar; with XDMF frames for GC with the full implicit side."""
    return make_scenario(
        **PULSE,
        time={"end": end, "dt_factor": 0.5},
        subdomain=_subdomains(reduced),
        coupling={"method": method, "ratio": 4},
        output={"xdmf": method == "gc" and not reduced, "checkpoint_every": every},
        **extra,
    )


def _crane(end: float, every: int | None = None, *overrides: str) -> Scenario:
    sets = [f"time.end={end}", "output.xdmf=false", *overrides]
    if every is not None:
        sets.append(f"output.checkpoint_every={every}")
    return load_scenario(QUICK, sets)


def _run(sc: Scenario, out: Path, restart: Path | None = None) -> RunResult:
    return run_scenario(sc, out, COMM, progress=False, restart=restart)


def _volatile(path: str, key: str) -> bool:
    """Wall times, the restart's own entries, and the reduction's set-up times; with two
    ranks, the place of the bridge's peak stress (the crane is mirror symmetric: mirror-image
    cells share the peak to round-off, and which one a two-rank run reports changes from
    one run to the next)."""
    if RTOL and key == "peak_bridge_von_mises_location_m":
        return True
    return key.startswith(VOLATILE) or (path == ".reduction" and key.endswith("_s"))


def _same_summary(a: Any, b: Any, floors: dict[str, float], path: str = "") -> None:
    """Equal summaries (serial), volatile entries left out; with two ranks, numbers within
    RTOL of their own size, or of ``floors[key]`` for those that are round-off themselves
    (the energy closure, the preload's balance, the "ec" residual)."""
    if isinstance(a, dict):
        keys, other = ({k for k in d if not _volatile(path, k)} for d in (a, b))
        assert keys == other, (path, keys ^ other)
        for k in sorted(keys - {"status", "diagnosis"}):
            _same_summary(a[k], b[k], floors, f"{path}.{k}")
    elif isinstance(a, list | tuple):
        assert len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            _same_summary(x, y, floors, f"{path}[{i}]")
    elif isinstance(a, float) and RTOL:
        floor = floors.get(path.rsplit(".", 1)[-1].split("[")[0], 0.0)
        assert abs(a - b) <= RTOL * max(abs(a), floor), (path, a, b)
    else:
        assert a == b or (isinstance(a, float) and math.isnan(a) and math.isnan(b)), (path, a, b)


def _floors(ref: RunResult) -> dict[str, float]:
    """The scales of a summary's round-off entries: 1 (relative errors), the energy (J), the
    trolley's weight (N)."""
    h, s = ref.history, ref.summary
    energy = max(float(np.max(np.abs(h[c]))) for c in ("total", "kinetic", "external_work"))
    relative = ("energy_balance_error", "ec_residual_max", "sum_relative_error")
    # gc-mean's check of its interface energy against its closed form: relative round-off.
    floors = dict.fromkeys((*relative, "interface_identity_error"), 1.0)
    floors.update(energy_balance_error_abs=energy, interface_energy_gc_min_step=energy)
    if "preload" in s:
        floors["support_reaction_N"] = s["preload"]["trolley_weight_N"]
    # A wheel's slip is a difference of displacements (a symmetric crane's across and along
    # the rail: round-off of zero), against the wheels' displacements.
    u = [float(np.max(np.abs(h[c]))) for c in h if c.startswith("wheel") and c.endswith("_uz")]
    if u:
        slips = ("slip_across_m", "slip_along_m", "max_pair_slip_m", "trolley_drift_m")
        floors.update({f"{w}_{k}": max(u) for w in ("max", "final") for k in slips[:2]})
        floors.update({k: max(u) for k in slips[2:]})
    return floors


def _same_histories(h1: dict, h2: dict) -> None:
    """Bit for bit serially; to RTOL on two ranks, each column against its scale
    (conftest.assert_same_histories: the measured points' accelerations, Δv/ΔT, against the
    velocities' scale over ΔT, the scale of their round-off)."""
    assert h1.keys() == h2.keys()
    if RTOL == 0.0:
        differ = [c for c in h1 if not np.array_equal(h1[c], h2[c])]
        assert not differ, differ
        return
    assert_same_histories(h1, h2, RTOL)


def _check_restart(
    full: Scenario,
    cut: Scenario | None,
    resumed: Scenario,
    tmp: Path,
    frames: bool = False,
    from_ref: bool = False,
) -> tuple[RunResult, RunResult]:
    """``full`` uninterrupted; ``cut`` (an earlier end, with checkpoints; None: already run
    in ``tmp / "cut"``, or, ``from_ref``, ``full`` itself: its directory, checkpoints and
    outputs to its end, copied there) then ``resumed`` (``full`` with checkpoints) from its
    latest checkpoint, in the same directory: the two runs' histories, history.csv,
    summaries, results.csv and spectra.csv (and XDMF frames) agree."""
    ref = _run(full, tmp / "ref")
    if from_ref:
        assert ref.summary["checkpoints"]["written"] >= 1
        if COMM.rank == 0:
            shutil.copytree(tmp / "ref", tmp / "cut")
        COMM.barrier()
    elif cut is not None:
        first = _run(cut, tmp / "cut")
        assert first.summary["checkpoints"]["written"] >= 1
    res = _run(resumed, tmp / "cut", restart=tmp / "cut")
    assert res.summary["restart"]["step"] > 0
    _same_histories(ref.history, res.history)
    _same_histories(
        read_history(tmp / "ref" / "history.csv"), read_history(tmp / "cut" / "history.csv")
    )
    floors = _floors(ref)
    _same_summary(ref.summary, res.summary, floors)
    _same_summary(
        json.loads((tmp / "ref" / "summary.json").read_text()),
        json.loads((tmp / "cut" / "summary.json").read_text()),
        floors,
    )
    for name in ("results.csv", "spectra.csv"):
        assert (tmp / "ref" / name).exists() == (tmp / "cut" / name).exists(), name
        if RTOL == 0.0 and (tmp / "ref" / name).exists():
            assert (tmp / "ref" / name).read_bytes() == (tmp / "cut" / name).read_bytes(), name
    if frames:
        for path in sorted((tmp / "ref").glob("*.xdmf")):
            _, _, a = read_xdmf(path)
            _, _, b = read_xdmf(tmp / "cut" / path.name)
            assert a.keys() == b.keys()
            for name in a:
                assert [t for t, _ in a[name]] == [t for t, _ in b[name]], (path.name, name)
                for (_, x), (_, y) in zip(a[name], b[name], strict=True):
                    if RTOL == 0.0:
                        assert np.array_equal(x, y), (path.name, name)
    return ref, res


# ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("reduced", [False, True], ids=["full", "reduced"])
@pytest.mark.parametrize("method", ["gc", "gc-mean", "ph", "ec"])
def test_restart_equals_the_uninterrupted_run_on_the_split_bar(method, reduced, shared_tmp) -> None:
    """60 macro steps against 40 with a checkpoint at 25 (the 15 rows and frames written
    after it are dropped), then continued to 60: the same run."""
    full, cut, resumed = (
        _pulse(method, end, every, reduced) for end, every in ((0.3, None), (0.2, 25), (0.3, 25))
    )
    _check_restart(full, cut, resumed, shared_tmp, frames=method == "gc" and not reduced)


def test_restart_after_an_interruption_within_a_macro_step(shared_tmp, monkeypatch) -> None:
    """A run stopped by Ctrl-C in the middle of macro step 33 (its state half-updated, rows
    and frames written up to step 32) continues from its checkpoint at step 25 to the
    uninterrupted run's result, XDMF frames included."""
    from crane_fem.coupling.gravouil_combescure import GravouilCombescure

    step = GravouilCombescure.step

    def interrupted(self: GravouilCombescure) -> Any:
        if self.system.n == 32:
            self.system.E.advance(self.system.E.steps(self.system.t, 2))
            raise KeyboardInterrupt
        return step(self)

    monkeypatch.setattr(GravouilCombescure, "step", interrupted)
    with pytest.raises(KeyboardInterrupt):
        _run(_pulse("gc", 0.3, 25), shared_tmp / "cut")
    monkeypatch.undo()
    cut = json.loads((shared_tmp / "cut" / "summary.json").read_text())
    assert cut["status"] == "interrupted" and cut["steps_done"] == 32
    _, res = _check_restart(_pulse("gc", 0.3), None, _pulse("gc", 0.3, 25), shared_tmp, True)
    assert res.summary["restart"]["step"] == 25


@pytest.mark.parametrize("reduced", [False, True], ids=["full", "reduced"])
@pytest.mark.parametrize("method", ["gc", "gc-mean"])
def test_restart_of_the_refining_step_through_impacts(method, reduced, shared_tmp) -> None:
    """The macro step that refines at impacts (coupling.fine_ratio) on the bar hitting the
    wall, continued from a checkpoint taken while it runs fine (after the impact's onset,
    within the quiet time): the continued run takes the same rungs and ends as the
    uninterrupted one, bit for bit serially."""

    def sc(end: float, every: int | None = None) -> Scenario:
        return make_scenario(
            model={"elements": 200, "split": 0.4},
            time={"end": end, "dt_factor": 0.9},
            subdomain=_subdomains(reduced),
            coupling={"method": method, "ratio": 8, "fine_ratio": 2, "refine_quiet": 0.1},
            output={"xdmf": False, "checkpoint_every": every},
        )

    # Δt = 4.5e-3, coarse ΔT = 0.036: the impact at t = 0.1 s is in the third coarse
    # interval, refined from there for 0.1 s; the checkpoint every 4 samples (0.144 s) of
    # the cut run (to 0.16 s) falls inside the fine stretch.
    ref, res = _check_restart(sc(0.5), sc(0.16, 4), sc(0.5, 4), shared_tmp)
    assert res.summary["restart"]["step"] > 4  # fine steps before the checkpoint
    ad = ref.summary["adaptive"]
    assert ad["fine_steps"] > 0 and ad["coarse_steps"] > 0, ad
    assert res.summary["adaptive"] == ad


@pytest.mark.parametrize("reduced", [False, True], ids=["full", "reduced"])
def test_restart_of_the_hybrid_through_impacts(reduced, shared_tmp) -> None:
    """ "hybrid" on the bar hitting the wall (its "ec" steps while the contact is open, GC and
    refined GC steps through the impact), continued from a checkpoint before the impact: the
    continued run equals the uninterrupted one, step counts of each kind included."""

    def sc(end: float, every: int | None = None) -> Scenario:
        return make_scenario(
            model={"elements": 200, "split": 0.4},
            time={"end": end, "dt_factor": 0.9},
            subdomain=_subdomains(reduced),
            coupling={"method": "hybrid", "ratio": 4, "impact_ratio": 2},
            output={"xdmf": False, "checkpoint_every": every},
        )

    # Δt = 4.5e-3, ΔT = 0.018: the impact at t = 0.1 falls in macro step 6; the checkpoint
    # at step 3 of the cut run (4 steps) is before it.
    ref, res = _check_restart(sc(0.5), sc(0.07, 3), sc(0.5, 3), shared_tmp)
    assert res.summary["restart"]["step"] == 3
    steps = ref.summary["hybrid_steps"]
    assert steps["ec"] > 0 and steps["gc"] > 0 and steps["gc_refined"] > 0, steps


def test_restart_of_the_monolithic_reference(shared_tmp) -> None:
    """The fully explicit reference, 7 steps per macro step: interrupted (no change of end)
    after its checkpoint at macro step 9 of 12, and extended from a run whose last macro
    step is short (no checkpoint there: a longer run takes that step whole: the latest is
    the one before)."""

    def sc(end: float, every: int | None = None) -> Scenario:
        return make_scenario(
            model={"elements": 100},
            time={"end": end, "dt_factor": 0.9},
            coupling={"method": "monolithic", "scheme": "cd-lagrange", "ratio": 7},
            output={"xdmf": False, "checkpoint_every": every},
        )

    # Δt = 0.009: 84 steps to 0.75 (12 macro steps), 58 to 0.52 (8 whole ones and 2 steps).
    _check_restart(sc(0.75), sc(0.75, 9), sc(0.75, 9), shared_tmp / "same")
    _, res = _check_restart(sc(0.75), sc(0.52, 3), sc(0.75, 3), shared_tmp / "extended")
    assert res.summary["restart"]["step"] == 6


def test_restart_of_the_crane(shared_tmp) -> None:
    """The quick crane (GC, m = 100, preloaded wheels, bridge stress, wheel peaks and
    impacts) through the wheels' lift-off: run to 0.013 s with a checkpoint every 40
    sampling instants, then continued from its latest (0.0104 s; its rows after it
    dropped) to 0.013 s."""
    sc = _crane(0.013, 40)
    _, res = _check_restart(sc, None, sc, shared_tmp, from_ref=True)
    # Not the run's last step: the continued run computes a quarter of it again.
    assert res.summary["restart"]["t"] == pytest.approx(0.0104, abs=1e-4)


def test_restart_of_a_mixed_model(shared_tmp) -> None:
    """A mixed model (tests/test_mixed_model.py: beams Newmark, a solid CD-Lagrange, tied by
    two joints) under gravity from rest, with a checkpoint every 200 sampling instants,
    continued from its latest: the uninterrupted run, bit for bit serially (XDMF frames of
    both meshes included)."""
    from test_mixed_model import scenario as mixed_scenario
    from test_mixed_model import write_bar

    mesh = write_bar(shared_tmp / "bar.msh")
    path = shared_tmp / "mixed.toml"
    if COMM.rank == 0:
        path.write_text(mixed_scenario(mesh), encoding="utf-8")
    COMM.barrier()
    sets = ["output.checkpoint_every=200", "output.xdmf=true", "output.xdmf_every=100"]
    sc = load_scenario(path, sets)
    _, res = _check_restart(sc, None, sc, shared_tmp, frames=True, from_ref=True)
    assert res.summary["restart"]["step"] > 0


@pytest.mark.slow
@pytest.mark.serial  # bit for bit serially; two-rank restarts: the crane's and the bar's tests
def test_restart_of_wheels_sliding_on_their_rail_tops(shared_tmp) -> None:
    """The quick crane shaken across its rails (1 g, frictionless, no flanges) with its
    wheels on the rail tops' triangles (wheel.contact = "surface"): the wheels slide 1–2 mm,
    their gaps follow the current projection and the rows are paired again (measured: once,
    between 0.02 and 0.026 s); run to 0.032 s with a checkpoint every 50 sampling instants,
    then continued from its latest (0.026 s), which holds that re-pairing: the pairing
    (triangles, ξ, normals, gaps) restored, the same as the uninterrupted run."""
    sets = (
        "wheel.contact='surface'",
        "loading.ground_motion.direction=[1.0, 0.0, 0.0]",
        "loading.ground_motion.pga=10.0",
    )
    sc = _crane(0.032, 50, *sets)
    ref, res = _check_restart(sc, None, sc, shared_tmp, from_ref=True)
    assert res.summary["restart"]["t"] == pytest.approx(0.026, abs=1e-4)
    # The checkpoint the run continued from was taken after the re-pairing.
    state = flatten(read_checkpoint(shared_tmp / "ref", COMM, sc).state)
    repairs = [int(v) for k, v in state.items() if k.endswith("/repairs")]
    assert len(repairs) == 1 and repairs[0] >= 1, state.keys()
    assert ref.summary["node_to_surface"]["repairings"] >= 1


# ----------------------------------------------------------------------------------------
def test_state_flattens_and_back() -> None:
    """Nested dicts of arrays and scalars survive the one-level form of the npz files."""
    state = {"a": {"x": np.arange(3.0), "n": 4, "ok": True}, "t": 0.1, "s": "[1.5]"}
    back = unflatten(flatten(state))
    assert np.array_equal(back["a"]["x"], state["a"]["x"])
    assert back["a"]["n"] == 4 and back["a"]["ok"] is True
    assert back["t"] == 0.1 and back["s"] == "[1.5]"
    with pytest.raises(ValueError, match="contains"):
        flatten({"a/b": 1.0})


def _same_attributes(a: object, b: object) -> None:
    """Every attribute of ``a`` equal to ``b``'s (arrays to the bit)."""
    va, vb = vars(a), vars(b)
    assert va.keys() == vb.keys()
    for k, x in va.items():
        if isinstance(x, np.ndarray):
            assert np.array_equal(x, vb[k]) and x.dtype == vb[k].dtype, k
        else:
            assert x == vb[k], k


def test_peaks_and_monitor_restore_every_attribute() -> None:
    """ContactPeaks and the growth monitor taken to a checkpoint in the middle of a flight
    and of an impact: a fresh object loaded from their state equals them attribute by
    attribute, and both go on to the same tables (a guard for state added later)."""
    dt = 1e-4
    t = dt * np.arange(1, 61)
    gap = np.zeros((60, 2))
    gap[5:20, 0] = 5e-4  # a lift-off of group 0, landing at step 20
    gap[40:, 1] = 2e-4  # group 1 takes off at step 40, still flying at the end
    impulse = np.where(gap > 0, 0.0, 10.0 * dt)
    impulse[20:25, 0] = 50.0 * dt  # the landing's impact
    static = np.array([10.0, 10.0])
    a, b = ContactPeaks(["g0", "g1"], dt, static), ContactPeaks(["g0", "g1"], dt, static)
    a.start(0.0, static, np.zeros(2))
    a.update(t[:22], impulse[:22], gap[:22])
    b.load_state_dict(unflatten(flatten(a.state_dict())))
    _same_attributes(a, b)
    for peaks in (a, b):
        peaks.update(t[22:], impulse[22:], gap[22:])
    assert a.table() == b.table()
    assert a.table()["g0"]["impacts"] and a.table()["g1"]["lift_offs"]["count"] == 1
    m1, m2 = (EnergyGrowthMonitor(10.0, "", "", dt, 2 * dt) for _ in range(2))
    m1.growth(1.0, 2.0, 0.5)
    m2.load_state_dict(unflatten(flatten(m1.state_dict())))
    _same_attributes(m1, m2)


def test_bad_restarts_are_refused_with_one_line(shared_tmp) -> None:
    """No checkpoint, one of another number of ranks, of another scenario, past the end
    time, or whose state does not fit: a one-line ScenarioError on every rank, before any
    step."""
    out = shared_tmp / "run"
    _run(_pulse("gc", 0.05, 5), out)

    def refused(sc: Scenario, restart: Path, match: str) -> None:
        with pytest.raises(ScenarioError, match=match) as err:
            _run(sc, shared_tmp / "again", restart=restart)
        assert "\n" not in str(err.value)

    refused(_pulse("gc", 0.05, 5), shared_tmp / "nowhere", "no checkpoint")
    refused(_pulse("gc", 0.05, 5, material={"E": 2.0}), out, "another scenario")
    refused(_pulse("gc", 0.02, 5), out, "before the checkpoint")
    # The scenario's free keys: the end time and the checkpoint interval.
    assert scenario_hash(_pulse("gc", 0.05, 5)) == scenario_hash(_pulse("gc", 0.5, None))
    latest = out / CHECKPOINT_DIR / "latest.json"
    # A state that does not fit this run's objects (another version's checkpoint).
    mine = out / CHECKPOINT_DIR / json.loads(latest.read_text())["dir"] / f"rank{COMM.rank}.npz"
    with np.load(mine) as data:
        arrays = {k: data[k] for k in data.files if k != "method/system/lam_macro_prev"}
    with mine.open("wb") as f:
        np.savez(f, **arrays)
    COMM.barrier()
    refused(_pulse("gc", 0.05, 5), out, "does not fit this run")
    if COMM.rank == 0:
        meta = json.loads(latest.read_text())
        latest.write_text(json.dumps({**meta, "nranks": COMM.size + 1}))
    COMM.barrier()
    refused(_pulse("gc", 0.05, 5), out, f"written by {COMM.size + 1} rank")


def test_an_interrupted_write_leaves_the_previous_checkpoint(shared_tmp) -> None:
    """A checkpoint becomes the latest only once every rank has written it: a directory left
    half-written is not read, and the next write replaces it and removes the older one."""
    sc = _pulse("gc", 0.05, 5)
    meta = {"step": 3, "t": 0.3, "scenario_hash": scenario_hash(sc)}
    write_checkpoint(shared_tmp, COMM, meta, {"x": np.full(2, COMM.rank, dtype=float)})
    root = shared_tmp / CHECKPOINT_DIR
    if COMM.rank == 0:
        (root / "step_00000004.tmp").mkdir()  # a write cut short
    COMM.barrier()
    got = read_checkpoint(shared_tmp, COMM, sc)
    assert got.step == 3 and np.array_equal(got.state["x"], [COMM.rank] * 2)
    write_checkpoint(shared_tmp, COMM, {**meta, "step": 4}, {"x": np.zeros(2)})
    assert read_checkpoint(shared_tmp, COMM, sc).step == 4
    assert sorted(p.name for p in root.iterdir()) == ["latest.json", "step_00000004"]


def test_damaged_checkpoints_refused_naming_the_file(shared_tmp) -> None:
    """A restart from a cut `latest.json` or a truncated `rank<r>.npz` (a run killed while
    writing them) is refused with one line naming the file, not a parser's traceback."""
    out = shared_tmp / "damaged"
    _run(_pulse("gc", 0.2, 25), out)
    latest = out / CHECKPOINT_DIR / "latest.json"
    meta = json.loads(latest.read_text())
    npz = out / CHECKPOINT_DIR / str(meta["dir"]) / f"rank{COMM.rank}.npz"
    COMM.barrier()
    good = npz.read_bytes()
    COMM.barrier()
    npz.write_bytes(good[: len(good) // 3])
    COMM.barrier()
    # Every rank's file is cut; the one line is the same on every rank (the first rank's).
    with pytest.raises(ScenarioError, match=r"cannot read .*rank\d+\.npz.*damaged"):
        _run(_pulse("gc", 0.3, 25), out, restart=out)
    COMM.barrier()
    npz.write_bytes(good)
    if COMM.rank == 0:
        latest.write_text(latest.read_text()[:20])
    COMM.barrier()
    with pytest.raises(ScenarioError, match=r"latest\.json is damaged"):
        _run(_pulse("gc", 0.3, 25), out, restart=out)


def test_summary_written_from_the_start(shared_tmp, monkeypatch) -> None:
    """While the time loop runs, summary.json already says the run has not ended (status
    "running"): a run killed outright (SIGKILL) leaves that, not nothing."""
    from crane_fem.coupling.gravouil_combescure import GravouilCombescure

    step = GravouilCombescure.step
    seen: list[dict[str, Any]] = []
    out = shared_tmp / "killed"

    def look(self: GravouilCombescure) -> Any:
        if self.system.n == 10 and not seen:
            seen.append(json.loads((out / "summary.json").read_text()))
        return step(self)

    monkeypatch.setattr(GravouilCombescure, "step", look)
    _run(_pulse("gc", 0.1), out)
    assert seen and seen[0]["status"] == "running"
    assert "killed" in seen[0]["diagnosis"]
    assert json.loads((out / "summary.json").read_text())["status"] == "completed"


def test_restart_says_where_it_continues(shared_tmp, capfd) -> None:
    """A restart names the macro step, time and directory it continues from."""
    out = shared_tmp / "said"
    _run(_pulse("gc", 0.2, 25), out)
    capfd.readouterr()
    _run(_pulse("gc", 0.3, 25), out, restart=out)
    err = capfd.readouterr().err
    if COMM.rank == 0:
        assert f"continuing from the checkpoint of macro step 25 (t = 0.125 s) in {out}" in err
