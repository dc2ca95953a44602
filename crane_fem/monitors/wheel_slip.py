"""The crane wheels' slip on their rails as a macro-step monitor: built from the crane's
wheel/rail pairs, followed at the sampling instants: its history columns, its peaks, the
slip at the end (the trolley's net drift) and the intervals where a wheel slides, merged into
the summary's wheels."""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np

from crane_fem.coupling import MacroRecord
from crane_fem.monitors.vertices import owned_vertices
from crane_fem.pipeline import Simulation
from crane_fem.slip import WheelSlip, pair_reach

__all__ = ["SLIDING_SPEED", "WheelSlipMonitor", "create_wheel_slip"]

#: m/s: a wheel slides while its mean slip changes faster than this between two sampling
#: instants (a braked wheel's creep on a rocking contact stays well below it).
SLIDING_SPEED = 1e-3


class WheelSlipMonitor:
    """:class:`WheelSlip` on the explicit side's field at every sampling instant (collective; a
    wheel beyond its pairs' reach stops the run with :class:`crane_fem.slip.SlipError`)."""

    def __init__(self, slip: WheelSlip) -> None:
        self.slip = slip
        n = slip.n_wheels
        #: The last sample's mean slip (across, along) of each wheel (m) and its time.
        self.last = np.zeros((n, 2))
        self.t_last = 0.0
        #: Per wheel: whether it slides now, since when, and its finished sliding intervals.
        self.sliding = np.zeros(n, dtype=bool)
        self.since = np.zeros(n)
        self.intervals: list[list[list[float]]] = [[] for _ in range(n)]

    @property
    def columns(self) -> list[str]:
        """The history columns: each wheel's mean slip across (x) and along (y) its rail."""
        n = self.slip.n_wheels
        return [f"wheel{k + 1}_slip_{d}" for k in range(n) for d in ("across", "along")]

    def history_row(self) -> dict[str, float]:
        return dict(zip(self.columns, self.last.ravel().tolist(), strict=True))

    def update(self, rec: MacroRecord, last: bool) -> None:
        assert rec.explicit_u is not None
        slip = self.slip.update(rec.t, rec.explicit_u)
        dt = rec.t - self.t_last
        if dt > 0.0:
            speed = np.linalg.norm(slip - self.last, axis=1) / dt
            now = speed > SLIDING_SPEED
            for k in np.flatnonzero(now & ~self.sliding):
                self.since[k] = self.t_last
            for k in np.flatnonzero(~now & self.sliding):
                self.intervals[k].append([float(self.since[k]), float(self.t_last)])
            self.sliding = now
        self.last, self.t_last = slip, rec.t

    def summarize(self, summary: dict[str, Any]) -> None:
        """Each wheel's slip into its row of the summary's ``wheels`` (if the contact peaks
        made one): its peaks, its slip at the end and its sliding intervals (an interval
        under way at the end closes there); and the trolley's net drift at the end, the mean
        of its wheels' (``trolley_drift_m``: across, along)."""
        if "wheels" not in summary:
            return
        for k, slip in self.slip.table().items():
            i = int(k) - 1
            spans = [*self.intervals[i]]
            if self.sliding[i]:
                spans.append([float(self.since[i]), float(self.t_last)])
            slip["final_slip_across_m"] = float(self.last[i, 0])
            slip["final_slip_along_m"] = float(self.last[i, 1])
            slip["sliding_intervals"] = spans[:100]
            slip["sliding_time_s"] = float(sum(b - a for a, b in spans))
            summary["wheels"][k].update(slip)
        summary["trolley_drift_m"] = self.last.mean(axis=0).tolist()

    def state_dict(self) -> dict[str, Any]:
        state = self.slip.state_dict()
        starts = [np.asarray(v, dtype=np.float64).reshape(-1, 2) for v in self.intervals]
        state.update(
            last=self.last.copy(),
            t_last=self.t_last,
            sliding=self.sliding.copy(),
            since=self.since.copy(),
            counts=np.array([s.shape[0] for s in starts], dtype=np.int64),
            intervals=np.concatenate([np.zeros((0, 2)), *starts]),
        )
        return state

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.slip.load_state_dict(state)
        self.last = np.array(state["last"], dtype=np.float64)
        self.t_last = float(state["t_last"])
        self.sliding = np.array(state["sliding"], dtype=bool)
        self.since = np.array(state["since"], dtype=np.float64)
        flat = np.asarray(state["intervals"], dtype=np.float64).reshape(-1, 2)
        edges = np.r_[0, np.cumsum(np.asarray(state["counts"], dtype=np.int64))]
        self.intervals = [flat[a:b].tolist() for a, b in itertools.pairwise(edges)]

    def destroy(self) -> None:
        pass


def create_wheel_slip(sim: Simulation) -> WheelSlipMonitor | None:
    """The crane wheels' slip on their rails, with the reach of each wheel's pairs from its
    rail patch's vertices (collective; None without a crane)."""
    crane, sub = sim.mesh.crane, sim.models.explicit
    if crane is None or sub is None:
        return None
    ids, xyz = owned_vertices(sim)
    rail = crane.pairs[:, 1]
    mine = np.flatnonzero(np.isin(ids, rail))
    got = sim.mesh.comm.allgather((ids[mine], xyz[mine]))
    gid = np.concatenate([g for g, _ in got])
    pos = np.concatenate([x for _, x in got])
    where = {int(g): pos[i, :2] for i, g in enumerate(gid)}
    reach = np.array(
        [
            pair_reach(np.array([where[int(r)] for r in rail[crane.wheel == k]]))
            for k in range(1, int(crane.wheel.max()) + 1)
        ]
    )
    if sim.constraints.sliding is not None:
        # Node-to-surface contacts follow the wheel to the end of its rail zone (they stop
        # the run there themselves, crane_fem.contact.sliding): the reach is the surface's.
        room = sim.constraints.sliding.reach()
        reach = np.array([room[k] for k in range(1, reach.size + 1)])
        return WheelSlipMonitor(WheelSlip(sub, crane.pairs, crane.wheel, reach, enforce=False))
    return WheelSlipMonitor(WheelSlip(sub, crane.pairs, crane.wheel, reach))
