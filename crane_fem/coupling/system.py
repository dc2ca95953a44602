"""The two sides of a heterogeneous run and the books every coupling method keeps on them.

An explicit zone (crane_fem.integrators.explicit_zone, Δt) and an implicit Newmark side
(ΔT = mΔt), either one alone for the monolithic references, joined by duplicated interface
DOFs with L_E V_E + L_I V_I = 0 (THEORY.md §3). What is here is shared by the methods of
crane_fem.coupling: the start (explicit half step, implicit initial acceleration), the energy
books of each side and of the interface, the trapezoidal form of the implicit step ("ec",
"gc-mean"), snapshots (to redo a macro step) and the record of a synchronisation time.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt
from mpi4py import MPI

from crane_fem.energy import BALANCE_TERMS
from crane_fem.integrators.explicit_zone import ExplicitZone, ZoneSnapshot
from crane_fem.kernels import explicit as kx
from crane_fem.model import StructuralModel
from crane_fem.timegrid import TimeGrid

__all__ = [
    "ENERGY_KEYS",
    "PH_KEYS",
    "CoupledSystem",
    "ImplicitSide",
    "MacroRecord",
    "MicroTrace",
    "Snapshot",
    "TrapezoidStep",
]

FloatArray = npt.NDArray[np.float64]

ENERGY_KEYS = [
    *BALANCE_TERMS,
    "interface_dissipated",
    "interface_energy_gc",
    "interface_work_physical",
]
#: "ph" with an undamped explicit side: the interface energy in the measure of the PH
#: argument (S_E + the implicit side's energy, crane_fem.coupling.ph_energy) and S_E itself.
PH_KEYS = ["interface_energy_ph", "energy_ph_explicit"]


class ImplicitSide(Protocol):
    """The implicit side as the coupling methods see it: a Newmark (β, γ) integrator whose
    vectors (state, loads, link forces) are of a space of its own, the subdomain's field
    (crane_fem.integrators.newmark) or reduced coordinates
    (crane_fem.integrators.newmark_reduced), reached only through these methods."""

    @property
    def model(self) -> StructuralModel: ...
    @property
    def load(self) -> Callable[[float], FloatArray]: ...
    @property
    def dT(self) -> float: ...
    @property
    def beta(self) -> float: ...
    @property
    def gamma(self) -> float: ...
    @property
    def W(self) -> FloatArray: ...

    u: FloatArray
    v: FloatArray
    a: FloatArray

    def solve(self, rhs: FloatArray) -> FloatArray: ...
    def mass_action(self, x: FloatArray) -> FloatArray: ...
    def stiffness_action(self, x: FloatArray) -> FloatArray: ...
    def damping_action(self, x: FloatArray, mx: FloatArray | None = None) -> FloatArray: ...
    def mass_and_damping(self, x: FloatArray) -> tuple[FloatArray, FloatArray]: ...
    def initialize(self, t0: float, link: FloatArray | None = None) -> None: ...
    def free_step(self, t_new: float) -> tuple[FloatArray, FloatArray, FloatArray]: ...
    def trapezoid_free_increment(self, f0: FloatArray, f1: FloatArray) -> FloatArray: ...
    def accept(self, u: FloatArray, v: FloatArray, a: FloatArray) -> None: ...
    def interface_values(self, x: FloatArray) -> FloatArray: ...
    def interface_force(self, force: FloatArray) -> FloatArray: ...
    def local_dot(self, x: FloatArray, y: FloatArray) -> float: ...
    def field(self, x: FloatArray) -> FloatArray: ...
    def field_rows(self, x: FloatArray, rows: npt.NDArray[np.int64]) -> FloatArray: ...
    def refined(self, dT: float) -> ImplicitSide: ...
    def link_response(self, force: FloatArray) -> FloatArray: ...
    def correct(self, force: FloatArray) -> None: ...
    def state_dict(self) -> dict[str, Any]: ...
    def load_state_dict(self, state: dict[str, Any]) -> None: ...
    def destroy(self) -> None: ...


@dataclass
class MicroTrace:
    """The micro steps of a macro step (global values, the same on every rank): their times,
    whether a contact impulse acted, and per contact group (columns) the summed contact
    impulse (N·s) and the smallest gap (m; +inf for a group without points)."""

    t: FloatArray
    active: npt.NDArray[np.bool_]
    impulse: FloatArray
    gap: FloatArray

    @classmethod
    def empty(cls, n_groups: int = 0) -> MicroTrace:
        z = np.zeros((0, n_groups))
        return cls(np.zeros(0), np.zeros(0, dtype=bool), z, z.copy())

    @classmethod
    def concat(cls, traces: list[MicroTrace]) -> MicroTrace:
        """The traces one after the other (the refined steps of a macro step)."""
        return cls(
            np.concatenate([tr.t for tr in traces]),
            np.concatenate([tr.active for tr in traces]),
            np.concatenate([tr.impulse for tr in traces]),
            np.concatenate([tr.gap for tr in traces]),
        )


@dataclass
class MacroRecord:
    """State at a synchronisation time t (macro step ``step``); energies are global."""

    step: int
    t: float
    energy: dict[str, float]
    explicit_u: FloatArray | None
    explicit_v: FloatArray | None
    #: The implicit side's displacement (0) or velocity (1) as a field on its owned DOFs,
    #: made on demand and apart (a reduced side expands its coordinates only for the
    #: records, and the one of the two, that need them).
    implicit_fields: Callable[[int], FloatArray] | None
    contact_impulse: FloatArray
    gaps: FloatArray
    interface_impulse: FloatArray
    micro: MicroTrace = field(default_factory=MicroTrace.empty)
    #: ‖S_E‖ (N·s): the interface impulse the explicit side received since t = 0 (gc/ph:
    #: S_E = Σ ½Δt (Λ_j−1 + Λ_j), trapezoid like the implicit side's; ec: Σ Δt G).
    impulse_explicit: float = 0.0
    #: ‖S_E − S_I‖ (N·s), S_I the implicit side's (gc/ph: Σ ½ΔT (Λ_n + Λ_n+1), paid with the
    #: macro-step multipliers only; ec: Σ ΔT G): momentum one side received and the other
    #: did not. Zero for m = 1, and for ec.
    impulse_defect: float = 0.0
    #: max |L_E V_E + L_I V_I| at t (m/s): the velocity continuity left, round-off for GC;
    #: evaluated at the sampling instants (NaN at the macro steps between).
    interface_velocity_jump: float = 0.0
    _fields: list[FloatArray | None] = field(default_factory=lambda: [None, None])
    #: The implicit side's displacement and velocity at some owned DOFs only (cheap on a
    #: reduced side: a few rows of its basis).
    implicit_rows: Callable[[npt.NDArray[np.int64]], tuple[FloatArray, FloatArray]] | None = None
    #: Micro steps of Δt from t = 0 to t (the clock's exact count).
    micro_step: int = 0

    def implicit_at(self, rows: npt.NDArray[np.int64]) -> tuple[FloatArray, FloatArray] | None:
        """(U, V) of the implicit side at owned DOFs ``rows``, without expanding the fields
        unless both already are."""
        u, v = self._fields
        if u is not None and v is not None:
            return u[rows], v[rows]
        return None if self.implicit_rows is None else self.implicit_rows(rows)

    def _implicit(self, which: int) -> FloatArray | None:
        if self._fields[which] is None and self.implicit_fields is not None:
            self._fields[which] = self.implicit_fields(which)
        return self._fields[which]

    @property
    def implicit_u(self) -> FloatArray | None:
        return self._implicit(0)

    @property
    def implicit_v(self) -> FloatArray | None:
        return self._implicit(1)

    def state_dict(self) -> dict[str, Any]:
        """What the record holds beyond the two sides' state (a checkpoint taken before the
        record is used; :meth:`CoupledSystem.resume_record` makes it again)."""
        return {
            "step": self.step,
            "t": self.t,
            "energy": dict(self.energy),
            "contact_impulse": self.contact_impulse,
            "gaps": self.gaps,
            "interface_impulse": self.interface_impulse,
            "micro": {
                "t": self.micro.t,
                "active": self.micro.active,
                "impulse": self.micro.impulse,
                "gap": self.micro.gap,
            },
            "impulse_explicit": self.impulse_explicit,
            "impulse_defect": self.impulse_defect,
            "interface_velocity_jump": self.interface_velocity_jump,
            "micro_step": self.micro_step,
        }


@dataclass
class Snapshot:
    """Everything a coupled macro step changes, to redo it."""

    explicit: ZoneSnapshot
    implicit: tuple[FloatArray, ...]
    arrays: tuple[FloatArray, ...]
    acc: dict[str, float]
    energies: tuple[float, float, float, float]
    clock: dict[str, Any]


@dataclass
class TrapezoidStep:
    """The implicit side at the start of a trapezoidal macro step and its free increment."""

    u0: FloatArray
    v0: FloatArray
    cv0: FloatArray
    f0: FloatArray
    f1: FloatArray
    du_free: FloatArray


class CoupledSystem:
    """An explicit zone and an implicit side coupled at ratio m, or either alone.

    Collective over the subdomains' communicator. Owns neither side: the builder that made
    them destroys them.

    Attributes:
        E, I: the explicit zone and the Newmark side (None when absent); the implicit side
            holds its interface rows L_I, and its vectors may be of a space of its own (a
            reduced basis): the books reach them only through its methods.
        m, dt, dT: the ratio of the macro step now taken, the micro and macro steps (s).
        grid: the run's clock (:class:`~crane_fem.timegrid.TimeGrid`): t and the steps done.
        acc: the accumulated energy terms (J, global).
        lam_macro_prev: the link force Λ (N) at the start of the macro step.
        impulse_E, impulse_I: the interface impulses each side received since t = 0 (N·s).
    """

    def __init__(
        self,
        explicit: ExplicitZone | None,
        implicit: ImplicitSide | None,
        ratio: int,
        dt: float,
        grid: TimeGrid | None = None,
    ) -> None:
        if explicit is None and implicit is None:
            raise ValueError("nothing to integrate")
        self.E, self.I = explicit, implicit
        self.coupled = explicit is not None and implicit is not None
        self.m = int(ratio) if self.coupled else 1
        self.dt = explicit.dt if explicit is not None else float(dt)
        self.dT = self.m * self.dt
        self.n_gamma = explicit.n_gamma if (explicit is not None and self.coupled) else 0
        self.n_groups = explicit.zone.n_groups if explicit is not None else 0
        side = explicit.model if explicit is not None else implicit.model  # type: ignore[union-attr]
        self.comm: MPI.Comm = side.comm
        self.acc = dict.fromkeys(ENERGY_KEYS, 0.0)
        self.lam_macro_prev = np.zeros(self.n_gamma)
        self.impulse_E = np.zeros(self.n_gamma)
        self.impulse_I = np.zeros(self.n_gamma)
        # Without a grid (a system stepped by hand), a clock that never ends.
        self.grid = grid if grid is not None else TimeGrid(self.dt, 2**62, self.m)
        self.e_kin = self.e_int = self.i_kin = self.i_int = 0.0
        self._cv_cache: tuple[FloatArray, FloatArray] | None = None
        #: Called (collective, with the system) at every record (and, in a monolithic
        #: implicit reference, every ``observe_every`` time steps between its records).
        #: Output only (the support reactions' peaks, read on a finer interval than the
        #: sampling's); it must not change the state.
        self.observers: list[Callable[[CoupledSystem], None]] = []
        #: A monolithic reference's readings between its records: every ``observe_every``
        #: micro steps of the clock (0: none), the owned DOFs ``probe`` read by the kernel
        #: (U_j, V_j), handed once per record to ``probe_reader`` (times (m,), U and V
        #: (m, probe size); collective). A record stays one kernel call.
        self.observe_every = 0
        self.probe: npt.NDArray[np.int64] = np.zeros(0, dtype=np.int64)
        self.probe_reader: Callable[[FloatArray, FloatArray, FloatArray], None] | None = None

    @property
    def n(self) -> int:
        """Macro steps done."""
        return self.grid.n

    @property
    def t(self) -> float:
        """The current synchronisation time (s)."""
        return self.grid.t

    def advance(self) -> None:
        """The macro step of the current ratio done: the clock moves on by m micro steps."""
        self.grid.advance(self.m)

    # ------------------------------------------------------------------------------------
    def sum(self, values: list[float]) -> FloatArray:
        """Sum a few rank-local scalars over the communicator (one reduction)."""
        buf = np.asarray(values, dtype=np.float64)
        out = np.empty_like(buf)
        self.comm.Allreduce(buf, out)
        return out

    def interface_drift(self) -> FloatArray:
        """L_E U_E + L_I U_I: how far the two sides' interface displacements have drifted
        apart (m, n_Γ, global; collective). GC and PH make only the velocities continuous
        (THEORY.md §3): at an impact inside a macro step the explicit side's interface path
        and the implicit side's trapezoid differ, and the difference stays."""
        E, I = self.E, self.I  # noqa: E741
        assert E is not None and I is not None
        return E.interface.apply(E.u) + I.interface_values(I.u)

    def implicit_energy(self) -> tuple[float, float]:
        """½ VᵀMV and ½ UᵀKU of the implicit side (global)."""
        I = self.I  # noqa: E741
        assert I is not None
        kin, pot = self.sum(
            [
                0.5 * I.local_dot(I.v, I.mass_action(I.v)),
                0.5 * I.local_dot(I.u, I.stiffness_action(I.u)),
            ]
        )
        return float(kin), float(pot)

    def initialize(self, interface_force: FloatArray | None = None) -> MacroRecord:
        """Explicit half step and implicit initial acceleration (collective).

        ``interface_force`` (n_Γ, N): the link forces Λ_0 at t = 0 when the subdomains start
        from a loaded equilibrium (a static preload); zero by default.
        """
        E, I = self.E, self.I  # noqa: E741
        self.e_kin = self.e_int = self.i_kin = self.i_int = 0.0
        lam, gaps = np.zeros(0), np.zeros(0)
        lam0 = np.zeros(self.n_gamma)
        if interface_force is not None and self.coupled:
            lam0 = np.asarray(interface_force, dtype=np.float64)
        if E is not None:
            # V_{1/2} = V_0 + ½Δt M⁻¹ (F_0 − K U_0 − C V_0) + the link impulse of the first
            # half step (½Δt Λ_0) and the impulses of the contacts closed at t = 0.
            n_g = E.n_gamma
            ctl = E.steps(
                0.0,
                1,
                h0=0.5 * E.dt,
                move0=False,
                mode=kx.IMPOSED if n_g else kx.NONE,
                imposed=(lam0 if n_g == lam0.size else np.zeros(n_g), np.zeros(n_g)),
                ic=np.array([[0.5, 0.0]]),
            )
            out = E.advance(ctl)
            E.state.v_int[:] = E.v0
            kin, pot = self.sum(E.local_energies())
            self.e_kin, self.e_int = float(kin), float(pot)
            lam, gaps = out.lam, out.gaps
        if I is not None:
            link = None
            if self.coupled:
                link = I.interface_force(lam0)
            I.initialize(0.0, link)
            self.i_kin, self.i_int = self.implicit_energy()
        if E is not None and self.coupled:
            E.state.w_prev[:] = E.stack.apply(E.v0)[: self.n_gamma]
            E.state.lam_prev[:] = E.dt * lam0
            self.lam_macro_prev = lam0.copy()
        # The first impulses act over Δt/2: as forces, 2 Λ̂ / Δt.
        return self.record(2.0 * lam, gaps, MicroTrace.empty(self.n_groups))

    def record(
        self,
        lam: FloatArray,
        gaps: FloatArray,
        micro: MicroTrace,
        interface_impulse: FloatArray | None = None,
    ) -> MacroRecord:
        """The record at the current synchronisation time: ``lam`` and ``gaps`` over the
        stacked rows of the explicit zone (interface, then contacts)."""
        e = dict(self.acc)
        e["kinetic"] = self.e_kin + self.i_kin
        e["internal"] = self.e_int + self.i_int
        e["kinetic_explicit"], e["internal_explicit"] = self.e_kin, self.e_int
        e["kinetic_implicit"], e["internal_implicit"] = self.i_kin, self.i_int
        e["total"] = (
            e["kinetic"]
            + e["internal"]
            - e["external_work"]
            + e["damping_dissipated"]
            + e["contact_dissipated"]
            + e["numerical_dissipated"]
            + e["interface_dissipated"]
            + e["friction_dissipated"]
        )
        for observe in self.observers:
            observe(self)
        n_g = self.n_gamma
        E, I = self.E, self.I  # noqa: E741
        if interface_impulse is None:
            interface_impulse = lam[:n_g] / self.dt if lam.size else np.zeros(0)
        jump = 0.0
        if self.coupled and E is not None and I is not None:
            # A diagnostic of the history rows: evaluated at the sampling instants only (a
            # dense product on a reduced side, and a reduction), NaN between.
            jump = math.nan
            if self.grid.sampled():
                w = E.stack.apply(E.v_int)[:n_g] + I.interface_values(I.v)
                jump = float(np.max(np.abs(w), initial=0.0))
        return MacroRecord(
            self.grid.n,
            self.grid.t,
            e,
            E.u if E is not None else None,
            E.v_int if E is not None else None,
            self._implicit_fields(),
            lam[n_g:] if lam.size else np.zeros(0),
            gaps[n_g:] if gaps.size else np.zeros(0),
            interface_impulse,
            micro,
            float(np.linalg.norm(self.impulse_E)),
            float(np.linalg.norm(self.impulse_E - self.impulse_I)),
            jump,
            implicit_rows=self._implicit_rows(),
            micro_step=self.grid.i,
        )

    def _implicit_fields(self) -> Callable[[int], FloatArray] | None:
        """The implicit side's current U (0) or V (1) as a field, on demand."""
        I = self.I  # noqa: E741
        if I is None:
            return None
        uv = (I.u, I.v)  # replaced, never changed in place, by the steps that follow

        def fields(which: int) -> FloatArray:
            return I.field(uv[which])

        return fields

    def _implicit_rows(
        self,
    ) -> Callable[[npt.NDArray[np.int64]], tuple[FloatArray, FloatArray]] | None:
        """The implicit side's current (U, V) at some owned DOFs, on demand."""
        I = self.I  # noqa: E741
        if I is None:
            return None
        u, v = I.u, I.v

        def rows(r: npt.NDArray[np.int64]) -> tuple[FloatArray, FloatArray]:
            return I.field_rows(u, r), I.field_rows(v, r)

        return rows

    def micro_trace(self, t0: float, out: kx.StepsOut) -> MicroTrace:
        """The micro steps of a kernel call from t0: t_j = t0 + jΔt, and what ``out`` holds
        of each."""
        t = t0 + np.arange(1, out.active.size + 1, dtype=np.float64) * self.dt
        return MicroTrace(t, out.active.copy(), out.group_impulse, out.group_gap)

    # ------------------------------------------------------------------------------------
    def explicit_balance(self, out: kx.StepsOut) -> float:
        """Book the explicit side's summed micro-step terms (local, reduced here) and its
        energies after the macro step; return the global link work on it (collective)."""
        E = self.E
        assert E is not None
        s = out.sums
        red = self.sum(
            [s[kx.EXT], s[kx.DAMP], s[kx.CONTACT], s[kx.LINK], *E.local_energies(), s[kx.FRICTION]]
        )
        self.acc["external_work"] += red[0]
        self.acc["damping_dissipated"] += red[1]
        self.acc["contact_dissipated"] -= red[2]
        self.acc["friction_dissipated"] -= red[6]
        self.e_kin, self.e_int = float(red[4]), float(red[5])
        return float(red[3])

    def damping_now(self) -> FloatArray:
        """C V of the implicit side now, from the last balance when V has not changed."""
        I = self.I  # noqa: E741
        assert I is not None
        if self._cv_cache is not None and self._cv_cache[0] is I.v:
            return self._cv_cache[1]
        return I.damping_action(I.v)

    def implicit_balance(
        self,
        uI0: FloatArray,
        vI0: FloatArray,
        f0: FloatArray,
        f1: FloatArray,
        cv0: FloatArray,
        force: FloatArray | None,
        force_action: FloatArray | None = None,
    ) -> tuple[float, float]:
        """Book the implicit step from (U_0, V_0) to the current state: work of the load and
        of damping with the mean velocity V̄ = ½(V_0 + V_1), energies, and the algorithmic
        energy of Newmark; return the link work ΔT V̄ᵀL_IᵀΛ̄ and its displacement form
        ΔUᵀL_IᵀΛ̄ for the mean link force ``force`` (None: uncoupled; ``force_action``: its
        L_IᵀΛ̄ when the caller has it already) (collective)."""
        I = self.I  # noqa: E741
        assert I is not None
        vbar = 0.5 * (vI0 + I.v)
        mv1, cv1 = I.mass_and_damping(I.v)
        self._cv_cache = (I.v, cv1)  # C V at the end: the next step's C V_0
        link = phys = 0.0
        if force is not None:
            fl = I.interface_force(force) if force_action is None else force_action
            link = self.dT * I.local_dot(vbar, fl)
            phys = I.local_dot(I.u - uI0, fl)
        kin_old, pot_old = self.i_kin, self.i_int
        red = self.sum(
            [
                self.dT * I.local_dot(vbar, 0.5 * (f0 + f1)),
                self.dT * I.local_dot(vbar, 0.5 * (cv0 + cv1)),
                link,
                phys,
                0.5 * I.local_dot(I.v, mv1),
                0.5 * I.local_dot(I.u, I.stiffness_action(I.u)),
            ]
        )
        w_ext, w_damp, link_i, phys_i = (float(x) for x in red[:4])
        self.i_kin, self.i_int = float(red[4]), float(red[5])
        self.acc["external_work"] += w_ext
        self.acc["damping_dissipated"] += w_damp
        # Algorithmic energy of Newmark in the measure ½VᵀMV + ½UᵀKU (zero for β = ¼, γ = ½
        # without damping): work of all forces in velocity form minus the energy change.
        d_energy = (self.i_kin + self.i_int) - (kin_old + pot_old)
        self.acc["numerical_dissipated"] += (w_ext - w_damp + link_i) - d_energy
        return link_i, phys_i

    def book_interface(self, work: float, gc_measure: float, physical: float) -> None:
        """Add the interface terms of a macro step: minus the link work both sides received
        in each of the three measures (J, global)."""
        self.acc["interface_dissipated"] -= work
        self.acc["interface_energy_gc"] -= gc_measure
        self.acc["interface_work_physical"] -= physical

    # ------------------------------------------------------------------------------------
    # The implicit side in the displacement–velocity form of the trapezoidal rule ("ec",
    # "gc-mean"): a free increment at the start of the macro step, the link increment of a
    # force G constant over it at the end.
    def trapezoid_start(self, t0: float) -> TrapezoidStep:
        """The implicit state at t0 and its free trapezoidal increment to t0 + ΔT."""
        I = self.I  # noqa: E741
        assert I is not None
        f0, f1 = I.load(t0), I.load(t0 + self.dT)
        return TrapezoidStep(
            I.u.copy(), I.v.copy(), self.damping_now(), f0, f1, I.trapezoid_free_increment(f0, f1)
        )

    def trapezoid_finish(
        self, st: TrapezoidStep, G: FloatArray, impulse: FloatArray, out: kx.StepsOut
    ) -> float:
        """Implicit side: ΔU = ΔU_free + ½ΔT² M̃⁻¹ L_Iᵀ G, V_n+1 = 2ΔU/ΔT − V_n; it receives
        ``impulse`` = ΔT G (as the explicit side summed it, so that the two agree to the last
        bit). Books both sides' terms (the explicit ones summed in ``out``) and the interface
        energy; returns the link work of G on both sides (collective)."""
        I, dT = self.I, self.dT  # noqa: E741
        assert I is not None
        fl = I.interface_force(G)  # L_Iᵀ G, once: the response and the work both use it
        du = st.du_free + 0.5 * dT * dT * I.solve(fl)
        I.accept(st.u0 + du, 2.0 * du / dT - st.v0, I.a)
        self.impulse_I += impulse
        # V̄ = ½(V_0 + V_1) = ΔU/ΔT here, so both link-work forms are Gᵀ L_I ΔU.
        link_i, _ = self.implicit_balance(st.u0, st.v0, st.f0, st.f1, st.cv0, G, fl)
        link = self.explicit_balance(out) + link_i
        self.book_interface(link, link, link)
        self.lam_macro_prev = G.copy()
        return link

    # ------------------------------------------------------------------------------------
    def snapshot(self) -> Snapshot:
        E, I = self.E, self.I  # noqa: E741
        assert E is not None and I is not None
        arrays = (self.lam_macro_prev, self.impulse_E, self.impulse_I)
        return Snapshot(
            E.save(),
            (I.u.copy(), I.v.copy(), I.a.copy()),
            tuple(a.copy() for a in arrays),
            dict(self.acc),
            (self.e_kin, self.e_int, self.i_kin, self.i_int),
            self.grid.state_dict(),
        )

    def restore(self, snap: Snapshot) -> None:
        E, I = self.E, self.I  # noqa: E741
        assert E is not None and I is not None
        E.restore(snap.explicit)
        I.u, I.v, I.a = (x.copy() for x in snap.implicit)
        self.lam_macro_prev, self.impulse_E, self.impulse_I = (x.copy() for x in snap.arrays)
        self.acc = dict(snap.acc)
        self.e_kin, self.e_int, self.i_kin, self.i_int = snap.energies
        self.grid.load_state_dict(snap.clock)
        self._cv_cache = None

    def state_dict(self) -> dict[str, Any]:
        """Everything that changes while stepping, between macro steps (a checkpoint; local
        arrays of this rank, not collective): the books, the step count and both sides."""
        out: dict[str, Any] = {
            "clock": self.grid.state_dict(),
            "acc": dict(self.acc),
            "lam_macro_prev": self.lam_macro_prev.copy(),
            "impulse_E": self.impulse_E.copy(),
            "impulse_I": self.impulse_I.copy(),
            "energies": np.array([self.e_kin, self.e_int, self.i_kin, self.i_int]),
        }
        if self.E is not None:
            out["explicit"] = self.E.state_dict()
        if self.I is not None:
            out["implicit"] = self.I.state_dict()
        return out

    def load_state_dict(self, state: dict[str, Any]) -> None:
        """Set the state from :meth:`state_dict` of the same system on the same partition.
        The cached C V is dropped (recomputed from V as the same sums)."""
        self.grid.load_state_dict(state["clock"])
        missing = set(self.acc) - set(state["acc"])
        if missing:
            raise ValueError(f"coupled system state: no energy terms {sorted(missing)}")
        self.acc = {k: float(state["acc"][k]) for k in self.acc}
        self.lam_macro_prev = np.array(state["lam_macro_prev"], dtype=np.float64)
        self.impulse_E = np.array(state["impulse_E"], dtype=np.float64)
        self.impulse_I = np.array(state["impulse_I"], dtype=np.float64)
        self.e_kin, self.e_int, self.i_kin, self.i_int = (float(x) for x in state["energies"])
        if self.E is not None:
            self.E.load_state_dict(state["explicit"])
        if self.I is not None:
            self.I.load_state_dict(state["implicit"])
        self._cv_cache = None

    def resume_record(self, state: dict[str, Any]) -> MacroRecord:
        """The record of :meth:`MacroRecord.state_dict` on the restored sides (its fields are
        the sides' current ones, as when it was made; not collective)."""
        E = self.E
        micro = state["micro"]
        return MacroRecord(
            int(state["step"]),
            float(state["t"]),
            {k: float(v) for k, v in state["energy"].items()},
            E.u if E is not None else None,
            E.v_int if E is not None else None,
            self._implicit_fields(),
            np.asarray(state["contact_impulse"], dtype=np.float64),
            np.asarray(state["gaps"], dtype=np.float64),
            np.asarray(state["interface_impulse"], dtype=np.float64),
            MicroTrace(
                np.asarray(micro["t"], dtype=np.float64),
                np.asarray(micro["active"], dtype=bool),
                np.asarray(micro["impulse"], dtype=np.float64),
                np.asarray(micro["gap"], dtype=np.float64),
            ),
            float(state["impulse_explicit"]),
            float(state["impulse_defect"]),
            float(state["interface_velocity_jump"]),
            implicit_rows=self._implicit_rows(),
            micro_step=int(state["micro_step"]),
        )

    def use_implicit(self, implicit: ImplicitSide, ratio: int) -> None:
        """Run the next macro steps with ``implicit`` (its ΔT = ratio × Δt) as the implicit
        side ("hybrid"'s refined steps); the books carry on."""
        self.I, self.m, self.dT = implicit, int(ratio), ratio * self.dt

    def mechanical_energy(self) -> float:
        """Kinetic + internal energy of both sides (global)."""
        return self.e_kin + self.e_int + self.i_kin + self.i_int

    def contact_gaps(self) -> FloatArray:
        """Gaps of the explicit contact points at the current time (global)."""
        E = self.E
        assert E is not None
        n_g = self.n_gamma
        return E.stack.g0[n_g:] + E.stack.apply(E.u)[n_g:]
