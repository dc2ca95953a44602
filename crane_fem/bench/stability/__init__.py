"""The stability map: stable, energy growth or unstable over Δt/Δt_crit, the ratio m and k."""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

from mpi4py import MPI

from crane_fem.bench import Section
from crane_fem.bench.common import write_csv
from crane_fem.bench.stability.figure import draw_map
from crane_fem.bench.stability.points import (
    CLASSES,
    ENERGY_GROWTH,
    GROWTH,
    REFUSED,
    STABLE,
    UNSTABLE,
    Point,
    Scheme,
    classify,
    run_point,
)
from crane_fem.bench.stability.report import duration, report_body
from crane_fem.bench.stability.scenes import (
    REFINING,
    Map,
    WallBar,
    cd_lagrange,
    coupled_point,
    penalty,
    penalty_limit_point,
    undamped_point,
    wall_point,
    wall_scenario,
    wall_schemes,
)

__all__ = [
    "CLASSES",
    "ENERGY_GROWTH",
    "FULL",
    "GROWTH",
    "NAME",
    "QUICK",
    "REFUSED",
    "STABLE",
    "SUMMARY",
    "UNSTABLE",
    "Grid",
    "Point",
    "Scheme",
    "WallBar",
    "cd_lagrange",
    "classify",
    "coupled_point",
    "penalty",
    "penalty_limit_point",
    "run",
    "run_point",
    "undamped_point",
    "wall_point",
    "wall_scenario",
]

NAME = "stability"
SUMMARY = "stability map: stable / energy growth / unstable over Δt/Δt_crit, m and penalty k"


@dataclass(frozen=True)
class Grid:
    """What one mode of the suite runs: Δt/(h/c) on the wall, penalty k (EA/h) and Δt as
    fractions of penalty's own limit, the couplings on the split bar on the wall (methods,
    m, Δt/Δt_crit), and on the undamped split bar ((method, m values), Δt/Δt_crit; the
    second Δt for GC only)."""

    wall_dt: tuple[float, ...]
    penalty_k: tuple[float, ...]
    penalty_own: tuple[float, ...]
    coupled_methods: tuple[str, ...]
    coupled_m: tuple[int, ...]
    coupled_dt: tuple[float, ...]
    undamped: tuple[tuple[str, tuple[int, ...]], ...]
    undamped_dt: tuple[float, ...]


QUICK = Grid(
    wall_dt=(0.1, 0.3, 0.5, 0.9, 0.99, 1.01, 1.5, 2.0, 5.0),
    penalty_k=(0.1, 1.0, 10.0, 100.0),
    penalty_own=(0.5, 0.9, 0.99),
    coupled_methods=("gc", "gc-mean", "hybrid", "ph", "gc refining", "gc-mean refining"),
    coupled_m=(1, 10, 100),
    coupled_dt=(0.25, 0.5, 0.9, 1.0, 1.01),
    undamped=(("gc", (2, 10, 100)), ("gc-mean", (2, 10, 100)), ("ph", (2, 10, 100))),
    undamped_dt=(0.9,),
)
FULL = Grid(
    wall_dt=(
        *(0.02, 0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 0.95, 0.99, 1.0),
        *(1.01, 1.05, 1.2, 1.5, 2.0, 3.0, 5.0, 10.0, 20.0),
    ),
    penalty_k=(0.01, 0.1, 0.3, 1.0, 3.0, 10.0, 30.0, 100.0, 1000.0),
    penalty_own=(0.3, 0.5, 0.7, 0.8, 0.9, 0.95, 0.99),
    coupled_methods=(
        *("gc", "gc-mean", "hybrid", "ec", "ph"),
        *("gc refining", "gc-mean refining"),
    ),
    coupled_m=(1, 10, 100, 1000),
    coupled_dt=(0.1, 0.25, 0.5, 0.75, 0.9, 0.99, 1.0, 1.01),
    undamped=tuple(
        (method, (1, 2, 3, 5, 10, 100)) for method in ("gc", "gc-mean", "hybrid", "ec", "ph")
    ),
    undamped_dt=(0.9, 0.5),
)


def run(out: Path, quick: bool) -> list[Section]:
    """Run the map (collective over COMM_WORLD): ``stability_map.csv`` and
    ``stability_map.png`` in ``out``, one run directory per point under
    ``out/runs/stability/``; one section, "stability-quick" or "stability-full"."""
    comm = MPI.COMM_WORLD
    t0 = time.perf_counter()
    grid = QUICK if quick else FULL
    runs = out / "runs" / "stability"
    bar = wall_scenario(runs)
    wall = [
        [wall_point(s, r, bar, runs) for r in grid.wall_dt]
        for s in wall_schemes(bar, grid.penalty_k)
    ]
    own = [[penalty_limit_point(k, f, bar, runs) for f in grid.penalty_own] for k in grid.penalty_k]
    # A refining method needs a coarse ratio above 1 (its fine ratio divides it).
    coupled = [
        [coupled_point(method, m, r, runs) for r in grid.coupled_dt]
        for method in grid.coupled_methods
        for m in grid.coupled_m
        if not (method.endswith(REFINING) and m == 1)
    ]
    undamped: list[list[Point]] = []
    for i, r in enumerate(grid.undamped_dt):
        for method, ms in grid.undamped:
            if i > 0 and method != "gc":
                continue  # the second Δt for GC only: its weak instability, not the others'
            row = method if i == 0 else f"{method} Δt={r:g}Δt_crit"
            undamped.append([undamped_point(method, m, r, runs, row) for m in ms])
    result = Map(bar, wall, own, coupled, undamped)
    elapsed = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
    csv_path, png_path = out / "stability_map.csv", out / "stability_map.png"
    body = ""
    if comm.rank == 0:
        write_csv(csv_path, [p.row() for p in result.points()])
        draw_map(png_path, result)
        body = report_body(result, elapsed, quick, csv_path, png_path)
        print(f"stability: {len(result.points())} runs, {duration(elapsed, quick)}")
    body = comm.bcast(body, root=0)
    key = "stability-quick" if quick else "stability-full"
    title = "Stability map" + (" (quick)" if quick else " (full sweep)")
    return [Section(key, title, body, [csv_path, png_path])]
