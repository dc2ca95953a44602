"""CD-Lagrange: explicit central difference with velocity-level contact multipliers, one step
per record (the single-subdomain bar path), on the compiled kernel.

THEORY.md §1 (paper §2.3). One step, lumped mass M, state (U_n, V_{n+1/2}):

    U_{n+1}   = U_n + Δt V_{n+1/2}                                   (1.1)
    V_free    = V_{n+1/2} + Δt M⁻¹ (F_{n+1} − K U_{n+1} − C V_{n+1/2}) (1.2)
    0 ≤ Λ ⟂ L V_free + W Λ ≥ 0 on the points with g(U_{n+1}) ≤ 0      (1.3)
    V_{n+3/2} = V_free + M⁻¹ Lᵀ Λ                                     (1.4)

with W = L M⁻¹ Lᵀ. Energy (derived in docs/theory-notes.md): with
E_n = ½ V_{n+1/2}ᵀ M V_{n+1/2} + ½ U_{n+1}ᵀ K U_n, multiplying (1.2)-(1.4) by
½ (V_{n+1/2} + V_{n+3/2})ᵀ M gives exactly

    E_{n+1} − E_n = Δt v̄ᵀ F_{n+1} − Δt v̄ᵀ C V_{n+1/2} + v̄ᵀ Lᵀ Λ,  v̄ = ½ (V_{n+1/2} + V_{n+3/2}),

so the record at t_{n+1} reports kinetic ½ V_{n+3/2}ᵀ M V_{n+3/2}, internal
½ U_{n+2}ᵀ K U_{n+1} = ½ U_{n+1}ᵀ K U_{n+1} + ½ Δt V_{n+3/2}ᵀ K U_{n+1} and accumulates the three
work terms; the balance then closes to round-off. The step itself is
:func:`crane_fem.kernels.explicit.run_steps` (the same kernel as every explicit path).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from crane_fem.contact import ContactSet
from crane_fem.integrators.base import StepRecord, TimeIntegrator
from crane_fem.integrators.explicit_zone import ExplicitZone
from crane_fem.kernels import explicit as kx
from crane_fem.loading.body import AffineLoad
from crane_fem.model import StructuralModel

__all__ = ["CDLagrange", "CentralDifference"]

FloatArray = npt.NDArray[np.float64]


class CentralDifference(TimeIntegrator):
    """Explicit central difference (velocity-Verlet form) with the contact law ``law`` of
    :mod:`crane_fem.kernels.explicit`. Collective over the model's communicator."""

    name = "central-difference"
    law = kx.LAW_LCP

    def __init__(
        self,
        model: StructuralModel,
        contacts: ContactSet,
        load: AffineLoad,
        dt: float,
        u0: FloatArray,
        v0: FloatArray,
        penalty: float = 0.0,
    ) -> None:
        super().__init__(model, contacts, load, dt, u0, v0)
        self.zone = ExplicitZone(model, load, dt, u0, v0, ContactSet.empty(model.comm), contacts)
        self.penalty = float(penalty)
        self._vel = np.zeros_like(self.u)  # output velocity at t_n

    def _advance(self, h: float, move: bool, count_work: bool) -> StepRecord:
        Z = self.zone
        t0 = self.t - self.dt if move else 0.0
        times = np.array([self.t])
        out = Z.advance(
            Z.steps(t0, 1, h0=h, move0=move, law=self.law, penalty=self.penalty, times=times)
        )
        kin, internal = Z.local_energies()
        s = out.sums
        red = self._reduce([kin, internal, s[kx.EXT], s[kx.DAMP], s[kx.CONTACT]])
        en = self.energy
        en.kinetic, en.internal = float(red[0]), float(red[1])
        if count_work:
            en.external_work += red[2]
            en.damping_dissipated += red[3]
            en.contact_dissipated -= red[4]
        self.u[:] = Z.u
        self._vel[:] = Z.v_int if count_work else self.v0
        return StepRecord(self.n, self.t, self.u, self._vel, out.lam, out.gaps, en)

    def initialize(self) -> StepRecord:
        """Half step V_{1/2} = V_0 + ½Δt M⁻¹(F_0 − K U_0 − C V_0) (+ contact at t_0)."""
        self.n = 0
        self.energy.__init__()  # type: ignore[misc]
        return self._advance(0.5 * self.dt, move=False, count_work=False)

    def step(self) -> StepRecord:
        self.n += 1
        return self._advance(self.dt, move=True, count_work=True)

    def destroy(self) -> None:
        self.zone.destroy()


class CDLagrange(CentralDifference):
    """CD-Lagrange (THEORY.md §1): impulses from the exact velocity-level LCP (1.3).

    The Delassus operator W = L M⁻¹ Lᵀ is built once; it is diagonal when contact points
    share no DOF (closed form Λ_l = max(0, −(L V_free)_l / W_ll)), otherwise the small LCP is
    solved exactly. No penalty, no iteration.
    """

    name = "cd-lagrange"

    def __init__(
        self,
        model: StructuralModel,
        contacts: ContactSet,
        load: AffineLoad,
        dt: float,
        u0: FloatArray,
        v0: FloatArray,
    ) -> None:
        super().__init__(model, contacts, load, dt, u0, v0)
        W = self.zone.W
        if contacts.p and np.any(np.diag(W) <= 0.0):
            raise ValueError("a contact point acts on fixed DOFs only (zero Delassus diagonal)")
