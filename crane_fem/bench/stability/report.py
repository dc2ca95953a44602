"""The stability map's Markdown: its tables and what it shows, in sentences built from the
points."""

from __future__ import annotations

import math
import re
import tomllib
from pathlib import Path

from crane_fem.bench.common import demo
from crane_fem.bench.stability.points import (
    ENERGY_GROWTH,
    GROWTH,
    REFUSED,
    STABLE,
    UNSTABLE,
    Point,
)
from crane_fem.bench.stability.scenes import Map

__all__ = ["duration", "report_body"]


def duration(seconds: float, quick: bool) -> str:
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


def report_body(mp: Map, elapsed: float, quick: bool, csv_path: Path, png_path: Path) -> str:
    bar = mp.bar
    parts = [
        f"The stability map of the contact integrators and of the couplings: "
        f"{len(mp.points())} runs ({duration(elapsed, quick)}, one process). Files: "
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
