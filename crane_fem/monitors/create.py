"""The monitors of a run with subdomains, built from the simulation and handed the macro
records in a fixed order: the guard and the contact peaks with every record, the sampled
ones (wheel slip, measured points, bridge stress, support reactions) at the sampling
instants, in the loop's output time."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from crane_fem.coupling import MacroRecord
from crane_fem.monitors.bridge_stress import BridgeStress
from crane_fem.monitors.contact_peaks import ContactPeaksMonitor
from crane_fem.monitors.contact_slip import ContactSlipMonitor, create_contact_slip
from crane_fem.monitors.energy_growth import EnergyGrowth
from crane_fem.monitors.group_stress import GroupStress, create_group_stress
from crane_fem.monitors.measured_points import MeasuredPoints, create_measured_points
from crane_fem.monitors.protocol import Monitor
from crane_fem.monitors.support_reactions import SupportsMonitor, create_supports
from crane_fem.monitors.wheel_slip import WheelSlipMonitor, create_wheel_slip
from crane_fem.pipeline import Simulation

__all__ = ["Monitors", "create_monitors"]


@dataclass
class Monitors:
    """The run's monitors (each a :class:`~crane_fem.monitors.protocol.Monitor`; those a
    scene lacks are None). Collective: every rank calls the same methods in the same order.
    Owns the support reactions' PETSc objects: :meth:`destroy`."""

    growth: EnergyGrowth
    peaks: ContactPeaksMonitor
    stress: BridgeStress | GroupStress | None = None
    supports: SupportsMonitor | None = None
    points: MeasuredPoints | None = None
    slip: WheelSlipMonitor | ContactSlipMonitor | None = None

    def _present(self, names: tuple[str, ...]) -> list[tuple[str, Monitor]]:
        return [(k, m) for k in names if (m := getattr(self, k)) is not None]

    def watch(self, rec: MacroRecord) -> None:
        """Every record, before the loop books it: the divergence guard (it may stop the run),
        then the contact peaks of its micro steps."""
        for _, m in self._present(("growth", "peaks")):
            m.update(rec, False)

    def sample(self, rec: MacroRecord, last: bool) -> None:
        """The records of the sampling instants and the last, in the loop's output time (they
        read whole fields; the stress and reactions every ``stress_every`` samples): the
        wheels' slip (it may stop the run beyond its pairs' reach), the measured points, the
        bridge stress, the support reactions."""
        for _, m in self._present(("slip", "points", "stress", "supports")):
            m.update(rec, last)

    @property
    def columns(self) -> list[str]:
        """The history columns of the sampled monitors: the measured points' (with the
        ground's acceleration), the support forces, the bridge's largest stress."""
        sampled = (self.points, self.supports, self.stress, self.slip)
        return [c for m in sampled if m is not None for c in m.columns]

    def history_row(self, t: float) -> dict[str, float]:
        """Their values at the sampling instant ``t`` (after :meth:`sample`; not
        collective)."""
        row: dict[str, float] = {}
        if self.points is not None:
            row.update(self.points.history_row(t))
        for m in (self.supports, self.stress, self.slip):
            if m is not None:
                row.update(m.history_row())
        return row

    def summarize(self, summary: dict[str, Any]) -> None:
        """Their entries in the summary; the slip joins the wheels' peaks."""
        for _, m in self._present(("stress", "peaks", "slip", "supports", "points")):
            m.summarize(summary)

    #: Checkpoint key of each monitor, in the order a checkpoint stores them.
    _CHECKPOINT = (
        ("peaks", "peaks"),
        ("monitor", "growth"),
        ("stress", "stress"),
        ("reactions", "supports"),
        ("motions", "points"),
        ("slip", "slip"),
    )

    def state_dict(self) -> dict[str, Any]:
        return {key: m.state_dict() for key, m in self._checkpointed()}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        for key, m in self._checkpointed():
            m.load_state_dict(state[key])

    def _checkpointed(self) -> list[tuple[str, Monitor]]:
        pairs = [(key, getattr(self, name)) for key, name in self._CHECKPOINT]
        return [(key, m) for key, m in pairs if m is not None]

    def destroy(self) -> None:
        for _, m in self._present(("growth", "peaks", "stress", "supports", "points", "slip")):
            m.destroy()


def create_monitors(sim: Simulation, out: Path) -> Monitors:
    """The monitors the scene calls for (collective): the divergence guard and the contact
    peaks always; for a crane the bridge stress, the support reactions and the wheels' slip,
    for a gmsh model its volume groups' stresses, its supports' reactions and its contacts'
    slip;
    the measured points where the scenario or the crane names some (spectra to ``out``)."""
    crane = sim.mesh.crane is not None
    points = create_measured_points(sim, out)
    return Monitors(
        EnergyGrowth(sim),
        ContactPeaksMonitor(sim),
        BridgeStress(sim) if crane else create_group_stress(sim),
        create_supports(sim) if crane or sim.scenario.support else None,
        points,
        create_wheel_slip(sim) or create_contact_slip(sim),
    )
