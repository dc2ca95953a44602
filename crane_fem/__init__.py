"""crane_fem: seismic analysis of structures with impacts on FEniCSx."""

from crane_fem import _compat  # noqa: F401  (loads MPI before dolfinx/petsc4py)

__all__ = ["__version__"]
__version__ = "0.1.0"
