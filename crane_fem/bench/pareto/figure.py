"""The Pareto chart's figure: error against cost per case and measure, with the front."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from crane_fem.bench.pareto.measures import MEASURES
from crane_fem.bench.pareto.points import CRITERION, Point, pareto_front

__all__ = ["FAMILIES", "plot_chart"]

#: One colour and marker per method family (in legend order).
FAMILIES = {
    "CD-Lagrange": ("C0", "o"),
    "penalty": ("C1", "s"),
    "Moreau–Jean θ=½": ("C2", "v"),
    "Moreau–Jean θ=1": ("C3", "^"),
    "gc": ("C4", "D"),
    "gc-mean": ("C5", "P"),
    "hybrid": ("C6", "X"),
    "gc, reduced implicit": ("C7", "*"),
}


def plot_chart(path: Path, points: list[Point], scene: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cases = [c for c in MEASURES if any(p.spec.case == c for p in points)]
    ncol = max(len(v) for v in MEASURES.values())
    fig, axes = plt.subplots(
        len(cases), ncol, figsize=(5.2 * ncol, 4.4 * len(cases)), squeeze=False
    )
    for row, case in enumerate(cases):
        pts = [p for p in points if p.spec.case == case and not p.spec.reference]
        for col, (key, label) in enumerate(MEASURES[case]):
            ax = axes[row, col]
            err = np.array([p.errors.get(key, math.nan) for p in pts])
            cost = np.array([p.cost for p in pts])
            good = np.array([p.usable for p in pts]) & np.isfinite(err)
            floor = 1e-16
            top = float(np.max(err[good])) * 3.0 if np.any(good) else 1.0
            for fam, (color, marker) in FAMILIES.items():
                sel = np.array([p.spec.family == fam for p in pts]) & good
                if np.any(sel):
                    ax.plot(
                        cost[sel],
                        np.maximum(err[sel], floor),
                        marker=marker,
                        color=color,
                        ls="-",
                        lw=1,
                        label=fam,
                    )
            bad = ~good & np.isfinite(cost)
            if np.any(bad):
                ax.scatter(
                    cost[bad],
                    np.full(int(bad.sum()), top),
                    marker="x",
                    color="red",
                    s=60,
                    zorder=5,
                    label="unstable / failed (at the top)",
                )
            front = pareto_front(np.where(good, cost, np.nan), err)
            if front.size:
                ax.step(
                    cost[front],
                    np.maximum(err[front], floor),
                    where="post",
                    color="k",
                    ls="--",
                    lw=1.2,
                    label="Pareto front",
                )
            if key in ("u_end_l2", "pair_l2"):
                ax.axhline(CRITERION, color="grey", ls=":", lw=1, label="criterion (a): 2 %")
            if key == "tolerance_ratio":
                ax.axhline(1.0, color="grey", ls=":", lw=1, label="(b): every tolerance met")
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.set_xlabel("wall time per simulated second (s/s)")
            ax.set_ylabel(label)
            name = "bar (exact reference)" if case == "bar" else f"{scene} (explicit references)"
            ax.set_title(name, fontsize=10)
            ax.grid(True, which="both", alpha=0.3)
            if col == 0:
                ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
