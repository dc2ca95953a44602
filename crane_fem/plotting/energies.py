"""Energy figures (Figs. 7–8): the balance terms and the interface dissipation, runs overlaid."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from crane_fem.energy import BALANCE_TERMS
from crane_fem.plotting.runs import Run, figure_title
from crane_fem.plotting.style import figure_legend, run_colour, run_dash, run_width, save

__all__ = ["energy_figure", "interface_figure"]


def energy_figure(runs: list[Run], path: Path) -> Path:
    """Kinetic, internal, external work, dissipated terms and the balance (total − total₀) of
    every run on one axes: colour for the term, line style for the run."""
    import matplotlib.pyplot as plt

    terms = [*BALANCE_TERMS, "interface_dissipated"]
    drawn = [
        name
        for name in terms
        if any(name in r.history and np.any(r.history[name] != 0.0) for r in runs)
    ]
    colours = {name: f"C{j}" for j, name in enumerate(drawn)}
    fig, ax = plt.subplots(figsize=(9, 5.2), layout="constrained")
    for i, run in enumerate(runs):
        h = run.history
        for name in drawn:
            if name in h:
                ax.plot(h["t"], h[name], run_dash(i), color=colours[name], lw=0.9)
        ax.plot(h["t"], h["total"] - h["total"][0], run_dash(i), color="k", lw=1.3)
    ax.set_xlabel("t (s)")
    ax.set_ylabel("energy (J)")
    ax.grid(alpha=0.3)
    figure_legend(
        fig,
        [(name.replace("_", " "), {"color": colours[name]}) for name in drawn]
        + [("balance (total − total₀)", {"color": "k", "lw": 1.3})]
        + (
            [(r.label, {"color": "0.45", "ls": run_dash(i)}) for i, r in enumerate(runs)]
            if len(runs) > 1
            else []
        ),
    )
    return save(fig, path, figure_title(runs, "energy balance"))


def interface_figure(runs: list[Run], path: Path) -> Path | None:
    """The energy dissipated at the explicit/implicit interface of the coupled runs, and as a
    fraction of the largest |external work| so far; None without a coupled run."""
    import matplotlib.pyplot as plt

    coupled = [
        (i, r)
        for i, r in enumerate(runs)
        if "interface_dissipated" in r.history and r.summary.get("method") != "monolithic"
    ]
    if not coupled:
        return None
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.4), layout="constrained")
    for i, run in coupled:
        h = run.history
        a1.plot(h["t"], h["interface_dissipated"], color=run_colour(i), lw=run_width(i))
        ext = np.maximum.accumulate(np.abs(h["external_work"]))
        with np.errstate(divide="ignore", invalid="ignore"):
            frac = np.where(ext > 0, h["interface_dissipated"] / ext, 0.0)
        a2.plot(h["t"], 100.0 * frac, color=run_colour(i), lw=run_width(i))
    a1.set_ylabel("interface dissipated energy (J)")
    a2.set_ylabel("interface dissipated / max |external work| (%)")
    for ax in (a1, a2):
        ax.set_xlabel("t (s)")
        ax.grid(alpha=0.3)
    figure_legend(fig, [(r.label, {"color": run_colour(i)}) for i, r in coupled])
    return save(fig, path, figure_title([r for _, r in coupled], "interface energy"))
