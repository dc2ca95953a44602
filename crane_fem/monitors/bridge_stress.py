"""The peak von Mises stress over a crane's bridge cells as a macro-step monitor."""

from __future__ import annotations

import math
from typing import Any

import dolfinx
import numpy as np

from crane_fem.coupling import MacroRecord
from crane_fem.pipeline import Simulation

__all__ = ["BridgeStress"]


class BridgeStress:
    """The peak von Mises stress over the crane's bridge cells (girders, end carriages, the
    rails outside the explicit zones) every ``output.stress_every`` sampling intervals and at
    the last: of the implicit side in a coupled run, of the whole mesh in the fully explicit one
    (collective). Its history column holds the value at the instants it was evaluated and NaN
    at the rows between them (``stress_every`` > 1): a value carried over would be stamped
    with a later time than its own."""

    def __init__(self, sim: Simulation) -> None:
        md = sim.models
        sub = md.implicit if md.implicit is not None else md.explicit
        assert sub is not None
        self.side = "implicit" if md.implicit is not None else "explicit"
        # Every ``stress_every`` sampling intervals, in micro steps.
        self.every = sim.scenario.output.stress_every * md.sample_steps
        tagged = sim.mesh.tagged
        tag = tagged.cell_groups["bridge_implicit"]
        n_parent = tagged.mesh.topology.index_map(tagged.mesh.topology.dim).size_local
        n_parent += tagged.mesh.topology.index_map(tagged.mesh.topology.dim).num_ghosts
        bridge = np.zeros(n_parent, dtype=bool)
        bridge[tagged.cell_tags.indices[tagged.cell_tags.values == tag]] = True
        self.vm = sub.stress()
        own = sub.parent_cells[: self.vm.n_cells]
        self.cells = np.flatnonzero(bridge[own]).astype(np.int32)
        # The part of each bridge cell (end carriages, girders, rails: THEORY.md §8 (b) asks
        # for the peak's part), from its centre.
        geo = sim.scenario.model.geometry()  # type: ignore[union-attr]
        mesh = sub.V.mesh
        mid = dolfinx.mesh.compute_midpoints(mesh, mesh.topology.dim, self.cells)
        names = [geo.part_at(*c) for c in mid] if self.cells.size else []
        self.parts = sorted(
            {f"{p} {k}" for p in ("end carriage", "girder", "rail") for k in (1, 2)}
        )
        index = {p: i for i, p in enumerate(self.parts)}
        self.labels = np.array([index[n] for n in names], dtype=np.int64)
        self.comm = sim.mesh.comm
        self.peak, self.t_peak = 0.0, 0.0
        self.location = np.zeros(3)
        self.part_peak = np.zeros(len(self.parts))
        self.part = ""
        #: The largest stress over the bridge at the last sampled record (Pa; NaN when the
        #: stress was not evaluated there): the history column.
        self.last = math.nan

    @property
    def columns(self) -> list[str]:
        """The history column: the largest stress over the bridge at the row's instant (Pa),
        NaN at a row where it is not evaluated."""
        return ["bridge_von_mises_max"]

    def history_row(self) -> dict[str, float]:
        return {"bridge_von_mises_max": self.last}

    def update(self, rec: MacroRecord, last: bool) -> None:
        # The stress needs the side's whole field (a reduced side expands it): sampled.
        if not (rec.micro_step % self.every == 0 or last):
            self.last = math.nan
            return
        u = rec.implicit_u if self.side == "implicit" else rec.explicit_u
        assert u is not None
        values, where = self.vm.peaks_by(u, self.cells, self.labels, len(self.parts), self.comm)
        np.maximum(self.part_peak, values, out=self.part_peak)
        k = int(np.argmax(values))
        self.last = float(values[k])
        if values[k] > self.peak:
            self.peak, self.t_peak, self.location = float(values[k]), rec.t, where[k]
            self.part = self.parts[k]

    def summarize(self, summary: dict[str, Any]) -> None:
        summary["peak_bridge_von_mises_Pa"] = self.peak
        summary["peak_bridge_von_mises_t"] = self.t_peak
        summary["peak_bridge_von_mises_location_m"] = self.location.tolist()
        summary["peak_bridge_von_mises_part"] = self.part
        summary["peak_bridge_von_mises_by_part_Pa"] = dict(
            zip(self.parts, self.part_peak.tolist(), strict=True)
        )

    def state_dict(self) -> dict[str, Any]:
        return {
            "peak": self.peak,
            "t_peak": self.t_peak,
            "location": self.location.copy(),
            "part": self.part,
            "part_peak": self.part_peak.copy(),
            "last": self.last,
        }

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.peak, self.t_peak = float(state["peak"]), float(state["t_peak"])
        self.location = np.array(state["location"], dtype=np.float64)
        self.part = str(state["part"])
        self.part_peak = np.array(state["part_peak"], dtype=np.float64)
        self.last = float(state["last"])

    def destroy(self) -> None:
        pass
