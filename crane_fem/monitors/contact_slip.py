"""The slip of a structure's sliding contacts (a gmsh model's node-to-surface, a frame's
point-on-line) as a macro-step monitor: each contact's mean slip vector in the history, its
largest point slip (and when) and its slip at the end in the summary's ``contact_groups``;
where a contact's rail direction is known (a line's tangent, a surface contact's ``along``),
its mean slip along and across it too, which a crane's wheels (groups ``wheel_<k>``) also
give in the summary's ``wheels``, as the 3D crane's wheel/rail pairs do."""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from crane_fem.contact.on_line import LineContacts
from crane_fem.contact.sliding import SlidingContacts, tangents_of
from crane_fem.coupling import MacroRecord
from crane_fem.pipeline import Simulation
from crane_fem.scenario import FrameModel, GmshModel

__all__ = ["ContactSlipMonitor", "create_contact_slip"]

FloatArray = npt.NDArray[np.float64]


class ContactSlipMonitor:
    """The contacts' ``slip`` at every sampling instant, per contact group that has points
    (collective)."""

    def __init__(
        self, sliding: SlidingContacts | LineContacts, axes: dict[str, FloatArray] | None = None
    ) -> None:
        self.sliding = sliding
        groups = np.concatenate([f.group for f in sliding.families]).astype(np.int64)
        used, self.group = np.unique(groups, return_inverse=True)
        self.names = [sliding.names[int(g)] for g in used]
        n = len(self.names)
        #: Per contact: its points' mean slip vector now (m), the largest point slip (m) and
        #: the time it was reached (s).
        self.mean = np.zeros((n, 3))
        self.peak = np.zeros(n)
        self.t_peak = np.zeros(n)
        #: The contacts whose rail direction is known (indices), their unit directions
        #: (k, 2, 3): along, across; their largest |mean slip| along and across (k, 2) and
        #: when.
        axes = axes or {}
        self.railed = np.array([i for i, a in enumerate(self.names) if a in axes], dtype=np.int64)
        self.axes = np.array([axes[self.names[i]] for i in self.railed]).reshape(-1, 2, 3)
        self.peak_rail = np.zeros((self.railed.size, 2))
        self.t_peak_rail = np.zeros((self.railed.size, 2))
        self._count = np.maximum(np.bincount(self.group, minlength=n).astype(np.float64), 1.0)
        self._columns = [f"{name}_slip_{c}" for name in self.names for c in "xyz"]

    @property
    def columns(self) -> list[str]:
        return self._columns

    def history_row(self) -> dict[str, float]:
        return dict(zip(self.columns, self.mean.ravel().tolist(), strict=True))

    def update(self, rec: MacroRecord, last: bool) -> None:
        assert rec.explicit_u is not None
        slip = self.sliding.slip(rec.explicit_u)
        n = len(self.names)
        for c in range(3):
            self.mean[:, c] = np.bincount(self.group, weights=slip[:, c], minlength=n) / self._count
        size = np.linalg.norm(slip, axis=1)
        peak = np.zeros(n)
        np.maximum.at(peak, self.group, size)
        better = peak > self.peak
        self.peak[better], self.t_peak[better] = peak[better], rec.t
        rail = np.abs(self._rail_components())
        better = rail > self.peak_rail
        self.peak_rail[better], self.t_peak_rail[better] = rail[better], rec.t

    def _rail_components(self) -> FloatArray:
        """The railed contacts' mean slip now along and across their rails (k, 2), m."""
        return np.einsum("kdj,kj->kd", self.axes, self.mean[self.railed])

    def summarize(self, summary: dict[str, Any]) -> None:
        """Each contact's ``max_slip_m`` (its largest point slip at a sampling instant),
        ``max_slip_time_s`` (that instant) and ``final_slip_m`` (its points' mean slip vector
        at the end) into its row of ``contact_groups``."""
        table = summary.setdefault("contact_groups", {})
        for k, name in enumerate(self.names):
            row = table.setdefault(name, {})
            row["max_slip_m"] = float(self.peak[k])
            row["max_slip_time_s"] = float(self.t_peak[k])
            row["final_slip_m"] = self.mean[k].tolist()
        wheels = summary.get("wheels", {})
        drift = []
        for j, (k, final) in enumerate(zip(self.railed, self._rail_components(), strict=True)):
            peak, when = self.peak_rail[j], self.t_peak_rail[j]
            rail = {
                "max_slip_along_m": float(peak[0]),
                "max_slip_along_time_s": float(when[0]),
                "max_slip_across_m": float(peak[1]),
                "max_slip_across_time_s": float(when[1]),
                "final_slip_along_m": float(final[0]),
                "final_slip_across_m": float(final[1]),
            }
            table[self.names[k]].update(rail)
            wheel = self.names[k].removeprefix("wheel_")
            if wheel in wheels:  # a crane's wheel: its slip on its rail, as the 3D crane's
                wheels[wheel].update(rail)
                drift.append([final[1], final[0]])
        if drift:  # the trolley's net drift (across, along), the mean of its wheels'
            summary["trolley_drift_m"] = np.mean(drift, axis=0).tolist()

    def state_dict(self) -> dict[str, Any]:
        return {
            "mean": self.mean.copy(),
            "peak": self.peak.copy(),
            "t_peak": self.t_peak.copy(),
            "peak_rail": self.peak_rail.copy(),
            "t_peak_rail": self.t_peak_rail.copy(),
        }

    def load_state_dict(self, state: dict[str, Any]) -> None:
        """The state of :meth:`state_dict` (a checkpoint from before the rails' components:
        their peaks start again from the current mean slip, at the restart)."""
        self.mean = np.asarray(state["mean"], dtype=np.float64).reshape(-1, 3)
        self.peak = np.asarray(state["peak"], dtype=np.float64)
        self.t_peak = np.asarray(state.get("t_peak", np.zeros_like(self.peak)), dtype=np.float64)
        shape = self.peak_rail.shape
        self.peak_rail = np.asarray(state.get("peak_rail", np.zeros(shape))).reshape(shape)
        self.t_peak_rail = np.asarray(state.get("t_peak_rail", np.zeros(shape))).reshape(shape)

    def destroy(self) -> None:
        pass


def create_contact_slip(sim: Simulation) -> ContactSlipMonitor | None:
    """The slip of a gmsh model's or a frame's sliding contacts (None for other models or
    none)."""
    sliding = sim.constraints.sliding
    if not isinstance(sim.scenario.model, GmshModel | FrameModel) or sliding is None:
        return None
    if not sliding.families:  # (a frame's ropes alone: nothing slides)
        return None
    return ContactSlipMonitor(sliding, _rail_axes(sim, sliding))


def _rail_axes(sim: Simulation, sliding: SlidingContacts | LineContacts) -> dict[str, FloatArray]:
    """Per contact name whose rail direction is known, its unit directions (2, 3) along the
    rail and across it (along × n): a frame's lines' tangents; a surface contact's ``along``
    (or ``rolling``) in the plane of its points' mean normal at t = 0, as the friction rows
    of a rolling contact take them (``tangents_of``)."""
    if isinstance(sliding, LineContacts):
        return {sliding.names[g]: axes for g, axes in sliding.slip_axes().items()}
    out = {}
    for c in sim.mesh.surface_contacts:
        if c.along is None:
            continue
        n = c.pairing.normal.mean(axis=0)
        across, along = tangents_of(n / np.linalg.norm(n), c.along)
        out[c.name] = np.concatenate([along, across])
    return out
