"""Run a scenario with subdomains: set up through the pipeline, loop over macro steps, monitor,
and feed the writers (history rows, one XDMF file per subdomain, the summary)."""

from __future__ import annotations

import dataclasses
import math
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
from mpi4py import MPI

from crane_fem.blas_threads import rank_blas_threads
from crane_fem.checkpoint import (
    Checkpoint,
    raise_if_any,
    read_checkpoint,
    resume_series,
    scenario_hash,
    write_checkpoint,
)
from crane_fem.contact.on_line import LineContacts
from crane_fem.contact.sliding import SlidingContacts
from crane_fem.coupling import MacroRecord, MacroStep
from crane_fem.errors import RunInterrupted, ScenarioError, UnstableRunError
from crane_fem.io import HistoryWriter, XDMFSeries, write_summary
from crane_fem.io.results import write_results_csv
from crane_fem.monitors import HistoryRows, Monitors, create_monitors
from crane_fem.pipeline import Simulation, create_simulation
from crane_fem.pipeline.frame import carried_weight
from crane_fem.pipeline.kinds import concrete_scenario
from crane_fem.run_record import RunResult, StopRequest, finish_summary, progress_bar
from crane_fem.scenario import Scenario
from crane_fem.subdomains import Subdomain

__all__ = ["run_coupled"]

FloatArray = npt.NDArray[np.float64]


def _xdmf_writers(
    sc: Scenario, sim: Simulation, out: Path, resume: tuple[Path, int] | None = None
) -> list[tuple[Subdomain, XDMFSeries]]:
    """One XDMF series per subdomain; ``resume`` = (restart directory, frames): continue its
    series after their first ``frames`` frames."""
    writers: list[tuple[Subdomain, XDMFSeries]] = []
    if not sc.output.xdmf:
        return writers
    md = sim.models
    subs = [sub for sub in (md.explicit, md.implicit) if sub is not None]
    paths = [out / f"solution_{sub.name.replace('+', '_')}.xdmf" for sub in subs]
    if resume is not None:
        resume_series(resume[0], out, paths, resume[1], sim.mesh.comm)
    for sub, path in zip(subs, paths, strict=True):
        is_e = sub is md.explicit
        names = ["displacement", "velocity"] + (["contact_force"] if is_e else [])
        series = XDMFSeries(
            path,
            sub.V,
            names,
            constants={"subdomain": 0.0 if is_e else 1.0},
            stress=sub.stress() if sub.bs > 1 else None,
            append=resume is not None,
        )
        writers.append((sub, series))
    return writers


@dataclass
class LoopBooks:
    """What the time loop accumulates from the records (global values; the support reactions'
    last velocities are this rank's): the history rows, the monitors, the energy drift and
    its scale, the interface energy's steps, the micro-step times and contact flags, the XDMF
    frames written. A checkpoint saves and restores it whole."""

    history: dict[str, list[float]]
    monitors: Monitors
    micro_t: list[FloatArray] = field(default_factory=list)
    micro_active: list[npt.NDArray[np.bool_]] = field(default_factory=list)
    total0: float | None = None
    scale: float = 0.0
    max_drift: float = 0.0
    ifd_min_step: float = math.inf
    ifd_prev: float = 0.0
    frames: int = 0

    _SCALARS = ("scale", "max_drift", "ifd_min_step", "ifd_prev", "frames")

    def book(self, rec: MacroRecord) -> None:
        """The energy drift, the interface energy's step and the micro steps of ``rec``."""
        e = rec.energy
        if self.total0 is None:
            self.total0 = e["total"]
        self.scale = max(
            self.scale, abs(e["kinetic"]) + abs(e["internal"]) + abs(e["external_work"])
        )
        self.max_drift = max(self.max_drift, abs(e["total"] - self.total0))
        step_ifd = e["interface_energy_gc"] - self.ifd_prev
        if rec.step > 0:
            self.ifd_min_step = min(self.ifd_min_step, step_ifd)
        self.ifd_prev = e["interface_energy_gc"]
        self.micro_t.append(rec.micro.t)
        self.micro_active.append(rec.micro.active)

    def state_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {k: getattr(self, k) for k in self._SCALARS}
        out["history"] = {c: np.asarray(v, dtype=np.float64) for c, v in self.history.items()}
        # The measured points' last row stands beside the books, where checkpoints keep it.
        points = self.monitors.points
        out["point_row"] = dict(points.row) if points is not None else {}
        out["micro_t"] = np.concatenate([np.zeros(0), *self.micro_t])
        out["micro_active"] = np.concatenate([np.zeros(0, dtype=bool), *self.micro_active])
        if self.total0 is not None:
            out["total0"] = self.total0
        out.update(self.monitors.state_dict())
        return out

    def load_state_dict(self, state: dict[str, Any]) -> None:
        """Restore in place (the loop's aliases stay valid)."""
        if set(state["history"]) != set(self.history):
            raise ValueError("the history has other columns")
        for c, rows in self.history.items():
            rows[:] = [float(x) for x in state["history"][c]]
        if self.monitors.points is not None:
            row = state.get("point_row", {})
            self.monitors.points.row = {k: float(v) for k, v in row.items()}
        self.micro_t[:] = [np.asarray(state["micro_t"], dtype=np.float64)]
        self.micro_active[:] = [np.asarray(state["micro_active"], dtype=bool)]
        self.total0 = float(state["total0"]) if "total0" in state else None
        self.scale, self.max_drift = float(state["scale"]), float(state["max_drift"])
        self.ifd_min_step, self.ifd_prev = float(state["ifd_min_step"]), float(state["ifd_prev"])
        self.frames = int(state["frames"])
        self.monitors.load_state_dict(state)


def _step_sizes(sim: Simulation) -> dict[str, Any]:
    """What a checkpoint must share with the run that continues it, beyond the scenario."""
    md = sim.models
    return {
        "method": md.method,
        "ratio": md.ratio,
        "dt": md.dt,
        "dT": md.dT,
        "sample_steps": md.sample_steps,
    }


def _records(
    method: MacroStep,
    force0: FloatArray | None,
    resumed: MacroRecord | None,
    sliding: SlidingContacts | LineContacts | None = None,
) -> Iterator[MacroRecord]:
    """The macro records of a run: the start's (or the resumed checkpoint's), then one per
    macro step to the clock's end (collective). Before each macro step, node-to-surface
    contacts are paired again where their points have slid (``sliding``: the hook that
    updates the explicit zone's contact rows)."""
    rec = method.initialize(force0) if resumed is None else resumed
    yield rec
    system = method.system
    grid = system.grid
    while not grid.finished:
        if sliding is not None and system.E is not None:
            sliding.update(system.E, system.t)
        yield method.step()


def _save(sim: Simulation, out: Path, rec: MacroRecord, books: LoopBooks) -> None:
    """The checkpoint of ``rec``'s macro step, before the loop uses ``rec`` (collective)."""
    sc = sim.scenario
    meta = {"step": rec.step, "micro_step": rec.micro_step, "t": rec.t, "scenario": sc.name}
    meta.update(scenario_hash=scenario_hash(sc), **_step_sizes(sim))
    state = {
        "method": sim.integrators.method.state_dict(),
        "record": rec.state_dict(),
        "books": books.state_dict(),
    }
    if sim.constraints.sliding is not None:
        state["sliding"] = sim.constraints.sliding.state_dict()
    write_checkpoint(out, sim.mesh.comm, meta, state)


def _resume(ckpt: Checkpoint, sim: Simulation, books: LoopBooks, restart: Path) -> MacroRecord:
    """Restore the method's state and the loop's books from ``ckpt``; return the record of
    its macro step, which the loop has not used yet (collective: refusals are the same on
    every rank)."""
    meta = ckpt.meta
    for key, value in _step_sizes(sim).items():
        if meta.get(key) != value:
            raise ScenarioError(
                f"--restart: the checkpoint's {key} = {meta.get(key)!r} differs from this "
                f"run's {value!r}"
            )
    if int(meta.get("micro_step", 0)) > sim.models.end_steps:
        raise ScenarioError(
            f"--restart: time.end = {sim.scenario.time.end:g} s is before the checkpoint in "
            f"{restart} (t = {meta['t']:g} s)"
        )
    error, rec = None, None
    try:
        # The contact rows first: the explicit zone's state arrays are sized by them.
        sliding = sim.constraints.sliding
        if sliding is not None:
            zone = sim.integrators.system.E
            sliding.load_state_dict(ckpt.state["sliding"], zone)
        sim.integrators.method.load_state_dict(ckpt.state["method"])
        books.load_state_dict(ckpt.state["books"])
        rec = sim.integrators.system.resume_record(ckpt.state["record"])
    except (KeyError, ValueError, TypeError) as exc:
        error = (
            f"--restart: the checkpoint in {restart} does not fit this run (written by another "
            f"version of crane-fem?): {' '.join(str(exc).split())}"
        )
    raise_if_any(sim.mesh.comm, error)
    assert rec is not None
    return rec


def _summary_head(sc: Scenario, sim: Simulation, comm: MPI.Comm) -> dict[str, Any]:
    md, cons, it = sim.models, sim.constraints, sim.integrators
    sub = md.explicit or md.implicit
    assert sub is not None
    n_steps = md.n_macro * it.system.m if md.coupled else md.n_steps
    summary: dict[str, Any] = {
        "scenario": sc.name,
        "method": md.label,
        "ratio": md.ratio,
        "explicit_subdomains": md.explicit_names,
        "implicit_subdomains": md.implicit_names,
        "dt": md.dt,
        "dT": md.dT,
        "dt_critical": md.dt_critical,
        "steps": md.n_macro if md.coupled else n_steps,
        "micro_steps": n_steps,
        "sampling_interval_s": md.sample_steps * md.dt,
        "interface_dofs": int(cons.l_explicit.p),
        # Global DOF counts of each side (their ratio and n_Γ set the cost of a coupled run).
        "dofs_explicit": md.explicit.model.K.getSize()[0] if md.explicit is not None else 0,
        "dofs_implicit": md.implicit.model.K.getSize()[0] if md.implicit is not None else 0,
        "mpi_size": comm.size,
        "status": "running",
    }
    if sim.mesh.mass_scaling is not None:
        summary["mass_scaling"] = sim.mesh.mass_scaling.summary()
    # Where the constraints live: owned DOFs of the contact and interface rows per rank.
    summary["contact_dofs_per_rank"] = comm.allgather(int(cons.contacts.dofs.size))
    E = it.explicit
    n_if = int(np.count_nonzero(E.stack.rows < E.n_gamma)) if E is not None else 0
    summary["interface_dofs_per_rank"] = comm.allgather(n_if if md.coupled else 0)
    if md.preload is not None and sim.mesh.surface_contacts:
        pre = md.preload
        summary["preload"] = {
            "weight_N": pre.weight,
            "contact_forces_N": {
                c.name: float(f)
                for c, f in zip(sim.mesh.surface_contacts, pre.wheel_force, strict=True)
            },
            "max_penetration_m": pre.penetration,
        }
    elif md.preload is not None and sim.mesh.frame_contacts is not None:
        pre, fc = md.preload, sim.mesh.frame_contacts
        carried = carried_weight(sc, sim.mesh.tagged, sim.mesh.fields)
        normal = [c.group for c in fc.lines] + [c.group for c in fc.planes]
        held = float(np.sum(pre.wheel_force[normal]))
        summary["preload"] = {
            "weight_N": pre.weight,
            # The bodies on contacts alone (a trolley with its load) against what the
            # contacts carry.
            "carried_weight_N": carried,
            "contact_forces_N": {
                n: float(f) for n, f in zip(fc.names, pre.wheel_force, strict=True)
            },
            "sum_relative_error": abs(held - carried) / carried if carried > 0.0 else 0.0,
            "max_penetration_m": pre.penetration,
        }
    elif md.preload is not None:
        pre = md.preload
        summary["preload"] = {
            "trolley_weight_N": pre.weight,
            "wheel_forces_N": [float(x) for x in pre.wheel_force],
            "sum_relative_error": pre.relative_error,
            "support_reaction_N": pre.support_reaction,
            "max_penetration_m": pre.penetration,
        }
    if it.reduction is not None:  # what the reduced implicit side keeps, and its set-up
        summary["reduction"] = it.reduction
    if it.operator_report is not None:  # what the interface operator keeps
        summary["interface_operator"] = dataclasses.asdict(it.operator_report)
    return summary


def run_coupled(
    sc: Scenario,
    outdir: str | Path,
    comm: MPI.Comm | None = None,
    progress: bool | None = None,
    restart: str | Path | None = None,
) -> RunResult:
    """Run a scenario with subdomains (a coupling method or the monolithic reference); outputs
    as :func:`crane_fem.driver.run_scenario` plus the ``interface_*`` columns and one XDMF file
    per subdomain. The summary gives the set-up and time-loop wall times apart.

    Collective over ``comm``.
    """
    comm = MPI.COMM_WORLD if comm is None else comm
    out = Path(outdir)
    t_wall = time.perf_counter()
    sc = concrete_scenario(sc, comm)  # (a frame crane as the frame it is)
    ckpt = read_checkpoint(Path(restart), comm, sc) if restart is not None else None
    sim = create_simulation(sc, comm)
    md, it = sim.models, sim.integrators
    method = it.method
    rows = HistoryRows(sim)
    monitors = create_monitors(sim, out)
    columns = rows.columns + monitors.columns
    b = LoopBooks({c: [] for c in columns}, monitors)
    history = b.history
    every = sc.output.every
    xdmf_every = sc.output.xdmf_every or max(1, it.system.grid.n_samples // 200)
    ckpt_every = sc.output.checkpoint_every
    summary = _summary_head(sc, sim, comm)
    resumed = None
    try:  # a refused restart leaves the files as they were
        if ckpt is not None:
            assert restart is not None
            resumed = _resume(ckpt, sim, b, Path(restart))
            summary["restart"] = {"from": str(restart), "step": ckpt.step, "t": ckpt.meta["t"]}
            if comm.rank == 0:
                print(
                    f"crane-fem: continuing from the checkpoint of macro step {ckpt.step} "
                    f"(t = {ckpt.meta['t']:.6g} s) in {restart}",
                    file=sys.stderr,
                    flush=True,
                )
        resume = (Path(restart), b.frames) if restart is not None else None
        writers = _xdmf_writers(sc, sim, out, resume)
    except BaseException:
        monitors.destroy()
        sim.destroy()
        raise
    grid = it.system.grid
    n_s = grid.sample
    # A summary from the start: a run killed outright (SIGKILL, out of memory) leaves one that
    # says it did not end; the end of the run replaces it.
    write_summary(
        out / "summary.json",
        {
            **summary,
            "diagnosis": "the run is under way, or was killed before it could write its end",
        },
        comm,
    )
    bar = progress_bar(sc, comm, progress, grid.end, "step")
    comm.barrier()
    t_loop = time.perf_counter()
    summary["wall_time_setup_s"] = comm.allreduce(t_loop - t_wall, op=MPI.MAX)
    t_output = t_checkpoint = 0.0
    n_checkpoints = 0
    stop = StopRequest(comm)
    try:
        with (
            stop,
            rank_blas_threads(comm),
            HistoryWriter(out / "history.csv", columns, comm, history) as writer,
        ):
            sliding = sim.constraints.sliding
            for rec in _records(method, it.interface_force0, resumed, sliding):
                bar.update(rec.micro_step - bar.n)
                sample, at_sample = divmod(rec.micro_step, n_s)
                at_sample = at_sample == 0
                # The checkpoint of a sampling instant is taken before its record is used:
                # the run continued from it uses the record as this one does.
                due = ckpt_every and at_sample and sample and sample % ckpt_every == 0
                if due and rec is not resumed and method.resumable():
                    t_ck = time.perf_counter()
                    _save(sim, out, rec, b)
                    t_checkpoint += time.perf_counter() - t_ck
                    n_checkpoints += 1
                # A diverging run or a wheel beyond its pairs' reach stops here, unbooked.
                monitors.watch(rec)
                b.book(rec)
                # Output time apart from the time loop's: the barriers keep a rank that waits
                # for rank 0's writing from booking that wait as integration.
                if comm.size > 1:
                    comm.Barrier()
                t_out = time.perf_counter()
                stopping = stop.requested()
                last = rec.micro_step >= grid.end or stopping
                if at_sample or last:
                    monitors.sample(rec, last)
                if (at_sample and sample % every == 0) or last:
                    row = rows.row(rec)
                    row.update(monitors.history_row(rec.t))
                    writer.write(row)
                    for c in columns:
                        history[c].append(row[c])
                frame = (at_sample and sample % xdmf_every == 0) or last
                if writers and frame:
                    b.frames += 1
                    for sub, w in writers:
                        is_e = sub is md.explicit
                        du = rec.explicit_u if is_e else rec.implicit_u
                        dv = rec.explicit_v if is_e else rec.implicit_v
                        assert du is not None and dv is not None
                        fields = {"displacement": du, "velocity": dv}
                        if is_e:
                            zone = it.system.E  # its rows: re-paired ones when sliding
                            assert zone is not None
                            fields["contact_force"] = (
                                zone.contacts.transpose(rec.contact_impulse, du.size) / md.dt
                            )
                        w.write(rec.t, fields)
                if comm.size > 1:
                    comm.Barrier()
                t_output += time.perf_counter() - t_out
                if stopping:
                    raise RunInterrupted(
                        f"interrupted by {stop.signal_name} at t = {rec.t:.6g} s "
                        f"(macro step {rec.step}, {rec.micro_step} of {grid.end} micro steps); "
                        "the files hold the steps done"
                    )
        summary["status"] = "completed"
    except UnstableRunError as exc:
        summary["status"] = "unstable"
        summary["diagnosis"] = str(exc)
        raise
    except RunInterrupted as exc:
        summary["status"] = "interrupted"
        summary["diagnosis"] = str(exc)
        raise
    except KeyboardInterrupt:
        summary["status"] = "interrupted"
        summary["diagnosis"] = "interrupted by the user; the files hold the steps done"
        raise
    except BaseException as exc:  # a refused step (CraneFemError) or a bug: not "running"
        summary["status"] = "failed"
        summary["diagnosis"] = str(exc) or type(exc).__name__
        raise
    finally:
        bar.close()
        for _, w in writers:
            w.close()
        # The time loop alone: integration, without the history rows, XDMF frames and
        # checkpoints.
        loop = time.perf_counter() - t_loop
        t_output += t_checkpoint
        summary["wall_time_integration_s"] = comm.allreduce(loop - t_output, op=MPI.MAX)
        summary["wall_time_output_s"] = comm.allreduce(t_output, op=MPI.MAX)
        if ckpt_every:
            summary["checkpoints"] = {
                "every": ckpt_every,
                "written": n_checkpoints,
                "wall_time_s": comm.allreduce(t_checkpoint, op=MPI.MAX),
            }
        summary["steps_done"] = grid.n
        summary["micro_steps_done"] = grid.i
        summary["interface_energy_gc_min_step"] = (
            b.ifd_min_step if math.isfinite(b.ifd_min_step) else 0.0
        )
        summary.update(method.summary())
        if sim.constraints.sliding is not None:
            summary["node_to_surface"] = sim.constraints.sliding.summary()
        summary["t_reached_s"] = history["t"][-1] if history["t"] else 0.0
        summary["time_end_s"] = sc.time.end
        monitors.summarize(summary)
        monitors.destroy()
        if comm.rank == 0:
            write_results_csv(out / "results.csv", summary)
        times = np.concatenate([np.zeros(0), *b.micro_t])
        active = np.concatenate([np.zeros(0, dtype=bool), *b.micro_active])
        finish_summary(summary, out, comm, t_wall, times, active, b.max_drift, b.scale)
        sim.destroy()
        comm.barrier()
    return RunResult(summary, {c: np.asarray(v, dtype=np.float64) for c, v in history.items()})
