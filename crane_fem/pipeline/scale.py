"""The size and mass of a user's mesh against SI units: a mesh drawn in mm is refused before
anything is built on it.

crane_fem reads coordinates in metres. A mesh drawn in millimetres is 1000× too large: a
4 m crane becomes 4 km across and, with ρ in kg/m³, 10⁹× too heavy. Left alone, its critical
step is 1000× too long, so the first error it meets is an unrelated one (a sampling interval
below Δt) and a run reports a weight of 10¹³ N. The rule, for a gmsh model's and a frame's
``model.mesh``: a bounding box wider than :data:`MAX_EXTENT_M` (1 km) or a mass above
:data:`MAX_MASS_KG` (10⁹ kg, a million tonnes) is refused. The extent catches any structure
wider than 1 m drawn in mm (whatever its density's units, e.g. the mm–t–s system); the mass
catches a solid heavier than 1 kg drawn in mm, however small. The largest cranes (a few
hundred metres, a few thousand tonnes) stay two orders of magnitude inside both limits.
"""

from __future__ import annotations

import dolfinx.mesh
import numpy as np
import numpy.typing as npt
from mpi4py import MPI

from crane_fem.errors import ScenarioError

__all__ = ["MAX_EXTENT_M", "MAX_MASS_KG", "cell_measures", "check_mesh_scale"]

FloatArray = npt.NDArray[np.float64]

#: The widest model accepted (m): above it, a mesh was drawn in another unit than metres.
MAX_EXTENT_M = 1000.0
#: The heaviest model accepted (kg): a million tonnes, 500× a 2000 t gantry crane.
MAX_MASS_KG = 1e9


def cell_measures(msh: dolfinx.mesh.Mesh) -> FloatArray:
    """The volume (m³) of each owned tetrahedron, or the length (m) of each owned line, of a
    P1 mesh (not collective)."""
    tdim = msh.topology.dim
    n_own = msh.topology.index_map(tdim).size_local
    cells = np.arange(n_own, dtype=np.int32)
    x = msh.geometry.x[dolfinx.mesh.entities_to_geometry(msh, tdim, cells)]
    if tdim == 1:
        return np.asarray(np.linalg.norm(x[:, 1] - x[:, 0], axis=1), dtype=np.float64)
    assert tdim == 3, "P1 tetrahedra or lines"
    edges = x[:, 1:] - x[:, :1]
    return np.asarray(np.abs(np.linalg.det(edges)) / 6.0, dtype=np.float64)


def _owned(value: float | FloatArray, n: int) -> FloatArray:
    """A per-cell field (owned, then ghost) or one value, on the ``n`` owned cells."""
    arr = np.asarray(value, dtype=np.float64)
    return np.full(n, float(arr)) if arr.ndim == 0 else arr[:n]


def check_mesh_scale(
    path: str, msh: dolfinx.mesh.Mesh, rho: float | FloatArray, area: float | FloatArray = 1.0
) -> None:
    """Refuse a mesh whose bounding box is wider than :data:`MAX_EXTENT_M` or whose mass
    Σ ρ (A) |cell| exceeds :data:`MAX_MASS_KG` (collective over the mesh's communicator:
    the same one line on every rank).

    Args:
        path: the mesh file, as the scene names it (``model.mesh``).
        msh: the mesh (P1 tetrahedra, or a frame's lines).
        rho: the density of every local cell (owned, then ghost) or one for all (kg/m³).
        area: a frame's section area per local cell, or one for all (m²; 1 for a solid).

    Raises:
        ScenarioError: the mesh looks drawn in mm.
    """
    comm = msh.comm
    x = msh.geometry.x
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    comm.Allreduce(x.min(axis=0, initial=np.inf), lo, op=MPI.MIN)
    comm.Allreduce(x.max(axis=0, initial=-np.inf), hi, op=MPI.MAX)
    sides = np.maximum(hi - lo, 0.0)
    size = cell_measures(msh)
    mass = comm.allreduce(
        float(np.sum(_owned(rho, size.size) * _owned(area, size.size) * size)), op=MPI.SUM
    )
    extent = float(np.max(sides))
    if extent <= MAX_EXTENT_M and mass <= MAX_MASS_KG:
        return
    box = " × ".join(f"{s:.4g}" for s in sides)
    heaviest = f"{MAX_MASS_KG:.0e}".replace("e+0", "e")
    raise ScenarioError(
        f"model.mesh: {path}: the mesh looks drawn in mm: its bounding box is {box} m and its "
        f"mass {mass:.3g} kg (crane_fem reads metres: a model wider than {MAX_EXTENT_M:g} m "
        f"or heavier than {heaviest} kg is refused); scale it by 0.001, e.g. "
        "gmsh.option.setNumber('Mesh.ScalingFactor', 0.001) before gmsh.write"
    )
