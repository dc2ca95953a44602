"""The scenes of the stability map: the bar on a rigid wall, the split bar on the wall and the
undamped split bar, each a point runner; :class:`Map`, the points of one run by scene."""

from __future__ import annotations

import math
import re
import tomllib
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mpi4py import MPI

from crane_fem.bench.common import demo, toml_value
from crane_fem.bench.stability.points import HISTORY_ROWS, Point, Scheme, run_point

__all__ = [
    "REFINING",
    "Map",
    "WallBar",
    "cd_lagrange",
    "coupled_point",
    "fine_ratio",
    "penalty",
    "penalty_limit_point",
    "undamped_point",
    "wall_point",
    "wall_scenario",
    "wall_schemes",
]


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


def wall_schemes(bar: WallBar, ks: Sequence[float]) -> list[Scheme]:
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


#: The suffix of a method name that refines its macro step at impacts (coupling.fine_ratio).
REFINING = " refining"


def fine_ratio(m: int) -> int:
    """The fine ratio the map gives a refining method at coarse ratio ``m`` (> 1): m / 10, or
    1 from m = 10 down."""
    return max(1, m // 10) if m % 10 == 0 else 1


def _coupled(method: str, m: int, family: str, row: str = "") -> Scheme:
    base = method.removesuffix(REFINING)
    settings: dict[str, Any] = {"coupling.method": base, "coupling.ratio": m}
    label = f"m = {m}"
    if method.endswith(REFINING):
        settings["coupling.fine_ratio"] = fine_ratio(m)
        label = f"m = {m} / {fine_ratio(m)}"
    return Scheme(family, f"{method} m={m}", label, settings, m=m, row=row)


def coupled_point(method: str, m: int, dt_ratio: float, runs: Path) -> Point:
    """The split bar on the wall (demos/split_bar.toml) with ``method`` at ratio ``m`` and
    Δt = ``dt_ratio`` Δt_crit of its explicit half (collective)."""
    scheme = _coupled(method, m, "coupled")
    data = tomllib.loads(demo("split_bar").read_text(encoding="utf-8"))
    dT = dt_ratio * _h_over_c(data) * m
    macro = math.ceil(float(data["time"]["end"]) / dT)
    settings = {
        **scheme.settings,
        "time.dt_factor": dt_ratio,
        "output.xdmf": False,
        "output.every": max(1, macro // HISTORY_ROWS),
    }
    if dT > float(data["time"]["end"]):  # a run lasts at least one whole macro step
        settings["time.end"] = dT * (1.0 + 1e-9)
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
