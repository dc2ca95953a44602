"""A 1D bar split into two named cell groups at a material point (for coupled runs)."""

from __future__ import annotations

import dolfinx.mesh
import numpy as np
from mpi4py import MPI

from crane_fem.geometry import groups
from crane_fem.geometry.tagged import TaggedMesh
from crane_fem.mesh import Segment, create_bar_mesh

__all__ = ["create_split_bar"]


def create_split_bar(comm: MPI.Comm, segment: Segment, split: float) -> TaggedMesh:
    """Bar ``segment`` with cells left/right of ``x0 + split`` tagged ``left``/``right``.

    ``split`` must fall on a node (a multiple of the element size) so that the interface is a
    mesh vertex. Collective.
    """
    bar = create_bar_mesh(comm, [segment])
    mesh = bar.mesh
    tdim = 1
    n_cells = mesh.topology.index_map(tdim).size_local
    cells = np.arange(n_cells, dtype=np.int32)
    mid = dolfinx.mesh.compute_midpoints(mesh, tdim, cells)[:, 0]
    tags = np.where(mid < segment.x0 + split, 1, 2).astype(np.int32)
    cell_tags = dolfinx.mesh.meshtags(mesh, tdim, cells, tags)
    mesh.topology.create_connectivity(0, 1)
    n_vert = mesh.topology.index_map(0).size_local + mesh.topology.index_map(0).num_ghosts
    verts = np.arange(n_vert, dtype=np.int32)
    x = mesh.geometry.x[:, 0]
    # Vertex i of an interval mesh has geometry node i (P1 coordinate element).
    vx = x[dolfinx.mesh.entities_to_geometry(mesh, 0, verts).ravel()]
    left = np.flatnonzero(vx == segment.x0)
    right = np.flatnonzero(vx == segment.x0 + segment.length)
    fidx = np.concatenate([left, right]).astype(np.int32)
    fval = np.concatenate([np.full(left.size, 1), np.full(right.size, 2)]).astype(np.int32)
    order = np.argsort(fidx)
    facet_tags = dolfinx.mesh.meshtags(mesh, 0, fidx[order], fval[order])
    return TaggedMesh(
        mesh,
        cell_tags,
        facet_tags,
        {groups.BAR_LEFT: 1, groups.BAR_RIGHT: 2},
        {groups.BAR_LEFT_END: 1, groups.BAR_RIGHT_END: 2},
    )
