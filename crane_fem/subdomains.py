"""Subdomains: a dolfinx submesh per group of cells, its formulation's space and operators,
and its DOF maps."""

from __future__ import annotations

from dataclasses import dataclass, field

import dolfinx
import dolfinx.mesh
import numpy as np
import numpy.typing as npt
from mpi4py import MPI

from crane_fem.formulations import CellFields, Formulation, SolidP1
from crane_fem.geometry.tagged import TaggedMesh
from crane_fem.model import StructuralModel, assemble_operators
from crane_fem.stress import CellStress

__all__ = ["PointMasses", "Subdomain", "create_subdomain", "global_ids"]

IntArray = npt.NDArray[np.int64]


@dataclass
class Subdomain:
    """One subdomain: its submesh, space, model and the parent vertex of each DOF block.

    ``parent_vertex[b]`` is the global parent-mesh vertex index of local DOF block ``b``
    (owned and ghost), the key by which interface and contact DOFs are matched across
    subdomains and ranks (no coordinate matching). The subdomain owns ``model``.
    """

    name: str
    scheme: str
    submesh: dolfinx.mesh.Mesh
    V: dolfinx.fem.FunctionSpace
    model: StructuralModel
    parent_vertex: IntArray
    vertex_global: IntArray
    fixed_vertices: IntArray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    #: The local parent cell of each local submesh cell (owned, then ghost).
    parent_cells: npt.NDArray[np.int32] = field(default_factory=lambda: np.zeros(0, np.int32))
    #: The element formulation of its cells, and their material and section (per local
    #: submesh cell: owned, then ghost).
    formulation: Formulation = field(default_factory=SolidP1)
    fields: CellFields = field(default_factory=lambda: CellFields(1.0, 0.0, 1.0))

    def stress(self) -> CellStress:
        """Its formulation's stress recovery on its space (collective)."""
        return self.formulation.stress(self.V, self.fields)  # type: ignore[return-value]

    @property
    def bs(self) -> int:
        return int(self.V.dofmap.index_map_bs)

    @property
    def n_owned_blocks(self) -> int:
        return int(self.V.dofmap.index_map.size_local)

    def owned_dofs_of(self, vertices: IntArray) -> tuple[IntArray, IntArray]:
        """Owned blocks whose parent vertex is in ``vertices`` (global ids, sorted unique).

        Returns ``(blocks, position)``: the local blocks and the index of their vertex in
        ``vertices`` (not collective).
        """
        owned = self.parent_vertex[: self.n_owned_blocks]
        blocks = np.flatnonzero(np.isin(owned, vertices)).astype(np.int64)
        return blocks, np.searchsorted(vertices, owned[blocks]).astype(np.int64)

    def boundary_vertices(self) -> IntArray:
        """Global parent ids of the vertices on the submesh boundary (collective)."""
        tdim = self.submesh.topology.dim
        self.submesh.topology.create_connectivity(tdim - 1, tdim)
        facets = dolfinx.mesh.exterior_facet_indices(self.submesh.topology)
        if tdim == 1:
            verts = facets
        else:
            self.submesh.topology.create_connectivity(tdim - 1, 0)
            verts = dolfinx.mesh.compute_incident_entities(
                self.submesh.topology, facets, tdim - 1, 0
            )
        return global_ids(self.submesh.comm, self.vertex_global[verts])

    def destroy(self) -> None:
        self.model.destroy()


def _vertex_to_block(mesh: dolfinx.mesh.Mesh, V: dolfinx.fem.FunctionSpace) -> IntArray:
    """P1: local DOF block of every local vertex (the cell's dofs follow its vertex order)."""
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim, 0)
    c2v = mesh.topology.connectivity(tdim, 0)
    n_vert = mesh.topology.index_map(0).size_local + mesh.topology.index_map(0).num_ghosts
    out = np.full(n_vert, -1, dtype=np.int64)
    out[c2v.array] = V.dofmap.list.ravel()
    return out


@dataclass(frozen=True)
class PointMasses:
    """Masses and rotary inertias carried at vertices: ``values[k]`` (bs,) on the DOFs of the
    global parent vertex ``vertices[k]`` (sorted unique; kg on translations, kg·m² on
    rotations)."""

    vertices: IntArray
    values: npt.NDArray[np.float64]


def create_subdomain(
    tagged: TaggedMesh,
    name: str,
    scheme: str,
    cells: npt.NDArray[np.int32],
    formulation: Formulation,
    fields: CellFields,
    rayleigh: tuple[float, float],
    fixed_vertices: IntArray,
    consistent_mass: bool,
    pinned_vertices: IntArray | None = None,
    point_masses: PointMasses | None = None,
    held_rotations: IntArray | None = None,
) -> Subdomain:
    """Build the subdomain of ``cells`` (owned parent cells; collective over the mesh comm).

    Args:
        formulation: the element formulation (crane_fem.formulations).
        fields: the material and section of every local parent cell (owned and ghost).
        fixed_vertices: global parent vertex ids that are clamped (all components).
        consistent_mass: also assemble the consistent mass matrix (Newmark).
        pinned_vertices: global parent vertex ids whose translations only are fixed.
        point_masses: masses carried at vertices, added to both masses.
        held_rotations: global parent vertex ids whose rotations are fixed (a beam node on
            ropes only).
    """
    parent = tagged.mesh
    tdim = parent.topology.dim
    sub, cell_map, vertex_map, _ = dolfinx.mesh.create_submesh(parent, tdim, cells)
    V = formulation.space(sub)
    n_sub_v = sub.topology.index_map(0).size_local + sub.topology.index_map(0).num_ghosts
    parent_local = vertex_map.sub_topology_to_topology(
        np.arange(n_sub_v, dtype=np.int32), inverse=False
    )
    vertex_global = np.asarray(
        parent.topology.index_map(0).local_to_global(parent_local.astype(np.int32)),
        dtype=np.int64,
    )
    v2b = _vertex_to_block(sub, V)
    n_blocks = V.dofmap.index_map.size_local + V.dofmap.index_map.num_ghosts
    parent_vertex = np.full(n_blocks, -1, dtype=np.int64)
    parent_vertex[v2b] = vertex_global

    bs = V.dofmap.index_map_bs
    fixed_blocks = np.flatnonzero(np.isin(parent_vertex, fixed_vertices))
    fixed_dofs = (fixed_blocks[:, None] * bs + np.arange(bs)[None, :]).ravel()
    if pinned_vertices is not None and pinned_vertices.size:
        pinned = np.flatnonzero(np.isin(parent_vertex, pinned_vertices))
        comps = np.arange(formulation.translations)
        fixed_dofs = np.union1d(fixed_dofs, (pinned[:, None] * bs + comps[None, :]).ravel())
    if held_rotations is not None and held_rotations.size:
        held = np.flatnonzero(np.isin(parent_vertex, held_rotations))
        comps = np.arange(formulation.translations, bs)
        fixed_dofs = np.union1d(fixed_dofs, (held[:, None] * bs + comps[None, :]).ravel())
    fixed_dofs = fixed_dofs.astype(np.int64)
    imap = sub.topology.index_map(tdim)
    sub_cells = np.arange(imap.size_local + imap.num_ghosts, dtype=np.int32)
    parent_cells = np.asarray(cell_map.sub_topology_to_topology(sub_cells, inverse=False))
    n_own = V.dofmap.index_map.size_local * bs
    extra = None
    if point_masses is not None and point_masses.vertices.size:
        owned = parent_vertex[: V.dofmap.index_map.size_local]
        at = np.flatnonzero(np.isin(owned, point_masses.vertices))
        extra = np.zeros(n_own)
        rows = np.searchsorted(point_masses.vertices, owned[at])
        extra.reshape(-1, bs)[at] = point_masses.values[rows]
    own_fields = fields.restrict(parent_cells)
    K, lumped, M = assemble_operators(
        formulation, V, own_fields, fixed_dofs, consistent_mass, extra
    )
    fixed = np.zeros(n_own, dtype=bool)
    fixed[fixed_dofs[fixed_dofs < n_own]] = True
    model = StructuralModel(V, K, lumped, fixed, rayleigh[0], rayleigh[1], M)
    return Subdomain(
        name,
        scheme,
        sub,
        V,
        model,
        parent_vertex,
        vertex_global,
        fixed_vertices,
        parent_cells,
        formulation,
        own_fields,
    )


def global_ids(comm: MPI.Comm, local: IntArray) -> IntArray:
    """Sorted union over ranks of integer ids (collective)."""
    return np.unique(np.concatenate(comm.allgather(np.asarray(local, dtype=np.int64))))
