"""The stability map's figure: one panel per scene, points coloured by class, the stability
boundary as a step line."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from crane_fem.bench.stability.points import (
    ENERGY_GROWTH,
    GROWTH,
    REFUSED,
    STABLE,
    UNSTABLE,
    Point,
)
from crane_fem.bench.stability.scenes import Map

__all__ = ["draw_map"]

_COLOURS = {STABLE: "#4daf4a", GROWTH: "#ff7f00", UNSTABLE: "#e41a1c", REFUSED: "#bdbdbd"}


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


def draw_map(path: Path, mp: Map) -> None:
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
