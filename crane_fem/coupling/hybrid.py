"""The hybrid of "ec" and GC for contacts (method "hybrid", docs/theory-notes.md §8).

"ec" while every explicit contact is open (the explicit side is then linear and the interface
conserves energy), GC otherwise; a GC macro step in which a contact changes state (an impact,
a lift-off), or whose interface energy exceeds ``interface_tolerance`` × the mechanical
energy, is redone as m / r GC steps of r micro steps (r = ``impact_ratio``) on a second
Newmark side with ΔT = rΔt (its own factorisation: the one method that needs two). It contains
the two methods it switches between.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import numpy.typing as npt

from crane_fem.coupling.energy_conserving import EnergyConserving
from crane_fem.coupling.gravouil_combescure import GCStep, GravouilCombescure
from crane_fem.coupling.protocol import MethodBase, MethodSetup
from crane_fem.coupling.system import CoupledSystem, ImplicitSide, MacroRecord, MicroTrace
from crane_fem.kernels import explicit as kx

__all__ = ["Hybrid", "create"]

FloatArray = npt.NDArray[np.float64]


class Hybrid(MethodBase):
    """The "hybrid" coupling (collective).

    Args:
        system: the two sides (average-acceleration Newmark).
        operator: the GC interface operator for the system's ratio.
        refined_operator: builds the GC operator of the refined steps from their Newmark side.
        impact_ratio: r, micro steps per implicit step in the refined macro steps (divides m).
        interface_tolerance: the interface energy of a GC step, relative to the mechanical
            energy, above which it is refined.
    """

    name = "hybrid"

    def __init__(
        self,
        system: CoupledSystem,
        operator: kx.InterfaceOp,
        refined_operator: Callable[[ImplicitSide], kx.InterfaceOp],
        impact_ratio: int = 1,
        interface_tolerance: float = 5e-4,
    ) -> None:
        super().__init__(system)
        m = system.m
        if impact_ratio < 1 or m % impact_ratio:
            raise ValueError(f"impact_ratio = {impact_ratio} must divide the ratio m = {m}")
        self.impact_ratio = int(impact_ratio)
        self.interface_tolerance = float(interface_tolerance)
        self.ec = EnergyConserving(system)
        self.gc = GravouilCombescure(system, operator)
        self._refined_operator = refined_operator
        self._fine: tuple[ImplicitSide, GravouilCombescure] | None = None
        self.steps_taken = {"gc": 0, "gc_refined": 0, "ec": 0}

    def step(self) -> MacroRecord:
        """One macro step (every decision is taken on global quantities, the same on every
        rank)."""
        s = self.system
        E, I = s.E, s.I  # noqa: E741
        assert E is not None and I is not None
        t0 = s.t
        closed = E.contacts.closed(s.contact_gaps())
        if not np.any(closed):
            res = self.ec.macro(t0, closed, fallback=True)
            if res is not None:
                # The next step may be GC: the acceleration at t0 + ΔT under the force G.
                I.initialize(t0 + s.dT, I.interface_force(res.G))
                self.steps_taken["ec"] += 1
                return self.ec.record(res)
        snap = s.snapshot() if self.impact_ratio < s.m else None
        e_gamma, mech = s.acc["interface_dissipated"], s.mechanical_energy()
        out = self.gc.macro(t0, watch=closed)
        d_gamma = abs(s.acc["interface_dissipated"] - e_gamma)
        mech = max(mech, s.mechanical_energy())
        if snap is not None and (out.changed or d_gamma > self.interface_tolerance * mech):
            s.restore(snap)
            out = self._refined(t0)
            self.steps_taken["gc_refined"] += 1
        else:
            self.steps_taken["gc"] += 1
        s.advance()
        return s.record(out.lam, out.gaps, out.micro)

    def _refined(self, t0: float) -> GCStep:
        """The macro step [t0, t0 + ΔT] as m / r GC steps of r micro steps; the implicit
        state (U, V, A) carries over both ways."""
        s = self.system
        I, m, r = s.I, s.m, self.impact_ratio  # noqa: E741
        assert I is not None
        if self._fine is None:
            fine_side = I.refined(r * s.dt)
            self._fine = (fine_side, GravouilCombescure(s, self._refined_operator(fine_side)))
        fine, gc_fine = self._fine
        fine.u, fine.v, fine.a = I.u.copy(), I.v.copy(), I.a.copy()
        s.use_implicit(fine, r)
        micro: list[MicroTrace] = []
        try:
            for i in range(m // r):
                res = gc_fine.macro(t0 + i * r * s.dt)
                micro.append(res.micro)
        finally:
            I.u, I.v, I.a = fine.u.copy(), fine.v.copy(), fine.a.copy()
            s.use_implicit(I, m)
        return GCStep(res.lam, res.gaps, MicroTrace.concat(micro), False)

    def summary(self) -> dict[str, Any]:
        return {"hybrid_steps": dict(self.steps_taken), **self.ec.summary()}

    def method_state(self) -> dict[str, Any]:
        """The steps of each kind and the "ec" passes (the refined side's state is copied in
        at each refined step: nothing of it carries over)."""
        return {"steps_taken": dict(self.steps_taken), "ec": self.ec.method_state()}

    def load_method_state(self, state: dict[str, Any]) -> None:
        self.steps_taken = {k: int(state["steps_taken"][k]) for k in self.steps_taken}
        self.ec.load_method_state(state["ec"])

    def destroy(self) -> None:
        if self._fine is not None:
            self._fine[0].destroy()


def create(system: CoupledSystem, setup: MethodSetup) -> Hybrid:
    """ "hybrid" with GC's operator at the system's ratio and at its refined steps, and its
    keys ``impact_ratio``, ``interface_tolerance`` where the scenario sets them."""
    op = setup.operator
    if op is None:
        raise ValueError("method 'hybrid' needs the interface operator")
    dt = system.dt
    return Hybrid(
        system,
        setup.operator_for(system),
        lambda side: op(side, round(side.dT / dt), False),
        **{k: v for k, v in setup.options.items() if k in ("impact_ratio", "interface_tolerance")},
    )
