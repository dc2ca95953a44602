"""Run a scenario: build, integrate, monitor, and feed the writers (history, XDMF, summary)."""

from __future__ import annotations

import dataclasses
import math
import sys
import time
import warnings
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
from mpi4py import MPI
from tqdm import tqdm

from crane_fem.energy import BALANCE_TERMS
from crane_fem.errors import UnstableRunError
from crane_fem.integrators import CDLagrange, CDPenalty, MoreauJean, StepRecord, TimeIntegrator
from crane_fem.io import HistoryWriter, XDMFSeries, write_summary
from crane_fem.problems import Problem, create_problem
from crane_fem.scenario import Scenario
from crane_fem.stability import EnergyGrowthMonitor, critical_time_step, max_frequency

__all__ = ["RunResult", "Simulation", "run_coupled", "run_scenario"]

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


@dataclass
class RunResult:
    """Summary and the in-memory history (global values, identical on every rank)."""

    summary: dict[str, Any]
    history: dict[str, FloatArray] = field(default_factory=dict)


def _progress(sc: Scenario, comm: MPI.Comm, progress: bool | None, total: int, unit: str) -> Any:
    """tqdm bar on rank 0, shown after 2 s, off when stderr is not a terminal (unless forced)."""
    show = progress if progress is not None else sc.output.progress
    on = comm.rank == 0 and (sys.stderr.isatty() if show == "auto" else bool(show))
    return tqdm(total=total, disable=not on, delay=2.0, mininterval=0.5, unit=unit, desc=sc.name)


def _finish_summary(
    summary: dict[str, Any],
    out: Path,
    comm: MPI.Comm,
    t_wall: float,
    times: list[float],
    active: list[bool],
    max_drift: float,
    scale: float,
) -> None:
    """Add cost, energy closure and contact intervals, then write summary.json (collective)."""
    intervals = _contact_intervals(times, active)
    summary.update(
        {
            "wall_time_s": comm.allreduce(time.perf_counter() - t_wall, op=MPI.MAX),
            "energy_balance_error": max_drift / scale if scale > 0 else 0.0,
            "energy_balance_error_abs": max_drift,
            "contact_intervals": len(intervals),
            "contact_interval_times": intervals[:100],
        }
    )
    write_summary(out / "summary.json", summary, comm)


def _contact_intervals(times: list[float], active: list[bool]) -> list[tuple[float, float]]:
    """Maximal runs of consecutive steps with a non-zero contact impulse: (first, last) times."""
    out: list[tuple[float, float]] = []
    start: float | None = None
    last = 0.0
    for t, a in zip(times, active, strict=True):
        if a and start is None:
            start = t
        if not a and start is not None:
            out.append((start, last))
            start = None
        last = t
    if start is not None:
        out.append((start, last))
    return out


def run_scenario(
    sc: Scenario,
    outdir: str | Path,
    comm: MPI.Comm | None = None,
    progress: bool | None = None,
) -> RunResult:
    """Run ``sc`` and write ``history.csv``, ``summary.json`` and ``solution.xdmf`` in ``outdir``.

    Collective over ``comm`` (default: COMM_WORLD, chosen here at the entry point).

    Raises:
        UnstableRunError: divergence detected; files written so far stay valid and the
            summary records the diagnosis.
    """
    comm = MPI.COMM_WORLD if comm is None else comm
    if sc.coupled_path:
        return run_coupled(sc, outdir, comm, progress)
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
    total0: float | None = None
    scale = 0.0
    max_drift = 0.0
    xdmf = (
        XDMFSeries(out / "solution.xdmf", p.model.V, ["displacement", "velocity", "contact_force"])
        if sc.output.xdmf
        else None
    )
    bar = _progress(sc, comm, progress, sim.n_steps, "step")
    try:
        with HistoryWriter(out / "history.csv", columns, comm) as writer:
            for rec in sim.records():
                en = rec.energy
                total = en.total
                if total0 is None:
                    total0 = total
                scale = max(scale, abs(en.kinetic) + abs(en.internal) + abs(en.external_work))
                max_drift = max(max_drift, abs(total - total0))
                force = rec.impulse / dt
                times.append(rec.t)
                active.append(bool(np.any(rec.impulse > 0.0)))
                if rec.step % every == 0 or rec.step == sim.n_steps:
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
        summary["status"] = "completed"
    except UnstableRunError as exc:
        summary["status"] = "unstable"
        summary["diagnosis"] = str(exc)
        raise
    finally:
        bar.close()
        if xdmf is not None:
            xdmf.close()
        summary["steps_done"] = len(times) - 1
        _finish_summary(summary, out, comm, t_wall, times, active, max_drift, scale)
        sim.destroy()
        comm.barrier()
    arrays = {c: np.asarray(v, dtype=np.float64) for c, v in history.items()}
    return RunResult(summary, arrays)


def _probe_sums(
    sub: Any, values: FloatArray | None, vertices: Any, exclude: Any
) -> tuple[FloatArray, int]:
    """Local sums of ``values`` (owned DOFs) per component over probe vertices."""
    assert values is not None
    blocks, _ = sub.owned_dofs_of(np.setdiff1d(vertices, exclude))
    bs = sub.bs
    vals = values.reshape(-1, bs)[blocks]
    return vals.sum(axis=0), int(blocks.size)


def _coupled_growth_check(monitor: EnergyGrowthMonitor, sim: Any, rec: Any) -> None:
    """Stop a diverging coupled run (:meth:`EnergyGrowthMonitor.growth`) with a diagnosis
    naming the subdomain whose kinetic energy dominates, the macro step, the energy the
    interface has created, m, and Δt against the explicit critical step."""
    e = rec.energy
    reason = monitor.growth(e["kinetic"], e["internal"], e["external_work"])
    if reason is None:
        return
    explicit = e["kinetic_explicit"] >= e["kinetic_implicit"]
    names = sim.explicit_names if explicit else sim.implicit_names
    scheme = "cd-lagrange" if explicit else "newmark"
    raise UnstableRunError(
        f"unstable run: subdomain '{'+'.join(names)}' ({scheme}) at macro step {rec.step} "
        f"(t = {rec.t:.6g} s): {reason}; the interface has "
        f"{'created' if e['interface_dissipated'] < 0 else 'dissipated'} "
        f"{abs(e['interface_dissipated']):.3e} J (method {sim.method}, m = {sim.ratio}); "
        f"Δt = {sim.dt:.4e} s is {sim.dt / sim.dt_critical:.3f}× the critical step "
        f"{sim.dt_critical:.4e} s"
    )


def run_coupled(
    sc: Scenario, outdir: str | Path, comm: MPI.Comm | None = None, progress: bool | None = None
) -> RunResult:
    """Run a scenario with subdomains (GC/PH coupling or monolithic reference); outputs as
    :func:`run_scenario` plus ``interface_*`` columns and one XDMF file per subdomain.

    Collective over ``comm``.
    """
    from crane_fem.coupled import CoupledSimulation
    from crane_fem.coupling import ENERGY_KEYS

    comm = MPI.COMM_WORLD if comm is None else comm
    out = Path(outdir)
    t_wall = time.perf_counter()
    sim = CoupledSimulation(sc, comm)
    integ = sim.integrator
    system = sim.system
    groups_c = sim.contacts.group_names
    bs = (sim.E_sub or sim.I_sub).bs  # type: ignore[union-attr]
    probe = sim.probe_vertices()
    columns = [
        "t",
        *ENERGY_KEYS,
        *integ.history_keys(),
        "total",
        "kinetic_explicit",
        "internal_explicit",
        "kinetic_implicit",
        "internal_implicit",
        "contact_force",
        "active_contacts",
    ]
    columns += [f"gap_{g}" for g in groups_c] + [f"force_{g}" for g in groups_c]
    columns += [f"probe_u{c}" for c in range(bs)] + [f"probe_v{c}" for c in range(bs)]
    columns += ["interface_force_norm", "interface_velocity_jump"]
    columns += ["interface_impulse", "interface_impulse_defect"]
    # Crane: one wheel/rail node pair per wheel (the first pair of each patch), vertical
    # displacement and velocity on both sides (the paper's Figs. 5–6).
    pair_probe: list[tuple[int, int, int]] = []
    if sim.crane is not None:
        for k in range(1, 5):
            i = int(np.flatnonzero(sim.crane.wheel == k)[0])
            pair_probe.append((k, int(sim.crane.pairs[i, 0]), int(sim.crane.pairs[i, 1])))
            columns += [f"wheel{k}_{side}_{q}" for side in ("wheel", "rail") for q in ("uz", "vz")]
    history: dict[str, list[float]] = {c: [] for c in columns}
    # A monolithic run of a coupled scenario steps `ratio` time steps per macro step (its
    # records fall on the coupled run's output times: the two histories share one grid).
    every = sc.output.every
    xdmf_every = sc.output.xdmf_every or max(1, sim.n_macro // 200)
    n_steps = sim.n_macro * system.m
    if not system.coupled:
        n_steps = integ.n_steps  # type: ignore[attr-defined]
    summary: dict[str, Any] = {
        "scenario": sc.name,
        "method": sim.method,
        "ratio": sim.ratio,
        "explicit_subdomains": sim.explicit_names,
        "implicit_subdomains": sim.implicit_names,
        "dt": sim.dt,
        "dT": sim.dT,
        "dt_critical": sim.dt_critical,
        "steps": sim.n_macro if system.coupled else n_steps,
        "micro_steps": n_steps,
        "interface_dofs": int(sim.interface_vertices.size * bs),
        # Global DOF counts of each side (their ratio and n_Γ set the cost of a coupled run).
        "dofs_explicit": sim.E_sub.model.K.getSize()[0] if sim.E_sub is not None else 0,
        "dofs_implicit": sim.I_sub.model.K.getSize()[0] if sim.I_sub is not None else 0,
        "mpi_size": comm.size,
        "status": "running",
    }
    # Where the constraints live: owned DOFs of the contact and interface rows per rank.
    summary["contact_dofs_per_rank"] = comm.allgather(int(sim.contacts.dofs.size))
    n_if = 0
    if sim.E_int is not None and system.coupled:
        n_if = int(np.count_nonzero(sim.E_int.stack.rows < sim.E_int.n_gamma))
    summary["interface_dofs_per_rank"] = comm.allgather(n_if)
    if sim.preload is not None:
        pre = sim.preload
        summary["preload"] = {
            "trolley_weight_N": pre.weight,
            "wheel_forces_N": [float(x) for x in pre.wheel_force],
            "sum_relative_error": pre.relative_error,
            "support_reaction_N": pre.support_reaction,
            "max_penetration_m": pre.penetration,
        }
    writers = []
    if sc.output.xdmf:
        solid = bs == 3
        for sub in (sim.E_sub, sim.I_sub):
            if sub is not None:
                is_e = sub is sim.E_sub
                names = ["displacement", "velocity"] + (["contact_force"] if is_e else [])
                writers.append(
                    (
                        sub,
                        XDMFSeries(
                            out / f"solution_{sub.name.replace('+', '_')}.xdmf",
                            sub.V,
                            names,
                            constants={"subdomain": 0.0 if is_e else 1.0},
                            von_mises=(sc.material.E, sc.material.nu) if solid else None,
                        ),
                    )
                )
    bar = _progress(sc, comm, progress, sim.n_macro, "macro step")
    micro: list[tuple[float, bool]] = []
    total0: float | None = None
    scale = max_drift = 0.0
    ifd_min_step = math.inf
    ifd_prev = 0.0
    monitor = EnergyGrowthMonitor(sc.monitor.energy_growth, "", "", sim.dt, sim.dt_critical)
    try:
        with HistoryWriter(out / "history.csv", columns, comm) as writer:
            rec = integ.initialize(sim.interface_force0)
            n = 0
            while True:
                e = rec.energy
                if not all(math.isfinite(v) for v in e.values()):
                    raise UnstableRunError(
                        f"unstable run: non-finite energy at macro step {rec.step} "
                        f"(t = {rec.t:.6g} s); Δt = {sim.dt:.4e} s, critical "
                        f"{sim.dt_critical:.4e} s"
                    )
                _coupled_growth_check(monitor, sim, rec)
                if total0 is None:
                    total0 = e["total"]
                scale = max(scale, abs(e["kinetic"]) + abs(e["internal"]) + abs(e["external_work"]))
                max_drift = max(max_drift, abs(e["total"] - total0))
                step_ifd = e["interface_energy_gc"] - ifd_prev
                if rec.step > 0:
                    ifd_min_step = min(ifd_min_step, step_ifd)
                ifd_prev = e["interface_energy_gc"]
                micro.extend(rec.micro)
                if rec.step % every == 0 or rec.step == sim.n_macro:
                    row: dict[str, float] = {"t": rec.t}
                    row.update({k: e[k] for k in columns if k in e})
                    force = rec.contact_impulse / sim.dt
                    row["contact_force"] = float(force.sum())
                    row["active_contacts"] = float(np.count_nonzero(force > 0))
                    gmin = sim.contacts.group_mins(rec.gaps)
                    gsum = sim.contacts.group_sums(force)
                    for i, g in enumerate(groups_c):
                        row[f"gap_{g}"] = float(gmin[i])
                        row[f"force_{g}"] = float(gsum[i])
                    su = np.zeros(bs)
                    sv = np.zeros(bs)
                    cnt = 0
                    if sim.E_sub is not None:
                        a, k = _probe_sums(sim.E_sub, rec.explicit_u, probe, np.zeros(0))
                        b, _ = _probe_sums(sim.E_sub, rec.explicit_v, probe, np.zeros(0))
                        su, sv, cnt = su + a, sv + b, cnt + k
                    if sim.I_sub is not None:
                        excl = sim.interface_vertices if sim.E_sub is not None else np.zeros(0)
                        a, k = _probe_sums(sim.I_sub, rec.implicit_u, probe, excl)
                        b, _ = _probe_sums(sim.I_sub, rec.implicit_v, probe, excl)
                        su, sv, cnt = su + a, sv + b, cnt + k
                    tot = comm.allreduce(np.r_[su, sv, cnt], op=MPI.SUM)
                    for k in range(bs):
                        row[f"probe_u{k}"] = float(tot[k] / max(tot[-1], 1))
                        row[f"probe_v{k}"] = float(tot[bs + k] / max(tot[-1], 1))
                    row["interface_force_norm"] = float(np.linalg.norm(rec.interface_impulse))
                    jump = 0.0
                    if (
                        system.coupled
                        and sim.E_int is not None
                        and system.LI is not None
                        and rec.implicit_v is not None
                    ):
                        n_g = system.n_gamma
                        jump = float(
                            np.max(
                                np.abs(
                                    sim.E_int.stack.apply(sim.E_int.v_int)[:n_g]
                                    + system.LI.apply(rec.implicit_v)[:n_g]
                                ),
                                initial=0.0,
                            )
                        )
                    row["interface_velocity_jump"] = jump
                    row["interface_impulse"] = rec.impulse_explicit
                    row["interface_impulse_defect"] = rec.impulse_defect
                    if pair_probe:
                        assert sim.E_sub is not None and rec.explicit_u is not None
                        assert rec.explicit_v is not None
                        ids = np.array([v for _, w, r in pair_probe for v in (w, r)])
                        order = np.argsort(ids)
                        blocks, pos = sim.E_sub.owned_dofs_of(ids[order])
                        vals = np.zeros((ids.size, 2))
                        dz = blocks * sim.E_sub.bs + 2
                        vals[order[pos], 0] = rec.explicit_u[dz]
                        vals[order[pos], 1] = rec.explicit_v[dz]
                        vals = comm.allreduce(vals, op=MPI.SUM)
                        for n_p, (k, _, _) in enumerate(pair_probe):
                            for s_i, side in enumerate(("wheel", "rail")):
                                row[f"wheel{k}_{side}_uz"] = float(vals[2 * n_p + s_i, 0])
                                row[f"wheel{k}_{side}_vz"] = float(vals[2 * n_p + s_i, 1])
                    writer.write(row)
                    for c in columns:
                        history[c].append(row[c])
                if writers and (rec.step % xdmf_every == 0 or rec.step == sim.n_macro):
                    for sub, w in writers:
                        is_e = sub is sim.E_sub
                        du = rec.explicit_u if is_e else rec.implicit_u
                        dv = rec.explicit_v if is_e else rec.implicit_v
                        assert du is not None and dv is not None
                        fields = {"displacement": du, "velocity": dv}
                        if is_e:
                            assert sim.E_int is not None
                            fields["contact_force"] = (
                                sim.contacts.transpose(rec.contact_impulse, du.size) / sim.dt
                            )
                        w.write(rec.t, fields)
                if n == sim.n_macro:
                    break
                rec = integ.step()
                n += 1
                bar.update(1)
        summary["status"] = "completed"
    except UnstableRunError as exc:
        summary["status"] = "unstable"
        summary["diagnosis"] = str(exc)
        raise
    finally:
        bar.close()
        for _, w in writers:
            w.close()
        summary["steps_done"] = round(history["t"][-1] / sim.dT) if history["t"] else 0
        summary["interface_energy_gc_min_step"] = (
            ifd_min_step if math.isfinite(ifd_min_step) else 0.0
        )
        summary.update(integ.summary())
        report = getattr(sim, "operator_report", None)
        if report is not None:  # what the interface operator keeps (crane_fem.coupling.operator)
            summary["interface_operator"] = dataclasses.asdict(report)
        times = [t for t, _ in micro]
        active = [a for _, a in micro]
        _finish_summary(summary, out, comm, t_wall, times, active, max_drift, scale)
        sim.destroy()
        comm.barrier()
    return RunResult(summary, {c: np.asarray(v, dtype=np.float64) for c, v in history.items()})
