"""Heterogeneous asynchronous coupling of subdomains (Gravouil–Combescure, Prakash–Hjelmstad)."""

from crane_fem.coupling.gravouil_combescure import CoupledIntegrator, MacroRecord
from crane_fem.coupling.interface import build_interface, constraint_set

__all__ = ["CoupledIntegrator", "MacroRecord", "build_interface", "constraint_set"]
