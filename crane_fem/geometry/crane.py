"""The distributed crane mesh: its groups and its contact pairs as global vertex ids.

The crane's modules, one concept each, from the bottom up: :mod:`.crane_parameters`
(:class:`CraneGeometry`), :mod:`.crane_pairs` (groups and node pairs of a gmsh model),
:mod:`.crane_mirror` (the meshed region reflected into the whole crane), :mod:`.crane_build`
(the gmsh OpenCASCADE model and its mesh), :mod:`.crane_file` (the ``.msh`` file and its
sidecar), and this one, which also hands their public names on.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import dolfinx.io.gmsh
import dolfinx.mesh
import gmsh
import numpy as np
import numpy.typing as npt
from mpi4py import MPI

from crane_fem.errors import ScenarioError
from crane_fem.geometry.crane_build import build_crane_model
from crane_fem.geometry.crane_file import mesh_sidecar, read_mesh_sidecar, write_crane_mesh
from crane_fem.geometry.crane_pairs import CraneMeshInfo, FlangePairs, mesh_info
from crane_fem.geometry.crane_parameters import CraneGeometry
from crane_fem.geometry.gmsh_file import distribute_gmsh_model
from crane_fem.geometry.groups import CRANE_FLANGE_SURFACES
from crane_fem.geometry.tagged import TaggedMesh

__all__ = [
    "FLANGE_SURFACE_NAMES",
    "CraneGeometry",
    "CraneMesh",
    "CraneMeshInfo",
    "FlangePairs",
    "build_crane_model",
    "create_crane_mesh",
    "input_nodes_to_global_vertices",
    "mesh_info",
    "mesh_sidecar",
    "read_mesh_sidecar",
    "write_crane_mesh",
]

#: The surface groups of a crane with flanges (:data:`.groups.CRANE_FLANGE_SURFACES`).
FLANGE_SURFACE_NAMES = CRANE_FLANGE_SURFACES


def _no_ids(*shape: int) -> npt.NDArray[np.int64]:
    return np.zeros(shape, dtype=np.int64)


@dataclass
class CraneMesh:
    """The distributed crane mesh with its groups and wheel/rail contact vertex pairs.

    ``pairs[k]`` = (wheel vertex, rail vertex) as global parent-mesh vertex ids; ``wheel[k]``
    (1–4) tells which wheel the pair belongs to. Identical on every rank.

    With flanges (empty without): ``flange_pairs[j]`` = (flange vertex, rail vertex), global
    parent-mesh vertex ids, a node-to-node lateral contact; ``flange_wheel[j]`` (1–4) its
    wheel; ``flange_inner[j]`` whether it is the wheel's inner flange (between the rail and
    x = 0); ``flange_normal[j]`` the unit normal (±e_x) pointing from the rail towards the
    flange; ``flange_gap[j]`` (m) the initial gap, (x_flange − x_rail)·normal = the clearance
    to round-off. The gap is g = g0 + (u_flange − u_rail)·normal ≥ 0. Identical on every rank.
    """

    tagged: TaggedMesh
    pairs: npt.NDArray[np.int64]
    wheel: npt.NDArray[np.int64]
    flange_pairs: npt.NDArray[np.int64] = field(default_factory=lambda: _no_ids(0, 2))
    flange_wheel: npt.NDArray[np.int64] = field(default_factory=lambda: _no_ids(0))
    flange_inner: npt.NDArray[np.bool_] = field(default_factory=lambda: np.zeros(0, dtype=bool))
    flange_normal: npt.NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 3)))
    flange_gap: npt.NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))


def input_nodes_to_global_vertices(
    mesh: dolfinx.mesh.Mesh, input_nodes: npt.NDArray[np.int64]
) -> npt.NDArray[np.int64]:
    """Global vertex ids of input (gmsh, 0-based) node indices of an affine P1 mesh (collective).

    Uses ``geometry.input_global_indices`` (dolfinx keeps each node's input index) and the
    vertex-to-geometry map; every rank returns the same array.
    """
    mesh.topology.create_connectivity(0, mesh.topology.dim)
    n_v = mesh.topology.index_map(0).size_local + mesh.topology.index_map(0).num_ghosts
    verts = np.arange(n_v, dtype=np.int32)
    geom = dolfinx.mesh.entities_to_geometry(mesh, 0, verts).ravel()
    inp = np.asarray(mesh.geometry.input_global_indices, dtype=np.int64)[geom]
    glob = np.asarray(mesh.topology.index_map(0).local_to_global(verts), dtype=np.int64)
    sel = np.isin(inp, input_nodes)
    found = np.concatenate(mesh.comm.allgather(np.column_stack([inp[sel], glob[sel]])))
    lookup = dict(zip(found[:, 0].tolist(), found[:, 1].tolist(), strict=False))
    missing = [int(i) for i in input_nodes if int(i) not in lookup]
    if missing:
        raise RuntimeError(f"input nodes {missing[:5]} are not mesh vertices")
    return np.array([lookup[int(i)] for i in input_nodes], dtype=np.int64)


def create_crane_mesh(
    comm: MPI.Comm, geo: CraneGeometry, msh_file: str | Path | None = None
) -> CraneMesh:
    """Validate, mesh with gmsh on rank 0 (or read ``msh_file``, a mesh written by
    :func:`write_crane_mesh`), distribute, and map the contact pairs (collective).

    Raises:
        ScenarioError: a geometry parameter out of range, or a missing or foreign mesh file,
            on every rank, before meshing.
    """
    geo.validate()  # every rank checks the same parameters: the same error everywhere
    if msh_file is not None and not Path(msh_file).is_file():
        raise ScenarioError(f"model.mesh: {msh_file} is not a file (write it with crane-fem mesh)")
    info: CraneMeshInfo | None = None
    error: str | None = None
    if comm.rank == 0:
        gmsh.initialize(interruptible=False)
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("General.NumThreads", 1)
        if msh_file is not None:
            gmsh.open(str(msh_file))
            try:
                info = mesh_info()
            except ScenarioError as exc:
                error = f"model.mesh: {msh_file}: {exc}"
        else:
            gmsh.model.add("crane")
            info = build_crane_model(geo)
    data = distribute_gmsh_model(comm, error)
    info = comm.bcast(info, root=0)
    assert info is not None and data.cell_tags is not None and data.facet_tags is not None
    # gmsh node tags are 1-based input indices (dolfinx.io.gmsh.extract_geometry).
    wheel_nodes = np.concatenate([w for w, _ in info.contact_pairs]) - 1
    rail_nodes = np.concatenate([r for _, r in info.contact_pairs]) - 1
    which = np.concatenate(
        [np.full(w.size, k + 1) for k, (w, _) in enumerate(info.contact_pairs)]
    ).astype(np.int64)
    pairs = np.column_stack(
        [
            input_nodes_to_global_vertices(data.mesh, wheel_nodes),
            input_nodes_to_global_vertices(data.mesh, rail_nodes),
        ]
    )
    tagged = TaggedMesh(
        data.mesh, data.cell_tags, data.facet_tags, info.volume_groups, info.surface_groups
    )
    crane = CraneMesh(tagged, pairs, which)
    fps = info.flange_pairs
    if fps:
        n = [fp.flange_nodes.size for fp in fps]
        crane.flange_pairs = np.column_stack(
            [
                input_nodes_to_global_vertices(
                    data.mesh, np.concatenate([fp.flange_nodes for fp in fps]) - 1
                ),
                input_nodes_to_global_vertices(
                    data.mesh, np.concatenate([fp.rail_nodes for fp in fps]) - 1
                ),
            ]
        )
        crane.flange_wheel = np.repeat([fp.wheel for fp in fps], n).astype(np.int64)
        crane.flange_inner = np.repeat([fp.inner for fp in fps], n)
        crane.flange_normal = np.zeros((sum(n), 3))
        crane.flange_normal[:, 0] = np.repeat([fp.normal_x for fp in fps], n)
        crane.flange_gap = np.concatenate([fp.gap for fp in fps])
    return crane
