"""The peak von Mises stress over a crane's bridge cells as a macro-step monitor."""

from __future__ import annotations

from typing import Any

import numpy as np

from crane_fem.coupling import MacroRecord
from crane_fem.pipeline import Simulation
from crane_fem.stress import VonMises

__all__ = ["BridgeStress"]


class BridgeStress:
    """The peak von Mises stress over the crane's bridge cells (girders, end carriages, the
    rails outside the explicit zones) every ``output.stress_every`` macro steps and at the
    last: of the implicit side in a coupled run, of the whole mesh in the fully explicit one
    (collective)."""

    def __init__(self, sim: Simulation) -> None:
        md = sim.models
        sub = md.implicit if md.implicit is not None else md.explicit
        assert sub is not None
        self.side = "implicit" if md.implicit is not None else "explicit"
        self.every = sim.scenario.output.stress_every
        tagged = sim.mesh.tagged
        tag = tagged.cell_groups["bridge_implicit"]
        n_parent = tagged.mesh.topology.index_map(tagged.mesh.topology.dim).size_local
        n_parent += tagged.mesh.topology.index_map(tagged.mesh.topology.dim).num_ghosts
        bridge = np.zeros(n_parent, dtype=bool)
        bridge[tagged.cell_tags.indices[tagged.cell_tags.values == tag]] = True
        self.vm = VonMises(sub.V, sim.scenario.material.E, sim.scenario.material.nu)
        own = sub.parent_cells[: self.vm.n_cells]
        self.cells = np.flatnonzero(bridge[own]).astype(np.int32)
        self.comm = sim.mesh.comm
        self.peak, self.t_peak = 0.0, 0.0
        self.location = np.zeros(3)

    def update(self, rec: MacroRecord, last: bool) -> None:
        # The stress needs the side's whole field (a reduced side expands it): sampled.
        if not (rec.step % self.every == 0 or last):
            return
        u = rec.implicit_u if self.side == "implicit" else rec.explicit_u
        assert u is not None
        value, where = self.vm.peak_at(u, self.cells, self.comm)
        if value > self.peak:
            self.peak, self.t_peak, self.location = value, rec.t, where

    def summarize(self, summary: dict[str, Any]) -> None:
        summary["peak_bridge_von_mises_Pa"] = self.peak
        summary["peak_bridge_von_mises_t"] = self.t_peak
        summary["peak_bridge_von_mises_location_m"] = self.location.tolist()

    def state_dict(self) -> dict[str, Any]:
        return {"peak": self.peak, "t_peak": self.t_peak, "location": self.location.copy()}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.peak, self.t_peak = float(state["peak"]), float(state["t_peak"])
        self.location = np.array(state["location"], dtype=np.float64)

    def destroy(self) -> None:
        pass
