"""Peaks of each contact group from every micro step: the largest contact force and its time,
the largest gap (a wheel's uplift), the lift-offs and the impacts, whatever the output rate.

A lift-off of a group (a wheel) is a separation, all its points open by more than
``LIFT_GAP``, whose flight rises higher than ``LIFT_HEIGHT``; the short, low separations that
follow an impact (chatter of the node-to-node contact, tens of micrometres) are not lift-offs.

An impact of a group is the burst of contact forces a landing sets off: it begins at the first
micro step, after a landing (the end of a lift-off) or, for a group that starts open, after its
first closing, whose force exceeds ``IMPACT_LOAD`` times the group's static force (the
preload's wheel force, or zero); it ends where the force then stays at or below that level for
``IMPACT_QUIET`` seconds (the rattling of the node-to-node pairs within a landing belongs to
it). Its impulse is the group's impulse summed from its onset to its end (N·s), its peak the
largest force. A bar on a wall (no static force) has one impact per contact interval.
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np
import numpy.typing as npt

__all__ = ["IMPACT_LOAD", "IMPACT_QUIET", "LIFT_GAP", "LIFT_HEIGHT", "ContactPeaks"]

FloatArray = npt.NDArray[np.float64]

LIFT_GAP = 1e-6  # m: a wheel is off its rail when all its pairs are open by more than this
LIFT_HEIGHT = 1e-4  # m: a lift-off is a flight higher than this; lower ones are chatter
#: An impact's forces exceed this many times the static force; the weight carried, shaken by
#: the ground's acceleration (1.4 g at most in the crane's records), stays mostly below it.
IMPACT_LOAD = 2.0
#: s: an impact ends when its forces stay at or below IMPACT_LOAD × static this long (the
#: crane's landing peaks 0.12 ms after its first strike; the elastic waves through a trolley
#: take 0.3 ms).
IMPACT_QUIET = 1e-3
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
    "_gap_last",
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
        # onset, impulse, peak impulse, quiet steps, impulse and time at the quiet's start
        self._strike = np.zeros((n, 6))
        self._quiet = max(1, round(IMPACT_QUIET / self.dt))
        self.peak_force = np.zeros(n)
        self.peak_time = np.zeros(n)
        self.max_gap = np.full(n, -np.inf)
        self.lift_offs: list[list[list[float]]] = [[] for _ in range(n)]
        #: Each lift-off's apex (its largest gap, m), in the order of ``lift_offs``.
        self.apexes: list[list[float]] = [[] for _ in range(n)]
        # The separation under way at the end of the last trace: onset time and height.
        self._flying = np.zeros(n, dtype=bool)
        self._onset = np.zeros(n)
        self._height = np.zeros(n)
        # The smallest gap of the last micro step: a largest gap there is a flight still
        # rising at the run's end.
        self._gap_last = np.full(n, -np.inf)
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
        self._gap_last[:] = gap[-1]
        off = gap > LIFT_GAP
        # Where each group opens or closes in this trace (after its state at the last one):
        # a group in flight throughout (a flange, clear of its rail side) only rises.
        turns = (off != np.concatenate([self._flying[None, :], off[:-1]])).any(axis=0)
        aloft = np.flatnonzero(self._flying & ~turns)
        if aloft.size:
            high = gap[:, aloft].max(axis=0, initial=0.0)
            self._height[aloft] = np.where(high > self._height[aloft], high, self._height[aloft])
        landings: dict[int, list[int]] = {}
        for g in np.flatnonzero(turns).tolist():
            landings[g] = self._separations(g, t, off[:, g], gap[:, g])
        following = set(np.flatnonzero(self._awaiting | self._striking).tolist())
        for k in sorted(following | {g for g, v in landings.items() if v}):
            # The trace cut at the landings: each landing awaits a new impact.
            cuts = [0, *landings.get(k, []), t.size]
            for i in range(len(cuts) - 1):
                if i > 0:
                    if self._striking[k]:  # the last impact ended by the flight's quiet
                        st = self._strike[k]
                        end = st[5] if st[3] > 0 else float(t[cuts[i]])
                        self._close(k, float(st[0]), float(st[4]), float(st[2]), end)
                    self._awaiting[k] = True
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
        """Follow group k's awaited or current impact over trace steps [a, b) (NumPy over the
        quiet runs between its loud steps)."""
        level = IMPACT_LOAD * self.static[k] * self.dt
        if self._awaiting[k]:
            hit = np.flatnonzero(impulse[a:b] > level)
            if hit.size == 0:
                return
            a += int(hit[0])
            self._awaiting[k], self._striking[k] = False, True
            self._strike[k] = (t[a], 0.0, 0.0, 0.0, 0.0, t[a])
        if not self._striking[k] or a >= b:
            return
        st = self._strike[k]
        seg = impulse[a:b]
        loud = np.flatnonzero(seg > level)
        # The quiet runs: before the first loud step (continuing the carried one), between
        # loud steps, after the last; each (start, length) in the segment.
        starts = np.r_[0, loud + 1]
        lengths = np.r_[loud, seg.size] - starts
        lengths[0] += int(st[3])
        long = np.flatnonzero(lengths >= self._quiet)
        if long.size:
            r = int(long[0])
            if r == 0 and st[3] > 0:  # the quiet began in an earlier trace
                j, t_end = st[4], st[5]
            else:
                e = int(starts[r])
                j = st[1] + float(seg[:e].sum())
                st[2] = max(st[2], float(seg[:e].max(initial=0.0)))
                t_end = float(t[a + e])
            self._close(k, float(st[0]), float(j), float(st[2]), t_end)
            return
        if loud.size:
            last = int(starts[-1])
            st[4] = st[1] + float(seg[:last].sum())
            st[5] = float(t[a + last]) if last < seg.size else 0.0
            st[3] = float(lengths[-1])
        else:
            if st[3] == 0:  # the quiet begins with this segment
                st[4], st[5] = st[1], float(t[a])
            st[3] += seg.size
        st[1] += float(seg.sum())
        st[2] = max(st[2], float(seg.max(initial=0.0)))

    def _close(self, k: int, onset: float, impulse: float, peak: float, t_end: float) -> None:
        self.impacts[k].append(
            {
                "t_s": onset,
                "impulse_Ns": impulse,
                "duration_s": t_end - onset,
                "peak_force_N": peak / self.dt,
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
        """Close and open group k's separations over one trace (a loop over its edges);
        the trace steps where a lift-off landed."""
        edges = np.flatnonzero(np.diff(np.r_[np.int8(self._flying[k]), off.astype(np.int8)]))
        # The largest gap (at least 0) of each stretch of the trace between its edges, at
        # once: stretch i ends at edge i (the last runs to the trace's end); a separation
        # rises over the stretch that ends where it closes.
        starts = np.r_[0, edges]
        tops = np.maximum(0.0, np.maximum.reduceat(gap, starts)).tolist()
        if edges.size and edges[0] == 0:
            tops[0] = 0.0  # (an empty stretch)
        opens = off[edges].tolist()
        landed: list[int] = []
        for i, e in enumerate(edges.tolist()):
            if opens[i]:  # a separation starts at step e
                self._flying[k], self._onset[k], self._height[k] = True, t[e], 0.0
            else:  # it ended at step e − 1
                self._height[k] = max(self._height[k], tops[i])
                if self._land(k, float(t[e - 1]) if e > 0 else self._t_last):
                    landed.append(e)
        if self._flying[k]:
            self._height[k] = max(self._height[k], tops[-1])
        return landed

    def _land(self, k: int, t_end: float) -> bool:
        """End group k's separation at ``t_end``; whether it was a lift-off."""
        lift = bool(self._height[k] > LIFT_HEIGHT)
        if lift:
            self.lift_offs[k].append([float(self._onset[k]), t_end])
            self.apexes[k].append(float(self._height[k]))
        self._flying[k] = False
        return lift

    def state_dict(self) -> dict[str, Any]:
        """The running peaks, separations and impacts (a checkpoint); the lift-offs and
        impacts found as JSON text (floats round-trip exactly)."""
        out: dict[str, Any] = {k: getattr(self, k).copy() for k in _ARRAYS}
        out["t_last"] = self._t_last
        out["lift_offs"] = json.dumps(self.lift_offs)
        out["impacts"] = json.dumps(self.impacts)
        out["apexes"] = json.dumps(self.apexes)
        return out

    def load_state_dict(self, state: dict[str, Any]) -> None:
        for k in _ARRAYS:
            if k == "_gap_last" and k not in state:  # (a checkpoint before it was kept)
                self._gap_last[:] = -np.inf
                continue
            src = np.asarray(state[k])
            if src.shape != getattr(self, k).shape:
                raise ValueError(f"contact peaks state {k!r}: shape {src.shape} does not match")
            setattr(self, k, src.astype(getattr(self, k).dtype))
        self._t_last = float(state["t_last"])
        self.lift_offs = json.loads(state["lift_offs"])
        self.impacts = json.loads(state["impacts"])
        # (A checkpoint before the apexes were kept: none for its earlier flights.)
        apexes = state.get("apexes")
        if apexes is None:
            self.apexes = [[float("nan")] * len(f) for f in self.lift_offs]
        else:
            self.apexes = json.loads(apexes)

    def table(self) -> dict[str, dict[str, Any]]:
        """Per group: ``lift_offs`` (count, intervals [onset, end], ``apex_m`` each one's
        largest gap; a flight still under way ends at the last time, its apex so far),
        ``max_uplift_m``, ``max_uplift_at_end`` (the largest gap is
        the last micro step's, a lift-off still rising: the window cuts the flight and the
        value is a lower bound of its apex), ``peak_force_N``, ``peak_force_time_s``,
        ``impacts`` (each: onset ``t_s``, ``impulse_Ns``, ``duration_s``, ``peak_force_N``;
        one still under way ends at the last time)."""
        out: dict[str, dict[str, Any]] = {}
        for k, name in enumerate(self.names):
            intervals = list(self.lift_offs[k])
            apexes = list(self.apexes[k])
            if self._flying[k] and self._height[k] > LIFT_HEIGHT:
                intervals.append([float(self._onset[k]), self._t_last])
                apexes.append(float(self._height[k]))
            out[name] = {
                "lift_offs": {"count": len(intervals), "intervals": intervals, "apex_m": apexes},
                "max_uplift_m": float(max(self.max_gap[k], 0.0)),
                "max_uplift_at_end": bool(
                    self.max_gap[k] > LIFT_HEIGHT and self._gap_last[k] >= self.max_gap[k]
                ),
                "peak_force_N": float(self.peak_force[k]),
                "peak_force_time_s": float(self.peak_time[k]),
                "impacts": list(self.impacts[k]) + self._open_impact(k),
            }
        return out

    def _open_impact(self, k: int) -> list[dict[str, float]]:
        if not self._striking[k]:
            return []
        onset, j, peak = self._strike[k, :3]
        return [
            {
                "t_s": float(onset),
                "impulse_Ns": float(j),
                "duration_s": self._t_last - float(onset),
                "peak_force_N": float(peak / self.dt),
            }
        ]
