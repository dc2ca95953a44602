"""A mesh with named cell and facet groups."""

from __future__ import annotations

from dataclasses import dataclass

import dolfinx.mesh
import numpy as np
import numpy.typing as npt
from mpi4py import MPI

__all__ = ["TaggedMesh"]


@dataclass
class TaggedMesh:
    """Mesh, cell/facet tags and ``{name: tag}`` for each; the tags are rank-local views."""

    mesh: dolfinx.mesh.Mesh
    cell_tags: dolfinx.mesh.MeshTags
    facet_tags: dolfinx.mesh.MeshTags
    cell_groups: dict[str, int]
    facet_groups: dict[str, int]

    def cells(self, names: list[str]) -> npt.NDArray[np.int32]:
        """Local cells (owned) in the named cell groups; KeyError naming an unknown group."""
        tags = [self.cell_groups[n] for n in names]
        n_owned = self.mesh.topology.index_map(self.mesh.topology.dim).size_local
        idx = self.cell_tags.indices[np.isin(self.cell_tags.values, tags)]
        return np.sort(idx[idx < n_owned]).astype(np.int32)

    def global_vertices(self, local: npt.NDArray[np.int32]) -> npt.NDArray[np.int64]:
        """Global (parent) indices of local vertices, gathered from every rank (collective)."""
        mine = self.mesh.topology.index_map(0).local_to_global(local.astype(np.int32))
        parts = self.mesh.comm.allgather(np.asarray(mine, dtype=np.int64))
        return np.unique(np.concatenate(parts))

    def facets(self, name: str) -> npt.NDArray[np.int32]:
        """Local facets (owned and ghost) of a named facet group."""
        return self.facet_tags.indices[self.facet_tags.values == self.facet_groups[name]]

    def facet_vertices(self, name: str) -> npt.NDArray[np.int32]:
        """Local vertices of the facets of a named facet group."""
        tdim = self.mesh.topology.dim
        facets = self.facets(name)
        if tdim == 1:
            return facets.astype(np.int32)
        self.mesh.topology.create_connectivity(tdim - 1, 0)
        return dolfinx.mesh.compute_incident_entities(self.mesh.topology, facets, tdim - 1, 0)

    def vertex_coordinates(self, ids: npt.NDArray[np.int64]) -> npt.NDArray[np.float64]:
        """Coordinates (n, 3) of the vertices of global ids ``ids``, the same on every rank
        (collective: each from the rank owning it)."""
        msh = self.mesh
        msh.topology.create_connectivity(0, msh.topology.dim)
        imap = msh.topology.index_map(0)
        own = np.arange(imap.size_local, dtype=np.int32)
        gids = np.asarray(imap.local_to_global(own), dtype=np.int64)
        sel = np.isin(gids, ids)
        rows = dolfinx.mesh.entities_to_geometry(msh, 0, own[sel]).ravel()
        X = np.zeros((ids.size, 3))
        X[np.searchsorted(ids, gids[sel])] = msh.geometry.x[rows]
        out: npt.NDArray[np.float64] = msh.comm.allreduce(X, op=MPI.SUM)
        return out
