"""The measured points as a macro-step monitor: the input ground acceleration and the points'
absolute accelerations sampled every sampling interval for the history, and their response
spectra written at the end."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from crane_fem.coupling import MacroRecord
from crane_fem.monitors.vertices import owned_vertices
from crane_fem.pipeline import Simulation
from crane_fem.points import GroundAcceleration, PointMotions, check_points, default_points

__all__ = ["MeasuredPoints", "create_measured_points"]


class MeasuredPoints:
    """:class:`PointMotions` sampled at every sampling instant (collective; a few rows of the
    implicit side); the last sample is the points' part of the next history row, and the
    spectra of all samples go to ``spectra.csv`` in ``out`` (rank 0 writes)."""

    def __init__(self, sim: Simulation, motions: PointMotions, out: Path) -> None:
        self.sim, self.motions, self.out = sim, motions, out
        self.row: dict[str, float] = {}

    @property
    def columns(self) -> list[str]:
        """The history columns: the ground's acceleration, then the points'."""
        return self.motions.columns

    def history_row(self, t: float) -> dict[str, float]:
        """The values of :attr:`columns` at the output time ``t`` (not collective)."""
        return self.motions.ground_row(t) | self.row

    def update(self, rec: MacroRecord, last: bool) -> None:
        if not self.motions.points:  # the ground's columns alone: nothing to sample
            return
        at = rec.implicit_at(self.motions.implicit_dofs)
        self.row = self.motions.sample(rec.t, rec.explicit_u, at[0] if at is not None else None)

    def summarize(self, summary: dict[str, Any]) -> None:
        """The spectra's settings (collective)."""
        summary.update(self.spectra())

    def spectra(self) -> dict[str, Any]:
        """Pseudo-acceleration spectra of the input and of the points' absolute motion in
        each direction the ground shakes, to ``spectra.csv`` (rank 0 writes); their settings
        (not collective; the samples are global)."""
        motions = self.motions
        t, series = motions.series()
        spec = self.sim.scenario.spectra
        axes = [c for c in "xyz" if f"ground_a{c}" in series and np.any(series[f"ground_a{c}"])]
        if t.size < 3 or not axes:
            return {}
        dt = float(t[1] - t[0])
        # A last macro step shortened to reach time.end breaks the uniform sampling: left out.
        odd = np.flatnonzero(np.abs(np.diff(t) - dt) > 1e-7 * dt)
        if odd.size:
            t, series = t[: odd[0] + 1], {k: v[: odd[0] + 1] for k, v in series.items()}
        if t.size < 3:
            return {}
        # Imported here: scipy.signal takes seconds, and a run without spectra needs none.
        from crane_fem.spectra import log_periods, response_spectrum, write_spectra_csv

        # The mean accelerations between samples resolve periods down to a few samples.
        periods = log_periods(max(spec.periods[0], 4 * dt), spec.periods[1], spec.count)
        curves = {}
        for c in axes:
            curves[f"input_{c}"] = response_spectrum(
                t, series[f"ground_a{c}"], periods, spec.damping
            )
            for p in motions.points:
                a = series[f"{p.name}_a{c}"]
                curves[f"{p.name}_{c}"] = response_spectrum(t, a, periods, spec.damping)
        if self.sim.mesh.comm.rank == 0:
            write_spectra_csv(self.out / "spectra.csv", curves)
        return {
            "spectra_damping": spec.damping,
            "spectra_sampling_s": dt,
            "spectra_points": {
                p.name: {"side": p.side, "distance_m": p.distance} for p in motions.points
            },
        }

    def state_dict(self) -> dict[str, Any]:
        return self.motions.state_dict()

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.motions.load_state_dict(state)

    def destroy(self) -> None:
        pass


def create_measured_points(sim: Simulation, out: Path) -> MeasuredPoints | None:
    """The absolute motions measured for response spectra (collective): the points' and the
    ground's; the ground's alone (its history columns, no spectra) where the scene names no
    point; None without points and without ground motion."""
    sc = sim.scenario
    points = default_points(sc)
    if not points and not sc.loading.ground_motions:
        return None
    ids, xyz = owned_vertices(sim)
    check_points(points, xyz, sim.mesh.comm)
    md = sim.models
    # A mixed model's points are its solids' (its beams are another mesh, numbered apart).
    implicit = md.implicit if sim.mesh.beams is None else None
    motions = PointMotions(
        points, md.explicit, implicit, xyz, ids, GroundAcceleration(sc), sim.mesh.comm
    )
    return MeasuredPoints(sim, motions, out)
