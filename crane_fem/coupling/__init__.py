"""Heterogeneous asynchronous coupling of an explicit and an implicit subdomain: the two
sides (:class:`CoupledSystem`), the interface operator, and one module per method behind the
:class:`MacroStep` protocol, registered by scenario name in :data:`METHODS`."""

from crane_fem.coupling.energy_conserving import EnergyConserving
from crane_fem.coupling.gc_mean import GCMean
from crane_fem.coupling.gravouil_combescure import GravouilCombescure
from crane_fem.coupling.hybrid import Hybrid
from crane_fem.coupling.interface import build_interface, constraint_set
from crane_fem.coupling.monolithic import ExplicitAlone, ImplicitAlone
from crane_fem.coupling.operator import OperatorReport, create_interface_operator
from crane_fem.coupling.prakash_hjelmstad import PrakashHjelmstad
from crane_fem.coupling.protocol import MacroStep
from crane_fem.coupling.system import ENERGY_KEYS, PH_KEYS, CoupledSystem, MacroRecord

__all__ = [
    "ENERGY_KEYS",
    "METHODS",
    "PH_KEYS",
    "CoupledSystem",
    "ExplicitAlone",
    "ImplicitAlone",
    "MacroRecord",
    "MacroStep",
    "OperatorReport",
    "build_interface",
    "constraint_set",
    "create_interface_operator",
    "method_class",
]

#: The coupling methods by their scenario name (``[coupling] method``).
METHODS: dict[str, type] = {
    cls.name: cls
    for cls in (GravouilCombescure, GCMean, PrakashHjelmstad, EnergyConserving, Hybrid)
}


def method_class(name: str) -> type:
    """The class of the coupling method ``name``; an unknown name is an error listing the
    valid ones."""
    try:
        return METHODS[name]
    except KeyError:
        raise ValueError(
            f"unknown coupling method {name!r}; valid: {', '.join(sorted(METHODS))}"
        ) from None
