"""The monolithic references: one subdomain over the whole mesh, explicit (CD-Lagrange, the
fully explicit reference) or implicit (Newmark), as macro steps of ``stride`` time steps so
that the driver records at the coupled run's output times.
"""

from __future__ import annotations

import math

import numpy as np

from crane_fem.coupling.protocol import MethodBase
from crane_fem.coupling.system import CoupledSystem, MacroRecord, MicroTrace
from crane_fem.kernels import explicit as kx

__all__ = ["ExplicitAlone", "ImplicitAlone"]


class _Alone(MethodBase):
    """``stride`` steps of Δt per macro step up to the system's clock's end (the last macro
    step may be shorter)."""

    def __init__(self, system: CoupledSystem, stride: int) -> None:
        super().__init__(system)
        if stride < 1:
            raise ValueError(f"stride = {stride} must be >= 1")
        self.stride = int(stride)

    @property
    def n_macro(self) -> int:
        return math.ceil(self.system.grid.end / self.stride)

    def resumable(self) -> bool:
        """Not after a last macro step shorter than ``stride``: a longer run would have
        taken it whole."""
        grid = self.system.grid
        return grid.i == grid.n * self.stride

    def _steps(self) -> int:
        """The steps of Δt of the next macro step."""
        return min(self.stride, self.system.grid.remaining)


class ExplicitAlone(_Alone):
    """The fully explicit reference (THEORY.md §1 on the whole mesh; collective)."""

    name = "monolithic-explicit"

    def initialize(self, interface_force: np.ndarray | None = None) -> MacroRecord:
        return self.system.initialize(None)

    def step(self) -> MacroRecord:
        s = self.system
        E = s.E
        assert E is not None
        n = self._steps()
        i0 = s.grid.i
        t0 = s.t
        # t_j as the step-by-step loop computes it: t_{j−1} + Δt with t_{j−1} = (j − 1) Δt.
        times = (i0 + np.arange(n)) * s.dt + s.dt
        # Readings between the records (a peak read on a finer interval than the
        # sampling's) after the clock's steps every, 2 every, ... (the same instants at any
        # sampling interval), taken by the kernel: one call per record.
        every = s.observe_every if s.probe_reader is not None else 0
        first = (-i0 - 1) % every if every else 0
        ctl = E.steps(
            t0,
            n,
            mode=kx.NONE,
            times=times,
            probe=s.probe if every else None,
            probe_every=every,
            probe_first=first,
        )
        out = E.advance(ctl)
        if out.probe_u.shape[0]:  # (the same readings on every rank: collective)
            assert s.probe_reader is not None
            at = i0 + first + 1 + every * np.arange(out.probe_u.shape[0])
            s.probe_reader(at.astype(np.float64) * s.grid.dt, out.probe_u, out.probe_v)
        s.explicit_balance(out)
        s.grid.advance(n)
        return s.record(out.lam, out.gaps, s.micro_trace(t0, out))


class ImplicitAlone(_Alone):
    """Newmark on the whole mesh, ΔT = Δt (collective)."""

    name = "monolithic-implicit"

    def initialize(self, interface_force: np.ndarray | None = None) -> MacroRecord:
        return self.system.initialize(None)

    def step(self) -> MacroRecord:
        s = self.system
        I = s.I  # noqa: E741
        assert I is not None
        n = self._steps()
        i0 = s.grid.i
        every = s.observe_every if s.observers else 0  # observed between records
        for k in range(n):
            t0 = (i0 + k) * s.dt
            t1 = t0 + s.dt
            cv0 = s.damping_now()
            uf, vf, af = I.free_step(t1)
            uI0, vI0 = I.u.copy(), I.v.copy()
            f0 = I.load(t0)
            I.accept(uf, vf, af)
            s.implicit_balance(uI0, vI0, f0, I.load(t1), cv0, None)
            if every and (i0 + k + 1) % every == 0 and k + 1 < n:
                s.grid.i = i0 + k + 1  # the clock at the observed state, restored below
                for fn in s.observers:
                    fn(s)
                s.grid.i = i0
        s.grid.advance(n)
        return s.record(np.zeros(0), np.zeros(0), MicroTrace.empty())
