"""The run's clock (Siconos' ``TimeDiscretisation``): micro steps of Δt counted exactly, macro
steps of varying length, the end and the fixed sampling instants."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

__all__ = ["TimeGrid"]


@dataclass
class TimeGrid:
    """Where a run is in time: ``i`` micro steps of Δt and ``n`` macro steps done.

    The time is t = i Δt, never a sum of macro steps (no drift) nor n ΔT (a macro step may
    change its length). The run ends after ``end`` micro steps; it is sampled (history rows,
    stress, reactions, measured points) every ``sample`` micro steps, the same physical
    instants in every method, so that no sampled peak depends on the macro step.

    Not collective: every rank advances its copy alike.
    """

    dt: float
    end: int
    sample: int
    i: int = 0
    n: int = 0

    def __post_init__(self) -> None:
        if self.sample < 1 or self.end < 1:
            raise ValueError(f"time grid: sample = {self.sample} and end = {self.end} must be >= 1")

    @property
    def t(self) -> float:
        """The current time (s)."""
        return self.i * self.dt

    @property
    def finished(self) -> bool:
        return self.i >= self.end

    @property
    def remaining(self) -> int:
        """Micro steps left to the end."""
        return max(0, self.end - self.i)

    def advance(self, micro: int) -> None:
        """One macro step of ``micro`` micro steps done."""
        if micro < 1:
            raise ValueError(f"a macro step of {micro} micro steps")
        self.i += int(micro)
        self.n += 1

    def sampled(self) -> bool:
        """Whether now is a sampling instant (or the end)."""
        return self.i % self.sample == 0 or self.finished

    @property
    def n_samples(self) -> int:
        """Sampling instants after t = 0 up to the end (the end counts as one)."""
        return -(-self.end // self.sample)

    def state_dict(self) -> dict[str, Any]:
        return {"i": self.i, "n": self.n}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.i, self.n = int(state["i"]), int(state["n"])
