"""Run a scenario with subdomains: set up through the pipeline, loop over macro steps, monitor,
and feed the writers (history rows, one XDMF file per subdomain, the summary)."""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import dolfinx.mesh
import numpy as np
import numpy.typing as npt
from mpi4py import MPI

from crane_fem.checkpoint import (
    Checkpoint,
    raise_if_any,
    read_checkpoint,
    resume_series,
    scenario_hash,
    write_checkpoint,
)
from crane_fem.coupling import ENERGY_KEYS, MacroRecord
from crane_fem.errors import RunInterrupted, ScenarioError, UnstableRunError
from crane_fem.io import HistoryWriter, XDMFSeries
from crane_fem.io.results import write_results_csv
from crane_fem.peaks import ContactPeaks
from crane_fem.pipeline import Simulation, create_simulation
from crane_fem.points import GroundAcceleration, PointMotions, default_points
from crane_fem.reactions import SupportReactions
from crane_fem.run_record import RunResult, StopRequest, finish_summary, progress_bar
from crane_fem.scenario import Scenario
from crane_fem.slip import WheelSlip, pair_reach
from crane_fem.stability import EnergyGrowthMonitor
from crane_fem.stress import VonMises
from crane_fem.subdomains import Subdomain

__all__ = ["HistoryRows", "run_coupled"]

FloatArray = npt.NDArray[np.float64]


def _growth_check(monitor: EnergyGrowthMonitor, sim: Simulation, rec: MacroRecord) -> None:
    """Stop a diverging run (:meth:`EnergyGrowthMonitor.growth`) or a non-finite one with a
    diagnosis naming the subdomain whose kinetic energy dominates, the macro step, the energy
    the interface has created, m, and Δt against the explicit critical step."""
    e, md = rec.energy, sim.models
    step = f"Δt = {md.dt:.4e} s is {md.dt / md.dt_critical:.3f}× the critical step "
    step += f"{md.dt_critical:.4e} s"
    explicit = e["kinetic_explicit"] >= e["kinetic_implicit"]
    if not all(math.isfinite(v) for v in e.values()):
        explicit = not math.isfinite(e["kinetic_explicit"]) or math.isfinite(e["kinetic_implicit"])
        reason = "non-finite energy"
    else:
        reason = monitor.growth(e["kinetic"], e["internal"], e["external_work"]) or ""
        if not reason:
            return
    names = md.explicit_names if explicit else md.implicit_names
    scheme = "cd-lagrange" if explicit else "newmark"
    ifd = e["interface_dissipated"]
    raise UnstableRunError(
        f"unstable run: subdomain '{'+'.join(names)}' ({scheme}) at macro step {rec.step} "
        f"(t = {rec.t:.6g} s): {reason}; the interface has "
        f"{'created' if not ifd >= 0 else 'dissipated'} {abs(ifd):.3e} J "
        f"(method {md.method}, m = {md.ratio}); {step}"
    )


class HistoryRows:
    """The history columns of a run with subdomains and the row of each record (collective:
    the probe and pair values are reduced over the communicator)."""

    def __init__(self, sim: Simulation) -> None:
        self.sim = sim
        md, it = sim.models, sim.integrators
        self.contacts = sim.constraints.contacts
        self.groups = self.contacts.group_names
        sub = md.explicit or md.implicit
        assert sub is not None
        self.bs = sub.bs
        probe = sim.probe_vertices()
        # The probe's owned blocks on each side (the implicit side's interface copies left out:
        # the explicit side has them); a side's field is read only where it holds the probe.
        self.probe_blocks: list[tuple[str, npt.NDArray[np.int64]]] = []
        for side, sub in (("explicit", md.explicit), ("implicit", md.implicit)):
            if sub is None:
                continue
            excl = sim.constraints.interface_vertices if side == "implicit" else np.zeros(0)
            blocks, _ = sub.owned_dofs_of(np.setdiff1d(probe, excl))
            self.probe_blocks.append((side, blocks))
        cols = ["t", *ENERGY_KEYS, *it.method.history_keys(), "total"]
        cols += ["kinetic_explicit", "internal_explicit", "kinetic_implicit", "internal_implicit"]
        cols += ["contact_force", "active_contacts"]
        cols += [f"gap_{g}" for g in self.groups] + [f"force_{g}" for g in self.groups]
        cols += [f"probe_u{c}" for c in range(self.bs)] + [f"probe_v{c}" for c in range(self.bs)]
        cols += ["interface_force_norm", "interface_velocity_jump"]
        cols += ["interface_impulse", "interface_impulse_defect"]
        cols += sim.mean_motion_columns()  # a block: its centre of mass
        # Crane: one wheel/rail node pair per wheel (the first pair of each patch), vertical
        # displacement and velocity on both sides (the paper's Figs. 5–6).
        self.pairs: list[tuple[int, int, int]] = []
        crane = sim.mesh.crane
        if crane is not None:
            for k in range(1, 5):
                i = int(np.flatnonzero(crane.wheel == k)[0])
                self.pairs.append((k, int(crane.pairs[i, 0]), int(crane.pairs[i, 1])))
                cols += [f"wheel{k}_{s}_{q}" for s in ("wheel", "rail") for q in ("uz", "vz")]
        self.columns = cols

    def row(self, rec: MacroRecord) -> dict[str, float]:
        sim, bs = self.sim, self.bs
        md = sim.models
        comm = sim.mesh.comm
        e = rec.energy
        row: dict[str, float] = {"t": rec.t}
        row.update({k: e[k] for k in self.columns if k in e})
        force = rec.contact_impulse / md.dt
        row["contact_force"] = float(force.sum())
        row["active_contacts"] = float(np.count_nonzero(force > 0))
        gmin = self.contacts.group_mins(rec.gaps)
        gsum = self.contacts.group_sums(force)
        for i, g in enumerate(self.groups):
            row[f"gap_{g}"] = float(gmin[i])
            row[f"force_{g}"] = float(gsum[i])
        su, sv, cnt = np.zeros(bs), np.zeros(bs), 0
        for side, blocks in self.probe_blocks:
            if blocks.size == 0:
                continue
            u = rec.explicit_u if side == "explicit" else rec.implicit_u
            v = rec.explicit_v if side == "explicit" else rec.implicit_v
            assert u is not None and v is not None
            su = su + u.reshape(-1, bs)[blocks].sum(axis=0)
            sv = sv + v.reshape(-1, bs)[blocks].sum(axis=0)
            cnt += int(blocks.size)
        tot = comm.allreduce(np.r_[su, sv, cnt], op=MPI.SUM)
        for k in range(bs):
            row[f"probe_u{k}"] = float(tot[k] / max(tot[-1], 1))
            row[f"probe_v{k}"] = float(tot[bs + k] / max(tot[-1], 1))
        row["interface_force_norm"] = float(np.linalg.norm(rec.interface_impulse))
        row["interface_velocity_jump"] = rec.interface_velocity_jump
        row["interface_impulse"] = rec.impulse_explicit
        row["interface_impulse_defect"] = rec.impulse_defect
        row.update(sim.mean_motion(rec.explicit_u, rec.explicit_v))
        if self.pairs:
            sub = md.explicit
            assert sub is not None and rec.explicit_u is not None and rec.explicit_v is not None
            ids = np.array([v for _, w_, r in self.pairs for v in (w_, r)])
            order = np.argsort(ids)
            blocks, pos = sub.owned_dofs_of(ids[order])
            vals = np.zeros((ids.size, 2))
            dz = blocks * sub.bs + 2
            vals[order[pos], 0] = rec.explicit_u[dz]
            vals[order[pos], 1] = rec.explicit_v[dz]
            vals = comm.allreduce(vals, op=MPI.SUM)
            for n_p, (k, _, _) in enumerate(self.pairs):
                for s_i, side in enumerate(("wheel", "rail")):
                    row[f"wheel{k}_{side}_uz"] = float(vals[2 * n_p + s_i, 0])
                    row[f"wheel{k}_{side}_vz"] = float(vals[2 * n_p + s_i, 1])
        return row


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
            von_mises=(sc.material.E, sc.material.nu) if sub.bs == 3 else None,
            append=resume is not None,
        )
        writers.append((sub, series))
    return writers


class BridgeStress:
    """The peak von Mises stress over the crane's bridge cells (girders, end carriages, the
    rails outside the explicit zones) every ``output.stress_every`` macro steps: of the
    implicit side in a coupled run, of the whole mesh in the fully explicit one
    (collective)."""

    def __init__(self, sim: Simulation) -> None:
        md = sim.models
        sub = md.implicit if md.implicit is not None else md.explicit
        assert sub is not None
        self.side = "implicit" if md.implicit is not None else "explicit"
        tagged = sim.mesh.tagged
        tag = tagged.cell_groups["bridge_implicit"]
        n_parent = tagged.mesh.topology.index_map(tagged.mesh.topology.dim).size_local
        n_parent += tagged.mesh.topology.index_map(tagged.mesh.topology.dim).num_ghosts
        bridge = np.zeros(n_parent, dtype=bool)
        bridge[tagged.cell_tags.indices[tagged.cell_tags.values == tag]] = True
        self.vm = VonMises(sub.V, sim.scenario.material.E, sim.scenario.material.nu)
        own = sub.parent_cells[: self.vm.n_cells]
        self.cells = np.flatnonzero(bridge[own]).astype(np.int32)
        self.comm = sim.mesh.comm
        self.peak, self.t_peak = 0.0, 0.0
        self.location = np.zeros(3)

    def update(self, rec: MacroRecord) -> None:
        u = rec.implicit_u if self.side == "implicit" else rec.explicit_u
        assert u is not None
        value, where = self.vm.peak_at(u, self.cells, self.comm)
        if value > self.peak:
            self.peak, self.t_peak, self.location = value, rec.t, where

    def state_dict(self) -> dict[str, Any]:
        return {"peak": self.peak, "t_peak": self.t_peak, "location": self.location.copy()}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.peak, self.t_peak = float(state["peak"]), float(state["t_peak"])
        self.location = np.array(state["location"], dtype=np.float64)


def _support_reactions(sc: Scenario, sim: Simulation) -> SupportReactions | None:
    """The reactions of the clamped faces, on the side that holds them (none without)."""
    md = sim.models
    for sub in (md.implicit, md.explicit):
        if sub is None or sub.bs != 3:
            continue
        if sim.mesh.comm.allreduce(int(np.count_nonzero(sub.model.fixed)), op=MPI.SUM):
            mat = sc.material
            return SupportReactions(
                sub, mat.E, mat.nu, mat.rho, mat.rayleigh_coefficients, sc.loading.gravity
            )
    return None


def _owned_vertices(sim: Simulation) -> tuple[npt.NDArray[np.int64], FloatArray]:
    """The global ids (the index map's) and coordinates (n, 3) of the parent mesh's owned
    vertices (not collective)."""
    mesh = sim.mesh.tagged.mesh
    local = np.arange(mesh.topology.index_map(0).size_local, dtype=np.int32)
    ids = np.asarray(mesh.topology.index_map(0).local_to_global(local), dtype=np.int64)
    xyz = np.asarray(mesh.geometry.x)[dolfinx.mesh.entities_to_geometry(mesh, 0, local).ravel()]
    return ids, xyz


def _wheel_slip(sim: Simulation) -> WheelSlip | None:
    """The crane wheels' slip on their rails, with the reach of each wheel's pairs from its
    rail patch's vertices (collective; None without a crane)."""
    crane, sub = sim.mesh.crane, sim.models.explicit
    if crane is None or sub is None:
        return None
    ids, xyz = _owned_vertices(sim)
    rail = crane.pairs[:, 1]
    mine = np.flatnonzero(np.isin(ids, rail))
    got = sim.mesh.comm.allgather((ids[mine], xyz[mine]))
    gid = np.concatenate([g for g, _ in got])
    pos = np.concatenate([x for _, x in got])
    where = {int(g): pos[i, :2] for i, g in enumerate(gid)}
    reach = np.array(
        [
            pair_reach(np.array([where[int(r)] for r in rail[crane.wheel == k]]))
            for k in range(1, int(crane.wheel.max()) + 1)
        ]
    )
    return WheelSlip(sub, crane.pairs, crane.wheel, reach)


def _point_motions(sc: Scenario, sim: Simulation) -> PointMotions | None:
    """The absolute motions measured for response spectra (none without points)."""
    points = default_points(sc)
    if not points:
        return None
    ids, xyz = _owned_vertices(sim)
    md = sim.models
    return PointMotions(
        points, md.explicit, md.implicit, xyz, ids, GroundAcceleration(sc), sim.mesh.comm
    )


def _spectra(sc: Scenario, motions: PointMotions, out: Path, comm: MPI.Comm) -> dict[str, Any]:
    """Pseudo-acceleration spectra of the input and of the points' absolute motion in each
    direction the ground shakes, to ``spectra.csv`` (rank 0 writes); their settings."""
    from crane_fem.spectra import log_periods, response_spectrum, write_spectra_csv

    t, series = motions.series()
    spec = sc.spectra
    axes = [c for c in "xyz" if f"ground_a{c}" in series and np.any(series[f"ground_a{c}"])]
    if t.size < 3 or not axes:
        return {}
    dt = float(t[1] - t[0])
    # A last macro step shortened to reach time.end breaks the uniform sampling: left out.
    odd = np.flatnonzero(np.abs(np.diff(t) - dt) > 1e-7 * dt)
    if odd.size:
        t, series = t[: odd[0] + 1], {k: v[: odd[0] + 1] for k, v in series.items()}
    if t.size < 3:
        return {}
    # The mean accelerations between samples resolve periods down to a few samples.
    periods = log_periods(max(spec.periods[0], 4 * dt), spec.periods[1], spec.count)
    curves = {}
    for c in axes:
        curves[f"input_{c}"] = response_spectrum(t, series[f"ground_a{c}"], periods, spec.damping)
        for p in motions.points:
            a = series[f"{p.name}_a{c}"]
            curves[f"{p.name}_{c}"] = response_spectrum(t, a, periods, spec.damping)
    if comm.rank == 0:
        write_spectra_csv(out / "spectra.csv", curves)
    return {
        "spectra_damping": spec.damping,
        "spectra_sampling_s": dt,
        "spectra_points": {
            p.name: {"side": p.side, "distance_m": p.distance} for p in motions.points
        },
    }


@dataclass
class LoopBooks:
    """What the time loop accumulates from the records (global values; the reactions' last
    velocities are this rank's): the history rows, the contact peaks, the divergence
    monitor, the bridge stress, the support reactions, the measured points and their last
    row, the wheels' slip, the energy drift and its scale, the interface energy's steps, the
    micro-step times and contact flags, the XDMF frames written. A checkpoint saves and
    restores it whole."""

    history: dict[str, list[float]]
    peaks: ContactPeaks
    monitor: EnergyGrowthMonitor
    stress: BridgeStress | None = None
    reactions: SupportReactions | None = None
    motions: PointMotions | None = None
    slip: WheelSlip | None = None
    point_row: dict[str, float] = field(default_factory=dict)
    micro_t: list[FloatArray] = field(default_factory=list)
    micro_active: list[npt.NDArray[np.bool_]] = field(default_factory=list)
    total0: float | None = None
    scale: float = 0.0
    max_drift: float = 0.0
    ifd_min_step: float = math.inf
    ifd_prev: float = 0.0
    frames: int = 0

    _PARTS = ("peaks", "monitor", "stress", "reactions", "motions", "slip")
    _SCALARS = ("scale", "max_drift", "ifd_min_step", "ifd_prev", "frames")

    def state_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {k: getattr(self, k) for k in self._SCALARS}
        out["history"] = {c: np.asarray(v, dtype=np.float64) for c, v in self.history.items()}
        out["point_row"] = dict(self.point_row)
        out["micro_t"] = np.concatenate([np.zeros(0), *self.micro_t])
        out["micro_active"] = np.concatenate([np.zeros(0, dtype=bool), *self.micro_active])
        if self.total0 is not None:
            out["total0"] = self.total0
        for k in self._PARTS:
            part = getattr(self, k)
            if part is not None:
                out[k] = part.state_dict()
        return out

    def load_state_dict(self, state: dict[str, Any]) -> None:
        """Restore in place (the loop's aliases of the parts stay valid)."""
        if set(state["history"]) != set(self.history):
            raise ValueError("the history has other columns")
        for c, rows in self.history.items():
            rows[:] = [float(x) for x in state["history"][c]]
        self.point_row = {k: float(v) for k, v in state.get("point_row", {}).items()}
        self.micro_t[:] = [np.asarray(state["micro_t"], dtype=np.float64)]
        self.micro_active[:] = [np.asarray(state["micro_active"], dtype=bool)]
        self.total0 = float(state["total0"]) if "total0" in state else None
        self.scale, self.max_drift = float(state["scale"]), float(state["max_drift"])
        self.ifd_min_step, self.ifd_prev = float(state["ifd_min_step"]), float(state["ifd_prev"])
        self.frames = int(state["frames"])
        for k in self._PARTS:
            part = getattr(self, k)
            if part is not None:
                part.load_state_dict(state[k])


def _step_sizes(sim: Simulation) -> dict[str, Any]:
    """What a checkpoint must share with the run that continues it, beyond the scenario."""
    md = sim.models
    return {"method": md.method, "ratio": md.ratio, "dt": md.dt, "dT": md.dT}


def _save(sim: Simulation, out: Path, rec: MacroRecord, books: LoopBooks) -> None:
    """The checkpoint of ``rec``'s macro step, before the loop uses ``rec`` (collective)."""
    sc = sim.scenario
    meta = {"step": rec.step, "t": rec.t, "scenario": sc.name}
    meta.update(scenario_hash=scenario_hash(sc), **_step_sizes(sim))
    state = {
        "method": sim.integrators.method.state_dict(),
        "record": rec.state_dict(),
        "books": books.state_dict(),
    }
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
    if ckpt.step > sim.models.n_macro:
        raise ScenarioError(
            f"--restart: time.end = {sim.scenario.time.end:g} s is before the checkpoint in "
            f"{restart} (t = {meta['t']:g} s)"
        )
    error, rec = None, None
    try:
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


def _peak_tables(peaks: ContactPeaks) -> dict[str, Any]:
    """The summary's peak tables from every micro step: ``wheels`` keyed by wheel number for
    a crane (its contact groups are ``wheel_<k>``) and, with flanges, ``flanges`` keyed
    ``in_<k>``/``out_<k>`` (groups ``flange_in_<k>``/``flange_out_<k>``), else
    ``contact_groups`` keyed by name."""
    table = peaks.table()
    if not table:
        return {}
    if all(name.startswith(("wheel_", "flange_")) for name in table):
        out = {"wheels": {n.removeprefix("wheel_"): v for n, v in table.items() if n[0] == "w"}}
        flanges = {n.removeprefix("flange_"): v for n, v in table.items() if n[0] == "f"}
        return out | ({"flanges": flanges} if flanges else {})
    return {"contact_groups": table}


def _summary_head(sc: Scenario, sim: Simulation, comm: MPI.Comm) -> dict[str, Any]:
    md, cons, it = sim.models, sim.constraints, sim.integrators
    sub = md.explicit or md.implicit
    assert sub is not None
    n_steps = md.n_macro * it.system.m if md.coupled else md.n_steps
    summary: dict[str, Any] = {
        "scenario": sc.name,
        "method": md.method,
        "ratio": md.ratio,
        "explicit_subdomains": md.explicit_names,
        "implicit_subdomains": md.implicit_names,
        "dt": md.dt,
        "dT": md.dT,
        "dt_critical": md.dt_critical,
        "steps": md.n_macro if md.coupled else n_steps,
        "micro_steps": n_steps,
        "interface_dofs": int(cons.interface_vertices.size * sub.bs),
        # Global DOF counts of each side (their ratio and n_Γ set the cost of a coupled run).
        "dofs_explicit": md.explicit.model.K.getSize()[0] if md.explicit is not None else 0,
        "dofs_implicit": md.implicit.model.K.getSize()[0] if md.implicit is not None else 0,
        "mpi_size": comm.size,
        "status": "running",
    }
    # Where the constraints live: owned DOFs of the contact and interface rows per rank.
    summary["contact_dofs_per_rank"] = comm.allgather(int(cons.contacts.dofs.size))
    E = it.explicit
    n_if = int(np.count_nonzero(E.stack.rows < E.n_gamma)) if E is not None else 0
    summary["interface_dofs_per_rank"] = comm.allgather(n_if if md.coupled else 0)
    if md.preload is not None:
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
    ckpt = read_checkpoint(Path(restart), comm, sc) if restart is not None else None
    sim = create_simulation(sc, comm)
    md, it = sim.models, sim.integrators
    method = it.method
    rows = HistoryRows(sim)
    contacts = sim.constraints.contacts
    static = None
    if md.preload is not None:  # the flange groups after the wheels carry no static force
        static = np.zeros(len(contacts.group_names))
        static[: md.preload.wheel_force.size] = md.preload.wheel_force
    motions = _point_motions(sc, sim)
    columns = rows.columns + (motions.columns if motions is not None else [])
    b = LoopBooks(
        {c: [] for c in columns},
        ContactPeaks(contacts.group_names, md.dt, static),
        EnergyGrowthMonitor(sc.monitor.energy_growth, "", "", md.dt, md.dt_critical),
        BridgeStress(sim) if sim.mesh.crane is not None else None,
        _support_reactions(sc, sim) if sim.mesh.crane is not None else None,
        motions,
        _wheel_slip(sim),
    )
    history, peaks, monitor = b.history, b.peaks, b.monitor
    stress, reactions = b.stress, b.reactions
    ground = GroundAcceleration(sc)
    every = sc.output.every
    xdmf_every = sc.output.xdmf_every or max(1, md.n_macro // 200)
    ckpt_every = sc.output.checkpoint_every
    summary = _summary_head(sc, sim, comm)
    resumed = None
    try:  # a refused restart leaves the files as they were
        if ckpt is not None:
            assert restart is not None
            resumed = _resume(ckpt, sim, b, Path(restart))
            summary["restart"] = {"from": str(restart), "step": ckpt.step, "t": ckpt.meta["t"]}
        resume = (Path(restart), b.frames) if restart is not None else None
        writers = _xdmf_writers(sc, sim, out, resume)
    except BaseException:
        if reactions is not None:
            reactions.destroy()
        sim.destroy()
        raise
    bar = progress_bar(sc, comm, progress, md.n_macro, "macro step")
    comm.barrier()
    t_loop = time.perf_counter()
    summary["wall_time_setup_s"] = comm.allreduce(t_loop - t_wall, op=MPI.MAX)
    t_output = t_checkpoint = 0.0
    n_checkpoints = 0
    stop = StopRequest(comm)
    try:
        with stop, HistoryWriter(out / "history.csv", columns, comm, history) as writer:
            rec = method.initialize(it.interface_force0) if resumed is None else resumed
            bar.update(rec.step)
            n = rec.step
            while True:
                # The checkpoint of a macro step is taken before its record is used: the run
                # continued from it uses the record as this one does.
                due = ckpt_every and rec.step and rec.step % ckpt_every == 0
                if due and rec is not resumed and method.resumable():
                    t_ck = time.perf_counter()
                    _save(sim, out, rec, b)
                    t_checkpoint += time.perf_counter() - t_ck
                    n_checkpoints += 1
                e = rec.energy
                _growth_check(monitor, sim, rec)
                if b.slip is not None:  # a wheel beyond its pairs' reach stops the run
                    assert rec.explicit_u is not None
                    b.slip.update(rec.t, rec.explicit_u)
                if b.total0 is None:
                    b.total0 = e["total"]
                b.scale = max(
                    b.scale, abs(e["kinetic"]) + abs(e["internal"]) + abs(e["external_work"])
                )
                b.max_drift = max(b.max_drift, abs(e["total"] - b.total0))
                step_ifd = e["interface_energy_gc"] - b.ifd_prev
                if rec.step > 0:
                    b.ifd_min_step = min(b.ifd_min_step, step_ifd)
                b.ifd_prev = e["interface_energy_gc"]
                if rec.step == 0:
                    f0 = contacts.group_sums(rec.contact_impulse) / md.dt
                    peaks.start(rec.t, f0, contacts.group_mins(rec.gaps))
                else:
                    peaks.update(rec.micro.t, rec.micro.impulse, rec.micro.gap)
                b.micro_t.append(rec.micro.t)
                b.micro_active.append(rec.micro.active)
                # Output time apart from the time loop's: the barriers keep a rank that waits
                # for rank 0's writing from booking that wait as integration.
                if comm.size > 1:
                    comm.Barrier()
                t_out = time.perf_counter()
                stopping = stop.requested()
                last = rec.step == md.n_macro or stopping
                # The measured points every macro step (a few rows of the implicit side);
                # the stress and the reactions need its whole field (a reduced side expands
                # it): every output.stress_every macro steps.
                sampled = rec.step % sc.output.stress_every == 0
                if motions is not None:
                    at = rec.implicit_at(motions.implicit_dofs)
                    b.point_row = motions.sample(
                        rec.t, rec.explicit_v, at[1] if at is not None else None
                    )
                if stress is not None and (sampled or last):
                    stress.update(rec)
                if reactions is not None and sampled:
                    on_i = md.implicit is not None and reactions.subdomain == md.implicit.name
                    u = rec.implicit_u if on_i else rec.explicit_u
                    v = rec.implicit_v if on_i else rec.explicit_v
                    assert u is not None and v is not None
                    reactions.update(rec.t, u, v, ground(rec.t))
                if rec.step % every == 0 or last:
                    row = rows.row(rec)
                    if motions is not None:
                        row.update(motions.ground_row(rec.t))
                    row.update(b.point_row)
                    writer.write(row)
                    for c in columns:
                        history[c].append(row[c])
                frame = rec.step % xdmf_every == 0 or last
                if writers and frame:
                    b.frames += 1
                    for sub, w in writers:
                        is_e = sub is md.explicit
                        du = rec.explicit_u if is_e else rec.implicit_u
                        dv = rec.explicit_v if is_e else rec.implicit_v
                        assert du is not None and dv is not None
                        fields = {"displacement": du, "velocity": dv}
                        if is_e:
                            fields["contact_force"] = (
                                sim.constraints.contacts.transpose(rec.contact_impulse, du.size)
                                / md.dt
                            )
                        w.write(rec.t, fields)
                if comm.size > 1:
                    comm.Barrier()
                t_output += time.perf_counter() - t_out
                if stopping:
                    raise RunInterrupted(
                        f"interrupted by {stop.signal_name} at t = {rec.t:.6g} s "
                        f"(macro step {rec.step} of {md.n_macro}); the files hold the steps done"
                    )
                if n == md.n_macro:
                    break
                rec = method.step()
                n += 1
                bar.update(1)
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
        summary["steps_done"] = round(history["t"][-1] / md.dT) if history["t"] else 0
        summary["interface_energy_gc_min_step"] = (
            b.ifd_min_step if math.isfinite(b.ifd_min_step) else 0.0
        )
        summary.update(method.summary())
        summary["t_reached_s"] = history["t"][-1] if history["t"] else 0.0
        summary["time_end_s"] = sc.time.end
        if stress is not None:  # every output.stress_every macro steps
            summary["peak_bridge_von_mises_Pa"] = stress.peak
            summary["peak_bridge_von_mises_t"] = stress.t_peak
            summary["peak_bridge_von_mises_location_m"] = stress.location.tolist()
        summary.update(_peak_tables(peaks))
        if b.slip is not None and "wheels" in summary:
            for k, slip in b.slip.table().items():
                summary["wheels"][k].update(slip)
        if reactions is not None:
            summary["supports"] = reactions.table()
            reactions.destroy()
        if motions is not None:
            summary.update(_spectra(sc, motions, out, comm))
        if comm.rank == 0:
            write_results_csv(out / "results.csv", summary)
        times = np.concatenate([np.zeros(0), *b.micro_t])
        active = np.concatenate([np.zeros(0, dtype=bool), *b.micro_active])
        finish_summary(summary, out, comm, t_wall, times, active, b.max_drift, b.scale)
        sim.destroy()
        comm.barrier()
    return RunResult(summary, {c: np.asarray(v, dtype=np.float64) for c, v in history.items()})
