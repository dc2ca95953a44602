"""The crane wheels' slip on their rails as a macro-step monitor: built from the crane's
wheel/rail pairs, followed at the sampling instants, its peaks merged into the summary's
wheels."""

from __future__ import annotations

from typing import Any

import numpy as np

from crane_fem.coupling import MacroRecord
from crane_fem.monitors.vertices import owned_vertices
from crane_fem.pipeline import Simulation
from crane_fem.slip import WheelSlip, pair_reach

__all__ = ["WheelSlipMonitor", "create_wheel_slip"]


class WheelSlipMonitor:
    """:class:`WheelSlip` on the explicit side's field at every sampling instant (collective; a
    wheel beyond its pairs' reach stops the run with :class:`crane_fem.slip.SlipError`)."""

    def __init__(self, slip: WheelSlip) -> None:
        self.slip = slip

    def update(self, rec: MacroRecord, last: bool) -> None:
        assert rec.explicit_u is not None
        self.slip.update(rec.t, rec.explicit_u)

    def summarize(self, summary: dict[str, Any]) -> None:
        """Each wheel's slip peaks into its row of the summary's ``wheels`` (if the contact
        peaks made one)."""
        if "wheels" in summary:
            for k, slip in self.slip.table().items():
                summary["wheels"][k].update(slip)

    def state_dict(self) -> dict[str, Any]:
        return self.slip.state_dict()

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.slip.load_state_dict(state)

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
    return WheelSlipMonitor(WheelSlip(sub, crane.pairs, crane.wheel, reach))
