"""The stability map: stable, energy growth or unstable over Δt/Δt_crit, the ratio m and k."""

from __future__ import annotations

import math
import re
import time
import tomllib
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from mpi4py import MPI

from crane_fem.bench import Section
from crane_fem.bench.common import FloatArray, demo, run_case, toml_value, write_csv
from crane_fem.errors import CraneFemError
from crane_fem.scenario import load_scenario

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

STABLE, GROWTH, UNSTABLE, REFUSED = "stable", "energy growth", "unstable", "refused"
#: The classes of a point. "refused": the package would not run it (Δt above the explicit
#: critical step on a coupled path, `ph` with a contact in the explicit side, `ec` whose
#: passes do not converge through a contact): the run stops with a CraneFemError, no verdict.
CLASSES = (STABLE, GROWTH, UNSTABLE, REFUSED)

#: A completed run whose max(kinetic + internal)/E0 exceeds this has created energy
#: ("energy growth"). No scene of the map has external work, so kinetic + internal can pass E0
#: only if the scheme or the interface creates energy. Measured on these scenes (full sweep),
#: the stable schemes stay at E0 or below to six digits (CD-Lagrange and Moreau–Jean on the
#: wall, where contact only dissipates; `ec`, `gc-mean` and `hybrid` on the undamped split
#: bar), while GC and PH show bounded excursions of up to +6.4 % (m = 1, while the pulse
#: crosses the interface, the same after 50 and 200 time units) and GC up to +4.9 % on the
#: split bar on the wall. 10 % sits above those and below what the map is looking for: GC's
#: weak instability (×1.6 to ×7·10⁵ over 200 time units without dissipation; RESULTS.md
#: "Long-run stability of the coupling") and explicit penalty near its own limit (the bar
#: leaves the wall with ×1.1 to ×9.6 the energy it came with).
ENERGY_GROWTH = 1.1

#: History rows kept per run (``output.every`` is set from it): enough to see growth, which
#: is slow when the run completes; the energy-growth monitor checks every step regardless.
HISTORY_ROWS = 500

_COLOURS = {STABLE: "#4daf4a", GROWTH: "#ff7f00", UNSTABLE: "#e41a1c", REFUSED: "#bdbdbd"}


@dataclass(frozen=True)
class Scheme:
    """A row of the map: its family ("wall", "coupled", "undamped"), the run's label, the
    parameter it stands for and the scenario settings that make it; ``row`` names its row
    in the tables (the label by default)."""

    family: str
    label: str
    parameter: str = ""
    settings: dict[str, Any] = field(default_factory=dict, hash=False, compare=False)
    k: float | None = None  #: penalty stiffness in units of EA/h
    m: int | None = None  #: coupling ratio ΔT/Δt
    row: str = ""

    @property
    def row_label(self) -> str:
        return self.row or self.label


@dataclass
class Point:
    """One run of the map and its class. ``dt_ratio``: Δt/(h/c) on the wall (the mesh's
    critical step), Δt/Δt_crit of the explicit half on the split bars; ``limit_ratio``:
    penalty's own limit 2/ω_p (springs closed) in units of h/c; ``own_ratio``: Δt/(2/ω_p);
    ``t_growth``: the first time E/E0 passed :data:`ENERGY_GROWTH`; ``contact_intervals``:
    the contact episodes of the run (one per impact without chatter)."""

    scheme: Scheme
    dt_ratio: float
    cls: str
    energy_ratio: float
    wall_s: float
    limit_ratio: float = math.nan
    own_ratio: float = math.nan
    t_growth: float = math.nan
    diagnosis: str = ""
    contact_intervals: int | None = None

    def row(self) -> dict[str, Any]:
        s = self.scheme

        def num(x: float) -> Any:
            return "" if math.isnan(x) else x

        return {
            "family": s.family,
            "scheme": s.label,
            "parameter": s.parameter,
            "dt_ratio": self.dt_ratio,
            "m": "" if s.m is None else s.m,
            "k_EA_over_h": "" if s.k is None else float(s.k),
            "class": self.cls,
            "max_energy_ratio": num(self.energy_ratio),
            "wall_s": self.wall_s,
            "penalty_limit_ratio": num(self.limit_ratio),
            "dt_over_penalty_limit": num(self.own_ratio),
            "t_growth": num(self.t_growth),
            "contact_intervals": "" if self.contact_intervals is None else self.contact_intervals,
            "diagnosis": self.diagnosis,
        }


def classify(status: str, energy: FloatArray) -> tuple[str, float]:
    """(class, max E/E0) of a run from its status and its kinetic + internal energy history
    (E0 first): "unstable" if the energy-growth monitor stopped it or an energy is not
    finite (max E/E0 then reported as inf), "energy growth" if it completed with
    max E/E0 > :data:`ENERGY_GROWTH`, else "stable"."""
    finite = energy.size > 0 and bool(np.all(np.isfinite(energy)))
    if status != "completed" or not finite:
        return UNSTABLE, math.inf  # the rows written before the stop miss the divergence
    e0 = float(energy[0])
    ratio = float(np.max(energy)) / e0 if e0 > 0.0 else math.inf
    return (GROWTH if ratio > ENERGY_GROWTH else STABLE), ratio


def run_point(
    scheme: Scheme,
    dt_ratio: float,
    scenario: Path,
    settings: dict[str, Any],
    outdir: Path,
    comm: MPI.Comm | None = None,
) -> Point:
    """Run ``scenario`` with ``settings`` into ``outdir`` and classify it (collective). A run
    the package refuses (a :class:`CraneFemError` other than divergence, once the scenario
    itself has validated) is "refused"."""
    overrides = [f"{k}={toml_value(v)}" for k, v in sorted(settings.items())]
    load_scenario(scenario, overrides)  # a bad key is the map's bug: raise it, don't classify
    t0 = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # "Δt exceeds the critical step"
            out = run_case(outdir.name, scenario, settings, outdir, comm)
    except CraneFemError as exc:
        reason = str(exc).splitlines()[0]
        wall = time.perf_counter() - t0
        return Point(scheme, dt_ratio, REFUSED, math.nan, wall, diagnosis=reason)
    h = out.history
    energy = h["kinetic"] + h["internal"] if "kinetic" in h else np.zeros(0)
    cls, ratio = classify(out.status, energy)
    t_growth = math.nan
    if cls == GROWTH:
        t_growth = float(h["t"][np.argmax(energy > ENERGY_GROWTH * energy[0])])
    wall = float(out.summary.get("wall_time_s", time.perf_counter() - t0))
    limit, crit = out.summary.get("dt_critical_penalty"), out.summary.get("dt_critical")
    lim = float(limit) / float(crit) if limit and crit else math.nan
    diagnosis = out.diagnosis.splitlines()[0] if out.diagnosis else ""
    intervals = out.summary.get("contact_intervals")
    return Point(
        scheme,
        dt_ratio,
        cls,
        ratio,
        wall,
        lim,
        math.nan,
        t_growth,
        diagnosis,
        None if intervals is None else int(intervals),
    )


# ---------------------------------------------------------------- bar on a rigid wall


@dataclass(frozen=True)
class WallBar:
    """demos/bar_impact.toml with Δt given in seconds (``time.dt_factor`` removed, so that
    every scheme is placed in units of the mesh's h/c): its scenario file, h/c and EA/h."""

    path: Path
    h_over_c: float
    ea_over_h: float
    end: float


def wall_scenario(directory: Path, elements: int | None = None) -> WallBar:
    """Write the bar on a wall into ``directory`` (rank 0; collective) with ``elements``
    elements (the demo's by default)."""
    data = tomllib.loads(demo("bar_impact").read_text(encoding="utf-8"))
    data["time"].pop("dt_factor", None)
    if elements is not None:
        data["model"]["elements"] = elements
    mdl, mat = data["model"], data["material"]
    h = float(mdl["length"]) / int(mdl["elements"])
    path = directory / f"bar_on_wall_{mdl['elements']}.toml"
    comm = MPI.COMM_WORLD
    if comm.rank == 0:
        directory.mkdir(parents=True, exist_ok=True)
        path.write_text(_toml(data), encoding="utf-8")
    comm.barrier()
    ea_h = float(mat["E"]) * float(mdl.get("area", 1.0)) / h
    return WallBar(path, _h_over_c(data), ea_h, float(data["time"]["end"]))


def _toml(data: dict[str, Any]) -> str:
    """A scenario mapping as TOML (scalars, tables, arrays of tables, inline tables)."""

    def value(v: Any) -> str:
        if isinstance(v, dict):
            return "{ " + ", ".join(f"{k} = {value(x)}" for k, x in v.items()) + " }"
        return toml_value(v)

    def body(d: dict[str, Any]) -> list[str]:
        return [f"{k} = {value(v)}" for k, v in d.items()]

    lines = body({k: v for k, v in data.items() if not isinstance(v, dict | list)})
    for key, v in data.items():
        if isinstance(v, dict):
            lines += ["", f"[{key}]", *body(v)]
        elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
            for item in v:
                lines += ["", f"[[{key}]]", *body(item)]
        elif isinstance(v, list):
            lines.append(f"{key} = {value(v)}")
    return "\n".join(lines) + "\n"


def cd_lagrange() -> Scheme:
    """CD-Lagrange on the wall."""
    return Scheme("wall", "cd-lagrange", "", {"integrator.scheme": "cd-lagrange"})


def penalty(k: float, bar: WallBar) -> Scheme:
    """Explicit penalty with stiffness ``k`` EA/h."""
    return Scheme(
        "wall",
        f"penalty k={k:g}EA/h",
        f"k = {k:g} EA/h",
        {"integrator.scheme": "penalty", "integrator.penalty": k * bar.ea_over_h},
        k=k,
    )


def _wall_schemes(bar: WallBar, ks: Sequence[float]) -> list[Scheme]:
    mj = [
        Scheme(
            "wall",
            f"moreau-jean θ={label}",
            f"θ = {label}",
            {"integrator.scheme": "moreau-jean", "integrator.theta": theta},
        )
        for label, theta in (("1/2", 0.5), ("1", 1.0))
    ]
    return [cd_lagrange(), *(penalty(k, bar) for k in ks), *mj]


def wall_point(scheme: Scheme, dt_ratio: float, bar: WallBar, runs: Path) -> Point:
    """``scheme`` on the bar on a wall at Δt = ``dt_ratio`` h/c (collective)."""
    dt = dt_ratio * bar.h_over_c
    every = max(1, math.ceil(bar.end / dt) // HISTORY_ROWS)
    settings = {"time.dt": dt, "output.xdmf": False, "output.every": every, **scheme.settings}
    label = f"wall-{_slug(scheme.label)}-dt{dt_ratio:g}"
    return run_point(scheme, dt_ratio, bar.path, settings, runs / label)


def penalty_limit_point(k: float, fraction: float, bar: WallBar, runs: Path) -> Point:
    """Penalty ``k`` EA/h at Δt = ``fraction`` × its own limit 2/ω_p (``time.dt_factor``,
    which for penalty refers to the limit with the springs closed; collective)."""
    scheme = penalty(k, bar)
    every = max(1, math.ceil(bar.end / (fraction * bar.h_over_c)) // HISTORY_ROWS)
    settings = {
        "time.dt_factor": fraction,
        "output.xdmf": False,
        "output.every": every,
        **scheme.settings,
    }
    label = f"wall-{_slug(scheme.label)}-own{fraction:g}"
    p = run_point(scheme, math.nan, bar.path, settings, runs / label)
    p.own_ratio = fraction
    p.dt_ratio = fraction * p.limit_ratio
    return p


# ---------------------------------------------------------------- split bars (coupled)


def _coupled(method: str, m: int, family: str, row: str = "") -> Scheme:
    return Scheme(
        family,
        f"{method} m={m}",
        f"m = {m}",
        {"coupling.method": method, "coupling.ratio": m},
        m=m,
        row=row,
    )


def coupled_point(method: str, m: int, dt_ratio: float, runs: Path) -> Point:
    """The split bar on the wall (demos/split_bar.toml) with ``method`` at ratio ``m`` and
    Δt = ``dt_ratio`` Δt_crit of its explicit half (collective)."""
    scheme = _coupled(method, m, "coupled")
    data = tomllib.loads(demo("split_bar").read_text(encoding="utf-8"))
    macro = math.ceil(float(data["time"]["end"]) / (dt_ratio * _h_over_c(data) * m))
    settings = {
        **scheme.settings,
        "time.dt_factor": dt_ratio,
        "output.xdmf": False,
        "output.every": max(1, macro // HISTORY_ROWS),
    }
    label = f"coupled-{_slug(method)}-m{m}-dt{dt_ratio:g}"
    return run_point(scheme, dt_ratio, demo("split_bar"), settings, runs / label)


def undamped_point(method: str, m: int, dt_ratio: float, runs: Path, row: str = "") -> Point:
    """The undamped split bar clamped at its right end, no wall, 200 time units
    (demos/split_bar_undamped.toml, its monitor relaxed to 1e12 so that growth is measured,
    not stopped) with ``method`` at ratio ``m`` and Δt = ``dt_ratio`` Δt_crit (collective)."""
    scheme = _coupled(method, m, "undamped", row or method)
    settings = {**scheme.settings, "time.dt_factor": dt_ratio}
    label = f"undamped-{_slug(method)}-m{m}-dt{dt_ratio:g}"
    return run_point(scheme, dt_ratio, demo("split_bar_undamped"), settings, runs / label)


def _h_over_c(data: dict[str, Any]) -> float:
    mdl, mat = data["model"], data["material"]
    return float(mdl["length"]) / int(mdl["elements"]) / math.sqrt(mat["E"] / mat["rho"])


def _slug(text: str) -> str:
    text = text.replace("θ=1/2", "theta0.5").replace("θ=", "theta")
    return re.sub(r"[^A-Za-z0-9.]+", "-", text).strip("-")


# ---------------------------------------------------------------- the grids


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
    coupled_methods=("gc", "gc-mean", "hybrid", "ph"),
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
    coupled_methods=("gc", "gc-mean", "hybrid", "ec", "ph"),
    coupled_m=(1, 10, 100, 1000),
    coupled_dt=(0.1, 0.25, 0.5, 0.75, 0.9, 0.99, 1.0, 1.01),
    undamped=tuple(
        (method, (1, 2, 3, 5, 10, 100)) for method in ("gc", "gc-mean", "hybrid", "ec", "ph")
    ),
    undamped_dt=(0.9, 0.5),
)


@dataclass
class Map:
    """The points of one run of the suite, by family (rows of points)."""

    bar: WallBar
    wall: list[list[Point]]
    own: list[list[Point]]
    coupled: list[list[Point]]
    undamped: list[list[Point]]

    def points(self) -> list[Point]:
        rows = (self.wall, self.own, self.coupled, self.undamped)
        return [p for family in rows for row in family for p in row]


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
        for s in _wall_schemes(bar, grid.penalty_k)
    ]
    own = [[penalty_limit_point(k, f, bar, runs) for f in grid.penalty_own] for k in grid.penalty_k]
    coupled = [
        [coupled_point(method, m, r, runs) for r in grid.coupled_dt]
        for method in grid.coupled_methods
        for m in grid.coupled_m
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
        _figure(png_path, result)
        body = _body(result, elapsed, quick, csv_path, png_path)
        print(f"stability: {len(result.points())} runs, {_duration(elapsed, quick)}")
    body = comm.bcast(body, root=0)
    key = "stability-quick" if quick else "stability-full"
    title = "Stability map" + (" (quick)" if quick else " (full sweep)")
    return [Section(key, title, body, [csv_path, png_path])]


# ---------------------------------------------------------------- the report


def _duration(seconds: float, quick: bool) -> str:
    return f"quick: {seconds:.0f} s" if quick else f"full sweep: {seconds / 60:.1f} min"


def _cell(p: Point, ratio: bool = False) -> str:
    text = p.cls if p.cls in (STABLE, REFUSED) else f"**{p.cls}**"
    if ratio and math.isfinite(p.energy_ratio):
        text += f" ({p.energy_ratio:.3g})"
    return text


def _table(rows: list[list[Point]], head: str, columns: list[str], ratio: bool = False) -> str:
    lines = ["| " + " | ".join([head, *columns]) + " |", "|---" * (len(columns) + 1) + "|"]
    for row in rows:
        cells = [row[0].scheme.row_label, *(_cell(p, ratio) for p in row)]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _first(row: list[Point], classes: tuple[str, ...]) -> Point | None:
    return next((p for p in row if p.cls in classes), None)


def _last_stable(row: list[Point]) -> Point | None:
    """The largest Δt of the row below which every point is stable."""
    last = None
    for p in row:
        if p.cls != STABLE:
            break
        last = p
    return last


def _dt(p: Point | None, unit: str) -> str:
    return "—" if p is None else f"{p.dt_ratio:.3g} {unit}"


def _intervals(mp: Map) -> list[str]:
    """The range of contact intervals of each wall row's completed runs (one impact: 1)."""
    by_row: dict[str, list[int]] = {}
    for row in [*mp.wall, *mp.own]:
        for p in row:
            if p.cls in (STABLE, GROWTH) and p.contact_intervals is not None:
                by_row.setdefault(row[0].scheme.label, []).append(p.contact_intervals)
    return [
        f"{label} {min(v)}" + (f"–{max(v)}" if max(v) > min(v) else "")
        for label, v in by_row.items()
    ]


def _spread(values: list[float], unit: str) -> str:
    """ "0.8–0.99 h/c (4 points)" for several values, "0.8 h/c" for one."""
    unit = unit if unit.startswith("·") else f" {unit}"
    if len(values) == 1:
        return f"{values[0]:g}{unit}"
    return f"{min(values):g}–{max(values):g}{unit} ({len(values)} points)"


def _by_class(points: list[Point], unit: str, own: bool = False) -> str:
    """The non-stable points of a row, by class: where, and how much energy was created."""
    parts = []
    for cls in (GROWTH, UNSTABLE, REFUSED):
        pts = [p for p in points if p.cls == cls]
        if not pts:
            continue
        text = f"{cls} at " + _spread([p.own_ratio if own else p.dt_ratio for p in pts], unit)
        if cls == GROWTH:
            ratios = [p.energy_ratio for p in pts]
            text += f", max E/E0 {_range(ratios)}"
        parts.append(text)
    return ", ".join(parts)


def _range(values: list[float]) -> str:
    lo, hi = min(values), max(values)
    return f"{lo:.3g}" if f"{lo:.3g}" == f"{hi:.3g}" else f"{lo:.3g}–{hi:.3g}"


def _short(diagnosis: str) -> str:
    """A refusal's reason without the run's particulars (times, residuals, advice)."""
    diagnosis = diagnosis.split("; use")[0]
    diagnosis = re.sub(r" (ending )?at t = \S+ s", "", diagnosis)
    return re.sub(r" by \S+ \(relative\)", "", diagnosis)


def _reading(mp: Map) -> list[str]:
    """What the map shows, in sentences built from the points."""
    out: list[str] = []
    cd = next((row for row in mp.wall if row[0].scheme.label == "cd-lagrange"), None)
    if cd is not None:
        ok = all(p.cls == STABLE for p in cd if p.dt_ratio < 1.0)
        out.append(
            f"- CD-Lagrange is stable up to Δt = {_dt(_last_stable(cd), 'h/c')} and unstable "
            f"from {_dt(_first(cd, (UNSTABLE,)), 'h/c')}: the CFL limit of the mesh, which "
            "contact does not lower" + (" (stable at every Δt < h/c of the grid)." if ok else ".")
        )
    fails = []
    for row in mp.wall:
        k = row[0].scheme.k
        bad = [p for p in row if p.dt_ratio < 1.0 and p.cls != STABLE]
        if k is not None and bad:
            lim = row[0].limit_ratio
            fails.append(f"k = {k:g} EA/h (2/ω_p = {lim:.3g} h/c): {_by_class(bad, 'h/c')}")
    if fails:
        out.append(
            "- Below the CFL limit (Δt < h/c), where CD-Lagrange is stable, explicit penalty "
            "fails: " + "; ".join(fails) + ". Its springs lower the limit to 2/ω_p "
            "(computed with them closed)."
        )
    near = [
        f"k = {row[0].scheme.k:g} EA/h: {_by_class(row, '·2/ω_p', own=True)}"
        for row in mp.own
        if any(p.cls != STABLE for p in row)
    ]
    if near:
        out.append(
            "- Even below its own limit explicit penalty is not safe: "
            + "; ".join(near)
            + ". There the bar leaves the wall with more energy than it came with."
        )
    elif mp.own:
        out.append("- Below its own limit 2/ω_p penalty was stable at every point of the grid.")
    chatter = _intervals(mp)
    if chatter:
        out.append(
            "- Contact intervals of the completed runs (one impact): " + "; ".join(chatter) + "."
        )
    for row in mp.wall:
        label = row[0].scheme.label
        if not label.startswith("moreau-jean"):
            continue
        bad = [p for p in row if p.cls != STABLE]
        out.append(
            f"- {label}: "
            + (
                f"stable at every Δt of the grid, up to {row[-1].dt_ratio:g} h/c "
                f"(max E/E0 = {max(p.energy_ratio for p in row):.3g}): implicit, no CFL limit."
                if not bad
                else _by_class(bad, "h/c") + "."
            )
        )
    if mp.coupled:
        out.append(_reading_coupled(mp))
    if mp.undamped:
        out.append(_reading_undamped(mp))
    return out


def _reading_coupled(mp: Map) -> str:
    done = [p for row in mp.coupled for p in row if p.cls != REFUSED]
    bad = [p for p in done if p.cls != STABLE]
    end = tomllib.loads(demo("split_bar").read_text(encoding="utf-8"))["time"]["end"]
    text = f"- Split bar on the wall ({end:g} time units, one impact): {len(done)} runs, "
    if not bad:
        text += f"all stable (max E/E0 = {max(p.energy_ratio for p in done):.4g})."
    else:
        text += ", ".join(f"{p.scheme.label} at {p.dt_ratio:g} ({p.cls})" for p in bad) + "."
    over = [p for row in mp.coupled for p in row if p.dt_ratio > 1.0]
    if over and all(p.cls == REFUSED for p in over):
        text += (
            f" Δt = {', '.join(sorted({f'{p.dt_ratio:g}' for p in over}))} Δt_crit is refused "
            "at setup: the coupled path checks Δt against the explicit half's critical step."
        )
    refused: dict[str, list[Point]] = {}
    for row in mp.coupled:
        for p in row:
            if p.cls == REFUSED and p.dt_ratio <= 1.0:
                refused.setdefault(_short(p.diagnosis), []).append(p)
    for reason, pts in refused.items():
        ms = sorted({p.scheme.m or 0 for p in pts})
        text += (
            f" Refused at {len(pts)} points below the limit (m = {', '.join(map(str, ms))}): "
            f"{reason}."
        )
    return text


def _reading_undamped(mp: Map) -> str:
    parts = []
    for row in mp.undamped:
        grow = [p for p in row if p.cls in (GROWTH, UNSTABLE)]
        fine = [p for p in row if p.cls == STABLE]
        text = row[0].scheme.row_label + ": "
        if grow:
            ms = ", ".join(str(p.scheme.m) for p in grow)
            text += f"energy growth at m = {ms} (max E/E0 {_range([p.energy_ratio for p in grow])})"
        if fine:
            ms = ", ".join(str(p.scheme.m) for p in fine)
            text += (", " if grow else "") + f"stable at m = {ms}"
            text += f" (max E/E0 {_range([p.energy_ratio for p in fine])})"
        parts.append(text)
    text = "- Undamped split bar (no wall, 200 time units): " + "; ".join(parts) + "."
    gc = [p for row in mp.undamped for p in row if p.scheme.label.startswith("gc ")]
    gc_grow = [p for p in gc if p.cls == GROWTH]
    on_wall = [
        p.energy_ratio
        for row in mp.coupled
        for p in row
        if p.scheme.label.startswith("gc ") and p.cls != REFUSED
    ]
    if gc_grow and on_wall:
        first = min(gc_grow, key=lambda p: p.t_growth)
        text += (
            " GC's weak instability shows where nothing dissipates: on the split bar on the "
            f"wall GC stays at max E/E0 ≤ {max(on_wall):.3g}, while undamped it passes "
            f"{ENERGY_GROWTH:g} E0 as early as t = {first.t_growth:.3g} (m = {first.scheme.m}) "
            f"(max {max(p.energy_ratio for p in gc_grow):.3g} E0)."
        )
    return text


def _body(mp: Map, elapsed: float, quick: bool, csv_path: Path, png_path: Path) -> str:
    bar = mp.bar
    parts = [
        f"The stability map of the contact integrators and of the couplings: "
        f"{len(mp.points())} runs ({_duration(elapsed, quick)}, one process). Files: "
        f"`{csv_path}` (one row per point), `{png_path}` (the map; stability boundary as a "
        "step line).",
        "",
        f"Classes: stable; **energy growth**: completed, but max(kinetic + internal)/E0 > "
        f"{ENERGY_GROWTH:g} (no scene has external work: a stable scheme stays at E0 or below, "
        "but for a bounded +6.4 % excursion of GC and PH at m = 1 while the pulse crosses the "
        "interface); **unstable**: stopped by the energy-growth monitor (kinetic energy > "
        "`monitor.energy_growth` × the energy supplied: 10 on the wall, 1e12 on the undamped "
        "split bar) or non-finite; refused: the package refuses the run (a CraneFemError other "
        "than divergence).",
        "",
        f"### Bar on a rigid wall (demos/bar_impact.toml, Δt in units of h/c = "
        f"{bar.h_over_c:.4g} s; k in units of EA/h = {bar.ea_over_h:.3g} N/m)",
        "",
        _table(mp.wall, "scheme", [f"Δt = {p.dt_ratio:g}·h/c" for p in mp.wall[0]]),
    ]
    if mp.own:
        parts += [
            "",
            "Penalty against its own limit 2/ω_p (computed with the springs closed; "
            "`time.dt_factor`, which for penalty refers to that limit); cells: class (max E/E0):",
            "",
            _own_table(mp.own),
        ]
    if mp.coupled:
        parts += [
            "",
            "### Split bar on the wall (demos/split_bar.toml), Δt in units of the explicit "
            "half's Δt_crit",
            "",
            _table(
                mp.coupled, "method, m", [f"Δt = {p.dt_ratio:g}·Δt_crit" for p in mp.coupled[0]]
            ),
        ]
    if mp.undamped:
        parts += [
            "",
            "### GC's weak instability: undamped split bar (demos/split_bar_undamped.toml, "
            "200 time units), Δt = 0.9·Δt_crit unless stated; cells: class (max E/E0)",
            "",
            _table(mp.undamped, "method", [f"m = {p.scheme.m}" for p in mp.undamped[0]], True),
        ]
    parts += ["", "Reading:", *_reading(mp)]
    return "\n".join(parts) + "\n"


def _own_table(own: list[list[Point]]) -> str:
    """Penalty rows: k, its own limit in units of h/c, the classes at fractions of it."""
    columns = ["2/ω_p (× h/c)", *(f"Δt = {p.own_ratio:g}·2/ω_p" for p in own[0])]
    lines = ["| " + " | ".join(["penalty k", *columns]) + " |", "|---" * (len(columns) + 1) + "|"]
    for row in own:
        lim = next((p.limit_ratio for p in row if math.isfinite(p.limit_ratio)), math.nan)
        cells = [row[0].scheme.parameter, f"{lim:.3f}", *(_cell(p, True) for p in row)]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


# ---------------------------------------------------------------- the figure


def _boundary(xs: list[float], classes: list[str], stop: tuple[str, ...]) -> float:
    """Where a row's class first enters ``stop``: between the two points, at the geometric
    mean; NaN when the grid does not bracket it (no point, or every point, in ``stop``)."""
    for i, c in enumerate(classes):
        if c in stop:
            return math.nan if i == 0 else math.sqrt(xs[i - 1] * xs[i])
    return math.nan


def _panel(ax: Any, rows: list[list[Point]], title: str, xlabel: str, by_m: bool) -> None:
    """One family: rows of squares coloured by class, x on a log scale; on the Δt panels the
    boundaries as step lines, on the m panel max E/E0 written over each point."""
    from matplotlib.ticker import FuncFormatter, NullFormatter

    for i, row in enumerate(rows):
        xs = [float(p.scheme.m or 1) if by_m else p.dt_ratio for p in row]
        ax.scatter(xs, [i] * len(xs), c=[_COLOURS[p.cls] for p in row], marker="s", s=55)
    if by_m:
        for i, row in enumerate(rows):
            for j, p in enumerate(row):
                if math.isfinite(p.energy_ratio):
                    ax.annotate(  # above and below in turn: neighbours on a log axis crowd
                        _short_number(p.energy_ratio),
                        (float(p.scheme.m or 1), i),
                        textcoords="offset points",
                        xytext=(0, 7 if j % 2 == 0 else -13),
                        ha="center",
                        fontsize=7,
                    )
    else:
        steps = {
            (UNSTABLE, REFUSED): ("k-", "first unstable (or refused) Δt"),
            (GROWTH, UNSTABLE, REFUSED): ("k:", "first not-stable Δt"),
        }
        for stop, (style, label) in steps.items():
            sx: list[float] = []
            sy: list[float] = []
            for i, row in enumerate(rows):
                b = _boundary([p.dt_ratio for p in row], [p.cls for p in row], stop)
                sx += [b, b]  # a NaN row (boundary outside the grid) breaks the line
                sy += [i - 0.5, i + 0.5]
            ax.plot(sx, sy, style, lw=1.2, label=label)
        ax.axvline(1.0, color="0.4", ls="--", lw=0.8)
        limits = [(i, row[0].limit_ratio) for i, row in enumerate(rows)]
        limits = [(i, v) for i, v in limits if math.isfinite(v)]
        if limits:
            ax.plot(
                [v for _, v in limits], [i for i, _ in limits], "kx", ms=8, label="2/ω_p (penalty)"
            )
    ax.set_xscale("log")
    xs_all = [float(p.scheme.m or 1) if by_m else p.dt_ratio for row in rows for p in row]
    if xs_all:
        ax.set_xlim(min(xs_all) / 1.5, max(xs_all) * 1.5)
        if max(xs_all) < 12.0 * min(xs_all):  # about a decade: label the grid itself
            ticks: list[float] = []
            for x in sorted(set(xs_all)):
                if not ticks or x > 1.15 * ticks[-1]:
                    ticks.append(x)
            ax.set_xticks(ticks)
    ax.xaxis.set_major_formatter(FuncFormatter(lambda x, _: f"{x:g}"))
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_yticks(range(len(rows)))
    ax.set_yticklabels([row[0].scheme.row_label for row in rows], fontsize=7)
    ax.set_ylim(len(rows) - 0.5, -0.5)
    ax.set_xlabel(xlabel)
    ax.set_title(title, fontsize=9)
    ax.grid(True, which="major", axis="x", alpha=0.3)


def _short_number(x: float) -> str:
    """1.06, 10.5, 3.2e3: three digits below 100 (the threshold is 1.1), two above."""
    return f"{x:.3g}" if x < 100.0 else f"{x:.1e}".replace("e+0", "e").replace("e+", "e")


def _figure(path: Path, mp: Map) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    schemes = [row for row in mp.wall if row[0].scheme.k is None]
    penalties = []
    for row in mp.wall:
        k = row[0].scheme.k
        if k is None:
            continue
        extra = [p for own in mp.own if own[0].scheme.k == k for p in own]
        extra = [p for p in extra if math.isfinite(p.dt_ratio)]  # refused: no limit known
        penalties.append(sorted(row + extra, key=lambda p: p.dt_ratio))
    fig, axes = plt.subplots(2, 2, figsize=(13, 9))
    _panel(axes[0, 0], schemes, "Bar on a rigid wall: schemes", "Δt / (h/c)", False)
    _panel(
        axes[0, 1],
        penalties,
        "Bar on a rigid wall: explicit penalty (grid in h/c and in 2/ω_p)",
        "Δt / (h/c)",
        False,
    )
    _panel(axes[1, 0], mp.coupled, "Split bar on the wall: couplings", "Δt / Δt_crit", False)
    _panel(
        axes[1, 1],
        mp.undamped,
        f"Undamped split bar, 200 time units: max E/E0 (growth > {ENERGY_GROWTH:g})",
        "m = ΔT/Δt",
        True,
    )
    handles = [Line2D([], [], marker="s", ls="", color=c, label=k) for k, c in _COLOURS.items()]
    extra_h, extra_l = axes[0, 1].get_legend_handles_labels()
    fig.legend(handles + extra_h, [*_COLOURS, *extra_l], loc="lower center", ncol=7)
    fig.suptitle("crane-fem stability map")
    fig.tight_layout(rect=(0, 0.05, 1, 0.97))
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)
