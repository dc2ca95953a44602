"""Figures of `crane-fem plot` on fake run directories: input motion, overlaid runs, wheel groups,
spectra, the render at the peak von Mises frame, and the warning for unfinished runs.

Plotting is not collective (rank 0 plots): on two ranks each rank would make the same
figures from its own directories, so the module runs in the serial pass only.
"""

import json
import warnings
from pathlib import Path
from typing import Any

import matplotlib
import numpy as np
import pytest

import crane_fem.plotting.wheels as wheels_module
from crane_fem.formulations import SolidVonMises
from crane_fem.plotting import (
    IncompleteRunWarning,
    Run,
    ground_motion_series,
    group_wheels,
    load_runs,
    nearest_frame,
    plot_figures,
    plot_outputs,
)
from crane_fem.plotting.motion import input_motion_figure
from crane_fem.plotting.render import load_peak_frame, nice_range, render_runs
from crane_fem.plotting.response_spectra import split_direction
from crane_fem.plotting.runs import figure_title
from crane_fem.plotting.wheels import WHEEL_RTOL, group_label

matplotlib.use("Agg")
pytestmark = [pytest.mark.serial, pytest.mark.no_kernels]

ENERGY = ["kinetic", "internal", "external_work", "damping_dissipated", "total"]


def _write_run(
    path: Path,
    summary: dict[str, Any],
    t: np.ndarray,
    scale: dict[int, float] | None = None,
    ground: bool = True,
) -> Path:
    """A fake run directory: history.csv with the columns the figures read, summary.json."""
    scale = scale or {}
    cols: dict[str, np.ndarray] = {"t": t}
    for j, name in enumerate(ENERGY):
        cols[name] = (j + 1) * np.sin(40 * t) ** 2
    cols["interface_dissipated"] = 1e-3 * t
    for k in range(1, 5):
        s = scale.get(k, 1.0)
        cols[f"wheel{k}_wheel_uz"] = s * 1e-3 * np.sin(60 * t)
        cols[f"wheel{k}_rail_uz"] = s * 2e-4 * np.sin(60 * t)
        cols[f"wheel{k}_wheel_vz"] = s * 6e-2 * np.cos(60 * t)
        cols[f"wheel{k}_rail_vz"] = s * 1.2e-2 * np.cos(60 * t)
        cols[f"force_wheel_{k}"] = s * 1.4e3 * np.maximum(np.cos(60 * t), 0.0)
        cols[f"wheel{k}_slip_across"] = s * 1e-4 * np.sin(30 * t)
        cols[f"wheel{k}_slip_along"] = s * 5e-3 * t
    if ground:
        cols["ground_az"] = 25.0 * np.sin(2 * np.pi * 20 * t)
        cols["ground_ax"] = 5.0 * np.sin(2 * np.pi * 10 * t)
    path.mkdir(parents=True)
    names = list(cols)
    rows = np.column_stack([cols[n] for n in names])
    np.savetxt(path / "history.csv", rows, delimiter=",", header=",".join(names), comments="")
    (path / "summary.json").write_text(json.dumps(summary))
    return path


def _summary(method: str, ratio: int, **extra: Any) -> dict[str, Any]:
    return {
        "scenario": "crane_fake",
        "method": method,
        "ratio": ratio,
        "explicit_subdomains": ["all"] if method == "monolithic" else ["contact_zones"],
        "status": "completed",
        "steps": 100,
        "dT": 1e-3,
        **extra,
    }


T = np.linspace(0.0, 0.1, 101)


def test_ground_motion_series_exact_polynomials() -> None:
    """The cumulative trapezoid from rest: exact velocity for a linear acceleration, and the
    displacement's known trapezoid error c₁h²t/12; exact for a constant one on uneven steps."""
    h = 1e-3
    t = np.arange(0.0, 0.2 + h / 2, h)
    c0, c1 = 3.0, -40.0
    v, d = ground_motion_series(t, c0 + c1 * t)
    np.testing.assert_allclose(v, c0 * t + c1 * t**2 / 2, rtol=0, atol=1e-13)
    exact = c0 * t**2 / 2 + c1 * t**3 / 6
    np.testing.assert_allclose(d - exact, c1 * h**2 * t / 12, rtol=0, atol=1e-14)
    assert v[0] == d[0] == 0.0
    rng = np.random.default_rng(1)
    tu = np.concatenate(([0.0], np.sort(rng.uniform(0.0, 1.0, 50)), [1.0]))
    v, d = ground_motion_series(tu, np.full_like(tu, 9.81))
    np.testing.assert_allclose(v, 9.81 * tu, rtol=1e-13)
    np.testing.assert_allclose(d, 9.81 * tu**2 / 2, rtol=1e-12, atol=1e-15)


def test_input_motion_figure_skipped_without_ground_columns(tmp_path: Path) -> None:
    run = load_runs(_write_run(tmp_path / "bar", _summary("gc", 10), T, ground=False))
    assert input_motion_figure(run, tmp_path / "input_motion.png") is None
    assert not (tmp_path / "input_motion.png").exists()


def test_group_wheels_identical_and_different() -> None:
    x = np.sin(np.linspace(0.0, 6.0, 200))
    same = {k: x.copy() for k in range(1, 5)}
    assert group_wheels(same) == [[1, 2, 3, 4]]
    # Within the tolerance (half of it, relative to the largest value): still one group.
    near = {**same, 3: x + 0.5 * WHEEL_RTOL}
    assert group_wheels(near) == [[1, 2, 3, 4]]
    # Wheels 3 and 4 3 % larger (the stress scene's 5.87 / 5.72 mm): two pairs.
    pairs = {**same, 3: 1.03 * x, 4: 1.03 * x}
    assert group_wheels(pairs) == [[1, 2], [3, 4]]
    assert group_wheels({1: x, 2: 2 * x, 3: 3 * x, 4: 4 * x}) == [[1], [2], [3], [4]]
    assert group_wheels({1: x, 2: -x, 3: x, 4: -x}) == [[1, 3], [2, 4]]
    assert group_label([1, 2, 3, 4]) == "wheels 1–4 (identical within 1 %)"
    assert group_label([2, 4]) == "wheels 2, 4 (identical within 1 %)"
    assert group_label([3]) == "wheel 3"


def test_pair_figure_overlays_runs_in_wheel_group_panels(tmp_path: Path, monkeypatch) -> None:
    """Both runs on the same axes, one panel per group of identical wheels, the legend naming
    each run by its directory and method."""
    _write_run(tmp_path / "heterogeneous", _summary("gc", 100), T, scale={3: 1.05, 4: 1.05})
    _write_run(tmp_path / "explicit", _summary("monolithic", 1), T, scale={3: 1.05, 4: 1.05})
    runs = load_runs(tmp_path)
    figs: list[Any] = []
    monkeypatch.setattr(wheels_module, "save", lambda fig, path, title=None: figs.append(fig))
    wheels_module.pair_figure(runs, "uz", "u_z (mm)", 1e3, tmp_path / "f.png", "displacement")
    (fig,) = figs
    axes = fig.get_axes()
    assert [ax.get_title(loc="left") for ax in axes] == [
        "wheels 1, 2 (identical within 1 %)",
        "wheels 3, 4 (identical within 1 %)",
    ]
    for ax in axes:
        assert len(ax.get_lines()) == 4  # 2 runs × (wheel, rail)
        assert len({line.get_color() for line in ax.get_lines()}) == 2
    legend = [t.get_text() for leg in fig.legends for t in leg.get_texts()]
    assert legend[:2] == ["heterogeneous: GC, m = 100", "explicit: fully explicit"]


def test_plot_parent_dir_writes_figures_and_spectra(tmp_path: Path) -> None:
    for name, method, ratio in (("heterogeneous", "gc", 100), ("explicit", "monolithic", 1)):
        run = _write_run(tmp_path / name, _summary(method, ratio, spectra_damping=0.05), T)
        periods = np.geomspace(0.01, 2.0, 30)
        psa = {
            "input_z": 9.81 * (1 + 2 * np.exp(-(np.log(periods / 0.05) ** 2))),
            "trolley_z": 9.81 * (1 + 5 * np.exp(-(np.log(periods / 0.1) ** 2))),
            "wheel_1_z": 9.81 * (1 + 4 * np.exp(-(np.log(periods / 0.08) ** 2))),
            "input_x": 2.0 * np.ones_like(periods),
            "trolley_x": 3.0 * np.ones_like(periods),
        }
        header = "period_s," + ",".join(f"psa_{n}" for n in psa)
        np.savetxt(
            run / "spectra.csv",
            np.column_stack([periods, *psa.values()]),
            delimiter=",",
            header=header,
            comments="",
        )
    figures = plot_figures(tmp_path)
    names = sorted(p.name for p in figures.paths)
    assert names == [
        "contact_forces.png",
        "fig5_pair_displacement.png",
        "fig6_pair_velocity.png",
        "fig7_energy_balance.png",
        "fig8_interface_energy.png",
        "input_motion.png",
        "slip.png",
        "spectra.png",
    ]
    for p in figures.paths:
        assert p.parent == tmp_path / "figures" and p.stat().st_size > 10_000, p
    assert figures.warnings == []
    assert split_direction("wheel_1_z") == ("wheel_1", "z")
    assert split_direction("support") == ("support", "")


def test_incomplete_run_message_and_titles(tmp_path: Path) -> None:
    t = np.linspace(0.0, 0.0731, 20)
    _write_run(tmp_path / "heterogeneous", _summary("gc", 100), t)
    # Interrupted, without t_reached_s / time_end_s: the history's last t, steps · dT.
    _write_run(
        tmp_path / "x", _summary("monolithic", 1, status="interrupted", steps=200, dT=1e-3), t
    )
    runs = load_runs(tmp_path)
    het, x = runs
    assert het.incomplete_message() is None
    line = (
        f"{tmp_path / 'x'}: run interrupted at t = 0.0731 s of 0.2 s; figures show the steps done"
    )
    assert x.incomplete_message() == line
    assert x.label == "x: fully explicit [interrupted]"
    assert figure_title(runs, "contact forces") == (
        "crane_fake: contact forces (incomplete: x interrupted)"
    )
    assert figure_title([x], "energy balance") == (
        "crane_fake (x: fully explicit): energy balance (incomplete: interrupted)"
    )
    figures = plot_figures(tmp_path)
    assert figures.warnings == [line]
    with pytest.warns(IncompleteRunWarning, match="run interrupted at t = 0.0731 s of 0.2 s"):
        plot_outputs(tmp_path)
    # The summary's own t_reached_s and time_end_s win; a killed run stays "running".
    s = _summary("gc", 10, status="running", t_reached_s=0.05, time_end_s=0.3)
    killed = Run(tmp_path / "k", runs[0].history, s)
    assert killed.incomplete_message() == (
        f"{tmp_path / 'k'}: run stopped without finishing (killed, or still running) at "
        "t = 0.05 s of 0.3 s; figures show the steps done"
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert plot_outputs(tmp_path / "heterogeneous")  # a completed run: no warning


def test_nearest_frame() -> None:
    times = [0.0, 0.1, 0.2, 0.3]
    assert nearest_frame(times, 0.14) == 1
    assert nearest_frame(times, 0.16) == 2
    assert nearest_frame(times, 0.25) == 2  # equally near: the earlier
    assert nearest_frame(times, -1.0) == 0 and nearest_frame(times, 9.0) == 3
    with pytest.raises(ValueError):
        nearest_frame([], 0.1)
    # Colour ranges: round steps, 4 to 10 intervals, a round top kept as it is.
    assert nice_range(10.1) == (12.5, 5) and nice_range(33.47) == (35.0, 7)
    assert nice_range(0.8) == (0.8, 4) and nice_range(35.0) == (35.0, 7)
    assert nice_range(9.99) == (10.0, 5) and nice_range(0.0) == (1.0, 4)


def _write_xdmf_run(path: Path, times: list[float], summary: dict[str, Any]) -> None:
    """A small box written by the solver's own XDMF writer, with von Mises stress; the
    displacement grows with t."""
    import dolfinx
    from mpi4py import MPI

    from crane_fem.io.xdmf import XDMFSeries

    mesh = dolfinx.mesh.create_box(
        MPI.COMM_SELF,
        [[0.0, 0.0, 0.0], [2.0, 0.5, 0.5]],
        [4, 2, 2],
        dolfinx.mesh.CellType.tetrahedron,
    )
    V = dolfinx.fem.functionspace(mesh, ("Lagrange", 1, (3,)))
    x = V.tabulate_dof_coordinates()[: V.dofmap.index_map.size_local]
    vm = SolidVonMises(V, 2e11, 0.3)
    with XDMFSeries(path / "solution_all.xdmf", V, ["displacement"], stress=vm) as w:
        for t in times:
            u = np.zeros((x.shape[0], 3))
            u[:, 2] = -t * 1e-3 * x[:, 0] ** 2
            w.write(t, {"displacement": u.ravel()})
    np.savetxt(
        path / "history.csv",
        np.array([[0.0, 0.0], [times[-1], 0.0]]),
        delimiter=",",
        header="t,total",
        comments="",
    )
    (path / "summary.json").write_text(json.dumps(summary))


def test_render_at_frame_nearest_peak_von_mises(tmp_path: Path) -> None:
    times = [0.0, 0.01, 0.02, 0.03, 0.04]
    run_dir = tmp_path / "heterogeneous"
    run_dir.mkdir()
    summary = _summary(
        "gc",
        100,
        peak_bridge_von_mises_Pa=3.2e7,
        peak_bridge_von_mises_t=0.0262,
        peak_bridge_von_mises_location_m=[2.0, 0.25, 0.5],
    )
    _write_xdmf_run(run_dir, times, summary)
    (run,) = load_runs(run_dir)
    frame = load_peak_frame(run)
    assert frame is not None and frame.index == 3 and frame.t == 0.03 and frame.t_peak == 0.0262
    assert frame.parts[0][3] is not None and frame.parts[0][3].max() > 0.0
    (png,) = render_runs([run], tmp_path)
    assert png == tmp_path / "render_peak.png" and png.stat().st_size > 20_000
    # Without the summary's peak time: the frame of the largest von Mises stress (the last).
    del run.summary["peak_bridge_von_mises_t"]
    frame = load_peak_frame(run)
    assert frame is not None and frame.index == 4 and frame.t_peak is None
