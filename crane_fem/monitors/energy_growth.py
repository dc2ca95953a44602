"""The divergence guard of a run with subdomains: stop a growing or non-finite run with a
diagnosis naming the subdomain, the macro step and the interface's energy."""

from __future__ import annotations

import math
from typing import Any

from crane_fem.coupling import MacroRecord
from crane_fem.errors import UnstableRunError
from crane_fem.pipeline import Simulation
from crane_fem.stability import EnergyGrowthMonitor

__all__ = ["EnergyGrowth"]


class EnergyGrowth:
    """Every macro record's energies against :class:`EnergyGrowthMonitor` (not collective:
    the energies are global, so the verdict is the same on every rank)."""

    def __init__(self, sim: Simulation) -> None:
        md = sim.models
        factor = sim.scenario.monitor.energy_growth
        self.sim = sim
        self.monitor = EnergyGrowthMonitor(factor, "", "", md.dt, md.dt_critical)

    def update(self, rec: MacroRecord, last: bool) -> None:
        """Stop a diverging run (:meth:`EnergyGrowthMonitor.growth`) or a non-finite one.

        Raises:
            UnstableRunError: naming the subdomain whose kinetic energy dominates, the macro
                step, the energy the interface has created, m, and Δt against the explicit
                critical step.
        """
        e, md = rec.energy, self.sim.models
        step = f"Δt = {md.dt:.4e} s is {md.dt / md.dt_critical:.3f}× the critical step "
        step += f"{md.dt_critical:.4e} s"
        explicit = e["kinetic_explicit"] >= e["kinetic_implicit"]
        if not all(math.isfinite(v) for v in e.values()):
            explicit = not math.isfinite(e["kinetic_explicit"]) or math.isfinite(
                e["kinetic_implicit"]
            )
            reason = "non-finite energy"
        else:
            reason = self.monitor.growth(e["kinetic"], e["internal"], e["external_work"]) or ""
            if not reason:
                return
        names = md.explicit_names if explicit else md.implicit_names
        scheme = "cd-lagrange" if explicit else "newmark"
        ifd = e["interface_dissipated"]
        raise UnstableRunError(
            f"unstable run: subdomain '{'+'.join(names)}' ({scheme}) at macro step {rec.step} "
            f"(t = {rec.t:.6g} s): {reason}; the interface has "
            f"{'created' if not ifd >= 0 else 'dissipated'} {abs(ifd):.3e} J "
            f"(method {md.method}, m = {md.ratio}); {step}"
        )

    def summarize(self, summary: dict[str, Any]) -> None:
        """Nothing: a diverging run's diagnosis is the loop's."""

    def state_dict(self) -> dict[str, Any]:
        return dict(self.monitor.state_dict())

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.monitor.load_state_dict(state)

    def destroy(self) -> None:
        pass
