"""GC against the implicit side's mean velocity (method "gc-mean", docs/theory-notes.md §9).

Every micro step targets the implicit side's mean interface velocity over the macro step,
a = L_I ΔU_free / ΔT of its free trapezoidal increment,

    L_E V_j + a + ½ m W_I Λ̂_j = 0     (with the explicit contacts, one mixed LCP),

and the implicit side is paid the total impulse S = Σ_j Λ̂_j (a constant force S/ΔT in the
trapezoidal rule). Its interface energy is −½ Σ_{i<j} (Λ̂_i − Λ̂_j)ᵀ W_I (Λ̂_i − Λ̂_j) ≤ 0 at
every macro step (zero for m = 1), contacts or not; it is booked from the two sides' energy
balances and checked against that closed form (``interface_identity_error``).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from crane_fem.coupling.gravouil_combescure import GCStep
from crane_fem.coupling.protocol import MethodBase, MethodSetup
from crane_fem.coupling.system import CoupledSystem, MacroRecord
from crane_fem.kernels import explicit as kx

__all__ = ["IDENTITY_EVERY", "GCMean", "create"]

#: The closed form of the interface energy is checked on one macro step in this many (and on
#: the first): it costs m n_Γ² multiply-adds, 1.7 ms at m = 200 on the crane's 444 interface
#: rows — a fifth of the stress-grade reduced scene's time loop if made at every step, a
#: tenth at one in eight.
IDENTITY_EVERY = 32


class GCMean(MethodBase):
    """The "gc-mean" coupling (collective); ``operator`` as for GC."""

    name = "gc-mean"

    def __init__(self, system: CoupledSystem, operator: kx.InterfaceOp) -> None:
        super().__init__(system)
        self.op = operator
        #: The largest gap (J) between the interface energy of a macro step booked from the
        #: energy balances and its closed form (over the steps checked: IDENTITY_EVERY).
        self.identity_error = 0.0

    def step(self) -> MacroRecord:
        s = self.system
        res = self.macro(s.t)
        s.advance()
        return res.record(s)

    def macro(self, t0: float, watch: npt.NDArray[np.bool_] | None = None) -> GCStep:
        """The step [t0, t0 + ΔT] with the system's m, ΔT and implicit side; books its energy
        terms (collective). ``watch``: contact points closed at t0, to flag a change."""
        s = self.system
        E, I = s.E, s.I  # noqa: E741
        assert E is not None and I is not None
        m, dT = s.m, s.dT
        st = s.trapezoid_start(t0)
        a = I.interface_values(st.du_free) / dT
        j = np.arange(1, m + 1)
        check = s.n % IDENTITY_EVERY == 0
        ctl = E.steps(
            t0,
            m,
            mode=kx.SOLVED,
            targets=(a, a),
            tc=np.column_stack([1.0 - j / m, j / m]),
            k_op=np.full(m, float(m)),
            keep_impulses=check,
            watch=watch,
        )
        out = E.advance(ctl, self.op)
        S = out.impulse_sum
        s.impulse_E += S
        G = S / dT
        link = s.trapezoid_finish(st, G, S, out)
        # The interface energy booked from the two sides' energy identities against its
        # closed form ½ (m Σ_j Λ̂_jᵀ W_I Λ̂_j − Sᵀ W_I S) = ½ Σ_{i<j} ‖Λ̂_i − Λ̂_j‖²_{W_I}.
        if check:
            impulses = out.impulses  # Λ̂_j
            sq = float(np.einsum("ij,ij->", impulses @ I.W, impulses))
            closed_form = 0.5 * (m * sq - float(S @ (I.W @ S)))
            self.identity_error = max(self.identity_error, abs(-link - closed_form))
        flags = out.flags
        micro = s.micro_trace(t0, out)
        return GCStep(
            out.lam, out.gaps, micro, bool(flags[kx.CHANGED]), G.copy(), bool(flags[kx.CLOSED])
        )

    def summary(self) -> dict[str, Any]:
        return {"interface_identity_error": self.identity_error}

    def method_state(self) -> dict[str, Any]:
        return {"identity_error": self.identity_error}

    def load_method_state(self, state: dict[str, Any]) -> None:
        self.identity_error = float(state["identity_error"])


def create(system: CoupledSystem, setup: MethodSetup) -> GCMean:
    """gc-mean on the system's implicit side and ratio."""
    return GCMean(system, setup.operator_for(system, fixed=True))
