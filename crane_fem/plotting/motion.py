"""The input ground motion of a run: acceleration, velocity and displacement per component."""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from crane_fem.plotting.runs import Run, figure_title
from crane_fem.plotting.style import figure_legend, run_colour, run_width, save

__all__ = ["GROUND_COLUMNS", "GroundMotion", "ground_motion_series", "input_motion_figure"]

FloatArray = npt.NDArray[np.float64]

#: history.csv columns of the input ground acceleration (m/s²), by component.
GROUND_COLUMNS = {"x": "ground_ax", "y": "ground_ay", "z": "ground_az"}


class GroundMotion(NamedTuple):
    """Ground velocity (m/s) and displacement (m) at the acceleration's sample times."""

    velocity: FloatArray
    displacement: FloatArray


def _cumtrapz(t: FloatArray, f: FloatArray) -> FloatArray:
    """∫ f dt from t[0] at every t[i] (trapezoid rule; any, even uneven, spacing)."""
    return np.concatenate(([0.0], np.cumsum(0.5 * (f[1:] + f[:-1]) * np.diff(t))))


def ground_motion_series(t: FloatArray, a: FloatArray) -> GroundMotion:
    """Velocity and displacement of the ground from its acceleration ``a`` (m/s²) sampled at
    ``t`` (s), integrated by the cumulative trapezoid rule from rest at ``t[0]``.

    This is the record over the run window only: a record that starts moving before ``t[0]``,
    or a baseline drift of the record, shows as a drift here (no baseline correction). Exact
    for a piecewise-linear ``a`` (velocity) and piecewise-constant ``a`` (displacement); for a
    linear ``a = c₀ + c₁t`` on a uniform step ``h`` the displacement is ``c₁ h² t / 12`` high.
    """
    v = _cumtrapz(t, a)
    return GroundMotion(v, _cumtrapz(t, v))


def _components(run: Run) -> list[str]:
    """The directions the ground shakes in (a column of zeros is a direction it does not)."""
    h = run.history
    return [c for c, col in GROUND_COLUMNS.items() if col in h and np.any(h[col] != 0.0)]


def input_motion_figure(runs: list[Run], path: Path) -> Path | None:
    """``input_motion.png``: acceleration (m/s²), velocity (mm/s), displacement (mm) stacked,
    one column per component present in the history (``ground_a<x|y|z>``), the record over the
    run window integrated from rest at t = 0. Runs whose input differs from the first's are
    overlaid; None when no run has the columns (older runs, bar scenes)."""
    import matplotlib.pyplot as plt

    withg = [(i, r) for i, r in enumerate(runs) if _components(r)]
    if not withg:
        return None
    comps = [c for c in GROUND_COLUMNS if any(c in _components(r) for _, r in withg)]
    # The same record in every run (the usual pair): draw it once.
    first = withg[0][1]
    drawn = [withg[0]] + [
        (i, r)
        for i, r in withg[1:]
        if not all(
            GROUND_COLUMNS[c] in r.history
            and GROUND_COLUMNS[c] in first.history
            and r.history["t"].shape == first.history["t"].shape
            and np.allclose(r.history[GROUND_COLUMNS[c]], first.history[GROUND_COLUMNS[c]])
            for c in comps
        )
    ]
    rows = (("acceleration (m/s²)", 1.0), ("velocity (mm/s)", 1e3), ("displacement (mm)", 1e3))
    fig, axes = plt.subplots(
        3,
        len(comps),
        figsize=(4.2 * len(comps) + 1.5, 7.5),
        squeeze=False,
        sharex=True,
        layout="constrained",
    )
    for j, c in enumerate(comps):
        for i, run in drawn:
            col = GROUND_COLUMNS[c]
            if col not in run.history:
                continue
            t, a = run.history["t"], run.history[col]
            v, d = ground_motion_series(t, a)
            for ax, y, (_, scale) in zip(axes[:, j], (a, v, d), rows, strict=True):
                lw = run_width(i) if len(drawn) > 1 else 1.0
                ax.plot(t, scale * y, color=run_colour(i), lw=lw)
        axes[0, j].set_title(f"{c} component", fontsize=10)
        axes[-1, j].set_xlabel("t (s)")
        for ax in axes[:, j]:
            ax.grid(alpha=0.3)
            ax.axhline(0.0, color="k", lw=0.5)
    for ax, (name, _) in zip(axes[:, 0], rows, strict=True):
        ax.set_ylabel(name)
    if len(drawn) > 1:
        figure_legend(fig, [(r.label, {"color": run_colour(i)}) for i, r in drawn])
    title = figure_title([r for _, r in drawn], "input ground motion")
    return save(
        fig, path, title + "\n(velocity, displacement: the record integrated from rest at t = 0)"
    )
