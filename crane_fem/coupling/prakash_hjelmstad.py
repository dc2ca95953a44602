"""Prakash–Hjelmstad (method "ph"): continuity at the macro step only, the link force linear
in time over the macro step (Prakash & Hjelmstad IJNME 2004; THEORY.md §3, docs/theory-notes.md
§10).

Λ_m comes from one linear solve at the start of each macro step: a predictor pass of the
explicit side under the ramp of the previous link force alone gives its free interface
velocity w at t_n+m, and the explicit side's linear response to a ramp of unit link forces,
Z (n_Γ probes of m micro steps, computed once), gives (Z + γΔT W_I) Λ_m = −(w + L_I V_I^free).
The explicit side must be linear over the macro step: an active contact stops the run. Its
interface energy is booked in the measure in which PH is lossless (crane_fem.coupling.ph_energy)
when the explicit side is undamped and small enough for its modes.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from crane_fem.coupling.energy_conserving import interface_response
from crane_fem.coupling.ph_energy import PHStorage
from crane_fem.coupling.protocol import MethodBase, MethodSetup
from crane_fem.coupling.system import PH_KEYS, CoupledSystem, MacroRecord
from crane_fem.errors import CraneFemError
from crane_fem.kernels import explicit as kx

__all__ = ["PrakashHjelmstad", "create"]

FloatArray = npt.NDArray[np.float64]


def _linear_only(t: float) -> CraneFemError:
    return CraneFemError(
        "coupling method 'ph' needs the explicit subdomain to be linear over each macro step, "
        f"but a contact is active at t = {t:.6g} s; use coupling.method = 'gc'"
    )


class PrakashHjelmstad(MethodBase):
    """The "ph" coupling (collective)."""

    name = "ph"

    def __init__(self, system: CoupledSystem) -> None:
        super().__init__(system)
        E = system.E
        assert E is not None
        self._Z: FloatArray | None = None
        # The explicit side's storage S_E (docs/theory-notes.md §10) when it is defined
        # (undamped explicit side, small enough for its modes), else the reason.
        self.storage: PHStorage | None = None
        self.measure = "not ph"
        self._prev: tuple[float, FloatArray, FloatArray] | None = None
        if E.model.damped:
            self.measure = "not evaluated: the explicit side is damped (not lossless)"
        else:
            try:
                self.storage = PHStorage(E.model, system.dt, system.m)
                self.measure = "evaluated"
            except ValueError as exc:
                self.measure = f"not evaluated: {exc}"
        if self.storage is not None:
            system.acc.update(dict.fromkeys(PH_KEYS, 0.0))

    def initialize(self, interface_force: npt.NDArray[Any] | None = None) -> MacroRecord:
        rec = self.system.initialize(interface_force)
        if self.storage is not None:
            self._prev = self._state(0.0, self.system.lam_macro_prev)
            self.system.acc["energy_ph_explicit"] = self._prev[0]
            rec.energy["energy_ph_explicit"] = self._prev[0]
        return rec

    def _solve(self, t0: float, wIf: FloatArray) -> FloatArray:
        """Λ_m from continuity at the macro step only (explicit side linear)."""
        s = self.system
        E, I = s.E, s.I  # noqa: E741
        assert E is not None and I is not None
        n_g, m = s.n_gamma, s.m
        if self._Z is None:
            self._Z = interface_response(E, m, ramp=True)
        state = E.save()
        j = np.arange(1, m + 1)
        ctl = E.steps(
            t0,
            m,
            mode=kx.IMPOSED,
            imposed=(s.lam_macro_prev, np.zeros(n_g)),
            ic=np.column_stack([1.0 - j / m, np.zeros(m)]),
        )
        out = E.advance(ctl)
        if np.any(out.active):
            raise _linear_only(t0 + (int(np.argmax(out.active)) + 1) * E.dt)
        w = out.w.copy()
        E.restore(state)
        H = self._Z + I.gamma * s.dT * I.W
        return np.asarray(np.linalg.solve(H, -(w + wIf)))

    def step(self) -> MacroRecord:
        s = self.system
        E, I, m, n_g = s.E, s.I, s.m, s.n_gamma  # noqa: E741
        assert E is not None and I is not None
        t0 = s.t
        t1 = t0 + s.dT
        cv0 = s.damping_now()
        uf, vf, af = I.free_step(t1)
        uI0, vI0 = I.u.copy(), I.v.copy()
        f0 = I.load(t0)
        wIf = I.interface_values(vf)
        lam_m = self._solve(t0, wIf)
        j = np.arange(1, m + 1)
        ctl = E.steps(
            t0,
            m,
            mode=kx.IMPOSED,
            imposed=(s.lam_macro_prev, lam_m),
            ic=np.column_stack([1.0 - j / m, j / m]),
        )
        out = E.advance(ctl)
        if np.any(out.active):
            raise _linear_only(t0 + (int(np.argmax(out.active)) + 1) * E.dt)
        s.impulse_E += out.impulse_trap
        link_e = s.explicit_balance(out)
        I.accept(uf, vf, af)
        lam_force = out.lam[:n_g] / s.dt
        I.correct(lam_force)
        s.impulse_I += 0.5 * s.dT * (s.lam_macro_prev + lam_force)
        mean_force = 0.5 * (s.lam_macro_prev + lam_force)
        link_i, phys_i = s.implicit_balance(uI0, vI0, f0, I.load(t1), cv0, mean_force)
        s.lam_macro_prev = lam_force
        if self.storage is not None:
            self._book(t1, lam_force, link_i)
        gc_e, phys_e = float(out.sums[kx.GC_WORK]), float(out.sums[kx.PHYS_WORK])
        s.book_interface(link_e + link_i, gc_e + link_i, phys_e + phys_i)
        s.advance()
        return s.record(out.lam, out.gaps, s.micro_trace(t0, out))

    def _state(self, t: float, lam_force: FloatArray) -> tuple[float, FloatArray, FloatArray]:
        """(S_E, V_E, F_E) at the macro time t: the storage of the explicit side for its
        integer-step velocity and total force (link force Λ plus the load), then the two
        vectors for the next trapezoidal supply (collective)."""
        s = self.system
        E = s.E
        assert E is not None and self.storage is not None
        full = np.zeros(E.stack.p)
        full[: s.n_gamma] = lam_force
        load = E.load(t)
        force = E.stack.transpose(full, E.model.n_owned) + load
        return self.storage(E.u, E.v_int, force), E.v_int.copy(), load.copy()

    def _book(self, t1: float, lam_force: FloatArray, link_i: float) -> None:
        """Book the interface energy of a macro step in the measure of its argument:
        −(ΔS_E − W_E + link work on the implicit side), W_E the load's trapezoidal supply
        ΔT·½(V_n + V_n+1)ᵀ·½(F_n + F_n+1) on the explicit side (collective)."""
        s = self.system
        assert self._prev is not None
        s0, v0, f0 = self._prev
        self._prev = self._state(t1, lam_force)
        s1, v1, f1 = self._prev
        w_ext = float(s.sum([0.25 * s.dT * float(np.dot(v0 + v1, f0 + f1))])[0])
        s.acc["interface_energy_ph"] -= (s1 - s0 - w_ext) + link_i
        s.acc["energy_ph_explicit"] = s1

    def method_state(self) -> dict[str, Any]:
        """(S_E, V_E, F_E) at the last macro time when the measure is evaluated (Z, the
        explicit side's response, is recomputed on demand, the same)."""
        if self._prev is None:
            return {}
        s_e, v, f = self._prev
        return {"prev_storage": s_e, "prev_v": v.copy(), "prev_f": f.copy()}

    def load_method_state(self, state: dict[str, Any]) -> None:
        if self.storage is None:
            return
        self._prev = (
            float(state["prev_storage"]),
            np.array(state["prev_v"], dtype=np.float64),
            np.array(state["prev_f"], dtype=np.float64),
        )

    def history_keys(self) -> list[str]:
        return list(PH_KEYS) if self.storage is not None else []

    def summary(self) -> dict[str, Any]:
        out: dict[str, Any] = {"ph_measure": self.measure}
        if self.storage is not None:
            out["ph_kappa_min"], out["ph_kappa_max"] = self.storage.kappa_range
        return out


def create(system: CoupledSystem, setup: MethodSetup) -> PrakashHjelmstad:
    """ "ph" (no operator or keys of its own)."""
    return PrakashHjelmstad(system)
