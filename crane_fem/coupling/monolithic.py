"""The monolithic references: one subdomain over the whole mesh, explicit (CD-Lagrange, the
fully explicit reference) or implicit (Newmark), as macro steps of ``stride`` time steps so
that the driver records at the coupled run's output times.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from crane_fem.coupling.protocol import MethodBase
from crane_fem.coupling.system import CoupledSystem, MacroRecord, MicroTrace
from crane_fem.kernels import explicit as kx

__all__ = ["ExplicitAlone", "ImplicitAlone"]


class _Alone(MethodBase):
    """``stride`` steps of Δt per macro step, ``n_steps`` in all (the last macro step may be
    shorter)."""

    def __init__(self, system: CoupledSystem, stride: int, n_steps: int) -> None:
        super().__init__(system)
        if stride < 1:
            raise ValueError(f"stride = {stride} must be >= 1")
        self.stride, self.n_steps, self.done = int(stride), int(n_steps), 0

    @property
    def n_macro(self) -> int:
        return math.ceil(self.n_steps / self.stride)

    def resumable(self) -> bool:
        """Not after a last macro step shorter than ``stride``: a longer run would have
        taken it whole."""
        return self.done == self.system.n * self.stride

    def method_state(self) -> dict[str, Any]:
        return {"done": self.done}

    def load_method_state(self, state: dict[str, Any]) -> None:
        self.done = int(state["done"])

    def _record(self, rec: MacroRecord) -> MacroRecord:
        rec.step = self.system.n
        rec.t = self.done * self.system.dt
        return rec


class ExplicitAlone(_Alone):
    """The fully explicit reference (THEORY.md §1 on the whole mesh; collective)."""

    name = "monolithic-explicit"

    def initialize(self, interface_force: np.ndarray | None = None) -> MacroRecord:
        return self._record(self.system.initialize(None))

    def step(self) -> MacroRecord:
        s = self.system
        E = s.E
        assert E is not None
        n = min(self.stride, self.n_steps - self.done)
        t0 = self.done * s.dt
        # t_j as the step-by-step loop computes it: t_{j−1} + Δt with t_{j−1} = (j − 1) Δt.
        times = (self.done + np.arange(n)) * s.dt + s.dt
        out = E.advance(E.steps(t0, n, mode=kx.NONE, times=times))
        s.explicit_balance(out)
        self.done += n
        s.n += 1
        return self._record(s.record(out.lam, out.gaps, s.micro_trace(t0, out)))


class ImplicitAlone(_Alone):
    """Newmark on the whole mesh, ΔT = Δt (collective)."""

    name = "monolithic-implicit"

    def initialize(self, interface_force: np.ndarray | None = None) -> MacroRecord:
        return self._record(self.system.initialize(None))

    def step(self) -> MacroRecord:
        s = self.system
        I = s.I  # noqa: E741
        assert I is not None
        n = min(self.stride, self.n_steps - self.done)
        for _ in range(n):
            t0 = self.done * s.dt
            t1 = t0 + s.dt
            cv0 = s.damping_now()
            uf, vf, af = I.free_step(t1)
            uI0, vI0 = I.u.copy(), I.v.copy()
            f0 = I.load(t0)
            I.accept(uf, vf, af)
            s.implicit_balance(uI0, vI0, f0, I.load(t1), cv0, None)
            self.done += 1
        s.n += 1
        return self._record(s.record(np.zeros(0), np.zeros(0), MicroTrace.empty()))
