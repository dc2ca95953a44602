"""The parent mesh's owned vertices, where the monitors find the points they follow."""

from __future__ import annotations

import dolfinx.mesh
import numpy as np
import numpy.typing as npt

from crane_fem.pipeline import Simulation

__all__ = ["owned_vertices"]


def owned_vertices(sim: Simulation) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64]]:
    """The global ids (the index map's) and coordinates (n, 3) of the parent mesh's owned
    vertices (not collective)."""
    mesh = sim.mesh.tagged.mesh
    local = np.arange(mesh.topology.index_map(0).size_local, dtype=np.int32)
    ids = np.asarray(mesh.topology.index_map(0).local_to_global(local), dtype=np.int64)
    xyz = np.asarray(mesh.geometry.x)[dolfinx.mesh.entities_to_geometry(mesh, 0, local).ravel()]
    return ids, xyz
