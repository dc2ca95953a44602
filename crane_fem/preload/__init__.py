"""The static self-weight state a dynamic run starts from, one module per kind of contact:
the crane's wheel/rail node pairs (``crane``), a gmsh model's node-to-surface contacts held
bonded (``bonded``)."""

from crane_fem.preload.bonded import BondedPoints, bonded_preload
from crane_fem.preload.crane import Preload, static_preload

__all__ = ["BondedPoints", "Preload", "bonded_preload", "static_preload"]
