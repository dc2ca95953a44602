"""The supports' peak forces are taken between the sampling instants (issue 32, item 7).

After a landing a face's force rings at 1–4 kHz, at and above the Nyquist frequency of the
crane's 0.13–0.16 ms sampling, so a peak read at the sampling instants only depends on where
they fall (an explicit run's support peak moved by −20 % over the phases of its own grid, and
a coupled run samples another grid when its Δt differs from the reference's). The reactions
now keep their peaks at every state a run holds between its sampling instants: a coupled
run's macro steps, a monolithic reference's pieces of the scene's fine macro step (its micro
steps unchanged)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

from crane_fem.coupled_run import _records
from crane_fem.monitors.support_reactions import create_supports
from crane_fem.pipeline import create_simulation
from crane_fem.points import GroundAcceleration
from crane_fem.scenario import load_scenario

QUICK = Path(__file__).parent.parent / "demos" / "crane_quick.toml"
COMM = MPI.COMM_WORLD


def _explicit(sample: int, fine: bool = True) -> list[str]:
    return [
        'coupling.method="monolithic"',
        "output.xdmf=false",
        "time.end=0.0015" if fine else "time.end=0.012",
        f"output.sample_interval={sample}e-4",
    ]


def test_monolithic_reference_observed_between_samples_unchanged() -> None:
    """A monolithic reference with the support monitor is observed every fine macro step's
    micro steps, its state unchanged by the pieces; the peaks are the largest of the forces
    at those states (the sampled ones only where they coincide)."""
    sc = load_scenario(QUICK, _explicit(2))
    sim = create_simulation(sc, COMM)
    mon = create_supports(sim)
    assert mon is not None
    system = sim.integrators.system
    assert system.observe_every == 10 and system.observers == [mon.observe]
    seen: list[float] = []
    forces = []
    g = GroundAcceleration(sc)
    ref = mon.reactions

    def spy(s) -> None:  # an independent evaluation of the faces' forces at each state
        seen.append(s.t)
        assert s.E is not None
        forces.append(
            np.linalg.norm(ref._residual(s.E.u, s.E.v_int, 0 * s.E.u, g(s.t))[:, :3], axis=1)
        )

    system.observers.append(spy)
    records = []
    for rec in _records(sim.integrators.method, None, None):
        mon.update(rec, rec.micro_step >= system.grid.end)
        records.append((rec.micro_step, rec.explicit_u.copy()))
    steps = np.rint(np.array(seen) / system.dt).astype(int)
    # Every 10 micro steps (the records' and the pieces' states), not only every sample.
    assert np.array_equal(np.unique(steps), np.arange(0, system.grid.end + 1, 10))
    assert system.grid.sample > 10
    # The peaks: the largest force over the observed states (the inertia term of the clamped
    # rows is small: within 2 % of a face's peak).
    peak = np.max(np.array(forces), axis=0)
    assert np.all(ref.peak >= 0.98 * peak) and np.all(ref.peak <= 1.02 * peak)
    u_obs = records[-1][1]
    sim.destroy()
    mon.destroy()

    # The same run without observers: the same micro steps, the same state to round-off.
    sim2 = create_simulation(sc, COMM)
    for rec in _records(sim2.integrators.method, None, None):
        last = rec
    assert last.micro_step == records[-1][0]
    assert last.explicit_u == pytest.approx(u_obs, rel=0, abs=1e-12 * np.max(np.abs(u_obs)))
    sim2.destroy()


def test_support_peaks_do_not_depend_on_the_sampling_interval(shared_tmp) -> None:
    """The faces' peaks of the explicit run sampled every 100 and every 300 micro steps are
    the same (they were the largest of the sampled forces, and so moved with the grid: they
    do here)."""
    import json

    from crane_fem.cli import main
    from crane_fem.io import read_history

    peaks, times, sampled = [], [], []
    for sample in (1, 4):
        out = shared_tmp / f"supports_peak_{sample}"
        args = ["run", str(QUICK), "-o", str(out), "--no-progress"]
        assert main([*args, *[a for s in _explicit(sample, False) for a in ("--set", s)]]) == 0
        COMM.barrier()
        faces = json.loads((out / "summary.json").read_text())["supports"]
        peaks.append([faces[k]["peak_force_N"] for k in sorted(faces)])
        times.append([faces[k]["peak_force_time_s"] for k in sorted(faces)])
        hist = read_history(out / "history.csv")
        f = np.stack([[hist[f"support{k}_f{c}"] for c in "xyz"] for k in sorted(faces)])
        sampled.append(np.nanmax(np.linalg.norm(f, axis=1), axis=1))
    assert min(times[0]) > 0.0  # the peaks are the motion's, not the preload's
    assert peaks[0] == pytest.approx(peaks[1], rel=1e-12)
    # ... where the sampled forces' largest moved with the grid
    assert np.max(np.abs(sampled[0] - sampled[1]) / sampled[0]) > 1e-6
