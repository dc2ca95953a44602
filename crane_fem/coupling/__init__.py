"""Heterogeneous asynchronous coupling of an explicit and an implicit subdomain: the two
sides (:class:`CoupledSystem`), the interface operator, and one module per method behind the
:class:`MacroStep` protocol, each with a ``create(system, setup)`` registered by scenario name
in :data:`METHODS`; a method that refines at impacts contains two of its own
(crane_fem.coupling.adaptive)."""

from collections.abc import Callable

from crane_fem.coupling import (
    energy_conserving,
    gc_mean,
    gravouil_combescure,
    hybrid,
    prakash_hjelmstad,
)
from crane_fem.coupling.adaptive import Adaptive, create_adaptive
from crane_fem.coupling.interface import build_interface, constraint_set
from crane_fem.coupling.monolithic import ExplicitAlone, ImplicitAlone
from crane_fem.coupling.operator import OperatorReport, create_interface_operator
from crane_fem.coupling.protocol import MacroStep, MethodSetup
from crane_fem.coupling.system import ENERGY_KEYS, PH_KEYS, CoupledSystem, MacroRecord

__all__ = [
    "ENERGY_KEYS",
    "METHODS",
    "PH_KEYS",
    "Adaptive",
    "CoupledSystem",
    "ExplicitAlone",
    "ImplicitAlone",
    "MacroRecord",
    "MacroStep",
    "MethodSetup",
    "OperatorReport",
    "build_interface",
    "constraint_set",
    "create_interface_operator",
    "create_method",
]

#: The coupling methods' factories by their scenario name (``[coupling] method``).
METHODS: dict[str, Callable[[CoupledSystem, MethodSetup], MacroStep]] = {
    "gc": gravouil_combescure.create,
    "gc-mean": gc_mean.create,
    "ph": prakash_hjelmstad.create,
    "ec": energy_conserving.create,
    "hybrid": hybrid.create,
}


def create_method(
    name: str, system: CoupledSystem, setup: MethodSetup, fine_ratio: int | None = None
) -> MacroStep:
    """The coupling method ``name`` on ``system`` (collective); with ``fine_ratio``, its
    macro step refines at impacts (``setup.options`` then holds ``refine_quiet`` and
    ``refine_margin`` where set). An unknown name is an error listing the valid ones."""
    try:
        create = METHODS[name]
    except KeyError:
        raise ValueError(
            f"unknown coupling method {name!r}; valid: {', '.join(sorted(METHODS))}"
        ) from None
    if fine_ratio is None:
        return create(system, setup)
    opts = setup.options
    return create_adaptive(
        system,
        lambda s: create(s, setup),  # type: ignore[arg-type,return-value]
        fine_ratio,
        setup.static,
        opts.get("refine_quiet"),
        opts.get("refine_margin"),
    )
