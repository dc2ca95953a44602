"""An elastic box above a rigid plane (the friction verification scenes): a dolfinx box mesh
of P1 tetrahedra with its bottom and top faces named."""

from __future__ import annotations

import math
from dataclasses import dataclass

import dolfinx.mesh
import numpy as np
from mpi4py import MPI

from crane_fem.geometry import groups
from crane_fem.geometry.tagged import TaggedMesh

__all__ = ["Block", "create_block"]


@dataclass(frozen=True)
class Block:
    """The box [0, lx] × [0, ly] × [gap, gap + lz] (m), tetrahedra of size about ``h``."""

    lx: float
    ly: float
    lz: float
    gap: float
    h: float

    @property
    def divisions(self) -> list[int]:
        """Cells per side: the sides split into intervals no longer than ``h``."""
        return [max(1, math.ceil(side / self.h - 1e-9)) for side in (self.lx, self.ly, self.lz)]


def create_block(comm: MPI.Comm, block: Block) -> TaggedMesh:
    """Mesh the block (collective). Cell group ``block``; facet groups ``bottom`` (z = gap)
    and ``top`` (z = gap + lz)."""
    z0, z1 = block.gap, block.gap + block.lz
    mesh = dolfinx.mesh.create_box(
        comm,
        [np.array([0.0, 0.0, z0]), np.array([block.lx, block.ly, z1])],
        block.divisions,
        dolfinx.mesh.CellType.tetrahedron,
    )
    tdim = mesh.topology.dim
    n_cells = mesh.topology.index_map(tdim).size_local + mesh.topology.index_map(tdim).num_ghosts
    cells = np.arange(n_cells, dtype=np.int32)
    cell_tags = dolfinx.mesh.meshtags(mesh, tdim, cells, np.ones(n_cells, dtype=np.int32))
    tol = 1e-9 * block.lz
    bottom = dolfinx.mesh.locate_entities_boundary(
        mesh, tdim - 1, lambda x: np.abs(x[2] - z0) <= tol
    )
    top = dolfinx.mesh.locate_entities_boundary(mesh, tdim - 1, lambda x: np.abs(x[2] - z1) <= tol)
    idx = np.concatenate([bottom, top]).astype(np.int32)
    val = np.concatenate([np.full(bottom.size, 1), np.full(top.size, 2)]).astype(np.int32)
    order = np.argsort(idx)
    facet_tags = dolfinx.mesh.meshtags(mesh, tdim - 1, idx[order], val[order])
    return TaggedMesh(
        mesh,
        cell_tags,
        facet_tags,
        {groups.BLOCK: 1},
        {groups.BLOCK_BOTTOM: 1, groups.BLOCK_TOP: 2},
    )
