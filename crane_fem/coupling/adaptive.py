"""A macro step that refines at impacts (docs/theory-notes.md §13, THEORY.md §9).

The run keeps two rungs of one coupling method (gc or gc-mean): the coarse ratio m_c in
flight and in steady contact, the fine ratio m_f (a divisor of m_c) around impacts. Each rung
has its own implicit side (its own M̃ = M + β ΔT² K: a factorisation on the full side, a
diagonal in its modes on the reduced one) and its own interface operator W_I(ΔT); Newmark is
a one-step scheme, so (U, V, A) carry over from one rung to the other.

The rung is chosen at the coarse grid's times (multiples of m_c micro steps) from the
explicit side's state, the same on every rank (global gaps, rates and group forces):

- a contact predicted to close within the next coarse step (g + ġ ΔT_c ≤ margin for an open
  point) refines it;
- a coarse step in which an open contact point closed is undone and redone on the fine rung,
  so that no impact is ever integrated on the coarse one (a lift-off, smooth, stays coarse);
- a fine step in which an open point closed, a group's force exceeded the impact level of
  crane_fem.peaks (``IMPACT_LOAD`` × its static force: a landing's burst, a flange strike —
  a flange's level is its wheel's), or a contact group started or stopped sliding, keeps the
  fine rung for ``quiet`` seconds more.

Every sampling instant is a coarse grid time, so the run is sampled at the same instants
whatever the rungs taken, and a checkpoint is taken between two whole coarse intervals.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from crane_fem.coupling.gravouil_combescure import GCStep
from crane_fem.coupling.protocol import MethodBase
from crane_fem.coupling.system import CoupledSystem, ImplicitSide, MacroRecord
from crane_fem.peaks import IMPACT_LOAD, IMPACT_QUIET, LIFT_GAP

__all__ = ["GAP_MARGIN", "QUIET_TIME", "Adaptive", "Rung"]

FloatArray = npt.NDArray[np.float64]

#: s: the contacts stay calm this long before the macro step coarsens (the end of an impact
#: in crane_fem.peaks: its forces stay below the impact level this long).
QUIET_TIME = IMPACT_QUIET
#: m: an open contact predicted nearer than this at the end of the next coarse step refines
#: it (the lift-off gap of crane_fem.peaks: nearer is "on the rail").
GAP_MARGIN = LIFT_GAP


class RungMethod(Protocol):
    """What the adaptive step asks of a rung's method: one macro step from t0 with the
    system's current ratio and implicit side, the contact points closed at t0 watched."""

    def macro(self, t0: float, watch: npt.NDArray[np.bool_] | None = None) -> GCStep: ...

    def summary(self) -> dict[str, Any]: ...

    def method_state(self) -> dict[str, Any]: ...

    def load_method_state(self, state: dict[str, Any]) -> None: ...


@dataclass
class Rung:
    """One rung: its ratio, its implicit side and the method stepping with them."""

    ratio: int
    side: ImplicitSide
    method: RungMethod


class Adaptive(MethodBase):
    """The refining macro step over a coarse and a fine rung of one method (collective).

    Args:
        system: the two sides; its implicit side is the coarse rung's.
        coarse, fine: the rungs (``fine.ratio`` divides ``coarse.ratio``).
        static: each contact group's static force (N; the preload's wheel forces), or None.
        quiet: s, the calm that coarsens the macro step again.
        margin: m, the predicted gap that refines the next coarse step.
    """

    name = "adaptive"

    def __init__(
        self,
        system: CoupledSystem,
        coarse: Rung,
        fine: Rung,
        static: FloatArray | None = None,
        quiet: float = QUIET_TIME,
        margin: float = GAP_MARGIN,
    ) -> None:
        super().__init__(system)
        if fine.ratio >= coarse.ratio or coarse.ratio % fine.ratio:
            raise ValueError(
                f"fine ratio {fine.ratio} must be smaller than the coarse {coarse.ratio} and "
                "divide it"
            )
        self.coarse, self.fine = coarse, fine
        self.rung = coarse
        n = system.n_groups
        self.level = IMPACT_LOAD * (np.zeros(n) if static is None else np.asarray(static))
        self.quiet_steps = max(1, round(quiet / system.dt))
        self.margin = float(margin)
        #: Micro step until which the fine rung is kept.
        self.fine_until = 0
        self._slipping: npt.NDArray[np.bool_] | None = None
        self.counts = {"coarse": 0, "fine": 0, "redone": 0, "predicted": 0}
        #: Fine steps that kept the fine rung, by reason (a step may have several).
        self.kept_fine_by = {"closing": 0, "impact": 0, "stick_slip": 0}

    # ------------------------------------------------------------------------------------
    def _use(self, rung: Rung) -> None:
        """Make ``rung`` the system's: the implicit state carries over (same space)."""
        if rung is self.rung:
            return
        old, new = self.rung.side, rung.side
        new.u, new.v, new.a = old.u, old.v, old.a
        self.system.use_implicit(new, rung.ratio)
        self.rung = rung

    def _closing(self) -> bool:
        """Whether a contact point open by more than ``margin`` is predicted within it by the
        end of the next coarse step (global gaps and rates)."""
        s = self.system
        E = s.E
        assert E is not None
        g, w = E.stack.gaps_and_velocities(E.u, E.v_int)
        n_g = s.n_gamma
        g, w = g[n_g:], w[n_g:]
        # Points nearer than the margin are on their surface already (a preloaded wheel's
        # unloaded pairs sit a few nanometres open): a change of theirs redoes the step.
        flying = g > self.margin
        ahead = g + w * (self.coarse.ratio * s.dt)
        return bool(np.any(flying & (ahead <= self.margin)))

    def _any(self, flag: bool) -> bool:
        """Whether ``flag`` holds on some rank (collective: one reduction), so that every
        rank takes the same rung."""
        return bool(self.system.sum([float(flag)])[0] > 0.0)

    def _stirred(self, res: GCStep) -> bool:
        """Whether the step ``res`` had a closing, an impact or flange strike (a group's
        force above its impact level) or a stick–slip change (collective: one reduction);
        each reason is counted."""
        imp = res.micro.impulse
        impact = bool(imp.size and np.any(imp.max(axis=0) / self.system.dt > self.level))
        slipping = self._slip_state()
        slip = self._slipping is not None and not np.array_equal(slipping, self._slipping)
        self._slipping = slipping
        why = self.system.sum([float(res.closed), float(impact), float(slip)]) > 0.0
        for key, hit in zip(("closing", "impact", "stick_slip"), why, strict=True):
            self.kept_fine_by[key] += int(hit)
        return bool(np.any(why))

    def _slip_state(self) -> npt.NDArray[np.bool_]:
        """Which contact groups (a wheel, a flange) had a frictional point sliding at the
        last micro step (empty without friction): a group that starts or stops sliding is a
        stick–slip change; its points' slip rocking under it is not."""
        E = self.system.E
        assert E is not None
        slipping = E.slipping()
        if slipping.size == 0:
            return slipping
        groups = E.contacts.group[np.flatnonzero(E.zone.t_count > 0)]
        count = np.bincount(groups, weights=slipping, minlength=self.system.n_groups)
        return np.asarray(count > 0.0)

    def step(self) -> MacroRecord:
        s = self.system
        grid = s.grid
        if grid.i % self.coarse.ratio == 0:
            fine = grid.i < self.fine_until
            if not fine and self._any(self._closing()):
                fine = True
                self.counts["predicted"] += 1
            if not fine:
                res = self._coarse_step()
                if res is not None:
                    s.advance()
                    return res.record(s)
        self._use(self.fine)
        E = s.E
        assert E is not None
        res = self.fine.method.macro(s.t, watch=E.contacts.closed(s.contact_gaps()))
        s.advance()
        self.counts["fine"] += 1
        if self._stirred(res):
            self.fine_until = grid.i + self.quiet_steps
        return res.record(s)

    def _coarse_step(self) -> GCStep | None:
        """A coarse step, or None when an open contact point closed in it (then undone)."""
        s = self.system
        E = s.E
        assert E is not None
        self._use(self.coarse)
        snap = s.snapshot()
        state = self.coarse.method.method_state()
        res = self.coarse.method.macro(s.t, watch=E.contacts.closed(s.contact_gaps()))
        if self._any(res.closed):
            s.restore(snap)
            self.coarse.method.load_method_state(state)
            self.counts["redone"] += 1
            self.fine_until = s.grid.i + self.coarse.ratio
            return None
        self.counts["coarse"] += 1
        self._slipping = self._slip_state()
        return res

    # ------------------------------------------------------------------------------------
    def summary(self) -> dict[str, Any]:
        c = self.counts
        micro = c["coarse"] * self.coarse.ratio + c["fine"] * self.fine.ratio
        out = {
            "adaptive": {
                "coarse_ratio": self.coarse.ratio,
                "fine_ratio": self.fine.ratio,
                "coarse_steps": c["coarse"],
                "fine_steps": c["fine"],
                "coarse_steps_redone": c["redone"],
                "refined_by_prediction": c["predicted"],
                "fine_time_fraction": c["fine"] * self.fine.ratio / micro if micro else 0.0,
                "fine_steps_kept_by": dict(self.kept_fine_by),
            }
        }
        # The rungs' own entries (gc-mean's identity check): the worst of the two.
        for key, value in self.coarse.method.summary().items():
            other = self.fine.method.summary().get(key, value)
            out[key] = max(value, other) if isinstance(value, float) else value
        return out

    def method_state(self) -> dict[str, Any]:
        return {
            "fine": self.rung is self.fine,
            "fine_until": self.fine_until,
            "counts": dict(self.counts),
            "kept_fine_by": dict(self.kept_fine_by),
            "slipping": np.zeros(0, bool) if self._slipping is None else self._slipping,
            "has_slipping": self._slipping is not None,
            "coarse": self.coarse.method.method_state(),
            "fine_method": self.fine.method.method_state(),
        }

    def load_method_state(self, state: dict[str, Any]) -> None:
        """After the system's state (loaded into the coarse side, the system's at set-up)."""
        self.rung = self.coarse
        if bool(state["fine"]):
            self._use(self.fine)
        self.fine_until = int(state["fine_until"])
        self.counts = {k: int(state["counts"][k]) for k in self.counts}
        self.kept_fine_by = {k: int(state["kept_fine_by"][k]) for k in self.kept_fine_by}
        has = bool(state["has_slipping"])
        self._slipping = np.asarray(state["slipping"], dtype=bool) if has else None
        # (A checkpoint keeps no empty table: a method without state of its own has none.)
        self.coarse.method.load_method_state(state.get("coarse", {}))
        self.fine.method.load_method_state(state.get("fine_method", {}))

    def destroy(self) -> None:
        self.fine.side.destroy()


def create_adaptive(
    system: CoupledSystem,
    base: Callable[[CoupledSystem], RungMethod],
    fine_ratio: int,
    static: FloatArray | None = None,
    quiet: float | None = None,
    margin: float | None = None,
) -> Adaptive:
    """The adaptive step over rungs of the method ``base`` makes for the system's current
    implicit side and ratio (the coarse rung) and for a side refined to ``fine_ratio``
    (collective: the fine side factorises its own M̃)."""
    I = system.I  # noqa: E741
    assert I is not None
    m_c = system.m
    coarse = Rung(m_c, I, base(system))
    fine_side = I.refined(fine_ratio * system.dt)
    system.use_implicit(fine_side, fine_ratio)
    try:
        fine = Rung(fine_ratio, fine_side, base(system))
    finally:
        system.use_implicit(I, m_c)
    return Adaptive(
        system,
        coarse,
        fine,
        static,
        QUIET_TIME if quiet is None else quiet,
        GAP_MARGIN if margin is None else margin,
    )
