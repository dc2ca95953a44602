"""Figures of a run directory (``crane-fem plot OUTDIR``), after Fekak et al. (2017) Figs. 5–8.

``OUTDIR`` is one run (``history.csv``, ``summary.json``) or a directory of runs side by side
(e.g. ``heterogeneous/`` and ``explicit/`` written by ``make demo``), whose curves are then
overlaid on the same axes, each run named in the legend by its directory and method. Figures go
to ``OUTDIR/figures/``:

- ``input_motion.png``: the input ground acceleration, velocity and displacement per component
  (history columns ``ground_a<x|y|z>``; the record over the run window, integrated from rest
  at t = 0), when the history has them;
- ``fig5_pair_displacement.png``: vertical displacement of one wheel/rail node pair per wheel,
  wheel and rail side; one panel per group of wheels identical within 1 % (see
  :mod:`crane_fem.plotting.wheels`);
- ``fig6_pair_velocity.png``: the same for the vertical velocity;
- ``fig7_energy_balance.png``: kinetic, internal, external work, dissipated terms and the
  balance (``total`` − ``total₀``) of each run;
- ``fig8_interface_energy.png``: the energy dissipated at the explicit/implicit interface, and
  as a fraction of the external work;
- ``contact_forces.png``: contact force per wheel group, runs overlaid, each run's peak (from
  every micro step, summary.json) marked;
- ``slip.png``: each wheel's slip across and along its rail; ``contact_slip.png``: a gmsh
  model's or a frame's contacts' mean slip, each one's largest point slip marked;
- ``spectra.png``: pseudo-acceleration response spectra (``spectra.csv``), a panel per
  direction, when the runs wrote them;
- ``render_peak.png`` (and ``render_peak_<run>.png`` for the other runs): the deformed mesh at
  the XDMF frame nearest the peak von Mises stress of the bridge, coloured by von Mises stress
  (pyvista off-screen), when the run wrote 3D XDMF output.

A run that did not complete (summary.json ``status`` other than ``completed``) is plotted as
far as it got; its figures' titles say ``(incomplete: <status>)`` and :func:`plot_figures`
returns one warning line per such run.
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import NamedTuple

from crane_fem.plotting.energies import energy_figure, interface_figure
from crane_fem.plotting.motion import ground_motion_series, input_motion_figure
from crane_fem.plotting.render import nearest_frame, render_peak, render_runs
from crane_fem.plotting.response_spectra import spectra_figure
from crane_fem.plotting.runs import Run, load_runs
from crane_fem.plotting.wheels import (
    contact_slip_figure,
    force_figure,
    group_wheels,
    pair_figure,
    slip_figure,
    wheel_numbers,
)

__all__ = [
    "Figures",
    "IncompleteRunWarning",
    "Run",
    "ground_motion_series",
    "group_wheels",
    "load_runs",
    "nearest_frame",
    "plot_figures",
    "plot_outputs",
    "render_peak",
]


class IncompleteRunWarning(UserWarning):
    """A run plotted did not complete (interrupted, unstable, or killed)."""


class Figures(NamedTuple):
    """What :func:`plot_figures` wrote, and one warning line per unfinished run (e.g.
    ``out/x: run interrupted at t = 0.0731 s of 0.2 s; figures show the steps done``)."""

    paths: list[Path]
    warnings: list[str]


def plot_figures(outdir: Path) -> Figures:
    """Write every figure of ``outdir`` (see the module docstring). Not collective: call on
    one rank. Raises FileNotFoundError / ValueError when ``outdir`` holds no readable run."""
    import matplotlib

    matplotlib.use("Agg")
    runs = load_runs(outdir)
    figdir = outdir / "figures"
    figdir.mkdir(parents=True, exist_ok=True)
    made: list[Path | None] = [input_motion_figure(runs, figdir / "input_motion.png")]
    if any(wheel_numbers(r) for r in runs):
        made.append(
            pair_figure(
                runs,
                "uz",
                "u_z (mm)",
                1e3,
                figdir / "fig5_pair_displacement.png",
                "vertical displacement of the wheel/rail contact node pairs",
            )
        )
        made.append(
            pair_figure(
                runs,
                "vz",
                "v_z (mm/s)",
                1e3,
                figdir / "fig6_pair_velocity.png",
                "vertical velocity of the wheel/rail contact node pairs",
            )
        )
    made.append(energy_figure(runs, figdir / "fig7_energy_balance.png"))
    made.append(interface_figure(runs, figdir / "fig8_interface_energy.png"))
    made.append(force_figure(runs, figdir / "contact_forces.png"))
    made.append(slip_figure(runs, figdir / "slip.png"))
    made.append(contact_slip_figure(runs, figdir / "contact_slip.png"))
    made.append(spectra_figure(runs, figdir / "spectra.png"))
    made.extend(render_runs(runs, figdir))
    notes = [m for r in runs if (m := r.incomplete_message()) is not None]
    return Figures([p for p in made if p is not None], notes)


def plot_outputs(outdir: Path) -> list[Path]:
    """:func:`plot_figures`' paths; each unfinished run's line is issued as an
    :class:`IncompleteRunWarning` (prefer :func:`plot_figures`, which returns them)."""
    figures = plot_figures(outdir)
    for line in figures.warnings:
        warnings.warn(line, IncompleteRunWarning, stacklevel=2)
    return figures.paths
