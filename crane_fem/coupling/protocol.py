"""The macro-step protocol every coupling method follows, and the life cycle they share.

Kratos' co-simulation solvers and Siconos' one-step integrators keep the method apart from the
orchestration: a method here turns one synchronisation time of a
:class:`~crane_fem.coupling.system.CoupledSystem` into the next; the driver only loops, records
and writes.
"""

from __future__ import annotations

from typing import Any, ClassVar, Protocol

import numpy.typing as npt

from crane_fem.coupling.system import CoupledSystem, ImplicitSide, MacroRecord

__all__ = ["ImplicitSide", "MacroStep", "MethodBase"]


class MacroStep(Protocol):
    """One coupling method: ``initialize`` once, then ``step`` per macro step (collective)."""

    name: ClassVar[str]
    system: CoupledSystem

    def initialize(self, interface_force: npt.NDArray[Any] | None = None) -> MacroRecord: ...

    def step(self) -> MacroRecord: ...

    def history_keys(self) -> list[str]: ...

    def summary(self) -> dict[str, Any]: ...

    def destroy(self) -> None: ...


class MethodBase:
    """The shared life cycle: start the system, no extra history columns or summary entries,
    nothing to release. A method overrides :meth:`step` and what else it needs."""

    name: ClassVar[str] = ""

    def __init__(self, system: CoupledSystem) -> None:
        self.system = system

    def initialize(self, interface_force: npt.NDArray[Any] | None = None) -> MacroRecord:
        return self.system.initialize(interface_force)

    def step(self) -> MacroRecord:  # pragma: no cover - every method overrides it
        raise NotImplementedError

    def history_keys(self) -> list[str]:
        return []

    def summary(self) -> dict[str, Any]:
        return {}

    def destroy(self) -> None:
        return None
