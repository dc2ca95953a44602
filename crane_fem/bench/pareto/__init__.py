"""The Pareto suite: error against wall time per simulated second, method by method."""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

from mpi4py import MPI

from crane_fem.bench import Section
from crane_fem.bench.common import Outcome, demo, explicit_settings, run_case, write_csv
from crane_fem.bench.pareto.cases import bar_specs, crane_specs
from crane_fem.bench.pareto.figure import plot_chart
from crane_fem.bench.pareto.measures import (
    accuracy_window,
    bar_errors,
    contact_end_exact,
    crane_errors,
    wheel_peaks,
)
from crane_fem.bench.pareto.points import CRITERION, Point, Spec, cheapest_within, pareto_front
from crane_fem.bench.pareto.report import csv_row, report_body
from crane_fem.errors import CraneFemError, ScenarioError

__all__ = [
    "CRITERION",
    "NAME",
    "SUMMARY",
    "Point",
    "Spec",
    "accuracy_window",
    "bar_errors",
    "bar_specs",
    "cheapest_within",
    "contact_end_exact",
    "crane_errors",
    "pareto_front",
    "run",
    "wheel_peaks",
]

NAME = "pareto"
SUMMARY = "error against wall time per simulated second: explicit, penalty, Moreau–Jean, couplings"


def _cost(o: Outcome) -> tuple[float, str]:
    """Wall time per simulated second: of the time loop (runs with subdomains); the
    single-subdomain bar path reports the whole run's only (set-up and output included)."""
    c = o.wall_per_second
    if math.isfinite(c):
        return c, "time loop"
    t_end = float(o.history["t"][-1]) if o.history.get("t") is not None else math.nan
    return float(o.summary.get("wall_time_s", math.nan)) / max(t_end, 1e-300), "whole run"


def _run(spec: Spec, runs: Path) -> Outcome | str:
    """The run of ``spec`` (collective), or why it stopped when it raised (a method that
    refuses the case: raised identically on every rank)."""
    try:
        return run_case(spec.label, spec.scenario, spec.settings, runs / spec.label)
    except ScenarioError:
        raise
    except CraneFemError as exc:
        return f"failed: {str(exc).splitlines()[0]}"


def _point(spec: Spec, o: Outcome | str, errors: Any) -> Point:
    if isinstance(o, str):
        return Point(spec, o, math.nan, "", {})
    cost, basis = _cost(o)
    if not o.stable:
        return Point(spec, o.status, cost, basis, {}, {"diagnosis": o.diagnosis})
    return Point(spec, o.status, cost, basis, errors(o))


def run(out: Path, quick: bool) -> list[Section]:
    """Run the suite (collective over COMM_WORLD); write ``pareto.csv`` and ``pareto.png``
    under ``out`` (rank 0) and return the "pareto-quick" or "pareto-full" section."""
    comm = MPI.COMM_WORLD
    t_start = time.perf_counter()
    runs = out / "runs" / "pareto"
    points: list[Point] = []

    bars, exact, force = bar_specs()
    # Warm-up (compiled kernels and forms) so that the first timed run of each path is fair.
    for spec in (bars[0], bars[-1]):
        warm = {**spec.settings, "time.end": 0.5}  # one macro step of the split bar at m = 100
        run_case(f"warmup_{spec.label}", spec.scenario, warm, runs / "warmup")
    for spec in bars:
        o = _run(spec, runs)
        points.append(_point(spec, o, lambda r: bar_errors(r.history, r.summary, exact, force)))

    scene = demo("crane_quick" if quick else "crane_stress")
    specs, scene_name = crane_specs(quick, math.inf)
    # The nominal fully explicit run first: criterion (b)'s reference, whose sampling the
    # Δt × ½ reference of (a) keeps (the same instants).
    nominal = run_case(specs[0].label, scene, specs[0].settings, runs / specs[0].label)
    if not nominal.stable:
        raise CraneFemError(f"{scene.name}: the nominal explicit run is {nominal.status}")
    sampling = float(nominal.summary["sampling_interval_s"])
    ref_settings = explicit_settings(scene, dt=0.5, sampling=sampling)
    dtf = float(ref_settings["time.dt_factor"])
    label = f"{scene.stem}_explicit_dt{dtf:g}"
    ref_spec = Spec("crane", "CD-Lagrange", label, scene, ref_settings, {"dt_factor": dtf}, True)
    ref = run_case(ref_spec.label, scene, ref_settings, runs / ref_spec.label)
    if not ref.stable:
        raise CraneFemError(f"{scene.name}: the Δt × ½ explicit reference is {ref.status}")
    t_acc, how = accuracy_window(ref.history)
    # The full scene's m = 10 runs stop at the window (rounded up to 10 ms, plus 10 ms).
    window = math.ceil(t_acc * 100.0 - 1e-9) / 100.0 + 0.01
    ref_cost, ref_basis = _cost(ref)
    points.append(Point(ref_spec, ref.status, ref_cost, ref_basis, {}))
    specs, scene_name = crane_specs(quick, window)
    for spec in specs:
        o = _run(spec, runs)
        points.append(_point(spec, o, lambda r: crane_errors(r, ref, t_acc, nominal)))

    elapsed = float(comm.bcast(time.perf_counter() - t_start, root=0))
    files = [out / "pareto.csv", out / "pareto.png"]
    if comm.rank == 0:
        write_csv(files[0], [csv_row(p) for p in points])
        plot_chart(files[1], points, scene_name)
    comm.barrier()
    key = "pareto-quick" if quick else "pareto-full"
    title = f"Pareto chart: error against wall time per simulated second ({key.split('-')[1]})"
    body = report_body(points, quick, scene_name, t_acc, how, window, elapsed, comm.size)
    return [Section(key, title, body, files)]
