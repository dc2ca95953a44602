"""Peaks of each contact group from every micro step: the largest contact force and its time,
the largest gap (a wheel's uplift), the lift-offs and the impacts, whatever the output rate.

A lift-off of a group (a wheel) is a separation, all its points open by more than
``LIFT_GAP``, whose flight rises higher than ``LIFT_HEIGHT``; the short, low separations that
follow an impact (chatter of the node-to-node contact, tens of micrometres) are not lift-offs.

An impact of a group begins at its first micro step with a force above its static force (the
preload's wheel force, or zero) after a landing (the end of a lift-off) or, for a group that
starts open, after its first closing; it ends at the first micro step where the group opens
again or its force falls back to the static force. Its impulse is the group's impulse summed
over those steps (N·s), its peak the largest force.
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np
import numpy.typing as npt

__all__ = ["LIFT_GAP", "LIFT_HEIGHT", "ContactPeaks"]

FloatArray = npt.NDArray[np.float64]

LIFT_GAP = 1e-6  # m: a wheel is off its rail when all its pairs are open by more than this
LIFT_HEIGHT = 1e-4  # m: a lift-off is a flight higher than this; lower ones are chatter
#: The array attributes of :class:`ContactPeaks` that change as it runs.
_ARRAYS = (
    "peak_force",
    "peak_time",
    "max_gap",
    "_awaiting",
    "_striking",
    "_strike",
    "_flying",
    "_onset",
    "_height",
)


class ContactPeaks:
    """Running peaks of the contact groups ``names`` over the micro steps of a run (not
    collective: the traces hold global values, the same on every rank).

    Args:
        names: the contact groups (the columns of the traces).
        dt: the micro step (s): a micro step's force is its impulse / Δt.
    """

    def __init__(self, names: list[str], dt: float, static: FloatArray | None = None) -> None:
        n = len(names)
        self.names, self.dt = list(names), float(dt)
        self.static = np.zeros(n) if static is None else np.asarray(static, dtype=np.float64)
        self.impacts: list[list[dict[str, float]]] = [[] for _ in range(n)]
        # An impact awaited (after a landing) or under way: its onset, impulse and peak.
        self._awaiting = np.zeros(n, dtype=bool)
        self._striking = np.zeros(n, dtype=bool)
        self._strike = np.zeros((n, 3))
        self.peak_force = np.zeros(n)
        self.peak_time = np.zeros(n)
        self.max_gap = np.full(n, -np.inf)
        self.lift_offs: list[list[list[float]]] = [[] for _ in range(n)]
        # The separation under way at the end of the last trace: onset time and height.
        self._flying = np.zeros(n, dtype=bool)
        self._onset = np.zeros(n)
        self._height = np.zeros(n)
        self._t_last = 0.0

    def start(self, t: float, force: FloatArray, gap: FloatArray) -> None:
        """The state at the start time: group forces (N) and smallest gaps (m); a group that
        starts open awaits its first impact."""
        self._awaiting[:] = gap > LIFT_GAP
        self.update(np.array([t]), force[None, :] * self.dt, gap[None, :])

    def update(self, t: FloatArray, impulse: FloatArray, gap: FloatArray) -> None:
        """Take micro steps at times ``t`` (n,), in time order after the ones already taken,
        with each group's impulse (N·s) and smallest gap (m), (n, groups)."""
        if t.size == 0 or not self.names:
            return
        force = impulse / self.dt
        j = np.argmax(force, axis=0)
        cols = np.arange(len(self.names))
        better = force[j, cols] > self.peak_force
        self.peak_force[better] = force[j, cols][better]
        self.peak_time[better] = t[j][better]
        np.maximum(self.max_gap, gap.max(axis=0), out=self.max_gap)
        off = gap > LIFT_GAP
        landings: dict[int, list[int]] = {}
        for g in np.flatnonzero(off.any(axis=0) | self._flying).tolist():
            landings[g] = self._separations(g, t, off[:, g], gap[:, g])
        following = set(np.flatnonzero(self._awaiting | self._striking).tolist())
        for k in sorted(following | {g for g, v in landings.items() if v}):
            # The trace cut at the landings: each landing awaits a new impact.
            cuts = [0, *landings.get(k, []), t.size]
            for i in range(len(cuts) - 1):
                if i > 0:
                    self._awaiting[k], self._striking[k] = True, False
                self._impact(k, t, off[:, k], impulse[:, k], cuts[i], cuts[i + 1])
        self._t_last = float(t[-1])

    def _impact(
        self,
        k: int,
        t: FloatArray,
        off: npt.NDArray[np.bool_],
        impulse: FloatArray,
        a: int,
        b: int,
    ) -> None:
        """Follow group k's awaited or current impact over trace steps [a, b)."""
        static = self.static[k] * self.dt
        if self._awaiting[k]:
            hit = np.flatnonzero(impulse[a:b] > static)
            if hit.size == 0:
                return
            a += int(hit[0])
            self._awaiting[k], self._striking[k] = False, True
            self._strike[k] = (t[a], 0.0, 0.0)
        if not self._striking[k]:
            return
        stop = np.flatnonzero(off[a:b] | (impulse[a:b] <= static))
        e = a + int(stop[0]) if stop.size else b
        self._strike[k, 1] += float(impulse[a:e].sum())
        self._strike[k, 2] = max(self._strike[k, 2], float(impulse[a:e].max(initial=0.0)))
        if stop.size:
            onset, j, peak = self._strike[k]
            self.impacts[k].append(
                {
                    "t_s": float(onset),
                    "impulse_Ns": float(j),
                    "duration_s": float(t[e] - onset),
                    "peak_force_N": float(peak / self.dt),
                }
            )
            self._striking[k] = False

    def _separations(
        self,
        k: int,
        t: FloatArray,
        off: npt.NDArray[np.bool_],
        gap: FloatArray,
    ) -> list[int]:
        """Close and open group k's separations over one trace (a loop over its few edges);
        the trace steps where a lift-off landed."""
        edges = np.flatnonzero(np.diff(np.r_[np.int8(self._flying[k]), off.astype(np.int8)]))
        a = 0
        landed: list[int] = []
        for e in edges.tolist():
            if off[e]:  # a separation starts at step e
                self._flying[k], self._onset[k], self._height[k] = True, t[e], 0.0
                a = e
            else:  # it ended at step e − 1
                self._height[k] = max(self._height[k], float(gap[a:e].max(initial=0.0)))
                if self._land(k, float(t[e - 1]) if e > 0 else self._t_last):
                    landed.append(e)
        if self._flying[k]:
            self._height[k] = max(self._height[k], float(gap[a:].max(initial=0.0)))
        return landed

    def _land(self, k: int, t_end: float) -> bool:
        """End group k's separation at ``t_end``; whether it was a lift-off."""
        lift = bool(self._height[k] > LIFT_HEIGHT)
        if lift:
            self.lift_offs[k].append([float(self._onset[k]), t_end])
        self._flying[k] = False
        return lift

    def state_dict(self) -> dict[str, Any]:
        """The running peaks, separations and impacts (a checkpoint); the lift-offs and
        impacts found as JSON text (floats round-trip exactly)."""
        out: dict[str, Any] = {k: getattr(self, k).copy() for k in _ARRAYS}
        out["t_last"] = self._t_last
        out["lift_offs"] = json.dumps(self.lift_offs)
        out["impacts"] = json.dumps(self.impacts)
        return out

    def load_state_dict(self, state: dict[str, Any]) -> None:
        for k in _ARRAYS:
            src = np.asarray(state[k])
            if src.shape != getattr(self, k).shape:
                raise ValueError(f"contact peaks state {k!r}: shape {src.shape} does not match")
            setattr(self, k, src.astype(getattr(self, k).dtype))
        self._t_last = float(state["t_last"])
        self.lift_offs = json.loads(state["lift_offs"])
        self.impacts = json.loads(state["impacts"])

    def table(self) -> dict[str, dict[str, Any]]:
        """Per group: ``lift_offs`` (count, intervals [onset, end]; a flight still under way
        ends at the last time), ``max_uplift_m``, ``peak_force_N``, ``peak_force_time_s``,
        ``impacts`` (each: onset ``t_s``, ``impulse_Ns``, ``duration_s``, ``peak_force_N``;
        one still under way ends at the last time)."""
        out: dict[str, dict[str, Any]] = {}
        for k, name in enumerate(self.names):
            intervals = list(self.lift_offs[k])
            if self._flying[k] and self._height[k] > LIFT_HEIGHT:
                intervals.append([float(self._onset[k]), self._t_last])
            out[name] = {
                "lift_offs": {"count": len(intervals), "intervals": intervals},
                "max_uplift_m": float(max(self.max_gap[k], 0.0)),
                "peak_force_N": float(self.peak_force[k]),
                "peak_force_time_s": float(self.peak_time[k]),
                "impacts": list(self.impacts[k]) + self._open_impact(k),
            }
        return out

    def _open_impact(self, k: int) -> list[dict[str, float]]:
        if not self._striking[k]:
            return []
        onset, j, peak = self._strike[k]
        return [
            {
                "t_s": float(onset),
                "impulse_Ns": float(j),
                "duration_s": self._t_last - float(onset),
                "peak_force_N": float(peak / self.dt),
            }
        ]
