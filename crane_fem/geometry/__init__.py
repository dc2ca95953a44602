"""Geometry: gmsh scripts and tagged meshes; physical-group names live in ``groups``."""

from crane_fem.geometry.bar import create_split_bar
from crane_fem.geometry.box_beam import create_box_beam
from crane_fem.geometry.tagged import TaggedMesh

__all__ = ["TaggedMesh", "create_box_beam", "create_split_bar"]
