"""Off-screen pyvista render of a run's deformed mesh at the time of peak von Mises stress."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from crane_fem.plotting.runs import Run, incomplete_tag

__all__ = [
    "PeakFrame",
    "XdmfFrames",
    "load_peak_frame",
    "nearest_frame",
    "nice_range",
    "render_peak",
    "render_runs",
]

FloatArray = npt.NDArray[np.float64]

#: The colour bar's title.
BAR_TITLE = "von Mises (MPa)"


def nearest_frame(times: npt.ArrayLike, t: float) -> int:
    """Index of the frame time nearest ``t`` (the earlier of two equally near)."""
    times = np.asarray(times, dtype=np.float64)
    if times.size == 0:
        raise ValueError("no frames")
    return int(np.argmin(np.abs(times - t)))


class XdmfFrames:
    """A dolfinx XDMF time series opened lazily: the mesh, and each field's frame times; a
    frame's values are read from the HDF5 file only when asked for (a long run holds hundreds
    of frames, the render needs one). Not collective."""

    def __init__(self, path: Path) -> None:
        self.path = path
        domain = ET.parse(path).getroot().find("Domain")
        if domain is None:
            raise ValueError(f"{path}: not an XDMF file (no Domain)")
        # The first mesh in the file: the series' (crane_fem.io.xdmf) or dolfinx's mesh grid.
        self.geometry = self._read(domain.find(".//Geometry/DataItem")).astype(np.float64)
        self.topology = self._read(domain.find(".//Topology/DataItem")).astype(np.int64)
        self._items: dict[str, list[tuple[float, ET.Element]]] = {}
        for coll in domain.findall("Grid[@GridType='Collection']"):
            for grid in coll.findall("Grid"):
                time = grid.find("Time")
                if time is None:
                    continue
                for attr in grid.findall("Attribute"):
                    item = attr.find("DataItem")
                    if item is None:
                        continue
                    self._items.setdefault(attr.get("Name", ""), []).append(
                        (float(time.get("Value", "nan")), item)
                    )

    def _read(self, item: ET.Element | None) -> npt.NDArray[Any]:
        import h5py

        if item is None or item.text is None:
            raise ValueError(f"{self.path}: a DataItem without data")
        fname, dset = item.text.strip().split(":")
        with h5py.File(self.path.parent / fname, "r") as f:
            return np.array(f[dset])

    @property
    def fields(self) -> list[str]:
        return list(self._items)

    def times(self, field: str) -> FloatArray:
        return np.array([t for t, _ in self._items.get(field, [])], dtype=np.float64)

    def values(self, field: str, k: int) -> npt.NDArray[Any]:
        """The field at frame ``k``: (n_nodes, bs) for node fields, (n_cells, 1) for cells."""
        return self._read(self._items[field][k][1])


@dataclass
class PeakFrame:
    """One run's render data at one XDMF frame: per subdomain file (geometry, tetrahedra,
    displacement (m), von Mises stress (Pa) per cell or None); the frame's index and time, and
    the summary's peak time (None when the summary has none)."""

    parts: list[tuple[FloatArray, npt.NDArray[np.int64], FloatArray, FloatArray | None]]
    index: int
    t: float
    t_peak: float | None


def load_peak_frame(run: Run) -> PeakFrame | None:
    """The frame to render: nearest the summary's ``peak_bridge_von_mises_t``, else the frame
    of largest von Mises stress, else of largest displacement; None if the run has no 3D XDMF
    output (bar scenes, ``output.xdmf = false``)."""
    files = sorted(run.path.glob("solution_*.xdmf"))
    if not files:
        return None
    series = [XdmfFrames(f) for f in files]
    if any(s.topology.shape[1] != 4 or "displacement" not in s.fields for s in series):
        return None  # not a 3D solid run
    times = series[0].times("displacement")
    n = min(s.times("displacement").size for s in series)
    if n == 0:
        return None
    times = times[:n]
    t_peak = run.summary.get("peak_bridge_von_mises_t")
    has_vm = all("von_mises" in s.fields for s in series)
    if t_peak is not None:
        k = nearest_frame(times, float(t_peak))
    elif has_vm:
        k = max(
            range(n), key=lambda j: max(float(np.max(s.values("von_mises", j))) for s in series)
        )
    else:
        k = max(
            range(n),
            key=lambda j: max(float(np.abs(s.values("displacement", j)).max()) for s in series),
        )
    parts = [
        (
            s.geometry,
            s.topology,
            s.values("displacement", k).astype(np.float64),
            s.values("von_mises", k).ravel().astype(np.float64) if has_vm else None,
        )
        for s in series
    ]
    return PeakFrame(parts, k, float(times[k]), None if t_peak is None else float(t_peak))


def _title(run: Run, frame: PeakFrame, factor: float) -> str:
    s = run.summary
    who = " — ".join(str(x) for x in (s.get("scenario"), run.label) if x)
    if frame.t_peak is None:
        when = f"t = {frame.t:.4f} s (frame of the largest response)"
    elif abs(frame.t - frame.t_peak) <= 1e-9 * max(1.0, abs(frame.t_peak)):
        when = f"t = {frame.t:.4f} s, the time of the peak von Mises stress"
    else:
        when = (
            f"t = {frame.t:.4f} s: the frame nearest the peak von Mises stress at "
            f"t = {frame.t_peak:.4f} s ({1e3 * (frame.t - frame.t_peak):+.2f} ms)"
        )
    return f"{who}{incomplete_tag([run])}\n{when}\ndisplacement × {factor:.3g}"


def render_peak(
    run: Run,
    path: Path,
    warp: float | None = None,
    clim: tuple[float, float] | None = None,
) -> Path | None:
    """Render ``run`` (all its subdomains' ``solution_*.xdmf``) deformed at the XDMF frame
    nearest the summary's ``peak_bridge_von_mises_t``, coloured by von Mises stress (MPa); the
    peak's location (``peak_bridge_von_mises_location_m``) marked when the summary has it.

    Frames are written every ``output.xdmf_every`` macro steps, so the frame time may differ
    from the peak time: the title says by how much. Off-screen through EGL; not collective.

    Args:
        run: the run.
        path: the PNG to write.
        warp: displacement magnification (default: the largest displacement drawn as 5 % of
            the model's extent).
        clim: colour range (MPa), e.g. shared by several runs; default [0, the frame's
            maximum rounded up to a round number].

    Returns:
        ``path``, or None when the run has no 3D XDMF output.
    """
    frame = load_peak_frame(run)
    return None if frame is None else _render(run, frame, path, warp, clim)


def render_runs(runs: list[Run], figdir: Path) -> list[Path]:
    """``render_peak.png`` of the first run that has 3D XDMF output, ``render_peak_<dir>.png``
    of the others, on one colour range (the largest frame maximum) so they compare."""
    frames = [(r, f) for r in runs if (f := load_peak_frame(r)) is not None]
    top = max((_vm_max(f) for _, f in frames), default=0.0)
    clim = (0.0, nice_range(top / 1e6)[0])
    return [
        _render(
            r,
            f,
            figdir / ("render_peak.png" if i == 0 else f"render_peak_{r.path.name}.png"),
            None,
            clim,
        )
        for i, (r, f) in enumerate(frames)
    ]


def nice_range(value: float) -> tuple[float, int]:
    """A colour range [0, top] with round tick labels: the step is the largest 1, 2, 2.5 or
    5 × 10ᵏ at most ``value``/4, and top the first multiple of it ≥ ``value`` (4 to 10
    intervals, top within one step of ``value``). Returns (top, intervals)."""
    if not value > 0.0:
        return 1.0, 4
    raw = value / 4
    power = 10.0 ** np.floor(np.log10(raw))
    step = max(m * power for m in (1.0, 2.0, 2.5, 5.0) if m * power <= raw * (1 + 1e-12))
    n = int(np.ceil(value / step - 1e-9))
    return n * step, n


def _vm_max(frame: PeakFrame) -> float:
    return max((float(vm.max()) for *_, vm in frame.parts if vm is not None), default=0.0)


def _render(
    run: Run,
    frame: PeakFrame,
    path: Path,
    warp: float | None,
    clim: tuple[float, float] | None,
) -> Path:
    import os

    # Off-screen through EGL (no X server on compute nodes and CI).
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import pyvista as pv

    pv.OFF_SCREEN = True
    u_max = max(float(np.linalg.norm(u, axis=1).max()) for _, _, u, _ in frame.parts)
    extent = max(float(np.ptp(g, axis=0).max()) for g, _, _, _ in frame.parts)
    factor = warp if warp is not None else (0.05 * extent / u_max if u_max > 0 else 1.0)
    vm_max = _vm_max(frame)
    if clim is None:
        clim = (0.0, nice_range(vm_max / 1e6)[0])
    # The colour bar in a renderer of its own, under the model: it cannot cover it.
    plotter = pv.Plotter(
        off_screen=True, window_size=[1600, 1000], shape=(2, 1), row_weights=[6, 1], border=False
    )
    plotter.subplot(0, 0)
    actor = None
    for geom, topo, u, vm in frame.parts:
        grid = pv.UnstructuredGrid({pv.CellType.TETRA: topo}, geom + factor * u)
        if vm is not None:
            grid.cell_data[BAR_TITLE] = vm / 1e6
            actor = plotter.add_mesh(
                grid, scalars=BAR_TITLE, cmap="viridis", clim=clim, show_scalar_bar=False
            )
        else:
            plotter.add_mesh(grid, color="lightgrey")
    location = run.summary.get("peak_bridge_von_mises_location_m")
    if location is not None and len(location) == 3:
        x = np.asarray(location, dtype=np.float64)
        # On the deformed mesh: moved as the nearest node.
        near = [(np.linalg.norm(g - x, axis=1), g, u) for g, _, u, _ in frame.parts]
        dist, g, u = min(near, key=lambda d: float(d[0].min()))
        i = int(np.argmin(dist))
        peak = float(run.summary.get("peak_bridge_von_mises_Pa", vm_max)) / 1e6
        plotter.add_point_labels(
            (g[i] + factor * u[i])[None, :],
            [f"peak {peak:.1f} MPa"],
            point_color="red",
            point_size=16,
            render_points_as_spheres=True,
            font_size=18,
            text_color="black",
            shape_opacity=0.7,
            always_visible=True,
        )
    plotter.add_text(_title(run, frame, factor), position="upper_left", font_size=15)
    plotter.camera_position = "iso"
    plotter.reset_camera()  # type: ignore[call-arg]
    plotter.camera.zoom(1.3)
    if actor is not None:
        plotter.subplot(1, 0)
        bar = plotter.add_scalar_bar(  # type: ignore[call-arg]
            title=BAR_TITLE,
            mapper=actor.mapper,
            vertical=False,
            position_x=0.3,
            position_y=0.25,
            width=0.6,
            height=0.6,
            title_font_size=22,
            label_font_size=28,
            n_labels=nice_range(clim[1])[1] + 1,  # clim[1] is already round: labels on steps
            fmt="%g",
            color="black",
        )
        # The title left of the bar (VTK sets it against the tick labels otherwise).
        bar.SetTitle("")
        plotter.add_text(BAR_TITLE, position="left_edge", font_size=14)
    plotter.screenshot(str(path))
    plotter.close()
    return path
