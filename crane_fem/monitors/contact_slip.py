"""The slip of a structure's sliding contacts (a gmsh model's node-to-surface, a frame's
point-on-line) as a macro-step monitor: each contact's mean slip vector in the history, its
largest point slip (and when) and its slip at the end in the summary's ``contact_groups``."""

from __future__ import annotations

from typing import Any

import numpy as np

from crane_fem.contact.on_line import LineContacts
from crane_fem.contact.sliding import SlidingContacts
from crane_fem.coupling import MacroRecord
from crane_fem.pipeline import Simulation
from crane_fem.scenario import FrameModel, GmshModel

__all__ = ["ContactSlipMonitor", "create_contact_slip"]


class ContactSlipMonitor:
    """The contacts' ``slip`` at every sampling instant, per contact group that has points
    (collective)."""

    def __init__(self, sliding: SlidingContacts | LineContacts) -> None:
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

    def state_dict(self) -> dict[str, Any]:
        return {"mean": self.mean.copy(), "peak": self.peak.copy(), "t_peak": self.t_peak.copy()}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.mean = np.asarray(state["mean"], dtype=np.float64).reshape(-1, 3)
        self.peak = np.asarray(state["peak"], dtype=np.float64)
        self.t_peak = np.asarray(state.get("t_peak", np.zeros_like(self.peak)), dtype=np.float64)

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
    return ContactSlipMonitor(sliding)
