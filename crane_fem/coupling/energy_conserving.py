"""The energy-conserving coupling (method "ec", docs/theory-notes.md §7).

Link multipliers constant over the macro step, G, and continuity of the interface displacement
increments instead of the velocities: the interface work of the step is
Gᵀ(L_E D_E + L_I ΔU_I), zero when the constraint holds, so there is no interface energy for
any m. The implicit side takes the trapezoidal rule in its displacement–velocity form. G is
found by Newton passes of the explicit side over the macro step, with the explicit side's
linear interface response Z (n_Γ probes of m micro steps, the contacts closed at t0 held as
bilateral rows) plus ½ΔT² W_I as the Jacobian; with the explicit side linear the second pass
meets the tolerance. A contact changing state within reach of the interface makes the passes a
fixed point of a nonsmooth map, which need not converge: the run then stops with an error.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt
import scipy.linalg

from crane_fem.coupling.protocol import MethodBase, MethodSetup
from crane_fem.coupling.system import CoupledSystem, MacroRecord, MicroTrace
from crane_fem.errors import CraneFemError
from crane_fem.integrators.explicit_zone import ExplicitZone
from crane_fem.kernels import explicit as kx
from crane_fem.loading.body import AffineLoad

__all__ = [
    "EC_CACHE",
    "EC_MAX_PASSES",
    "EC_TOL",
    "ECStep",
    "EnergyConserving",
    "create",
    "interface_response",
]

FloatArray = npt.NDArray[np.float64]

#: The constraint residual accepted after a pass, relative to the interface increments (the
#: round-off of a pass of 1000 micro steps is ~3e-9 of them), and the passes allowed per
#: macro step.
EC_TOL = 1e-7
EC_MAX_PASSES = 8
#: Factored interface operators kept, one per set of closed contacts met.
EC_CACHE = 16


def _amax(x: FloatArray) -> float:
    return float(np.max(np.abs(x), initial=0.0))


def interface_response(
    E: ExplicitZone, m: int, closed: npt.NDArray[np.bool_] | None = None, ramp: bool = False
) -> FloatArray:
    """The explicit side's linear interface response over one macro step from rest, no load,
    column k for the unit link force e_k: constant (``ramp`` False, "ec") with
    Z[:, k] = L_E D_E, D_E = Σ_j Δt V_j, or the ramp (j/m) e_k ("ph") with Z[:, k] = L_E V_E,m.
    The ``closed`` contact points are held as bilateral constraints, the others open (n_Γ
    linear runs of m micro steps in the compiled kernel; collective)."""
    n_g, dt = E.n_gamma, E.dt
    keep = closed if closed is not None else np.zeros(E.contacts.p, dtype=bool)
    contacts = E.contacts.subset(keep)
    rows = E.stack.subset(np.arange(E.stack.p) < n_g)
    n_own = E.model.n_owned
    zero = np.zeros(n_own)
    probe = ExplicitZone(E.model, AffineLoad(zero), dt, zero, zero, rows, contacts)
    try:
        p_c = probe.stack.p - n_g
        if p_c:
            probe.with_bilateral_contacts(np.linalg.inv(probe.W[n_g:, n_g:]))
        law = kx.LAW_BILATERAL if p_c else kx.LAW_LCP
        j = np.arange(1, m + 1)
        ic = np.column_stack([j / m if ramp else np.ones(m), np.zeros(m)])
        Z = np.zeros((n_g, n_g))
        initial = probe.save()
        for k in range(n_g):
            probe.restore(initial)
            e = np.zeros(n_g)
            e[k] = 1.0
            ctl = probe.steps(0.0, m, mode=kx.IMPOSED, law=law, imposed=(e, np.zeros(n_g)), ic=ic)
            probe.advance(ctl)
            end = probe.v_int if ramp else probe.u + 0.5 * dt * probe.vh
            Z[:, k] = probe.stack.apply(end)[:n_g]
    finally:
        probe.destroy()
    return Z if ramp else 0.5 * (Z + Z.T)


class ECStep:
    """What an "ec" macro step returns: last stacked impulses and gaps, micro-step contact
    flags, and the link force G."""

    __slots__ = ("G", "gaps", "lam", "micro")

    def __init__(self, lam: FloatArray, gaps: FloatArray, micro: MicroTrace, G: FloatArray) -> None:
        self.lam, self.gaps, self.micro, self.G = lam, gaps, micro, G


class EnergyConserving(MethodBase):
    """The "ec" coupling (average-acceleration Newmark only; collective)."""

    name = "ec"

    def __init__(self, system: CoupledSystem) -> None:
        super().__init__(system)
        # Cholesky factors of Z_E + ½ΔT² W_I per set of closed contacts, explicit passes per
        # macro step and the worst relative residual (the predictor for G is
        # ``lam_macro_prev``, the previous macro step's link force).
        self._factors: dict[bytes, tuple[FloatArray, bool]] = {}
        self.max_passes = EC_MAX_PASSES
        self.passes: list[int] = []
        self.residual = 0.0

    def step(self) -> MacroRecord:
        s = self.system
        closed = s.E.contacts.closed(s.contact_gaps())  # type: ignore[union-attr]
        res = self.macro(s.t, closed, fallback=False)
        assert res is not None
        return self.record(res)

    def record(self, res: ECStep) -> MacroRecord:
        s = self.system
        s.advance()
        return s.record(res.lam, res.gaps, res.micro, res.G.copy())

    def _factor(self, closed: npt.NDArray[np.bool_]) -> tuple[FloatArray, bool]:
        """Cholesky factor of Z_E + ½ΔT² W_I for the set of closed contacts (cached)."""
        s = self.system
        assert s.E is not None and s.I is not None
        key = closed.tobytes()
        if key not in self._factors:
            if len(self._factors) >= EC_CACHE:  # drop the oldest contact set
                del self._factors[next(iter(self._factors))]
            J = interface_response(s.E, s.m, closed) + 0.5 * s.dT * s.dT * s.I.W
            self._factors[key] = scipy.linalg.cho_factor(J)
        return self._factors[key]

    def _pass(self, t0: float, G: FloatArray) -> tuple[kx.StepsOut, FloatArray]:
        """The m micro steps under the constant link force G; returns the kernel's output
        and L_E D_E with D_E = ½(U_m + U_m+1) − ½(U_0 + U_1) = Σ_j Δt V_j."""
        s = self.system
        E = s.E
        assert E is not None
        n_g, m = s.n_gamma, s.m
        d0 = E.stack.apply(E.u + 0.5 * E.dt * E.vh)[:n_g]
        ctl = E.steps(
            t0, m, mode=kx.IMPOSED, imposed=(G, np.zeros(n_g)), ic=np.tile([1.0, 0.0], (m, 1))
        )
        out = E.advance(ctl)
        # The impulses Δt G at t_n+1 … t_n+m are this macro step's, as ΔT G on the implicit
        # side: summed as they are applied.
        s.impulse_E += out.impulse_sum
        d1 = E.stack.apply(E.u + 0.5 * E.dt * E.vh)[:n_g]
        return out, d1 - d0

    def macro(self, t0: float, closed: npt.NDArray[np.bool_], fallback: bool) -> ECStep | None:
        """The step [t0, t0 + ΔT]: implicit free trapezoidal increment, explicit passes under
        a constant link force G corrected until the interface displacement increments agree
        (one correction when no contact changes state between passes), then the implicit
        link increment ½ΔT² M̃⁻¹ L_Iᵀ G. Books its energy terms (collective).

        ``closed``: the contacts closed at t0 (held in the Newton direction). With
        ``fallback`` ("hybrid"), a pass in which a contact becomes active, or passes that do
        not converge, leave every state as it was at t0 and return None; without it,
        non-convergence is an error."""
        s = self.system
        I = s.I  # noqa: E741
        assert I is not None
        dT = s.dT
        t1 = t0 + dT
        factor = self._factor(closed)
        st = s.trapezoid_start(t0)
        r_I = I.interface_values(st.du_free)
        start = s.snapshot()  # each pass starts from t0
        G = s.lam_macro_prev.copy()  # predictor: the previous macro step's G
        for k in range(self.max_passes):
            if k:
                s.restore(start)
            out, ld = self._pass(t0, G)
            if fallback and bool(np.any(out.active)):
                s.restore(start)
                return None
            r = ld + r_I + 0.5 * dT * dT * (I.W @ G)
            scale = max(_amax(ld), _amax(r_I), 1e-300)
            if _amax(r) <= EC_TOL * scale:
                break
            if k == self.max_passes - 1:
                if fallback:
                    s.restore(start)
                    return None
                raise CraneFemError(
                    f"coupling method 'ec': the interface constraint of the macro step ending "
                    f"at t = {t1:.6g} s is still off by {_amax(r) / scale:.2e} (relative) after "
                    f"{k + 1} explicit passes: a contact changing state within the step, within "
                    "reach of the interface, makes the explicit side nonlinear (the passes "
                    "need not converge); use coupling.method = 'gc' or 'hybrid'"
                )
            G = G - scipy.linalg.cho_solve(factor, r)
        self.passes.append(k + 1)
        self.residual = max(self.residual, _amax(r) / scale)
        s.trapezoid_finish(st, G, dT * G, out)  # the work of G on both sides: Gᵀ r
        return ECStep(out.lam, out.gaps, s.micro_trace(t0, out), G)

    def method_state(self) -> dict[str, Any]:
        """The passes per macro step and the worst residual (the cached factors are rebuilt
        on demand, the same)."""
        return {"passes": np.asarray(self.passes, dtype=np.int64), "residual": self.residual}

    def load_method_state(self, state: dict[str, Any]) -> None:
        self.passes = [int(k) for k in state["passes"]]
        self.residual = float(state["residual"])

    def summary(self) -> dict[str, Any]:
        if not self.passes:
            return {}
        return {
            "ec_passes_mean": float(np.mean(self.passes)),
            "ec_passes_max": int(np.max(self.passes)),
            "ec_residual_max": self.residual,
        }


def create(system: CoupledSystem, setup: MethodSetup) -> EnergyConserving:
    """ "ec" (no operator or keys of its own)."""
    return EnergyConserving(system)
