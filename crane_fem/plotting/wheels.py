"""Per-wheel figures (Figs. 5–6, the contact forces, the slip), one panel per group of identical
wheels; the contact forces and slip of a gmsh model's or a frame's contacts, one panel each.

The crane's four wheels often move alike (a symmetric scene under a vertical record): four
copies of one curve hide the runs' differences in four small panels. Wheels whose histories
agree to within :data:`WHEEL_RTOL` of the largest value drawn share one panel.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from crane_fem.plotting.runs import Run, figure_title
from crane_fem.plotting.style import figure_legend, run_colour, run_width, save

__all__ = [
    "WHEEL_RTOL",
    "contact_slip_figure",
    "force_figure",
    "group_label",
    "group_wheels",
    "pair_figure",
    "slip_figure",
    "wheel_numbers",
]

FloatArray = npt.NDArray[np.float64]

#: Wheels whose curves differ by at most this fraction of the largest |value| in the panel are
#: drawn once. A panel is about 250 px high and its y range spans the largest value, so 1 % is
#: 2–3 px, within the width of a drawn line: curves closer than that cannot be told apart on the
#: figure, and a panel per wheel would only repeat them.
WHEEL_RTOL = 0.01


def wheel_numbers(run: Run) -> list[int]:
    """The wheel numbers with probed contact node pairs in the run's history."""
    return [k for k in range(1, 5) if f"wheel{k}_wheel_uz" in run.history]


def group_wheels(series: dict[int, FloatArray], rtol: float = WHEEL_RTOL) -> list[list[int]]:
    """Groups of wheels whose series agree: wheel ``j`` joins the first group whose first wheel
    ``k`` has ``max |x_j − x_k| ≤ rtol · max_i max |x_i|`` (the largest value of all wheels),
    else starts a group. Wheels in increasing order; groups ordered by their first wheel.

    Args:
        series: per wheel, every sample compared (e.g. the wheel- and rail-side columns of
            every run, concatenated: a group must hold in every run).
        rtol: the tolerance, relative to the largest |value|.
    """
    if not series:
        return []
    scale = max(float(np.max(np.abs(x))) if x.size else 0.0 for x in series.values())
    groups: list[list[int]] = []
    for k in sorted(series):
        for g in groups:
            ref = series[g[0]]
            if ref.shape == series[k].shape and (
                float(np.max(np.abs(series[k] - ref), initial=0.0)) <= rtol * scale
            ):
                g.append(k)
                break
        else:
            groups.append([k])
    return groups


def group_label(group: list[int], rtol: float = WHEEL_RTOL) -> str:
    """``wheel 2``, ``wheels 1–4 (identical within 1 %)``, ``wheels 1, 3 (…)``."""
    if len(group) == 1:
        return f"wheel {group[0]}"
    consecutive = len(group) > 2 and group == list(range(group[0], group[-1] + 1))
    names = f"{group[0]}–{group[-1]}" if consecutive else ", ".join(map(str, group))
    return f"wheels {names} (identical within {100 * rtol:g} %)"


def _groups(runs: list[Run], columns: Callable[[int], list[str]]) -> list[list[int]]:
    """Wheel groups over every run, comparing the named columns of each wheel."""
    ks = sorted(set().union(*(wheel_numbers(r) for r in runs)))
    series = {
        k: np.concatenate([r.history[c] for r in runs for c in columns(k) if c in r.history])
        for k in ks
    }
    return group_wheels(series)


def _mark_stops(ax: Any, runs: list[Run]) -> None:
    """A dotted vertical line where an unfinished run stopped."""
    for i, run in enumerate(runs):
        if not run.complete:
            ax.axvline(run.t_reached, color=run_colour(i), ls=":", lw=0.8)


def pair_figure(
    runs: list[Run], quantity: str, unit: str, scale: float, path: Path, what: str
) -> Path:
    """One wheel/rail node pair per wheel group (Figs. 5–6): ``quantity`` ``uz`` or ``vz``
    scaled by ``scale`` into ``unit``; runs overlaid (colour), wheel / rail side (line style)."""
    import matplotlib.pyplot as plt

    def cols(k: int) -> list[str]:
        return [f"wheel{k}_wheel_{quantity}", f"wheel{k}_rail_{quantity}"]

    groups = _groups(runs, cols)
    fig, axes = plt.subplots(
        len(groups),
        1,
        figsize=(9, 1.6 + 2.4 * len(groups)),
        squeeze=False,
        sharex=True,
        layout="constrained",
    )
    sides = (("wheel", "-"), ("rail", "--"))
    one = len(runs) == 1  # one run: the sides by colour, as in the paper's figures

    def colour(i: int, j: int) -> str:
        return f"C{j}" if one else run_colour(i)

    for ax, group in zip(axes[:, 0], groups, strict=True):
        k = group[0]
        for i, run in enumerate(runs):
            for j, (side, dash) in enumerate(sides):
                col = f"wheel{k}_{side}_{quantity}"
                if col in run.history:
                    y = scale * run.history[col]
                    lw = 1.0 if one else run_width(i)
                    ax.plot(run.history["t"], y, dash, color=colour(i, j), lw=lw)
        _mark_stops(ax, runs)
        ax.set_title(group_label(group), fontsize=9, loc="left")
        ax.set_ylabel(unit)
        ax.grid(alpha=0.3)
    entries: list[tuple[str, dict[str, Any]]]
    if one:
        entries = [(f"{s} node", {"color": f"C{j}", "ls": d}) for j, (s, d) in enumerate(sides)]
    else:
        entries = [
            (r.label, {"color": run_colour(i), "lw": run_width(i)}) for i, r in enumerate(runs)
        ] + [(f"{side} node", {"color": "k", "ls": dash}) for side, dash in sides]
    figure_legend(fig, entries)
    axes[-1, 0].set_xlabel("t (s)")
    return save(fig, path, figure_title(runs, what))


def _peak(run: Run, group: str) -> tuple[float, float] | None:
    """(time, force) of a contact group's peak in the run's summary (``wheels`` for the
    crane's ``wheel_<k>`` groups, else ``contact_groups``), or None."""
    s = run.summary
    if group.startswith("wheel_") and "wheels" in s:
        entry = s["wheels"].get(group.removeprefix("wheel_"))
    else:
        entry = s.get("contact_groups", {}).get(group)
    if not entry:
        return None
    return float(entry["peak_force_time_s"]), float(entry["peak_force_N"])


def force_figure(runs: list[Run], path: Path) -> Path | None:
    """Contact force per group (wheel groups as in :func:`pair_figure`), runs overlaid, each
    run's peak from every micro step (summary.json, which the rows may miss) marked."""
    import matplotlib.pyplot as plt

    names = [c for c in runs[0].history if c.startswith("force_")]
    if not names:
        return None
    wheel_cols = {int(c[len("force_wheel_") :]): c for c in names if c[6:].startswith("wheel_")}
    panels: list[tuple[str, list[str]]] = []
    if wheel_cols:
        series = {
            k: np.concatenate([r.history[c] for r in runs if c in r.history])
            for k, c in wheel_cols.items()
        }
        for g in group_wheels(series):
            panels.append((group_label(g), [wheel_cols[k] for k in g]))
    panels += [(c[6:], [c]) for c in names if c not in wheel_cols.values()]
    fig, axes = plt.subplots(
        len(panels),
        1,
        figsize=(9, 1.6 + 2.2 * len(panels)),
        squeeze=False,
        sharex=True,
        layout="constrained",
    )
    for ax, (title, cols) in zip(axes[:, 0], panels, strict=True):
        for i, run in enumerate(runs):
            if cols[0] not in run.history:
                continue
            colour = run_colour(i)
            ax.plot(run.history["t"], run.history[cols[0]] / 1e3, color=colour, lw=run_width(i))
            peaks = [p for c in cols if (p := _peak(run, c[6:])) is not None]
            if peaks:
                t, f = max(peaks, key=lambda p: p[1])
                ax.plot(t, f / 1e3, "v", color=colour, ms=6)
                ax.annotate(
                    f"{f / 1e3:.1f} kN",
                    (t, f / 1e3),
                    textcoords="offset points",
                    xytext=(4, 2 - 10 * i),
                    fontsize=8,
                    color=colour,
                )
        _mark_stops(ax, runs)
        ax.set_title(title, fontsize=9, loc="left")
        ax.set_ylabel("force (kN)")
        ax.grid(alpha=0.3)
    figure_legend(
        fig,
        [(r.label, {"color": run_colour(i), "lw": run_width(i)}) for i, r in enumerate(runs)]
        + [("peak over every micro step", {"color": "k", "marker": "v", "ls": "none"})],
    )
    axes[-1, 0].set_xlabel("t (s)")
    return save(fig, path, figure_title(runs, "contact forces"))


def slip_figure(runs: list[Run], path: Path) -> Path | None:
    """Each wheel's slip on its rail, across (x) and along (y), runs overlaid, with the
    reach of its contact pairs and its sliding intervals shaded (the first run's); None
    without slip columns."""
    import matplotlib.pyplot as plt

    wheels = sorted(
        int(c[len("wheel") : -len("_slip_along")])
        for c in runs[0].history
        if c.startswith("wheel") and c.endswith("_slip_along")
    )
    if not wheels:
        return None
    fig, axes = plt.subplots(
        len(wheels),
        2,
        figsize=(11, 1.6 + 2.0 * len(wheels)),
        squeeze=False,
        sharex=True,
        layout="constrained",
    )
    for row, k in zip(axes, wheels, strict=True):
        w = (runs[0].summary.get("wheels") or {}).get(str(k), {})
        for ax, d in zip(row, ("across", "along"), strict=True):
            col = f"wheel{k}_slip_{d}"
            for i, run in enumerate(runs):
                if col in run.history:
                    ax.plot(
                        run.history["t"],
                        1e3 * run.history[col],
                        color=run_colour(i),
                        lw=run_width(i),
                    )
            reach = w.get("slip_reach_m")
            if reach:
                for sign in (-1.0, 1.0):
                    ax.axhline(sign * 1e3 * reach, color="grey", ls=":", lw=1)
            for a, b in w.get("sliding_intervals", []):
                ax.axvspan(a, b, color="tab:orange", alpha=0.12, lw=0)
            _mark_stops(ax, runs)
            ax.set_title(f"wheel {k}: slip {d} its rail", fontsize=9, loc="left")
            ax.set_ylabel("slip (mm)")
            ax.grid(alpha=0.3)
    figure_legend(
        fig,
        [(r.label, {"color": run_colour(i), "lw": run_width(i)}) for i, r in enumerate(runs)]
        + [
            ("reach of the contact pairs", {"color": "grey", "ls": ":"}),
            ("sliding (first run)", {"color": "tab:orange", "alpha": 0.3, "lw": 6}),
        ],
    )
    for ax in axes[-1]:
        ax.set_xlabel("t (s)")
    return save(fig, path, figure_title(runs, "wheel slip on the rails"))


#: The slip components drawn, by line style.
_COMPONENT_DASHES = {"x": "-", "y": "--", "z": ":"}


def contact_slip_figure(runs: list[Run], path: Path) -> Path | None:
    """Each sliding contact's mean slip (history ``<contact>_slip_<x|y|z>``), a panel per
    contact, runs overlaid (colour), components by line style (those that move, above 0.1 %
    of the contact's largest); the largest slip of one point (summary ``contact_groups``
    ``max_slip_m`` at ``max_slip_time_s``) marked for each run. None without such columns
    (the crane's wheels are :func:`slip_figure`'s)."""
    import matplotlib.pyplot as plt

    names = [c[: -len("_slip_x")] for c in runs[0].history if c.endswith("_slip_x")]
    if not names:
        return None
    fig, axes = plt.subplots(
        len(names),
        1,
        figsize=(9, 1.6 + 2.2 * len(names)),
        squeeze=False,
        sharex=True,
        layout="constrained",
    )
    drawn: set[str] = set()
    for ax, name in zip(axes[:, 0], names, strict=True):
        cols = {c: f"{name}_slip_{c}" for c in _COMPONENT_DASHES}
        big = max(
            (
                float(np.max(np.abs(r.history[col])))
                for r in runs
                for col in cols.values()
                if col in r.history
            ),
            default=0.0,
        )
        for i, run in enumerate(runs):
            for c, col in cols.items():
                if col not in run.history or np.max(np.abs(run.history[col])) <= 1e-3 * big:
                    continue
                drawn.add(c)
                ax.plot(
                    run.history["t"],
                    1e3 * run.history[col],
                    _COMPONENT_DASHES[c],
                    color=run_colour(i),
                    lw=run_width(i),
                )
            g = (run.summary.get("contact_groups") or {}).get(name, {})
            if "max_slip_m" in g and "max_slip_time_s" in g:
                ax.plot(g["max_slip_time_s"], 1e3 * g["max_slip_m"], "v", color=run_colour(i))
        _mark_stops(ax, runs)
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set_title(f"contact {name}: mean slip of its points", fontsize=9, loc="left")
        ax.set_ylabel("slip (mm)")
        ax.grid(alpha=0.3)
    figure_legend(
        fig,
        [(r.label, {"color": run_colour(i), "lw": run_width(i)}) for i, r in enumerate(runs)]
        + [(c, {"color": "k", "ls": d}) for c, d in _COMPONENT_DASHES.items() if c in drawn]
        + [("largest slip of one point", {"color": "k", "marker": "v", "ls": "none"})],
    )
    axes[-1, 0].set_xlabel("t (s)")
    return save(fig, path, figure_title(runs, "contact slip (relative to the surface)"))
