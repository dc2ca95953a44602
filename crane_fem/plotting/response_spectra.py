"""Pseudo-acceleration response spectra of the runs (``spectra.csv``), one panel per direction."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import numpy.typing as npt

from crane_fem.plotting.runs import Run, figure_title
from crane_fem.plotting.style import figure_legend, run_dash, save
from crane_fem.spectra import G, read_spectra_csv

__all__ = ["spectra_figure", "split_direction"]

FloatArray = npt.NDArray[np.float64]


def split_direction(name: str) -> tuple[str, str]:
    """``wheel_1_z`` → (``wheel_1``, ``z``); a name without a direction suffix → (name, "")."""
    head, _, tail = name.rpartition("_")
    return (head, tail) if head and tail in ("x", "y", "z") else (name, "")


def spectra_figure(runs: list[Run], path: Path) -> Path | None:
    """``spectra.png``: the PSA (g) against the period (s, log axis) of every curve of every
    run's ``spectra.csv``, a panel per direction; the input's in black (once when every run has
    the same), the in-structure points by colour, runs by line style. None without a CSV."""
    import matplotlib.pyplot as plt

    data = [
        (i, r, *read_spectra_csv(r.path / "spectra.csv"))
        for i, r in enumerate(runs)
        if (r.path / "spectra.csv").exists()
    ]
    if not data:
        return None
    directions = sorted({split_direction(n)[1] for *_, curves in data for n in curves})
    points = sorted(
        {split_direction(n)[0] for *_, curves in data for n in curves if not n.startswith("input")}
    )
    colours = {p: f"C{j}" for j, p in enumerate(points)}
    fig, axes = plt.subplots(
        1,
        len(directions),
        figsize=(5.2 * len(directions) + 1.0, 4.8),
        squeeze=False,
        sharey=True,
        layout="constrained",
    )
    first_inputs: dict[str, FloatArray] = {}
    for ax, direction in zip(axes[0], directions, strict=True):
        for i, _run, periods, curves in data:
            for name, psa in curves.items():
                point, d = split_direction(name)
                if d != direction:
                    continue
                if point.startswith("input"):
                    ref = first_inputs.setdefault(name, psa)
                    if ref is not psa and ref.shape == psa.shape and np.allclose(ref, psa):
                        continue  # the same record in this run: drawn once
                    ax.plot(periods, psa / G, run_dash(i), color="k", lw=1.8)
                else:
                    ax.plot(periods, psa / G, run_dash(i), color=colours[point], lw=1.1)
        ax.set_xscale("log")
        ax.set_xlabel("period T (s)")
        ax.set_title(f"{direction} direction" if direction else "spectra", fontsize=10)
        ax.grid(alpha=0.3, which="both")
    axes[0, 0].set_ylabel("pseudo-acceleration PSA (g)")
    figure_legend(
        fig,
        [("input (ground)", {"color": "k", "lw": 1.8})] * bool(first_inputs)
        + [(p.replace("_", " "), {"color": colours[p]}) for p in points]
        + (
            [(r.label, {"color": "0.45", "ls": run_dash(i)}) for i, r, *_ in data]
            if len(data) > 1
            else []
        ),
    )
    dampings = sorted({float(r.summary.get("spectra_damping", 0.05)) for _, r, *_ in data})
    zeta = ", ".join(f"{100 * z:g} %" for z in dampings)
    return save(fig, path, figure_title([r for _, r, *_ in data], f"response spectra, ζ = {zeta}"))
