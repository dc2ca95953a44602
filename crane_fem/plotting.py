"""Figures of a run directory (``crane-fem plot OUTDIR``), after Fekak et al. (2017) Figs. 5–8.

``OUTDIR`` is one run (``history.csv``, ``summary.json``) or a directory of runs side by side
(e.g. ``heterogeneous/`` and ``explicit/`` written by ``make demo``). Figures go to
``OUTDIR/figures/``:

- ``fig5_pair_displacement.png``: vertical displacement of one wheel/rail node pair per wheel,
  wheel and rail side, one column per run;
- ``fig6_pair_velocity.png``: the same for the vertical velocity;
- ``fig7_energy_balance.png``: kinetic, internal, external work, dissipated terms and the
  balance (``total``) of each run;
- ``fig8_interface_energy.png``: the energy dissipated at the explicit/implicit interface, and
  as a fraction of the external work;
- ``contact_forces.png``: contact force per wheel, runs overlaid, each run's peak (from
  every micro step, summary.json) marked;
- ``render_peak.png``: the deformed crane at the time of peak response, coloured by von Mises
  stress (pyvista off-screen, from the XDMF output), when the run wrote XDMF.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from crane_fem.energy import BALANCE_TERMS
from crane_fem.io.history import read_history
from crane_fem.scenario import COUPLED_METHODS

__all__ = ["Run", "load_runs", "plot_outputs", "render_peak"]

FloatArray = npt.NDArray[np.float64]


@dataclass
class Run:
    """One run directory: its history columns, summary and a label."""

    path: Path
    history: dict[str, FloatArray]
    summary: dict[str, object]

    @property
    def label(self) -> str:
        s = self.summary
        if s.get("method") == "monolithic":
            return "fully explicit" if s.get("explicit_subdomains") else "fully implicit"
        if s.get("method") in COUPLED_METHODS:
            return f"heterogeneous ({str(s['method']).upper()}, m = {s.get('ratio')})"
        return self.path.name


def _read_history(path: Path) -> dict[str, FloatArray]:
    history = read_history(path)
    if not history or history[next(iter(history))].size == 0:
        raise ValueError(f"{path}: no data rows")
    return history


def load_runs(outdir: Path) -> list[Run]:
    """The run in ``outdir`` or the runs in its subdirectories (sorted: heterogeneous first)."""
    dirs = (
        [outdir]
        if (outdir / "history.csv").exists()
        else sorted(p.parent for p in outdir.glob("*/history.csv"))
    )
    if not dirs:
        raise FileNotFoundError(f"{outdir}: no history.csv here nor in a subdirectory")
    runs = []
    for d in dirs:
        summary = (
            json.loads((d / "summary.json").read_text()) if (d / "summary.json").exists() else {}
        )
        runs.append(Run(d, _read_history(d / "history.csv"), summary))
    runs.sort(key=lambda r: (r.summary.get("method") == "monolithic", r.path.name))
    return runs


def _wheels(run: Run) -> list[int]:
    return [k for k in range(1, 5) if f"wheel{k}_wheel_uz" in run.history]


def _save(fig: Any, path: Path) -> Path:
    import matplotlib.pyplot as plt

    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def _pair_figure(runs: list[Run], quantity: str, unit: str, scale: float, path: Path) -> Path:
    import matplotlib.pyplot as plt

    wheels = sorted(set().union(*(_wheels(r) for r in runs)))
    fig, axes = plt.subplots(
        len(wheels),
        len(runs),
        figsize=(5.5 * len(runs), 2.2 * len(wheels)),
        squeeze=False,
        sharex=True,
        sharey="row",
    )
    for j, run in enumerate(runs):
        t = run.history["t"]
        for i, k in enumerate(wheels):
            ax = axes[i, j]
            for side, style in (("wheel", "-"), ("rail", "--")):
                col = f"wheel{k}_{side}_{quantity}"
                if col in run.history:
                    ax.plot(t, scale * run.history[col], style, lw=0.9, label=f"{side} node")
            ax.set_ylabel(f"wheel {k}\n{unit}")
            ax.grid(alpha=0.3)
            if i == 0:
                ax.set_title(run.label)
        axes[-1, j].set_xlabel("t (s)")
    axes[0, 0].legend(loc="best", fontsize=8)
    return _save(fig, path)


def _energy_figure(runs: list[Run], path: Path) -> Path:
    import matplotlib.pyplot as plt

    terms = [*BALANCE_TERMS, "interface_dissipated"]
    fig, axes = plt.subplots(1, len(runs), figsize=(5.5 * len(runs), 3.8), squeeze=False)
    for j, run in enumerate(runs):
        ax = axes[0, j]
        h = run.history
        for name in terms:
            if name in h and np.any(h[name] != 0.0):
                ax.plot(h["t"], h[name], lw=0.9, label=name.replace("_", " "))
        bal = h["total"] - h["total"][0]
        ax.plot(h["t"], bal, "k:", lw=1.2, label="balance (total − total₀)")
        ax.set_title(run.label)
        ax.set_xlabel("t (s)")
        ax.set_ylabel("energy (J)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    return _save(fig, path)


def _interface_figure(runs: list[Run], path: Path) -> Path | None:
    import matplotlib.pyplot as plt

    coupled = [
        r
        for r in runs
        if "interface_dissipated" in r.history and r.summary.get("method") != "monolithic"
    ]
    if not coupled:
        return None
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 3.8))
    for run in coupled:
        h = run.history
        a1.plot(h["t"], h["interface_dissipated"], lw=1.0, label=run.label)
        ext = np.maximum.accumulate(np.abs(h["external_work"]))
        with np.errstate(divide="ignore", invalid="ignore"):
            frac = np.where(ext > 0, h["interface_dissipated"] / ext, 0.0)
        a2.plot(h["t"], 100.0 * frac, lw=1.0, label=run.label)
    a1.set_ylabel("interface dissipated energy (J)")
    a2.set_ylabel("interface dissipated / max |external work| (%)")
    for ax in (a1, a2):
        ax.set_xlabel("t (s)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    return _save(fig, path)


def _peak(run: Run, group: str) -> tuple[float, float] | None:
    """(time, force) of a contact group's peak in the run's summary (``wheels`` for the
    crane's ``wheel_<k>`` groups, else ``contact_groups``), or None."""
    s: dict[str, Any] = dict(run.summary)
    if group.startswith("wheel_") and "wheels" in s:
        entry = s["wheels"].get(group.removeprefix("wheel_"))
    else:
        entry = s.get("contact_groups", {}).get(group)
    if not entry:
        return None
    return float(entry["peak_force_time_s"]), float(entry["peak_force_N"])


def _force_figure(runs: list[Run], path: Path) -> Path | None:
    import matplotlib.pyplot as plt

    names = [c for c in runs[0].history if c.startswith("force_")]
    if not names:
        return None
    fig, axes = plt.subplots(
        len(names), 1, figsize=(9, 1.9 * len(names)), squeeze=False, sharex=True
    )
    for i, name in enumerate(names):
        ax = axes[i, 0]
        for run in runs:
            if name in run.history:
                (line,) = ax.plot(run.history["t"], run.history[name], lw=0.8, label=run.label)
                # The peak from every micro step (summary.json), which the rows may miss.
                peak = _peak(run, name[6:])
                if peak is not None:
                    ax.plot(*peak, "v", color=line.get_color(), ms=6)
                    ax.annotate(
                        f"{peak[1] / 1e3:.1f} kN",
                        peak,
                        textcoords="offset points",
                        xytext=(4, 2),
                        fontsize=7,
                        color=line.get_color(),
                    )
        ax.set_ylabel(f"{name[6:]}\n(N)")
        ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=8)
    axes[-1, 0].set_xlabel("t (s)")
    return _save(fig, path)


def render_peak(run_dir: Path, path: Path, warp: float | None = None) -> Path | None:
    """Off-screen pyvista render of the deformed mesh (all subdomain XDMF files of the run)
    at the output time of largest displacement, coloured by von Mises stress (MPa)."""
    import os

    # Off-screen through EGL (no X server on compute nodes and CI).
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import pyvista as pv

    from crane_fem.io import read_xdmf

    pv.OFF_SCREEN = True

    files = sorted(run_dir.glob("solution_*.xdmf"))
    if not files:
        return None
    parts = [read_xdmf(f) for f in files]
    if any(topo.shape[1] != 4 or "displacement" not in flds for _, topo, flds in parts):
        return None  # not a 3D solid run
    n = min(len(flds["displacement"]) for _, _, flds in parts)

    def largest(k: int) -> float:
        return max(float(np.abs(flds["displacement"][k][1]).max()) for _, _, flds in parts)

    peak = max(range(n), key=largest)
    u_max = max(
        float(np.linalg.norm(flds["displacement"][peak][1], axis=1).max()) for _, _, flds in parts
    )
    extent = max(float(np.ptp(geom, axis=0).max()) for geom, _, _ in parts)
    factor = warp if warp is not None else (0.05 * extent / u_max if u_max > 0 else 1.0)
    plotter = pv.Plotter(off_screen=True, window_size=[1400, 800])
    t_peak = parts[0][2]["displacement"][peak][0]
    bar = "von Mises (MPa)"
    for geom, topo, flds in parts:
        grid = pv.UnstructuredGrid({pv.CellType.TETRA: topo}, geom)
        grid.points = geom + factor * flds["displacement"][peak][1]
        if "von_mises" in flds:
            grid.cell_data[bar] = flds["von_mises"][peak][1].ravel() / 1e6
        plotter.add_mesh(grid, scalars=bar if "von_mises" in flds else None, cmap="viridis")
    plotter.add_text(f"t = {t_peak:.4f} s, displacement x {factor:.3g}", font_size=10)
    plotter.camera_position = "iso"
    plotter.screenshot(str(path))
    plotter.close()
    return path


def plot_outputs(outdir: Path) -> list[Path]:
    """Write every figure of ``outdir`` (see the module docstring); returns their paths."""
    import matplotlib

    matplotlib.use("Agg")
    runs = load_runs(outdir)
    figdir = outdir / "figures"
    figdir.mkdir(parents=True, exist_ok=True)
    made: list[Path | None] = []
    if any(_wheels(r) for r in runs):
        made.append(
            _pair_figure(runs, "uz", "u_z (mm)", 1e3, figdir / "fig5_pair_displacement.png")
        )
        made.append(_pair_figure(runs, "vz", "v_z (mm/s)", 1e3, figdir / "fig6_pair_velocity.png"))
    made.append(_energy_figure(runs, figdir / "fig7_energy_balance.png"))
    made.append(_interface_figure(runs, figdir / "fig8_interface_energy.png"))
    made.append(_force_figure(runs, figdir / "contact_forces.png"))
    made.append(render_peak(runs[0].path, figdir / "render_peak.png"))
    return [p for p in made if p is not None]
