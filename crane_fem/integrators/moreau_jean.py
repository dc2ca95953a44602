"""Moreau–Jean θ-scheme: implicit, with a velocity-level LCP at every step (baseline).

With V_θ = θ V_{n+1} + (1−θ) V_n and U_{n+1} = U_n + Δt V_θ (Jean 1999; Acary & Brogliato 2008):

    M (V_{n+1} − V_n) = Δt (F_θ − K U_θ − C V_θ) + Lᵀ Λ_{n+1}
    ⇒ Ŵ V_{n+1} = M V_n + Δt F_θ − Δt K U_n − θ(1−θ)Δt² K V_n − (1−θ)Δt C V_n + Lᵀ Λ,
       Ŵ = M + θΔt C + θ²Δt² K (assembled and factored once, MUMPS),

and, on the points whose predicted gap g_n + ½Δt L V_n is closed (Siconos' γ = ½ rule),
0 ≤ Λ ⟂ L V_{n+1} ≥ 0 (Newton impact law, zero restitution). The Delassus operator
W = L Ŵ⁻¹ Lᵀ and the columns Ŵ⁻¹ Lᵀ are computed once (p solves).

Energy: E = ½ Vᵀ M V + ½ Uᵀ K U changes by the work of F_θ, C V_θ and Lᵀ Λ against
V̄ = ½ (V_n + V_{n+1}) plus the integrator's own term Δt (V̄ᵀ K U_θ − Ūᵀ K V_θ), which is zero
for θ = ½ and is booked as ``numerical_dissipated``.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from petsc4py import PETSc

from crane_fem.contact import ContactSet, solve_lcp
from crane_fem.integrators.base import StepRecord, TimeIntegrator
from crane_fem.model import LoadFunction, StructuralModel

__all__ = ["MoreauJean"]

FloatArray = npt.NDArray[np.float64]


class MoreauJean(TimeIntegrator):
    """Moreau–Jean θ-scheme (θ ∈ [½, 1]); owns its operator and KSP (``destroy``, collective).

    The KSP has options prefix ``crane_fem_moreau_jean_`` (direct LU with MUMPS by default).
    """

    name = "moreau-jean"

    def __init__(
        self,
        model: StructuralModel,
        contacts: ContactSet,
        load: LoadFunction,
        dt: float,
        u0: FloatArray,
        v0: FloatArray,
        theta: float = 0.5,
    ) -> None:
        super().__init__(model, contacts, load, dt, u0, v0)
        if not 0.5 <= theta <= 1.0:
            raise ValueError(f"theta must lie in [1/2, 1], got {theta}")
        self.theta = float(theta)
        th, h = self.theta, self.dt
        self.A = model.K.copy()
        self.A.scale(th * th * h * h + th * h * model.beta)
        diag = model.create_vector((1.0 + th * h * model.alpha) * model.mass)
        self.A.setDiagonal(diag, addv=True)  # addv=True: ADD_VALUES
        diag.destroy()
        self.ksp = PETSc.KSP().create(model.comm)  # type: ignore[arg-type]
        self.ksp.setOptionsPrefix("crane_fem_moreau_jean_")
        self.ksp.setOperators(self.A)
        self.ksp.setType("preonly")
        pc = self.ksp.getPC()
        pc.setType("lu")
        pc.setFactorSolverType("mumps")
        self.ksp.setFromOptions()

        self.v = self.v0.copy()
        self.ku = np.zeros_like(self.u)
        self.kv = np.zeros_like(self.u)
        self._rhs = np.zeros_like(self.u)
        self._sol = np.zeros_like(self.u)
        self._vecs = {
            name: model.create_vector(arr)
            for name, arr in (
                ("u", self.u),
                ("v", self.v),
                ("ku", self.ku),
                ("kv", self.kv),
                ("rhs", self._rhs),
                ("sol", self._sol),
            )
        }
        p = contacts.p
        self.X = np.zeros((p, self.u.size))  # rows: Ŵ⁻¹ Lᵀ e_l on owned DOFs
        for col in range(p):
            e = np.zeros(p)
            e[col] = 1.0
            self.X[col] = self._solve(contacts.transpose(e, model.n_owned))
        self.W = np.zeros((p, p))
        for col in range(p):
            self.W[:, col] = contacts.apply(self.X[col])
        self.W = 0.5 * (self.W + self.W.T)
        self.W_diagonal = bool(np.all(self.W == np.diag(np.diag(self.W))))
        self._f_prev = np.zeros_like(self.u)

    def _solve(self, rhs: FloatArray) -> FloatArray:
        self._rhs[:] = rhs
        self.ksp.solve(self._vecs["rhs"], self._vecs["sol"])
        if self.ksp.is_diverged:
            reason = self.ksp.getConvergedReason()
            raise RuntimeError(f"Moreau–Jean linear solve failed (KSP reason {reason})")
        return self._sol.copy()

    def _mult_k(self, src: str, dst: str) -> None:
        self.model.K.mult(self._vecs[src], self._vecs[dst])

    def initialize(self) -> StepRecord:
        m, c = self.model, self.contacts
        self.n = 0
        self.v[:] = self.v0
        self._mult_k("u", "ku")
        self._mult_k("v", "kv")
        self._f_prev = self.load(0.0)
        kin, pot = self._reduce(
            [0.5 * float(np.dot(self.v, m.mass * self.v)), 0.5 * float(np.dot(self.u, self.ku))]
        )
        self.energy.__init__()  # type: ignore[misc]
        self.energy.kinetic, self.energy.internal = kin, pot
        gaps = c.g0 + c.apply(self.u)
        return StepRecord(0, 0.0, self.u, self.v, np.zeros(c.p), gaps, self.energy)

    def step(self) -> StepRecord:
        m, c = self.model, self.contacts
        th, h = self.theta, self.dt
        f_new = self.load(self.t + h)
        f_th = th * f_new + (1.0 - th) * self._f_prev
        v_old, u_old, ku_old, kv_old = self.v.copy(), self.u.copy(), self.ku.copy(), self.kv.copy()
        cv_old = m.alpha * m.mass * v_old + m.beta * kv_old
        rhs = (
            m.mass * v_old
            + h * f_th
            - h * ku_old
            - th * (1.0 - th) * h * h * kv_old
            - (1.0 - th) * h * cv_old
        )
        v_free = self._solve(rhs)
        gaps_n, vn = c.gaps_and_velocities(u_old, v_old)
        active = gaps_n + 0.5 * h * vn <= 0.0
        q = c.apply(v_free) if c.p else np.zeros(0)
        impulse = solve_lcp(self.W, q, active, self.W_diagonal)
        self.v[:] = v_free + impulse @ self.X
        v_th = th * self.v + (1.0 - th) * v_old
        self.u[:] = u_old + h * v_th
        self._mult_k("u", "ku")
        self._mult_k("v", "kv")
        self.n += 1
        self._f_prev = f_new

        vmid = 0.5 * (v_old + self.v)
        umid = 0.5 * (u_old + self.u)
        ku_th = th * self.ku + (1.0 - th) * ku_old
        kv_th = th * self.kv + (1.0 - th) * kv_old
        cv_th = m.alpha * m.mass * v_th + m.beta * kv_th
        f_contact = c.transpose(impulse, m.n_owned)
        vals = self._reduce(
            [
                0.5 * float(np.dot(self.v, m.mass * self.v)),
                0.5 * float(np.dot(self.u, self.ku)),
                h * float(np.dot(vmid, f_th)),
                h * float(np.dot(vmid, cv_th)),
                float(np.dot(vmid, f_contact)),
                h * float(np.dot(vmid, ku_th) - np.dot(umid, kv_th)),
            ]
        )
        en = self.energy
        en.kinetic, en.internal = vals[0], vals[1]
        en.external_work += vals[2]
        en.damping_dissipated += vals[3]
        en.contact_dissipated -= vals[4]
        en.numerical_dissipated += vals[5]
        gaps = c.g0 + c.apply(self.u) if c.p else np.zeros(0)
        return StepRecord(self.n, self.t, self.u, self.v, impulse, gaps, en)

    def destroy(self) -> None:
        self.ksp.destroy()
        self.A.destroy()
        for vec in self._vecs.values():
            vec.destroy()
