"""One-step integrator interface and the record each step yields."""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from crane_fem.contact import ContactSet
from crane_fem.energy import EnergyBalance
from crane_fem.model import LoadFunction, StructuralModel

__all__ = ["StepRecord", "TimeIntegrator"]

FloatArray = npt.NDArray[np.float64]


@dataclass
class StepRecord:
    """State at output time ``t`` (step ``step``).

    ``u`` and ``v`` are owned-DOF arrays owned by the integrator (copy them to keep them);
    ``impulse`` (p,) holds the contact impulses Λ of this step (N·s; the mean contact force
    over the step is Λ/Δt), ``gaps`` (p,) the gaps at ``t``. Both are global.
    """

    step: int
    t: float
    u: FloatArray
    v: FloatArray
    impulse: FloatArray
    gaps: FloatArray
    energy: EnergyBalance


class TimeIntegrator(ABC):
    """A one-step scheme for ``M a + C v + K u = f(t) + Lᵀ λ`` with unilateral contact.

    Subclasses own their PETSc objects and release them in :meth:`destroy` (collective).
    """

    name: str = "integrator"

    def __init__(
        self,
        model: StructuralModel,
        contacts: ContactSet,
        load: LoadFunction,
        dt: float,
        u0: FloatArray,
        v0: FloatArray,
    ) -> None:
        if not dt > 0.0:
            raise ValueError(f"time step must be positive, got {dt}")
        self.model = model
        self.contacts = contacts
        self.load = load
        self.dt = float(dt)
        self.n = 0
        self.u = np.array(u0, dtype=np.float64)
        self.v0 = np.array(v0, dtype=np.float64)
        self.energy = EnergyBalance()

    @property
    def t(self) -> float:
        return self.n * self.dt

    def _reduce(self, local: list[float]) -> FloatArray:
        """Sum a few rank-local scalars over the communicator (one reduction)."""
        buf = np.asarray(local, dtype=np.float64)
        out = np.empty_like(buf)
        self.model.comm.Allreduce(buf, out)
        return out

    @abstractmethod
    def initialize(self) -> StepRecord:
        """Set up the first step from (u0, v0) and return the record at t = 0 (collective)."""

    @abstractmethod
    def step(self) -> StepRecord:
        """Advance one step and return the record at the new time (collective)."""

    def run(self, n_steps: int) -> Iterator[StepRecord]:
        """Yield the record at t = 0, then one per step, ``n_steps`` steps (collective)."""
        yield self.initialize()
        for _ in range(n_steps):
            yield self.step()

    @abstractmethod
    def destroy(self) -> None:
        """Release PETSc objects (collective)."""

    def __enter__(self) -> TimeIntegrator:
        return self

    def __exit__(self, *exc: object) -> None:
        self.destroy()
