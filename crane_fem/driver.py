"""Run a scenario: build, integrate, monitor, and feed the writers (history, XDMF, summary).

The single-subdomain bar path lives here; scenarios with subdomains (coupled or the
monolithic references) run through :mod:`crane_fem.coupled_run`.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
from mpi4py import MPI

from crane_fem.energy import BALANCE_TERMS
from crane_fem.errors import RunInterrupted, ScenarioError, UnstableRunError
from crane_fem.integrators import CDLagrange, CDPenalty, MoreauJean, StepRecord, TimeIntegrator
from crane_fem.io import HistoryWriter, XDMFSeries
from crane_fem.io.results import write_results_csv
from crane_fem.peaks import ContactPeaks
from crane_fem.problems import Problem, create_problem
from crane_fem.run_record import RunResult, StopRequest, finish_summary, progress_bar
from crane_fem.scenario import Scenario
from crane_fem.stability import EnergyGrowthMonitor, critical_time_step, max_frequency

__all__ = ["RunResult", "Simulation", "run_scenario"]

FloatArray = npt.NDArray[np.float64]

ENERGY_COLUMNS = [*BALANCE_TERMS, "total"]


class Simulation:
    """A scenario's problem, step sizes and integrator (collective; ``destroy`` releases all).

    Attributes:
        dt: time step (s); ``dt_critical``: critical explicit step of the mesh (s);
        dt_critical_penalty: the step limit with the penalty springs closed (penalty only).
    """

    def __init__(self, sc: Scenario, comm: MPI.Comm) -> None:
        self.scenario = sc
        self.comm = comm
        self.problem: Problem = create_problem(comm, sc)
        model = self.problem.model
        self.omega_max = max_frequency(model)
        alpha, beta = model.alpha, model.beta
        self.dt_critical = critical_time_step(self.omega_max, alpha, beta)
        self.dt_critical_penalty: float | None = None
        integ = sc.integrator
        if integ.scheme == "penalty" and integ.penalty is not None:
            omega_p = max_frequency(model, (self.problem.contacts, integ.penalty))
            self.dt_critical_penalty = critical_time_step(omega_p, alpha, beta)
        # The explicit limit of the scheme: with penalty, the springs (all closed) count too.
        limit = min(self.dt_critical, self.dt_critical_penalty or math.inf)
        if sc.time.dt is not None:
            self.dt = sc.time.dt
        else:
            assert sc.time.dt_factor is not None
            self.dt = sc.time.dt_factor * limit
        self.n_steps = max(1, math.ceil(sc.time.end / self.dt - 1e-9))
        if integ.scheme != "moreau-jean" and self.dt > limit:
            warnings.warn(
                f"time step {self.dt:.4e} s exceeds the critical explicit step {limit:.4e} s "
                f"({self.dt / limit:.3f}×): the run is expected to diverge",
                RuntimeWarning,
                stacklevel=2,
            )
        p = self.problem
        args = (model, p.contacts, p.load, self.dt, p.u0, p.v0)
        self.integrator: TimeIntegrator
        if integ.scheme == "cd-lagrange":
            self.integrator = CDLagrange(*args)
        elif integ.scheme == "penalty":
            assert integ.penalty is not None
            self.integrator = CDPenalty(*args, stiffness=integ.penalty)
        else:
            self.integrator = MoreauJean(*args, theta=integ.theta_value)
        self.monitor = EnergyGrowthMonitor(
            sc.monitor.energy_growth,
            subdomain="bar",
            scheme=integ.scheme,
            dt=self.dt,
            dt_critical=limit if integ.scheme != "moreau-jean" else math.inf,
        )

    def records(self) -> Iterator[StepRecord]:
        """Yield the record at t = 0 and after every step; raise on divergence (collective)."""
        for rec in self.integrator.run(self.n_steps):
            self.monitor.check(rec)
            yield rec

    def destroy(self) -> None:
        self.integrator.destroy()
        self.problem.destroy()


def run_scenario(
    sc: Scenario,
    outdir: str | Path,
    comm: MPI.Comm | None = None,
    progress: bool | None = None,
    restart: str | Path | None = None,
) -> RunResult:
    """Run ``sc`` and write ``history.csv``, ``summary.json`` and ``solution.xdmf`` in ``outdir``.

    ``restart``: an output directory holding checkpoints of ``sc`` (``output.checkpoint_every``);
    the run continues from the latest one into ``outdir``.

    Collective over ``comm`` (default: COMM_WORLD, chosen here at the entry point).

    Raises:
        UnstableRunError: divergence detected; files written so far stay valid and the
            summary records the diagnosis.
    """
    comm = MPI.COMM_WORLD if comm is None else comm
    if sc.coupled_path:
        from crane_fem.coupled_run import run_coupled

        return run_coupled(sc, outdir, comm, progress, restart)
    if restart is not None:
        raise ScenarioError("--restart: checkpoints are written by scenes with subdomains only")
    out = Path(outdir)
    t_wall = time.perf_counter()
    sim = Simulation(sc, comm)
    p, dt = sim.problem, sim.dt
    contacts = p.contacts
    groups = contacts.group_names
    columns = ["t", *ENERGY_COLUMNS, "contact_force", "active_contacts"]
    columns += [f"gap_{g}" for g in groups] + [f"force_{g}" for g in groups]
    columns += [f"velocity_{b.name}" for b in p.bodies]
    history: dict[str, list[float]] = {c: [] for c in columns}
    every = sc.output.every
    xdmf_every = sc.output.xdmf_every or max(1, sim.n_steps // 200)

    summary: dict[str, Any] = {
        "scenario": sc.name,
        "scheme": sc.integrator.scheme,
        "dt": dt,
        "dt_critical": sim.dt_critical,
        "dt_critical_penalty": sim.dt_critical_penalty,
        "dt_over_dt_critical": dt / sim.dt_critical,
        "omega_max": sim.omega_max,
        "steps": sim.n_steps,
        "h_min": p.h_min,
        "wave_speed": p.wave_speed,
        "mpi_size": comm.size,
        "status": "running",
    }
    times: list[float] = []
    active: list[bool] = []
    peaks = ContactPeaks(groups, dt)
    total0: float | None = None
    scale = 0.0
    max_drift = 0.0
    xdmf = (
        XDMFSeries(out / "solution.xdmf", p.model.V, ["displacement", "velocity", "contact_force"])
        if sc.output.xdmf
        else None
    )
    bar = progress_bar(sc, comm, progress, sim.n_steps, "step")
    stop = StopRequest(comm)
    try:
        with stop, HistoryWriter(out / "history.csv", columns, comm) as writer:
            for rec in sim.records():
                # A signal is looked for every 64 steps (a collective under MPI).
                stopping = rec.step % 64 == 0 and rec.step > 0 and stop.requested()
                en = rec.energy
                total = en.total
                if total0 is None:
                    total0 = total
                scale = max(scale, abs(en.kinetic) + abs(en.internal) + abs(en.external_work))
                max_drift = max(max_drift, abs(total - total0))
                force = rec.impulse / dt
                times.append(rec.t)
                active.append(bool(np.any(rec.impulse > 0.0)))
                peaks.update(
                    np.array([rec.t]),
                    contacts.group_sums(rec.impulse)[None, :],
                    contacts.group_mins(rec.gaps)[None, :],
                )
                if rec.step % every == 0 or rec.step == sim.n_steps or stopping:
                    row = {"t": rec.t, **en.as_dict()}
                    row["contact_force"] = float(force.sum())
                    row["active_contacts"] = float(np.count_nonzero(rec.impulse > 0.0))
                    gmin = contacts.group_mins(rec.gaps)
                    gsum = contacts.group_sums(force)
                    for i, g in enumerate(groups):
                        row[f"gap_{g}"] = float(gmin[i])
                        row[f"force_{g}"] = float(gsum[i])
                    local = [float(np.dot(p.model.mass[b.owned], rec.v[b.owned])) for b in p.bodies]
                    momenta = comm.allreduce(np.array(local), op=MPI.SUM) if local else []
                    for b, mom in zip(p.bodies, momenta, strict=True):
                        row[f"velocity_{b.name}"] = float(mom) / b.mass
                    writer.write(row)
                    for c in columns:
                        history[c].append(row[c])
                if xdmf is not None and (rec.step % xdmf_every == 0 or rec.step == sim.n_steps):
                    xdmf.write(
                        rec.t,
                        {
                            "displacement": rec.u,
                            "velocity": rec.v,
                            "contact_force": contacts.transpose(force, p.model.n_owned),
                        },
                    )
                bar.update(1 if rec.step > 0 else 0)
                if stopping:
                    raise RunInterrupted(
                        f"interrupted by {stop.signal_name} at t = {rec.t:.6g} s "
                        f"(step {rec.step} of {sim.n_steps}); the files hold the steps done"
                    )
        summary["status"] = "completed"
    except RunInterrupted as exc:
        summary["status"] = "interrupted"
        summary["diagnosis"] = str(exc)
        raise
    except UnstableRunError as exc:
        summary["status"] = "unstable"
        summary["diagnosis"] = str(exc)
        raise
    except BaseException as exc:  # a refused step or a bug: not "running"
        summary["status"] = "failed"
        summary["diagnosis"] = str(exc) or type(exc).__name__
        raise
    finally:
        bar.close()
        if xdmf is not None:
            xdmf.close()
        summary["steps_done"] = len(times) - 1
        summary["t_reached_s"] = times[-1] if times else 0.0
        summary["time_end_s"] = sc.time.end
        if groups:  # every step's peaks, whatever output.every
            summary["contact_groups"] = peaks.table()
        if comm.rank == 0:
            write_results_csv(out / "results.csv", summary)
        finish_summary(summary, out, comm, t_wall, times, active, max_drift, scale)
        sim.destroy()
        comm.barrier()
    arrays = {c: np.asarray(v, dtype=np.float64) for c, v in history.items()}
    return RunResult(summary, arrays)
