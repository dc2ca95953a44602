"""The macro-step protocol every coupling method follows, and the life cycle they share.

Kratos' co-simulation solvers and Siconos' one-step integrators keep the method apart from the
orchestration: a method here turns one synchronisation time of a
:class:`~crane_fem.coupling.system.CoupledSystem` into the next; the driver only loops, records
and writes.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, ClassVar, Protocol

import numpy as np
import numpy.typing as npt

from crane_fem.coupling.system import CoupledSystem, ImplicitSide, MacroRecord
from crane_fem.kernels.zone import InterfaceOp

__all__ = ["ImplicitSide", "MacroStep", "MethodBase", "MethodSetup"]


@dataclass(frozen=True)
class MethodSetup:
    """What a coupling module's ``create(system, setup)`` may use beyond the system: the
    interface operator of an implicit side at a ratio (the methods that solve the interface
    every micro step), the method's own ``[coupling]`` keys that the scenario sets, and each
    contact group's static force (N; the preload's, or None)."""

    operator: Callable[[ImplicitSide, int, bool], InterfaceOp] | None = None
    options: dict[str, Any] = field(default_factory=dict)
    static: npt.NDArray[np.float64] | None = None

    def operator_for(self, system: CoupledSystem, fixed: bool = False) -> InterfaceOp:
        """The operator of the system's current implicit side and ratio (``fixed``: for
        k = m only, as gc-mean uses it)."""
        if self.operator is None or system.I is None:
            raise ValueError("this coupling method needs the interface operator")
        return self.operator(system.I, system.m, fixed)


class MacroStep(Protocol):
    """One coupling method: ``initialize`` once, then ``step`` per macro step (collective)."""

    name: ClassVar[str]
    system: CoupledSystem

    def initialize(self, interface_force: npt.NDArray[Any] | None = None) -> MacroRecord: ...

    def step(self) -> MacroRecord: ...

    def history_keys(self) -> list[str]: ...

    def summary(self) -> dict[str, Any]: ...

    def resumable(self) -> bool: ...

    def state_dict(self) -> dict[str, Any]: ...

    def load_state_dict(self, state: dict[str, Any]) -> None: ...

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

    # Checkpoints: the state a continued run needs, between macro steps, as nested dicts of
    # arrays and scalars (this rank's arrays; crane_fem.checkpoint writes them). What is built
    # once at set-up (operators, factorisations, the interface operator, "ec"'s and "ph"'s
    # explicit responses, recomputed on demand the same way) is not in it.
    def resumable(self) -> bool:
        """Whether a run continued from now steps as the uninterrupted one would."""
        return True

    def state_dict(self) -> dict[str, Any]:
        """The system's state and the method's own (not collective)."""
        return {"system": self.system.state_dict(), "method": self.method_state()}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        """Set the state from :meth:`state_dict` of the same method and partition."""
        self.system.load_state_dict(state["system"])
        self.load_method_state(state.get("method", {}))

    def method_state(self) -> dict[str, Any]:
        """The method's own accumulators (none here)."""
        return {}

    def load_method_state(self, state: dict[str, Any]) -> None:
        return None

    def destroy(self) -> None:
        return None
