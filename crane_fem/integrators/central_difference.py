"""CD-Lagrange: explicit central difference with velocity-level contact multipliers.

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
work terms; the balance then closes to round-off.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from crane_fem.contact import ContactSet, solve_lcp
from crane_fem.integrators.base import StepRecord, TimeIntegrator
from crane_fem.model import LoadFunction, StructuralModel

__all__ = ["CDLagrange", "CentralDifference"]

FloatArray = npt.NDArray[np.float64]


class CentralDifference(TimeIntegrator):
    """Explicit central difference (velocity-Verlet form) with a pluggable contact law.

    Time loop work: one SpMV (two with stiffness-proportional damping), vector updates and
    p-sized reductions. Collective over the model's communicator.
    """

    name = "central-difference"

    def __init__(
        self,
        model: StructuralModel,
        contacts: ContactSet,
        load: LoadFunction,
        dt: float,
        u0: FloatArray,
        v0: FloatArray,
    ) -> None:
        super().__init__(model, contacts, load, dt, u0, v0)
        self.vh = np.zeros_like(self.u)  # V_{n+1/2}
        self.ku = np.zeros_like(self.u)
        self.kv = np.zeros_like(self.u)
        self._vel = np.zeros_like(self.u)  # output velocity at t_n
        self._u_vec = model.create_vector(self.u)
        self._ku_vec = model.create_vector(self.ku)
        self._work = np.zeros_like(self.u)
        self._work_vec = model.create_vector(self._work)
        self._kv_vec = model.create_vector(self.kv)

    def _damping_force(self, v: FloatArray) -> FloatArray:
        m = self.model
        if not m.damped:
            return np.zeros_like(v)
        f = m.alpha * m.mass * v
        if m.beta != 0.0:
            self._work[:] = v
            m.K.mult(self._work_vec, self._kv_vec)
            f += m.beta * self.kv
        return f

    def _advance_velocity(self, t_new: float, h: float, count_work: bool) -> StepRecord:
        """From U at t_new and V_prev (in self.vh) build V_next; h = Δt or Δt/2 (start)."""
        m = self.model
        m.K.mult(self._u_vec, self._ku_vec)
        f = self.load(t_new)
        v_prev = self.vh.copy()
        cv = self._damping_force(v_prev)
        rhs = f - self.ku - cv
        v_next, impulse, gaps, f_contact = self._contact_update(v_prev, rhs, h)
        vbar = 0.5 * (v_prev + v_next)
        kin = 0.5 * float(np.dot(v_next, m.mass * v_next))
        e_uku = 0.5 * float(np.dot(self.u, self.ku))
        e_vku = 0.5 * self.dt * float(np.dot(v_next, self.ku))
        w_ext = h * float(np.dot(vbar, f))
        w_damp = h * float(np.dot(vbar, cv))
        w_contact = float(np.dot(vbar, f_contact))
        kin, e_uku, e_vku, w_ext, w_damp, w_contact = self._reduce(
            [kin, e_uku, e_vku, w_ext, w_damp, w_contact]
        )
        en = self.energy
        en.kinetic = kin
        en.internal = e_uku + e_vku
        if count_work:
            en.external_work += w_ext
            en.damping_dissipated += w_damp
            en.contact_dissipated -= w_contact
        self.vh[:] = v_next
        self._vel[:] = vbar if count_work else self.v0
        return StepRecord(self.n, self.t, self.u, self._vel, impulse, gaps, en)

    def _contact_update(
        self, v_prev: FloatArray, rhs: FloatArray, h: float
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """Return (V_next, Λ, gaps, Lᵀ Λ on owned DOFs): the contact law of the subclass."""
        raise NotImplementedError

    def initialize(self) -> StepRecord:
        """Half step V_{1/2} = V_0 + ½Δt M⁻¹(F_0 − K U_0 − C V_0) (+ contact at t_0)."""
        self.n = 0
        self.vh[:] = self.v0
        self.energy.__init__()  # type: ignore[misc]
        return self._advance_velocity(0.0, 0.5 * self.dt, count_work=False)

    def step(self) -> StepRecord:
        self.u += self.dt * self.vh
        self.n += 1
        return self._advance_velocity(self.t, self.dt, count_work=True)

    def destroy(self) -> None:
        for vec in (self._u_vec, self._ku_vec, self._work_vec, self._kv_vec):
            vec.destroy()


class CDLagrange(CentralDifference):
    """CD-Lagrange (THEORY.md §1): impulses from the exact velocity-level LCP (1.3).

    The Delassus operator W = L M⁻¹ Lᵀ is built once; it is diagonal when contact points
    share no DOF (closed form Λ_l = max(0, −(L V_free)_l / W_ll)), otherwise the small LCP is
    solved exactly (:func:`crane_fem.contact.solve_lcp`). No penalty, no iteration.
    """

    name = "cd-lagrange"

    def __init__(
        self,
        model: StructuralModel,
        contacts: ContactSet,
        load: LoadFunction,
        dt: float,
        u0: FloatArray,
        v0: FloatArray,
    ) -> None:
        super().__init__(model, contacts, load, dt, u0, v0)
        self.W = contacts.delassus(model.minv)
        if contacts.p and np.any(np.diag(self.W) <= 0.0):
            raise ValueError("a contact point acts on fixed DOFs only (zero Delassus diagonal)")
        self.W_diagonal = bool(np.all(self.W == np.diag(np.diag(self.W))))

    def _contact_update(
        self, v_prev: FloatArray, rhs: FloatArray, h: float
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        m, c = self.model, self.contacts
        v_free = v_prev + h * m.minv * rhs
        gaps, q = c.gaps_and_velocities(self.u, v_free)
        impulse = solve_lcp(self.W, q, c.closed(gaps), self.W_diagonal)
        f_contact = c.transpose(impulse, m.n_owned)
        return v_free + m.minv * f_contact, impulse, gaps, f_contact
