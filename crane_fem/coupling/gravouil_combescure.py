"""Gravouil–Combescure (GC): the interface solved at every micro step, the implicit side
corrected with the last multipliers (THEORY.md §3, method "gc").

Explicit side (velocity-Verlet CD, half-step velocities V_{j±1/2}); its interface velocity at
t_j is V_j = ½ (V_{j−1/2} + V_{j+1/2}), so an interface impulse Λ̂_j = Δt Λ_j applied to
V_{j+1/2} changes V_j by ½ M_E⁻¹ L_Eᵀ Λ̂_j (γ_E Δt = ½ Δt in THEORY's force form). The implicit
link velocity at t_j is taken as j/m of the end-of-step one that Λ_j would produce:
γ ΔT M̃⁻¹ L_Iᵀ Λ_j (j/m) = j γ M̃⁻¹ L_Iᵀ Λ̂_j. Multiplying the continuity condition
L_E V_E,j + L_I V_I,j = 0 by 2 gives a symmetric system, which also carries the explicit
contact rows (0 ≤ Λ_c ⟂ L_c V_{j+1/2} ≥ 0), solved together (docs/theory-notes.md §5):

    [ W_ΓΓ + 2jγ W_I   W_Γc ] [Λ̂_j]     [ 2 (L_E V_j^free + L_I V_I,j^free) ]
    [ W_cΓ             W_cc ] [Λ_c ] + [ L_c V_{j+1/2}^free               ] ⟂ ...

with W_E = L M_E⁻¹ Lᵀ over the stacked rows (interface; contacts). After the m micro steps the
implicit side is corrected with Λ_m = Λ̂_m / Δt (THEORY step 3). The implicit side costs two
solves with the factored M̃ per macro step: the free step and the correction.
GC is weakly unstable over long undamped runs (docs/theory-notes.md §6).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from crane_fem.coupling.protocol import MethodBase, MethodSetup
from crane_fem.coupling.system import CoupledSystem, MacroRecord, MicroTrace
from crane_fem.kernels import explicit as kx

__all__ = ["GCStep", "GravouilCombescure", "create"]

FloatArray = npt.NDArray[np.float64]


class GCStep:
    """What a GC macro step returns: the last micro step's stacked impulses and gaps, the
    micro-step contact flags, whether the closed contact set differed from the watched one
    at some micro step, the link force the record reports (None: the last micro step's,
    ``lam`` / Δt), and whether a watched open point closed."""

    __slots__ = ("changed", "closed", "gaps", "interface_force", "lam", "micro")

    def __init__(
        self,
        lam: FloatArray,
        gaps: FloatArray,
        micro: MicroTrace,
        changed: bool,
        interface_force: FloatArray | None = None,
        closed: bool = False,
    ) -> None:
        self.lam, self.gaps, self.micro, self.changed = lam, gaps, micro, changed
        self.interface_force = interface_force
        self.closed = closed

    def record(self, system: CoupledSystem) -> MacroRecord:
        """The record of the system after this step (its clock advanced)."""
        return system.record(self.lam, self.gaps, self.micro, self.interface_force)


#: The fraction of the interface displacement drift that ``drift_correction`` removes per
#: macro step (a relaxation over about ten macro steps). Measured on the 3c crane over 1.5 s
#: (docs/theory-notes.md §16): 1 (the whole drift each step) fed back into the impacts and let
#: the drift grow to 1 mm; 0.1 keeps it below 1e-7 m between impacts.
DRIFT_RELAXATION = 0.1


class GravouilCombescure(MethodBase):
    """THEORY.md's GC coupling (collective).

    Args:
        system: the two sides (both present).
        operator: the interface operator A_j (crane_fem.coupling.operator) for the system's
            ratio and implicit side.
    """

    name = "gc"

    def __init__(
        self, system: CoupledSystem, operator: kx.InterfaceOp, drift_correction: bool = False
    ) -> None:
        super().__init__(system)
        self.op = operator
        self.drift_correction = drift_correction
        self.max_drift = 0.0

    def summary(self) -> dict[str, Any]:
        """The interface displacement drift: its largest over the run (an impact's macro step
        makes it; the correction removes it over the next) and at the end (collective)."""
        end = float(np.max(np.abs(self.system.interface_drift()), initial=0.0))
        return {"interface_drift_max_m": max(self.max_drift, end), "interface_drift_end_m": end}

    def method_state(self) -> dict[str, Any]:
        return {"max_drift": self.max_drift}

    def load_method_state(self, state: dict[str, Any]) -> None:
        self.max_drift = float(state.get("max_drift", 0.0))

    def step(self) -> MacroRecord:
        s = self.system
        res = self.macro(s.t)
        s.advance()
        return res.record(s)

    def macro(self, t0: float, watch: npt.NDArray[np.bool_] | None = None) -> GCStep:
        """The GC step [t0, t0 + ΔT] with the system's m, ΔT and implicit side; books its
        energy terms (collective). ``watch``: contact points closed at t0, to flag a change."""
        s = self.system
        E, I, m, n_g = s.E, s.I, s.m, s.n_gamma  # noqa: E741
        assert E is not None and I is not None
        t1 = t0 + s.dT
        cv0 = s.damping_now()
        uf, vf, af = I.free_step(t1)
        uI0, vI0 = I.u.copy(), I.v.copy()
        f0 = I.load(t0)
        wI0, wIf = I.interface_values(vI0), I.interface_values(vf)
        drift = s.interface_drift()
        self.max_drift = max(self.max_drift, float(np.max(np.abs(drift), initial=0.0)))
        if self.drift_correction:
            # The interface velocity targets shifted by a fraction of the drift per macro step:
            # the explicit side's interface relaxes back onto the implicit side's.
            shift = DRIFT_RELAXATION * drift / s.dT
            wI0, wIf = wI0 + shift, wIf + shift
        j = np.arange(1, m + 1)
        ctl = E.steps(
            t0,
            m,
            mode=kx.SOLVED,
            targets=(wI0, wIf),
            tc=np.column_stack([1.0 - j / m, j / m]),
            k_op=j.astype(np.float64),
            watch=watch,
        )
        out = E.advance(ctl, self.op)
        # Trapezoid over [t_j−1, t_j], as the implicit side's.
        s.impulse_E += out.impulse_trap
        link_e = s.explicit_balance(out)
        I.accept(uf, vf, af)
        lam_force = out.lam[:n_g] / s.dt
        I.correct(lam_force)
        s.impulse_I += 0.5 * s.dT * (s.lam_macro_prev + lam_force)
        mean_force = 0.5 * (s.lam_macro_prev + lam_force)
        link_i, phys_i = s.implicit_balance(uI0, vI0, f0, I.load(t1), cv0, mean_force)
        s.lam_macro_prev = lam_force
        # The GC-measure and physical work of the explicit side are global already (dot
        # products of reduced interface vectors).
        gc_e, phys_e = float(out.sums[kx.GC_WORK]), float(out.sums[kx.PHYS_WORK])
        s.book_interface(link_e + link_i, gc_e + link_i, phys_e + phys_i)
        flags = out.flags
        return GCStep(
            out.lam,
            out.gaps,
            s.micro_trace(t0, out),
            bool(flags[kx.CHANGED]),
            closed=bool(flags[kx.CLOSED]),
        )


def create(system: CoupledSystem, setup: MethodSetup) -> GravouilCombescure:
    """GC on the system's implicit side and ratio."""
    return GravouilCombescure(
        system,
        setup.operator_for(system),
        bool(setup.options.get("drift_correction", False)),
    )
