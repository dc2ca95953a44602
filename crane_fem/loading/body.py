"""Body loads of a subdomain in the affine form F(t) = F_0 + Σ_k s_k(t) F_k: self-weight,
ground motion (−M ι a_g(t) per direction), a tip traction pulse.

The explicit kernel takes the vectors once and the scalars s_k(t_j) of a whole macro step at
a time (crane_fem.kernels.explicit); the implicit side and the bar integrators call the load.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from crane_fem.loading.accelerogram import Accelerogram

__all__ = ["AffineLoad", "GroundMotionHistory", "PulseHistory"]

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class GroundMotionHistory:
    """a_g at run time t: ``record`` from record time ``start`` on, faded in by a half-cosine
    over ``taper`` seconds."""

    record: Accelerogram
    start: float = 0.0
    taper: float = 0.0

    def _ramp(self, t: float) -> float:
        return 0.5 - 0.5 * math.cos(math.pi * t / self.taper) if t < self.taper else 1.0

    def __call__(self, t: float) -> float:
        return self._ramp(t) * self.record(self.start + t)

    def at(self, times: FloatArray) -> FloatArray:
        """The values of :meth:`__call__` at many times (math.cos in the taper, as there)."""
        out = self.record.at(self.start + times)
        early = np.flatnonzero(times < self.taper)
        for k in early:
            out[k] = self._ramp(float(times[k])) * out[k]
        return out


@dataclass(frozen=True)
class PulseHistory:
    """sin(π t / duration) on [0, duration], zero after."""

    duration: float

    def __call__(self, t: float) -> float:
        return math.sin(math.pi * t / self.duration) if 0.0 <= t <= self.duration else 0.0

    def at(self, times: FloatArray) -> FloatArray:
        return np.array([self(float(t)) for t in times], dtype=np.float64)


History = GroundMotionHistory | PulseHistory | Callable[[float], float]


@dataclass(frozen=True)
class AffineLoad:
    """F(t) = ``base`` + Σ_k ``histories[k](t)`` ``shapes[k]`` on the owned DOFs (N)."""

    base: FloatArray
    shapes: FloatArray = field(default_factory=lambda: np.zeros((0, 0)))
    histories: Sequence[History] = ()

    def __post_init__(self) -> None:
        if self.shapes.size == 0:
            object.__setattr__(self, "shapes", np.zeros((0, self.base.size)))
        if self.shapes.shape != (len(self.histories), self.base.size):
            raise ValueError("AffineLoad: one shape of the base's size per history")

    def __call__(self, t: float) -> FloatArray:
        out = self.base.copy()
        for h, shape in zip(self.histories, self.shapes, strict=True):
            out += h(t) * shape
        return out

    def coefficients(self, times: FloatArray) -> FloatArray:
        """s_k(t_j) as an (n_times, n_shapes) array."""
        out = np.zeros((times.size, len(self.histories)))
        for k, h in enumerate(self.histories):
            at = getattr(h, "at", None)
            out[:, k] = at(times) if at is not None else [h(float(t)) for t in times]
        return out
