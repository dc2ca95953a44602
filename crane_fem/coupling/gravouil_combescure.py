"""Heterogeneous asynchronous coupling: explicit CD-Lagrange (Δt) + implicit Newmark (ΔT = mΔt).

THEORY.md §3 (Gravouil–Combescure, "gc") and the Prakash–Hjelmstad variant ("ph", its energy
measure in crane_fem.coupling.ph_energy, §10); see docs/theory-notes.md §5 for the derivation
of the impulse form used here. Also "ec" (§7),
"hybrid" (§8) and "gc-mean" (§9: the mean implicit velocity as the micro-step target, interface
energy a sum of squares).

Explicit side (velocity-Verlet CD, half-step velocities V_{j±1/2}); its interface velocity at
t_j is V_j = ½ (V_{j−1/2} + V_{j+1/2}), so an interface impulse Λ̂_j = Δt Λ_j applied to
V_{j+1/2} changes V_j by ½ M_E⁻¹ L_Eᵀ Λ̂_j (γ_E Δt = ½ Δt in THEORY's force form). The implicit
link velocity at t_j is taken as j/m of the end-of-step one that Λ_j would produce:
γ ΔT M̃⁻¹ L_Iᵀ Λ_j (j/m) = j γ M̃⁻¹ L_Iᵀ Λ̂_j. Multiplying the continuity condition
L_E V_E,j + L_I V_I,j = 0 by 2 gives a symmetric system, which also carries the explicit
contact rows (0 ≤ Λ_c ⟂ L_c V_{j+1/2} ≥ 0), solved together:

    [ W_ΓΓ + 2jγ W_I   W_Γc ] [Λ̂_j]     [ 2 (L_E V_j^free + L_I V_I,j^free) ]
    [ W_cΓ             W_cc ] [Λ_c ] + [ L_c V_{j+1/2}^free               ] ⟂ ...

with W_E = L M_E⁻¹ Lᵀ over the stacked rows (interface; contacts). After the m micro steps the
implicit side is corrected with Λ_m = Λ̂_m / Δt (THEORY step 3).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
import scipy.linalg
from petsc4py import PETSc

from crane_fem.contact import ContactSet, solve_mixed_lcp, solve_mixed_lcp_blocks
from crane_fem.coupling.ph_energy import PHStorage
from crane_fem.energy import BALANCE_TERMS
from crane_fem.errors import CraneFemError
from crane_fem.integrators.newmark import Newmark
from crane_fem.model import LoadFunction, StructuralModel

__all__ = ["CoupledIntegrator", "ExplicitCD", "MacroRecord"]

FloatArray = npt.NDArray[np.float64]


class ExplicitCD:
    """CD-Lagrange on the explicit subdomain, split into a free step and a constraint update.

    Rows of ``stack``: the n_Γ interface rows first, then the contact points. Collective.
    """

    def __init__(
        self,
        model: StructuralModel,
        load: LoadFunction,
        dt: float,
        u0: FloatArray,
        v0: FloatArray,
        interface: ContactSet,
        contacts: ContactSet,
    ) -> None:
        self.model, self.load, self.dt = model, load, float(dt)
        self.n_gamma = interface.p
        self.contacts = contacts
        self.stack = ContactSet.stack(interface, contacts)
        self.W = self.stack.delassus(model.minv)
        self.u = np.array(u0, dtype=np.float64)
        self.vh = np.array(v0, dtype=np.float64)
        self.v0 = np.array(v0, dtype=np.float64)
        self.ku = np.zeros_like(self.u)
        self._work = np.zeros_like(self.u)
        self._kw = np.zeros_like(self.u)
        self._vecs = [model.create_vector(a) for a in (self.u, self.ku, self._work, self._kw)]
        # K in block (3 × 3) storage for the product of every step: 1.5× faster than the
        # assembled AIJ (55 against 84 µs on the 9.5k-DOF crane). A copy owned here: convert
        # without an output matrix would convert the model's K in place.
        self._K = model.K.convert("baij", PETSc.Mat())
        self.v_int = self.v0.copy()  # velocity at the last integer time

    def _k(self, x: FloatArray) -> FloatArray:
        self._work[:] = x
        self._K.mult(self._vecs[2], self._vecs[3])
        return self._kw.copy()

    def residual(self, t: float) -> FloatArray:
        """Out-of-balance force F(t) − K U of the current displacement (collective)."""
        self._K.mult(self._vecs[0], self._vecs[1])
        return self.load(t) - self.ku

    def damping(self, v: FloatArray) -> FloatArray:
        m = self.model
        out = m.alpha * m.mass * v if m.alpha else np.zeros_like(v)
        if m.beta:
            out = out + m.beta * self._k(v)
        return out

    def free(self, t: float, h: float, move: bool) -> dict[str, FloatArray]:
        """Free step to t (``move``: U += Δt V_{j−1/2}; h = Δt, or Δt/2 for the start)."""
        if move:
            self.u += self.dt * self.vh
        self._K.mult(self._vecs[0], self._vecs[1])
        f = self.load(t)
        cv = self.damping(self.vh)
        v_free = self.vh + h * self.model.minv * (f - self.ku - cv)
        g_old, q = self.stack.gaps_and_velocities(self.vh, v_free)
        l_old = g_old - self.stack.g0  # L V_{j−1/2}
        gaps = self.stack.g0 + self.stack.apply(self.u) if self.stack.p else np.zeros(0)
        return {"f": f, "cv": cv, "v_free": v_free, "q": q, "l_old": l_old, "gaps": gaps}

    def finish(self, fr: dict[str, FloatArray], lam: FloatArray, h: float) -> dict[str, float]:
        """Apply the stacked impulses, update V_{j+1/2} and V_j; return local energy terms."""
        m = self.model
        v_old = self.vh
        jump = self.stack.transpose(lam, m.n_owned)
        v_new = fr["v_free"] + m.minv * jump
        v_int = 0.5 * (v_old + v_new)
        n_g = self.n_gamma
        lam_c = np.zeros_like(lam)
        lam_c[n_g:] = lam[n_g:]
        jump_c = self.stack.transpose(lam_c, m.n_owned)
        terms = {
            "kinetic": 0.5 * float(np.dot(v_new, m.mass * v_new)),
            "internal": 0.5 * float(np.dot(self.u, self.ku))
            + 0.5 * self.dt * float(np.dot(v_new, self.ku)),
            "external_work": h * float(np.dot(v_int, fr["f"])),
            "damping_dissipated": h * float(np.dot(v_int, fr["cv"])),
            "contact_work": float(np.dot(v_int, jump_c)),
            "link_work": float(np.dot(v_int, jump - jump_c)),
        }
        self.vh = v_new
        self.v_int = v_int
        return terms

    def save(self) -> tuple[FloatArray, ...]:
        return self.u.copy(), self.vh.copy(), self.v_int.copy()

    def restore(self, state: tuple[FloatArray, ...]) -> None:
        self.u[:] = state[0]
        self.vh = state[1].copy()
        self.v_int = state[2].copy()

    def destroy(self) -> None:
        self._K.destroy()
        for v in self._vecs:
            v.destroy()


@dataclass
class MacroRecord:
    """State at a synchronisation time t (macro step ``step``); energies are global."""

    step: int
    t: float
    energy: dict[str, float]
    explicit_u: FloatArray | None
    explicit_v: FloatArray | None
    implicit_u: FloatArray | None
    implicit_v: FloatArray | None
    contact_impulse: FloatArray
    gaps: FloatArray
    interface_impulse: FloatArray
    micro: list[tuple[float, bool]] = field(default_factory=list)
    #: ‖S_E‖ (N·s): the interface impulse the explicit side received since t = 0 (gc/ph:
    #: S_E = Σ ½Δt (Λ_j−1 + Λ_j), trapezoid like the implicit side's; ec: Σ Δt G).
    impulse_explicit: float = 0.0
    #: ‖S_E − S_I‖ (N·s), S_I the implicit side's (gc/ph: Σ ½ΔT (Λ_n + Λ_n+1), paid with the
    #: macro-step multipliers only; ec: Σ ΔT G): momentum one side received and the other
    #: did not. Zero for m = 1, and for ec.
    impulse_defect: float = 0.0


#: "ec": the constraint residual accepted after a pass, relative to the interface increments
#: (the round-off of a pass of 1000 micro steps is ~3e-9 of them),
#: and the passes allowed per macro step. With the explicit side linear over the macro step
#: the second pass meets the tolerance; a contact changing state within reach of the
#: interface makes the passes a fixed point of a nonsmooth map, which need not converge:
#: the run then stops with an error (as "ph" does).
EC_TOL = 1e-7
EC_MAX_PASSES = 8
#: Factored interface operators kept, one per set of closed contacts met.
EC_CACHE = 16
#: Energy terms an explicit pass sums over its micro steps.
LINK_TERMS = ("external_work", "damping_dissipated", "contact_work", "link_work")


@dataclass
class _Snapshot:
    """Everything a coupled macro step changes, to redo it ("hybrid")."""

    explicit: tuple[FloatArray, ...]
    implicit: tuple[FloatArray, ...]
    arrays: tuple[FloatArray, ...]
    acc: dict[str, float]
    energies: tuple[float, float, float, float]


@dataclass
class _TrapezoidStep:
    """The implicit side at the start of a trapezoidal macro step and its free increment."""

    u0: FloatArray
    v0: FloatArray
    cv0: FloatArray
    f0: FloatArray
    f1: FloatArray
    du_free: FloatArray


def _amax(x: FloatArray) -> float:
    return float(np.max(np.abs(x), initial=0.0))


ENERGY_KEYS = [
    *BALANCE_TERMS,
    "interface_dissipated",
    "interface_energy_gc",
    "interface_work_physical",
]
#: "ph" with an undamped explicit side: the interface energy in the measure of the PH
#: argument (S_E + the implicit side's energy, crane_fem.coupling.ph_energy) and S_E itself.
PH_KEYS = ["interface_energy_ph", "energy_ph_explicit"]


class CoupledIntegrator:
    """GC / PH coupling of one explicit and one implicit subdomain, or either one alone
    (monolithic reference). Owns both subdomain integrators (``destroy``, collective).

    Args:
        explicit: the explicit subdomain integrator, or None.
        implicit: the Newmark subdomain integrator, or None.
        ratio: m (ΔT = m Δt); 1 when one side is missing.
        method: "gc" (THEORY.md §3: j/m-weighted interface operators H_j; weakly unstable
            over long undamped runs, docs/theory-notes.md §6), "ph", or "ec" (multipliers
            constant over the macro step, interface displacement increments continuous: no
            interface energy, docs/theory-notes.md §7; average-acceleration Newmark only),
            "hybrid" (§8) or "gc-mean" (§9: GC against the implicit mean velocity, the
            implicit side paid the total impulse; interface energy ≥ 0 every macro step).
        l_implicit: the implicit side's interface rows (L_I).
    """

    def __init__(
        self,
        explicit: ExplicitCD | None,
        implicit: Newmark | None,
        ratio: int,
        method: str = "gc",
        l_implicit: ContactSet | None = None,
        dt: float | None = None,
        impact_ratio: int = 1,
        interface_tolerance: float = 5e-4,
    ) -> None:
        if explicit is None and implicit is None:
            raise ValueError("nothing to integrate")
        self.E, self.I, self.m, self.method = explicit, implicit, int(ratio), method
        self.LI = l_implicit
        self.dt = explicit.dt if explicit is not None else float(dt or implicit.dT)  # type: ignore[union-attr]
        self.dT = self.m * self.dt if explicit is not None else self.dt
        self.coupled = explicit is not None and implicit is not None
        self.n_gamma = explicit.n_gamma if (explicit is not None and self.coupled) else 0
        comm = (explicit or implicit).model.comm  # type: ignore[union-attr]
        self.comm = comm
        self.acc = dict.fromkeys(ENERGY_KEYS, 0.0)
        self.lam_prev = np.zeros(self.n_gamma)  # Λ̂ of the previous micro step
        self.lam_macro_prev = np.zeros(self.n_gamma)  # Λ (force) at the start of the step
        self.w_prev = np.zeros(self.n_gamma)  # L_E V_E at the previous micro step
        # Interface impulses since t = 0, explicit side (Σ Δt Λ_j) and implicit side
        # (trapezoid of the macro-step multipliers): their difference is momentum one side
        # received and the other did not.
        self.impulse_E = np.zeros(self.n_gamma)
        self.impulse_I = np.zeros(self.n_gamma)
        self.n = 0
        self._Z: FloatArray | None = None
        # "ec": the Cholesky factors of Z_E + ½ΔT² W_I per set of closed contacts, explicit
        # passes per macro step and the worst relative residual (its predictor for G is
        # ``lam_macro_prev``, the previous macro step's link force).
        self._ec_lu: dict[bytes, tuple[FloatArray, bool]] = {}
        self.ec_max_passes = EC_MAX_PASSES
        self.ec_passes: list[int] = []
        self.ec_residual = 0.0
        # "hybrid": micro steps per implicit step in the refined macro steps, the interface
        # energy of a GC step (relative to the mechanical energy) above which it is refined,
        # the Newmark operator of the refined steps (built at the first one), the interface
        # solvers per ratio, the contact set watched by ``_micro``, and the count of macro
        # steps of each kind. (The state arrays of Newmark are replaced, never changed in
        # place: ``_damping_now`` relies on it.)
        if impact_ratio < 1 or self.m % impact_ratio:
            raise ValueError(f"impact_ratio = {impact_ratio} must divide the ratio m = {self.m}")
        self.impact_ratio = int(impact_ratio)
        self.interface_tolerance = float(interface_tolerance)
        self._I_impact: Newmark | None = None
        self._solvers: dict[int, tuple[FloatArray | None, FloatArray, FloatArray]] = {}
        self._watch: npt.NDArray[np.bool_] | None = None
        self._changed = False
        self.hybrid_steps = {"gc": 0, "gc_refined": 0, "ec": 0}
        # "gc-mean": the largest gap (J) between the interface energy of a macro step booked
        # from the energy balances and its closed form (docs/theory-notes.md §9).
        self.mean_identity_error = 0.0
        self._cv_cache: tuple[FloatArray, FloatArray] | None = None
        self._setup_interface_solver()
        # "ph": the explicit side's storage S_E (docs/theory-notes.md §10) when it is
        # defined (undamped explicit side, small enough for its modes), else the reason.
        self.ph_storage: PHStorage | None = None
        self.ph_measure = "not ph"
        self._ph_prev: tuple[float, FloatArray, FloatArray] | None = None
        if self.coupled and method == "ph":
            assert explicit is not None
            if explicit.model.damped:
                self.ph_measure = "not evaluated: the explicit side is damped (not lossless)"
            else:
                try:
                    self.ph_storage = PHStorage(explicit.model, self.dt, self.m)
                    self.ph_measure = "evaluated"
                except ValueError as exc:
                    self.ph_measure = f"not evaluated: {exc}"
            if self.ph_storage is not None:
                self.acc.update(dict.fromkeys(PH_KEYS, 0.0))

    def _setup_interface_solver(self) -> None:
        """Diagonalise the micro-step interface operators once.

        The interface block of W_E is diagonal (D, lumped mass, distinct DOFs), so
        A_j = W_E,ΓΓ + 2jγ W_I = D^½ (I + 2jγ S) D^½ with S = D^-½ W_I D^-½ = Q diag(s) Qᵀ:
        one symmetric eigendecomposition serves every j, each solve costs two O(n_Γ²) products.
        """
        self._Q: FloatArray | None = None
        self._s = self._dinv_sqrt = np.zeros(0)
        if not self.coupled or self.n_gamma == 0:
            return
        E, I = self.E, self.I  # noqa: E741
        assert E is not None and I is not None
        n_g = self.n_gamma
        self._W_ec = E.W[:n_g, n_g:]
        self._W_cc = E.W[n_g:, n_g:]
        self._cc_diagonal = bool(np.all(self._W_cc == np.diag(np.diag(self._W_cc))))
        self._ec_zero = not np.any(self._W_ec)
        Wee = E.W[:n_g, :n_g]
        d = np.diag(Wee).copy()
        if np.any(Wee != np.diag(d)) or np.any(d <= 0.0):
            return  # general case: Cholesky of A_j each micro step
        self._dinv_sqrt = 1.0 / np.sqrt(d)
        S = self._dinv_sqrt[:, None] * I.W * self._dinv_sqrt[None, :]
        self._s, self._Q = np.linalg.eigh(0.5 * (S + S.T))

    def _solver_for(self, j: int) -> Callable[[FloatArray], FloatArray] | None:
        if self._Q is None:
            return None
        assert self.I is not None
        Q, ds = self._Q, self._dinv_sqrt
        scale = 1.0 / (1.0 + 2.0 * j * self.I.gamma * self._s)

        def solve(x: FloatArray) -> FloatArray:
            y = ds[:, None] * x if x.ndim == 2 else ds * x
            y = Q @ ((scale[:, None] if x.ndim == 2 else scale) * (Q.T @ y))
            return ds[:, None] * y if x.ndim == 2 else ds * y

        return solve

    # ------------------------------------------------------------------------------------
    def _sum(self, values: list[float]) -> FloatArray:
        buf = np.asarray(values, dtype=np.float64)
        out = np.empty_like(buf)
        self.comm.Allreduce(buf, out)
        return out

    def _implicit_energy(self) -> tuple[float, float]:
        I = self.I  # noqa: E741
        assert I is not None
        kin, pot = self._sum(
            [
                0.5 * float(np.dot(I.v, I.mass_action(I.v))),
                0.5 * float(np.dot(I.u, I.stiffness_action(I.u))),
            ]
        )
        return float(kin), float(pot)

    def initialize(self, interface_force: FloatArray | None = None) -> MacroRecord:
        """Explicit half step and implicit initial acceleration (collective).

        ``interface_force`` (n_Γ, N): the link forces Λ_0 at t = 0 when the subdomains start
        from a loaded equilibrium (a static preload); zero by default.
        """
        E, I = self.E, self.I  # noqa: E741
        self._e_kin = self._e_int = self._i_kin = self._i_int = 0.0
        lam = np.zeros(0)
        gaps = np.zeros(0)
        lam0 = np.zeros(self.n_gamma)
        if interface_force is not None and self.coupled:
            lam0 = np.asarray(interface_force, dtype=np.float64)
        if E is not None:
            fr = E.free(0.0, 0.5 * E.dt, move=False)
            n_g = E.n_gamma
            lam = np.zeros(E.stack.p)
            lam[:n_g] = 0.5 * E.dt * lam0  # the link impulse over the first half step
            active = E.contacts.closed(fr["gaps"][n_g:])
            if np.any(active):  # initially closed contacts
                q_c = fr["q"][n_g:] + E.W[n_g:, :n_g] @ lam[:n_g]
                lam[n_g:] = solve_mixed_lcp(E.W[n_g:, n_g:], q_c, 0, active)
            terms = E.finish(fr, lam, 0.5 * E.dt)
            E.v_int = E.v0.copy()
            kin, pot = self._sum([terms["kinetic"], terms["internal"]])
            self._e_kin, self._e_int = float(kin), float(pot)
            gaps = fr["gaps"]
        if I is not None:
            link = None
            if self.coupled and self.LI is not None:
                link = self.LI.transpose(lam0, I.model.n_owned)
            I.initialize(0.0, link)
            self._i_kin, self._i_int = self._implicit_energy()
        if E is not None and self.coupled:
            self.w_prev = E.stack.apply(E.v0)[: self.n_gamma]
            self.lam_prev = E.dt * lam0
            self.lam_macro_prev = lam0.copy()
            if self.ph_storage is not None:
                self._ph_prev = self._ph_state(0.0, lam0)
                self.acc["energy_ph_explicit"] = self._ph_prev[0]
        # The first impulses act over Δt/2: as forces, 2 Λ̂ / Δt.
        return self._record(2.0 * lam, gaps, [])

    def _record(
        self, lam: FloatArray, gaps: FloatArray, micro: list[tuple[float, bool]]
    ) -> MacroRecord:
        e = dict(self.acc)
        e["kinetic"] = self._e_kin + self._i_kin
        e["internal"] = self._e_int + self._i_int
        e["kinetic_explicit"], e["internal_explicit"] = self._e_kin, self._e_int
        e["kinetic_implicit"], e["internal_implicit"] = self._i_kin, self._i_int
        e["total"] = (
            e["kinetic"]
            + e["internal"]
            - e["external_work"]
            + e["damping_dissipated"]
            + e["contact_dissipated"]
            + e["numerical_dissipated"]
            + e["interface_dissipated"]
        )
        n_g = self.n_gamma
        E, I = self.E, self.I  # noqa: E741
        return MacroRecord(
            self.n,
            self.n * self.dT,
            e,
            E.u if E is not None else None,
            E.v_int if E is not None else None,
            I.u if I is not None else None,
            I.v if I is not None else None,
            lam[n_g:] if lam.size else np.zeros(0),
            gaps[n_g:] if gaps.size else np.zeros(0),
            lam[:n_g] / self.dt if lam.size else np.zeros(0),
            micro,
            float(np.linalg.norm(self.impulse_E)),
            float(np.linalg.norm(self.impulse_E - self.impulse_I)),
        )

    # ------------------------------------------------------------------------------------
    def _explicit_balance(self, sums: dict[str, float]) -> float:
        """Book the explicit side's summed micro-step terms (local, reduced here) and its
        energies after the macro step; return the global link work on it (collective)."""
        assert self.E is not None
        red = self._sum([sums[k] for k in LINK_TERMS] + E_energy(self.E))
        self.acc["external_work"] += red[0]
        self.acc["damping_dissipated"] += red[1]
        self.acc["contact_dissipated"] -= red[2]
        self._e_kin, self._e_int = float(red[4]), float(red[5])
        return float(red[3])

    def _damping_now(self) -> FloatArray:
        """C V of the implicit side now, from the last balance when V has not changed."""
        I = self.I  # noqa: E741
        assert I is not None
        if self._cv_cache is not None and self._cv_cache[0] is I.v:
            return self._cv_cache[1]
        return I.damping_action(I.v)

    def _implicit_balance(
        self,
        uI0: FloatArray,
        vI0: FloatArray,
        f0: FloatArray,
        f1: FloatArray,
        cv0: FloatArray,
        force: FloatArray | None,
    ) -> tuple[float, float]:
        """Book the implicit step from (U_0, V_0) to the current state: work of the load and
        of damping with the mean velocity V̄ = ½(V_0 + V_1), energies, and the algorithmic
        energy of Newmark; return the link work ΔT V̄ᵀL_IᵀΛ̄ and its displacement form
        ΔUᵀL_IᵀΛ̄ for the mean link force ``force`` (None: uncoupled) (collective)."""
        I = self.I  # noqa: E741
        assert I is not None
        vbar = 0.5 * (vI0 + I.v)
        mv1, cv1 = I.mass_and_damping(I.v)
        self._cv_cache = (I.v, cv1)  # C V at the end: the next step's C V_0
        link = phys = 0.0
        if force is not None:
            assert self.LI is not None
            fl = self.LI.transpose(force, I.model.n_owned)
            link = self.dT * float(np.dot(vbar, fl))
            phys = float(np.dot(I.u - uI0, fl))
        kin_old, pot_old = self._i_kin, self._i_int
        red = self._sum(
            [
                self.dT * float(np.dot(vbar, 0.5 * (f0 + f1))),
                self.dT * float(np.dot(vbar, 0.5 * (cv0 + cv1))),
                link,
                phys,
                0.5 * float(np.dot(I.v, mv1)),
                0.5 * float(np.dot(I.u, I.stiffness_action(I.u))),
            ]
        )
        w_ext, w_damp, link_i, phys_i = (float(x) for x in red[:4])
        self._i_kin, self._i_int = float(red[4]), float(red[5])
        self.acc["external_work"] += w_ext
        self.acc["damping_dissipated"] += w_damp
        # Algorithmic energy of Newmark in the measure ½VᵀMV + ½UᵀKU (zero for β = ¼, γ = ½
        # without damping): work of all forces in velocity form minus the energy change.
        d_energy = (self._i_kin + self._i_int) - (kin_old + pot_old)
        self.acc["numerical_dissipated"] += (w_ext - w_damp + link_i) - d_energy
        return link_i, phys_i

    def _micro(
        self,
        j: int,
        t: float,
        wI0: FloatArray,
        wIf: FloatArray,
        imposed: FloatArray | None,
        operator_step: int | None = None,
    ) -> tuple[FloatArray, FloatArray, dict[str, float], FloatArray]:
        """One explicit micro step; interface impulses solved (gc) or imposed (ph).

        The interface operator is W_E + 2kγ W_I with k = ``operator_step`` (j by default:
        GC's H_j; m for "gc-mean", whose target wI0 = wIf is the implicit mean velocity)."""
        E = self.E
        assert E is not None
        n_g, m = self.n_gamma, self.m
        k_op = j if operator_step is None else operator_step
        fr = E.free(t, E.dt, move=True)
        active = E.contacts.closed(fr["gaps"][n_g:])
        if self._watch is not None and not self._changed:
            self._changed = bool(np.any(active != self._watch))
        q = fr["q"].copy()
        solver = self._solver_for(k_op) if n_g and imposed is None else None
        if n_g and imposed is None:
            wI = (1.0 - j / m) * wI0 + (j / m) * wIf
            q[:n_g] = (fr["l_old"][:n_g] + fr["q"][:n_g]) + 2.0 * wI
            assert self.I is not None
        if n_g and imposed is None and solver is not None:
            # Interface rows eliminated with the diagonalised operator; the contact rows
            # (their Schur complement) solved as an LCP.
            lam = np.empty(E.stack.p)
            lam[:n_g], lam[n_g:] = solve_mixed_lcp_blocks(
                solver,
                self._W_ec,
                self._W_cc,
                q[:n_g],
                q[n_g:],
                active,
                self._cc_diagonal,
                self._ec_zero,
            )
        elif n_g and imposed is None:
            assert self.I is not None
            A = E.W.copy()
            A[:n_g, :n_g] += 2.0 * k_op * self.I.gamma * self.I.W
            lam = solve_mixed_lcp(A, q, n_g, active, solver)
        else:
            A = E.W
            lam = np.zeros(E.stack.p)
            if imposed is not None:
                lam[:n_g] = imposed
                q[n_g:] += A[n_g:, :n_g] @ imposed
            sub = solve_mixed_lcp(A[n_g:, n_g:], q[n_g:], 0, active)
            lam[n_g:] = sub
        u_old = E.u.copy() - E.dt * E.vh  # U_{j-1}
        terms = E.finish(fr, lam, E.dt)
        w = E.stack.apply(E.v_int)[:n_g] if n_g else np.zeros(0)
        # GC-measure (trapezoid, velocity form) and physical interface work of the E side.
        if n_g:
            lbar = 0.5 * (self.lam_prev + lam[:n_g])
            du = E.stack.apply(E.u - u_old)[:n_g]
            terms["gc_work"] = float(np.dot(lbar, 0.5 * (self.w_prev + w)))
            terms["phys_work"] = float(np.dot(lbar / E.dt, du))
        self.lam_prev = lam[:n_g].copy()
        self.w_prev = w
        return lam, fr["gaps"], terms, w

    def step(self) -> MacroRecord:
        """One macro step (m micro steps when coupled) (collective)."""
        if self.coupled and self.method == "ec":
            return self._step_ec()
        if self.coupled and self.method == "hybrid":
            return self._step_hybrid()
        if self.coupled and self.method == "gc-mean":
            lam, gaps, micro, G = self._mean_macro(self.n * self.dT)
            return self._ec_record(lam, gaps, micro, G)
        lam, gaps, micro = self._gc_macro(self.n * self.dT)
        self.n += 1
        return self._record(lam, gaps, micro)

    def _gc_macro(self, t0: float) -> tuple[FloatArray, FloatArray, list[tuple[float, bool]]]:
        """The GC (or PH) step [t0, t0 + ΔT] with the current m, ΔT and implicit side; books
        its energy terms; returns the last multipliers, gaps and the micro-step contact flags
        (collective)."""
        E, I, m = self.E, self.I, self.m  # noqa: E741
        t1 = t0 + self.dT
        n_g = self.n_gamma
        micro: list[tuple[float, bool]] = []
        e_local = dict.fromkeys(LINK_TERMS, 0.0)
        gc_e = phys_e = 0.0
        lam = np.zeros(0)
        gaps = np.zeros(0)
        if I is not None:
            cv0 = self._damping_now()
            uf, vf, af = I.free_step(t1)
            uI0, vI0 = I.u.copy(), I.v.copy()
            f0 = I.load(t0)
        if E is not None:
            wI0 = wIf = np.zeros(n_g)
            if self.coupled:
                assert self.LI is not None
                wI0, wIf = self.LI.apply(vI0)[:n_g], self.LI.apply(vf)[:n_g]
            imposed_ramp = None
            if self.coupled and self.method == "ph":
                lam_m = self._ph_solve(t0, wIf)
                imposed_ramp = lam_m
            for j in range(1, (m if self.coupled else 1) + 1):
                tj = t0 + j * E.dt
                imposed = None
                if imposed_ramp is not None:
                    imposed = E.dt * ((1 - j / m) * self.lam_macro_prev + (j / m) * imposed_ramp)
                lam_before = self.lam_prev.copy()
                lam, gaps, terms, _ = self._micro(j, tj, wI0, wIf, imposed)
                if self.coupled:  # trapezoid over [t_j−1, t_j], as the implicit side's
                    self.impulse_E += 0.5 * (lam_before + lam[:n_g])
                for k in e_local:
                    e_local[k] += terms[k]
                gc_e += terms.get("gc_work", 0.0)
                phys_e += terms.get("phys_work", 0.0)
                active_c = bool(np.any(lam[n_g:] > 0.0))
                micro.append((tj, active_c))
                if active_c and self.method == "ph" and self.coupled:
                    raise CraneFemError(
                        f"coupling method 'ph' needs the explicit subdomain to be linear over "
                        f"each macro step, but a contact is active at t = {tj:.6g} s; "
                        "use coupling.method = 'gc'"
                    )
            # gc_e and phys_e are already global (dot products of reduced interface vectors).
            link_e, gc_e_g, phys_e_g = self._explicit_balance(e_local), gc_e, phys_e
        if I is not None:
            I.accept(uf, vf, af)
            lam_force = lam[:n_g] / self.dt if (self.coupled and lam.size) else np.zeros(0)
            if self.coupled:
                I.correct(lam_force)
                self.impulse_I += 0.5 * self.dT * (self.lam_macro_prev + lam_force)
            mean_force = 0.5 * (self.lam_macro_prev + lam_force) if self.coupled else None
            link_i, phys_i = self._implicit_balance(uI0, vI0, f0, I.load(t1), cv0, mean_force)
            self.lam_macro_prev = lam_force
            if self.ph_storage is not None:
                self._ph_book(t1, lam_force, link_i)
        if self.coupled:
            self.acc["interface_dissipated"] -= link_e + link_i
            self.acc["interface_energy_gc"] -= gc_e_g + link_i
            self.acc["interface_work_physical"] -= phys_e_g + phys_i
        return lam, gaps, micro

    def _ph_state(self, t: float, lam_force: FloatArray) -> tuple[float, FloatArray, FloatArray]:
        """(S_E, V_E, F_E) at the macro time t: the storage of the explicit side for its
        integer-step velocity and total force (link force Λ plus the load), then the two
        vectors for the next trapezoidal supply (collective)."""
        E = self.E
        assert E is not None and self.ph_storage is not None
        full = np.zeros(E.stack.p)
        full[: self.n_gamma] = lam_force
        load = E.load(t)
        force = E.stack.transpose(full, E.model.n_owned) + load
        return self.ph_storage(E.u, E.v_int, force), E.v_int.copy(), load.copy()

    def _ph_book(self, t1: float, lam_force: FloatArray, link_i: float) -> None:
        """Book the interface energy of a "ph" macro step in the measure of its argument:
        −(ΔS_E − W_E + link work on the implicit side), W_E the load's trapezoidal supply
        ΔT·½(V_n + V_n+1)ᵀ·½(F_n + F_n+1) on the explicit side (collective)."""
        assert self._ph_prev is not None
        s0, v0, f0 = self._ph_prev
        self._ph_prev = self._ph_state(t1, lam_force)
        s1, v1, f1 = self._ph_prev
        w_ext = float(self._sum([0.25 * self.dT * float(np.dot(v0 + v1, f0 + f1))])[0])
        self.acc["interface_energy_ph"] -= (s1 - s0 - w_ext) + link_i
        self.acc["energy_ph_explicit"] = s1

    # ------------------------------------------------------------------------------------
    # The implicit side in the displacement–velocity form of the trapezoidal rule ("ec",
    # "gc-mean"): a free increment at the start of the macro step, the link increment of a
    # force G constant over it at the end.
    def _trapezoid_start(self, t0: float) -> _TrapezoidStep:
        """The implicit state at t0 and its free trapezoidal increment to t0 + ΔT."""
        I = self.I  # noqa: E741
        assert I is not None
        f0, f1 = I.load(t0), I.load(t0 + self.dT)
        return _TrapezoidStep(
            I.u.copy(), I.v.copy(), self._damping_now(), f0, f1, I.trapezoid_free_increment(f0, f1)
        )

    def _trapezoid_finish(
        self, st: _TrapezoidStep, G: FloatArray, impulse: FloatArray, sums: dict[str, float]
    ) -> float:
        """Implicit side: ΔU = ΔU_free + ½ΔT² M̃⁻¹ L_Iᵀ G, V_n+1 = 2ΔU/ΔT − V_n; it receives
        ``impulse`` = ΔT G (as the explicit side summed it, so that the two agree to the last
        bit). Books both sides' terms (the explicit ones summed in ``sums``) and
        the interface energy; returns the link work of G on both sides (collective)."""
        I, dT = self.I, self.dT  # noqa: E741
        assert I is not None
        du = st.du_free + 0.5 * dT * dT * I.link_response(G)
        I.accept(st.u0 + du, 2.0 * du / dT - st.v0, I.a)
        self.impulse_I += impulse
        # V̄ = ½(V_0 + V_1) = ΔU/ΔT here, so both link-work forms are Gᵀ L_I ΔU.
        link_i, _ = self._implicit_balance(st.u0, st.v0, st.f0, st.f1, st.cv0, G)
        link = self._explicit_balance(sums) + link_i
        self.acc["interface_dissipated"] -= link
        self.acc["interface_energy_gc"] -= link
        self.acc["interface_work_physical"] -= link
        self.lam_macro_prev = G.copy()
        return link

    # ------------------------------------------------------------------------------------
    # "gc-mean": GC with the implicit side's mean velocity over the macro step as the
    # explicit side's target and the total interface impulse paid to the implicit side
    # (docs/theory-notes.md §9). Its interface energy is −½ Σ_{i<j} (Λ̂_i − Λ̂_j)ᵀ W_I
    # (Λ̂_i − Λ̂_j) ≤ 0 at every macro step (zero for m = 1), contacts or not.
    def _mean_macro(
        self, t0: float
    ) -> tuple[FloatArray, FloatArray, list[tuple[float, bool]], FloatArray]:
        """The "gc-mean" step [t0, t0 + ΔT]: implicit free trapezoidal increment ΔU_free,
        whose mean interface velocity a = L_I ΔU_free / ΔT is the target of every micro step,

            L_E V_j + a + ½ m W_I Λ̂_j = 0     (with the explicit contacts, one mixed LCP),

        then the implicit link increment ½ΔT M̃⁻¹ L_Iᵀ S for the total impulse S = Σ_j Λ̂_j
        (a constant force S/ΔT in the trapezoidal rule). Books its energy terms; returns the
        last multipliers, gaps, micro-step contact flags and S/ΔT (collective)."""
        E, I = self.E, self.I  # noqa: E741
        assert E is not None and I is not None and self.LI is not None
        n_g, m, dT = self.n_gamma, self.m, self.dT
        st = self._trapezoid_start(t0)
        a = self.LI.apply(st.du_free)[:n_g] / dT
        sums = dict.fromkeys(LINK_TERMS, 0.0)
        micro: list[tuple[float, bool]] = []
        impulses = np.empty((m, n_g))  # Λ̂_j, for the dissipation identity
        lam = gaps = np.zeros(0)
        for j in range(1, m + 1):
            tj = t0 + j * E.dt
            lam, gaps, terms, _ = self._micro(j, tj, a, a, None, operator_step=m)
            impulses[j - 1] = lam[:n_g]
            for k in sums:
                sums[k] += terms[k]
            micro.append((tj, bool(np.any(lam[n_g:] > 0.0))))
        S = impulses.sum(axis=0)
        self.impulse_E += S
        G = S / dT
        link = self._trapezoid_finish(st, G, S, sums)
        # The interface energy booked from the two sides' energy identities against its
        # closed form ½ (m Σ_j Λ̂_jᵀ W_I Λ̂_j − Sᵀ W_I S) = ½ Σ_{i<j} ‖Λ̂_i − Λ̂_j‖²_{W_I}.
        sq = float(np.einsum("ij,ij->", impulses @ I.W, impulses))  # Σ_j Λ̂_jᵀ W_I Λ̂_j
        closed_form = 0.5 * (m * sq - float(S @ (I.W @ S)))
        self.mean_identity_error = max(self.mean_identity_error, abs(-link - closed_form))
        return lam, gaps, micro, G

    # ------------------------------------------------------------------------------------
    # "ec": multipliers constant over the macro step, continuity of the interface
    # displacement increment (docs/theory-notes.md §7). The interface work of the step is
    # Gᵀ(L_E D_E + L_I ΔU_I), zero when the constraint holds: no interface energy for any m.
    def _ec_pass(
        self, t0: float, G: FloatArray
    ) -> tuple[FloatArray, FloatArray, dict[str, float], list[tuple[float, bool]], FloatArray]:
        """The m micro steps under the constant link force G; returns the last impulses and
        gaps, the summed local energy terms, the micro-step contact flags and L_E D_E with
        D_E = ½(U_m + U_m+1) − ½(U_0 + U_1) = Σ_j Δt V_j."""
        E = self.E
        assert E is not None
        n_g = self.n_gamma
        lin = E.stack
        d0 = lin.apply(E.u + 0.5 * E.dt * E.vh)[:n_g]
        sums = dict.fromkeys(LINK_TERMS, 0.0)
        micro: list[tuple[float, bool]] = []
        lam = gaps = np.zeros(0)
        for j in range(1, self.m + 1):
            tj = t0 + j * E.dt
            lam, gaps, terms, _ = self._micro(j, tj, G, G, E.dt * G)
            # The impulses Δt G at t_n+1 … t_n+m are this macro step's, as ΔT G on the
            # implicit side: summed as they are applied.
            self.impulse_E += lam[:n_g]
            for k in sums:
                sums[k] += terms[k]
            micro.append((tj, bool(np.any(lam[n_g:] > 0.0))))
        d1 = lin.apply(E.u + 0.5 * E.dt * E.vh)[:n_g]
        return lam, gaps, sums, micro, d1 - d0

    def _interface_response(
        self, closed: npt.NDArray[np.bool_] | None = None, ramp: bool = False
    ) -> FloatArray:
        """The explicit side's linear interface response over one macro step from rest, no
        load, column k for the unit link force e_k: constant (``ramp`` False, "ec") with
        Z[:, k] = L_E D_E, or the ramp (j/m) e_k ("ph") with Z[:, k] = L_E V_E,m. The
        ``closed`` contact points are held as bilateral constraints, the others open (n_Γ
        linear runs of m micro steps; collective)."""
        E = self.E
        assert E is not None
        n_g, m = self.n_gamma, self.m
        zero = np.zeros_like(E.u)
        keep = closed if closed is not None else np.zeros(E.contacts.p, dtype=bool)
        contacts = E.contacts.subset(keep)
        probe = ExplicitCD(E.model, lambda t: zero, E.dt, zero, zero, _rows(E.stack, n_g), contacts)
        p_c = probe.stack.p - n_g
        w_cc = scipy.linalg.cho_factor(probe.W[n_g:, n_g:]) if p_c else None
        Z = np.zeros((n_g, n_g))
        try:
            for k in range(n_g):
                probe.u[:] = 0.0
                probe.vh = np.zeros_like(zero)
                lam = np.zeros(probe.stack.p)
                for j in range(1, m + 1):
                    fr = probe.free(0.0, E.dt, move=True)
                    lam[:] = 0.0
                    lam[k] = E.dt * (j / m if ramp else 1.0)
                    if w_cc is not None:
                        q_c = fr["q"][n_g:] + probe.W[n_g:, k] * lam[k]
                        lam[n_g:] = -scipy.linalg.cho_solve(w_cc, q_c)
                    probe.finish(fr, lam, E.dt)
                end = probe.v_int if ramp else probe.u + 0.5 * E.dt * probe.vh
                Z[:, k] = probe.stack.apply(end)[:n_g]
        finally:
            probe.destroy()
        return Z if ramp else 0.5 * (Z + Z.T)

    def _ec_factor(self, closed: npt.NDArray[np.bool_]) -> tuple[FloatArray, bool]:
        """Cholesky factor of Z_E + ½ΔT² W_I for the set of closed contacts (cached)."""
        assert self.I is not None
        key = closed.tobytes()
        if key not in self._ec_lu:
            if len(self._ec_lu) >= EC_CACHE:  # drop the oldest contact set
                del self._ec_lu[next(iter(self._ec_lu))]
            J = self._interface_response(closed) + 0.5 * self.dT * self.dT * self.I.W
            self._ec_lu[key] = scipy.linalg.cho_factor(J)
        return self._ec_lu[key]

    def _step_ec(self) -> MacroRecord:
        """One macro step of the "ec" coupling (collective)."""
        E = self.E
        assert E is not None
        closed = E.contacts.closed(self._contact_gaps())
        out = self._ec_macro(self.n * self.dT, closed, fallback=False)
        assert out is not None
        return self._ec_record(*out)

    def _contact_gaps(self) -> FloatArray:
        """Gaps of the explicit contact points at the current time (global)."""
        E = self.E
        assert E is not None
        n_g = self.n_gamma
        return E.stack.g0[n_g:] + E.stack.apply(E.u)[n_g:]

    def _ec_record(
        self, lam: FloatArray, gaps: FloatArray, micro: list[tuple[float, bool]], G: FloatArray
    ) -> MacroRecord:
        self.n += 1
        rec = self._record(lam, gaps, micro)
        rec.interface_impulse = G.copy()
        return rec

    def _ec_macro(
        self, t0: float, closed: npt.NDArray[np.bool_], fallback: bool
    ) -> tuple[FloatArray, FloatArray, list[tuple[float, bool]], FloatArray] | None:
        """The "ec" step [t0, t0 + ΔT]: implicit free trapezoidal increment, explicit passes
        under a constant link force G corrected until the interface displacement increments
        agree (one correction when no contact changes state between passes), then the
        implicit link increment ½ΔT² M̃⁻¹ L_Iᵀ G. Books its energy terms and returns the last
        multipliers, gaps, micro-step contact flags and G (collective).

        ``closed``: the contacts closed at t0 (held in the Newton direction). With
        ``fallback`` ("hybrid"), a pass in which a contact becomes active, or passes that do
        not converge, leave every state as it was at t0 and return None; without it,
        non-convergence is an error."""
        E, I = self.E, self.I  # noqa: E741
        assert E is not None and I is not None and self.LI is not None
        n_g, dT = self.n_gamma, self.dT
        t1 = t0 + dT
        # Newton direction from the explicit compliance with the contacts as they are at the
        # start of the step (closed ones held as bilateral constraints).
        factor = self._ec_factor(closed)
        st = self._trapezoid_start(t0)
        r_I = self.LI.apply(st.du_free)[:n_g]
        start = self._snapshot()  # each pass starts from t0
        G = self.lam_macro_prev.copy()  # predictor: the previous macro step's G
        for k in range(self.ec_max_passes):
            if k:
                self._restore(start)
            lam, gaps, sums, micro, ld = self._ec_pass(t0, G)
            if fallback and any(a for _, a in micro):
                self._restore(start)
                return None
            r = ld + r_I + 0.5 * dT * dT * (I.W @ G)
            scale = max(_amax(ld), _amax(r_I), 1e-300)
            if _amax(r) <= EC_TOL * scale:
                break
            if k == self.ec_max_passes - 1:
                if fallback:
                    self._restore(start)
                    return None
                raise CraneFemError(
                    f"coupling method 'ec': the interface constraint of the macro step ending "
                    f"at t = {t1:.6g} s is still off by {_amax(r) / scale:.2e} (relative) after "
                    f"{k + 1} explicit passes: a contact changing state within the step, within "
                    "reach of the interface, makes the explicit side nonlinear (the passes "
                    "need not converge); use coupling.method = 'gc' or 'hybrid'"
                )
            G = G - scipy.linalg.cho_solve(factor, r)
        self.ec_passes.append(k + 1)
        self.ec_residual = max(self.ec_residual, _amax(r) / scale)
        self._trapezoid_finish(st, G, dT * G, sums)  # the work of G on both sides: Gᵀ r
        return lam, gaps, micro, G

    # ------------------------------------------------------------------------------------
    # "hybrid": ec while every explicit contact is open (the explicit side is linear, the
    # interface then conserves energy), GC otherwise; a GC macro step in which a contact
    # changes state (an impact, a lift-off), or whose interface energy exceeds
    # ``interface_tolerance`` × the mechanical energy, is redone as m / r GC steps of r micro
    # steps (docs/theory-notes.md §8).
    def _snapshot(self) -> _Snapshot:
        E, I = self.E, self.I  # noqa: E741
        assert E is not None and I is not None
        arrays = (self.lam_prev, self.lam_macro_prev, self.w_prev, self.impulse_E, self.impulse_I)
        return _Snapshot(
            E.save(),
            (I.u.copy(), I.v.copy(), I.a.copy()),
            tuple(a.copy() for a in arrays),
            dict(self.acc),
            (self._e_kin, self._e_int, self._i_kin, self._i_int),
        )

    def _restore(self, snap: _Snapshot) -> None:
        E, I = self.E, self.I  # noqa: E741
        assert E is not None and I is not None
        E.restore(snap.explicit)
        I.u, I.v, I.a = (x.copy() for x in snap.implicit)
        arrays = [x.copy() for x in snap.arrays]
        self.lam_prev, self.lam_macro_prev, self.w_prev, self.impulse_E, self.impulse_I = arrays
        self.acc = dict(snap.acc)
        self._e_kin, self._e_int, self._i_kin, self._i_int = snap.energies

    def _use_ratio(self, m: int, implicit: Newmark) -> None:
        """Run the next GC steps with m micro steps per step on ``implicit`` (its ΔT = mΔt)."""
        self.I, self.m, self.dT = implicit, m, m * self.dt
        if m not in self._solvers:
            self._setup_interface_solver()
            self._solvers[m] = (self._Q, self._s, self._dinv_sqrt)
        self._Q, self._s, self._dinv_sqrt = self._solvers[m]

    def _gc_refined(self, t0: float) -> tuple[FloatArray, FloatArray, list[tuple[float, bool]]]:
        """The macro step [t0, t0 + ΔT] as m / r GC steps of r micro steps; the implicit
        state (U, V, A of average acceleration or any Newmark) carries over both ways."""
        I, m, r = self.I, self.m, self.impact_ratio  # noqa: E741
        assert I is not None
        if self._I_impact is None:
            self._solvers.setdefault(m, (self._Q, self._s, self._dinv_sqrt))
            self._I_impact = Newmark(
                I.model, I.load, r * self.dt, I.u, I.v, I.beta, I.gamma, I.interface, I.consistent
            )
        fine = self._I_impact
        fine.u, fine.v, fine.a = I.u.copy(), I.v.copy(), I.a.copy()
        self._use_ratio(r, fine)
        micro: list[tuple[float, bool]] = []
        try:
            for i in range(m // r):
                lam, gaps, mic = self._gc_macro(t0 + i * r * self.dt)
                micro += mic
        finally:
            I.u, I.v, I.a = fine.u.copy(), fine.v.copy(), fine.a.copy()
            self._use_ratio(m, I)
        return lam, gaps, micro

    def _mechanical_energy(self) -> float:
        """Kinetic + internal energy of both sides (global)."""
        return self._e_kin + self._e_int + self._i_kin + self._i_int

    def _step_hybrid(self) -> MacroRecord:
        """One macro step of the "hybrid" coupling (collective; every decision is taken on
        global quantities, the same on every rank)."""
        E, I = self.E, self.I  # noqa: E741
        assert E is not None and I is not None and self.LI is not None
        t0 = self.n * self.dT
        closed = E.contacts.closed(self._contact_gaps())
        if not np.any(closed):
            out = self._ec_macro(t0, closed, fallback=True)
            if out is not None:
                # The next step may be GC: the acceleration at t0 + ΔT under the force G.
                I.initialize(t0 + self.dT, self.LI.transpose(out[3], I.model.n_owned))
                self.hybrid_steps["ec"] += 1
                return self._ec_record(*out)
        snap = self._snapshot() if self.impact_ratio < self.m else None
        e_gamma, mech = self.acc["interface_dissipated"], self._mechanical_energy()
        self._watch, self._changed = closed, False
        try:
            lam, gaps, micro = self._gc_macro(t0)
        finally:
            self._watch = None
        d_gamma = abs(self.acc["interface_dissipated"] - e_gamma)
        mech = max(mech, self._mechanical_energy())
        if snap is not None and (self._changed or d_gamma > self.interface_tolerance * mech):
            self._restore(snap)
            lam, gaps, micro = self._gc_refined(t0)
            self.hybrid_steps["gc_refined"] += 1
        else:
            self.hybrid_steps["gc"] += 1
        self.n += 1
        return self._record(lam, gaps, micro)

    def _ph_solve(self, t0: float, wIf: FloatArray) -> FloatArray:
        """Prakash–Hjelmstad: Λ_m from continuity at the macro step only (explicit linear)."""
        E, I = self.E, self.I  # noqa: E741
        assert E is not None and I is not None
        n_g, m = self.n_gamma, self.m
        if self._Z is None:
            self._Z = self._interface_response(ramp=True)
        state = E.save()
        lam_prev_saved, w_prev_saved = self.lam_prev.copy(), self.w_prev.copy()
        w = np.zeros(n_g)
        for j in range(1, m + 1):
            imposed = E.dt * (1 - j / m) * self.lam_macro_prev
            lam, _, _, w = self._micro(j, t0 + j * E.dt, w, w, imposed)
            if np.any(lam[n_g:] > 0.0):
                raise CraneFemError(
                    "coupling method 'ph' needs the explicit subdomain to be linear over each "
                    f"macro step, but a contact is active at t = {t0 + j * E.dt:.6g} s; use "
                    "coupling.method = 'gc'"
                )
        E.restore(state)
        self.lam_prev, self.w_prev = lam_prev_saved, w_prev_saved
        H = self._Z + I.gamma * self.dT * I.W
        return np.linalg.solve(H, -(w + wIf))

    def destroy(self) -> None:
        if self.E is not None:
            self.E.destroy()
        if self.I is not None:
            self.I.destroy()
        if self._I_impact is not None:
            self._I_impact.destroy()


def _rows(stack: ContactSet, n: int) -> ContactSet:
    """The first n rows of a stacked constraint set."""
    return stack.subset(np.arange(stack.p) < n)


def E_energy(E: ExplicitCD) -> list[float]:
    """Local shadow kinetic and internal energy of the explicit side after a micro step."""
    m = E.model
    return [
        0.5 * float(np.dot(E.vh, m.mass * E.vh)),
        0.5 * float(np.dot(E.u, E.ku)) + 0.5 * E.dt * float(np.dot(E.vh, E.ku)),
    ]
