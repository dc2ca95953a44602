"""The supports' peak forces are read between the sampling instants (issue 32, item 7).

After a landing a face's force rings at 1–4 kHz, at and above the Nyquist frequency of the
crane's 0.13–0.16 ms sampling, so a peak read at the sampling instants only depends on where
they fall (an explicit run's support peak moved by −20 % over the phases of its own grid). A
fully explicit run now reads them every ``output.peak_interval`` (the kernel reads the
faces' columns between the records: still one call per record), a coupled run at each macro
step."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import COMM
from petsc4py import PETSc

from crane_fem.cli import main
from crane_fem.coupled_run import _records
from crane_fem.integrators.explicit_zone import ExplicitZone
from crane_fem.io import read_history
from crane_fem.model import assemble_operators
from crane_fem.monitors.support_reactions import create_supports
from crane_fem.pipeline import create_simulation
from crane_fem.points import GroundAcceleration
from crane_fem.scenario import load_scenario

QUICK = Path(__file__).parent.parent / "demos" / "crane_quick.toml"
BAR = QUICK.parent / "bar_impact.toml"


def _explicit(*more: str) -> list[str]:
    return ['coupling.method="monolithic"', "output.xdmf=false", *more]


def _petsc_forces(sim, reactions, u, v, a, ground) -> np.ndarray:
    """The faces' forces as the PETSc face rows give them (the evaluation before the SciPy
    face operator): R = K_f (u + β v) + M_f (a + α v + body), summed per face (serial)."""
    sub = sim.models.explicit
    bs, n_own = sub.bs, sub.model.n_owned
    start = sub.V.dofmap.index_map.local_range[0] * bs
    K, _, M = assemble_operators(sub.formulation, sub.V, sub.fields, np.zeros(0, int), True)
    isrow = PETSc.IS().createGeneral(reactions.rows + start, comm=reactions.comm)
    iscol = PETSc.IS().createStride(n_own, first=start, step=1, comm=reactions.comm)
    body = np.zeros((n_own // bs, bs))
    body[:, :3] = ground[:3] - reactions.gravity
    r = np.zeros(reactions.rows.size)
    for A, x in ((K, u + reactions.beta * v), (M, a + body.ravel() + reactions.alpha * v)):
        A_f = A.createSubMatrix(isrow, iscol)
        xv, yv = A_f.createVecRight(), A_f.createVecLeft()
        xv.array[:] = x
        A_f.mult(xv, yv)
        r += yv.array
        for obj in (A_f, xv, yv, A):
            obj.destroy()
    for obj in (isrow, iscol):
        obj.destroy()
    out = np.zeros((reactions.n_faces, bs))
    np.add.at(out, (reactions.labels, reactions.rows % bs), r)
    return out


def test_kernel_readings_are_the_states_of_a_run_recorded_there() -> None:
    """A fully explicit run read every ``peak_interval`` (10 micro steps here) stays one
    kernel call per record: the kernel reads U_j and V_j at the faces' columns between the
    records. Those readings are, bit for bit, the states a run recording every 10 micro
    steps holds at the same instants, and the records' states are the same. The faces'
    forces of the SciPy face operator are the PETSc face rows' to round-off (1e-9 of the
    force here: sums of ~1e5 N terms in another order; serially: the PETSc twin sums this
    rank's rows). A record's readings evaluated at once (one reduction over the ranks) give
    its last reading's forces as one evaluation of that reading alone."""
    sets = _explicit("time.end=0.002", "output.peak_interval=1.3e-5")
    calls = {"advance": 0}
    advance = ExplicitZone.advance

    def count_advance(self, *args, **kw):
        calls["advance"] += 1
        return advance(self, *args, **kw)

    mp = pytest.MonkeyPatch()
    mp.setattr(ExplicitZone, "advance", count_advance)
    try:
        # Read between its records (every 0.13 ms sampling interval: 100 micro steps).
        sc = load_scenario(QUICK, sets)
        sim = create_simulation(sc, COMM)
        mon = create_supports(sim)
        assert mon is not None
        system, r = sim.integrators.system, mon.reactions
        assert system.observe_every == 10  # 1.3e-5 s / Δt = 1.30e-6 s
        readings: dict[float, tuple[np.ndarray, np.ndarray]] = {}
        read = system.probe_reader
        assert read is not None

        def spy(times, u, v) -> None:
            for k, t in enumerate(times):
                readings[float(t)] = (u[k].copy(), v[k].copy())
            read(times, u, v)
            if times.size > 1:
                a = (v[-1] - v[-2]) / (times[-1] - times[-2])
                one = r._residual(u[-1], v[-1], a, mon.ground.at(times[-1:])[0])
                assert np.allclose(r._track_f, one, rtol=1e-12, atol=1e-9 * np.abs(one).max())

        system.probe_reader = spy
        records = {}
        for rec in _records(sim.integrators.method, None, None):
            if not records:  # the start's record: count the steps' calls
                calls["advance"] = 0
            mon.update(rec, rec.micro_step >= system.grid.end)
            records[rec.t] = rec.explicit_u.copy()
        assert calls["advance"] == len(records) - 1  # one kernel call per record
        end, sample = system.grid.end, system.grid.sample
        steps = set(range(10, end, 10)) - set(range(0, end + 1, sample))
        assert sorted(readings) == sorted(i * system.grid.dt for i in steps)
        if COMM.size == 1:  # the last state's forces against the PETSc face rows
            E = system.E
            g = GroundAcceleration(sc)(system.t)
            a = 1e3 * E.v_int + 0.5  # any acceleration: the M_f rows' columns too
            ref = _petsc_forces(sim, r, E.u, E.v_int, a, g)
            mine = r._residual(E.u[r.columns], E.v_int[r.columns], a[r.columns], g)
            assert np.abs(mine - ref).max() <= 1e-9 * np.abs(ref).max()
        cols = r.columns.copy()
        mon.destroy()
        sim.destroy()
        if COMM.size > 1:
            # (In the whole suite's two-rank pass a second simulation's start state, from
            # its preload, differed from the first's in its last bits at t = 0: the
            # bit-for-bit comparison of two runs is the serial pass's.)
            return
        # The same run recording every 10 micro steps (its records every ratio's micro
        # steps), no supports' monitor.
        calls["advance"] = 0
        every10 = ["output.sample_interval=1.3e-5", "coupling.ratio=10"]
        fine = create_simulation(load_scenario(QUICK, [*sets, *every10]), COMM)
        seen = 0
        for rec in _records(fine.integrators.method, None, None):
            zone = fine.integrators.system.E
            if rec.t in readings:
                u, v = readings[rec.t]
                assert np.array_equal(zone.u[cols], u) and np.array_equal(zone.v_int[cols], v)
                seen += 1
            if rec.t in records:
                assert np.array_equal(rec.explicit_u, records[rec.t])
        assert seen == len(readings) > 0
        fine.destroy()
    finally:
        mp.undo()


@pytest.mark.slow
@pytest.mark.serial  # its two-rank part: the readings' reduction, in the test above
def test_explicit_support_peaks_do_not_depend_on_the_sampling_interval(shared_tmp) -> None:
    """The quick crane's fully explicit run through its landing (0.052 s; its faces then ring
    at 3.8 kHz and 1 kHz), sampled every 0.13 and every 0.39 ms. Read every
    ``peak_interval`` = 15 µs (12 micro steps, on the clock's grid: the same instants at both
    samplings) the peaks agree to 0.1 % (only the records' own instants differ) and are the
    peaks read every 3.9 µs within 2 %: read every τ, a ringing at f loses at most
    1 − cos(π f τ) of its amplitude, 1.7 % at 3.8 kHz and τ = 15.7 µs (0.2 % at 3.9 µs),
    and the ringing is a part of the force. At the sampling instants only they were not:
    the vertical peaks differ by 6 % between the two samplings."""
    runs = {"0.13 ms": ("1.3e-4", None), "0.39 ms": ("3.9e-4", None)}
    runs["3.9 us"] = ("3.9e-4", "3.9e-6")
    peaks, sampled = {}, {}
    for label, (sample, interval) in runs.items():
        out = shared_tmp / f"supports_peak_{label.replace(' ', '_')}"
        sets = _explicit("time.end=0.06", f"output.sample_interval={sample}")
        if interval is not None:
            sets.append(f"output.peak_interval={interval}")
        args = ["run", str(QUICK), "-o", str(out), "--no-progress"]
        assert main([*args, *[a for s in sets for a in ("--set", s)]]) == 0
        COMM.barrier()
        faces = json.loads((out / "summary.json").read_text())["supports"]
        keys = sorted(faces)
        peaks[label] = np.array(
            [[faces[k]["peak_force_N"], faces[k]["peak_vertical_N"]] for k in keys]
        )
        assert min(faces[k]["peak_force_time_s"] for k in keys) > 0.05  # after the landing
        hist = read_history(out / "history.csv")
        f = np.stack([[hist[f"support{k}_f{c}"] for c in "xyz"] for k in keys])
        sampled[label] = np.column_stack(
            [np.nanmax(np.linalg.norm(f, axis=1), axis=1), np.nanmax(np.abs(f[:, 2]), axis=1)]
        )
        # The sampled rows are among the readings: never above the peaks.
        assert np.all(sampled[label] <= peaks[label])
    ref = peaks["3.9 us"]
    assert np.all(np.abs(peaks["0.13 ms"] / peaks["0.39 ms"] - 1.0) <= 1e-3), peaks
    for label in ("0.13 ms", "0.39 ms"):
        assert np.all(np.abs(peaks[label] / ref - 1.0) <= 0.02), (label, peaks, ref)
    # Read at the sampling instants only, the vertical peaks moved with the sampling.
    moved = np.abs(sampled["0.13 ms"][:, 1] / sampled["0.39 ms"][:, 1] - 1.0)
    assert np.all(moved > 0.03), sampled


@pytest.mark.parametrize(
    ("scene", "value", "fragment"),
    [
        (QUICK, "0", "greater than 0"),
        (QUICK, "-1e-5", "greater than 0"),
        (BAR, "1e-5", "scenes with [[subdomain]] or [coupling] only"),
    ],
)
def test_bad_peak_interval_one_line(scene, value, fragment, capsys) -> None:
    """A non-positive ``output.peak_interval``, or one on a scene without supports' reactions
    (a 1D bar): one line naming the key, exit code 2, from `check` as from `run`, before any
    work."""
    for command in ("check", "run"):
        code = main([command, str(scene), "--set", f"output.peak_interval={value}"])
        err = capsys.readouterr().err.strip().splitlines()
        assert code == 2 and len(err) == 1, (command, err)
        assert "output.peak_interval" in err[0] and fragment in err[0], err[0]


def test_an_older_checkpoints_whole_field_velocity_is_cut_to_the_faces_columns() -> None:
    """A checkpoint written before the reactions kept their last velocity at their columns
    holds the whole owned field: loading it keeps that field's values at the columns."""
    from crane_fem.reactions import _PEAKS, SupportReactions

    r = SupportReactions.__new__(SupportReactions)  # (the state alone: no faces assembled)
    r.columns = np.array([3, 1, 4])
    state = {k: np.zeros(2) for k in _PEAKS} | {"t_prev": 0.5, "v_prev": np.arange(6.0) / 2}
    r.load_state_dict(state)
    assert np.array_equal(r._v_prev, [1.5, 0.5, 2.0])
    state["v_prev"] = np.array([7.0, 8.0, 9.0])  # a checkpoint of this form: as it is
    r.load_state_dict(state)
    assert np.array_equal(r._v_prev, [7.0, 8.0, 9.0])
