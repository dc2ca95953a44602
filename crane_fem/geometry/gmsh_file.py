"""A user's own gmsh model on disk: a ``.msh`` file whose physical groups name its bodies
(volume groups) and its supports and contact surfaces (surface groups); or a frame's line
mesh, whose line groups are its members and whose point groups its supports, masses and
contact points."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import dolfinx.io.gmsh
import dolfinx.mesh
import gmsh
import numpy as np
import scipy.spatial
from mpi4py import MPI

from crane_fem.errors import ScenarioError
from crane_fem.geometry.tagged import TaggedMesh

__all__ = [
    "PhysicalNames",
    "create_frame_mesh",
    "create_gmsh_mesh",
    "distribute_gmsh_model",
    "read_physical_names",
]


@dataclass(frozen=True)
class PhysicalNames:
    """The named physical groups of a ``.msh`` file: ``{name: tag}`` per dimension."""

    volumes: dict[str, int]
    surfaces: dict[str, int]
    lines: dict[str, int] = field(default_factory=dict)
    points: dict[str, int] = field(default_factory=dict)


_DIM_NAMES = {0: "point", 1: "line", 2: "surface", 3: "volume"}


def read_physical_names(path: str | Path, cells: int = 3) -> PhysicalNames:
    """The named physical groups of a gmsh ``.msh`` file, from its ``$PhysicalNames``
    section (ASCII in both the text and the binary formats; not collective, no gmsh).
    ``cells``: the dimension of the model's cells (3: a solid's volumes, 1: a frame's lines),
    of which at least one named group is required.

    Raises:
        ScenarioError: the file is missing or unreadable, has no named group of dimension
            ``cells``, or gives one name to two groups of the same dimension.
    """
    p = Path(path)
    if not p.is_file():
        raise ScenarioError(f"model.mesh: {p} is not a file (a .msh written by gmsh)")
    try:
        with p.open("rb") as fh:
            head = fh.read(1 << 20)
            while b"$EndPhysicalNames" not in head and b"$Nodes" not in head:
                more = fh.read(1 << 20)
                if not more:
                    break
                head += more
    except OSError as exc:
        raise ScenarioError(f"model.mesh: cannot read {p}: {exc}") from None
    start = head.find(b"$PhysicalNames")
    end = head.find(b"$EndPhysicalNames")
    if not head.startswith(b"$MeshFormat") or start < 0 or end < start:
        raise ScenarioError(
            f"model.mesh: {p} is not a gmsh .msh file with named physical groups "
            "(gmsh.model.addPhysicalGroup(dim, tags, name=...) in the script that wrote it)"
        )
    found: dict[int, dict[str, int]] = {0: {}, 1: {}, 2: {}, 3: {}}
    lines = head[start:end].decode("utf-8", errors="replace").splitlines()[2:]
    for line in lines:
        dim_s, tag_s, name = line.split(maxsplit=2)
        dim, name = int(dim_s), name.strip().strip('"')
        if dim not in found:
            continue
        if name in found[dim]:
            raise ScenarioError(
                f"model.mesh: {p} names two {_DIM_NAMES[dim]} groups "
                f"{name!r}: each group needs its own name"
            )
        found[dim][name] = int(tag_s)
    if not found[cells]:
        what = "volume (3D)" if cells == 3 else "line (1D)"
        whose = "body's volumes" if cells == 3 else "member's lines"
        raise ScenarioError(
            f"model.mesh: {p} has no named {what} physical group: name every {whose} "
            f"(gmsh.model.addPhysicalGroup({cells}, tags, name=...)); unnamed cells are dropped"
        )
    return PhysicalNames(found[3], found[2], found[1], found[0])


def _type_names(types: set[int]) -> str:
    """gmsh element types with their names, e.g. ``5 (Hexahedron 8), 6 (Prism 6)`` (gmsh
    initialized)."""
    return ", ".join(f"{t} ({gmsh.model.mesh.getElementProperties(t)[0]})" for t in sorted(types))


def distribute_gmsh_model(
    comm: MPI.Comm, error: str | None, gdim: int = 3
) -> dolfinx.io.gmsh.MeshData:
    """The gmsh model rank 0 holds, distributed with ghost cells across shared facets (the
    contact and interface code reads its neighbours' cells), then gmsh finalized on rank 0
    (collective). ``error``: rank 0's refusal of the model, raised on every rank instead.

    Raises:
        ScenarioError: rank 0's ``error``, on every rank.
    """
    error = comm.bcast(error, root=0)
    if error is not None:
        if comm.rank == 0:
            gmsh.finalize()
        raise ScenarioError(error)
    partitioner = dolfinx.mesh.create_cell_partitioner(  # type: ignore[call-arg]
        dolfinx.mesh.GhostMode.shared_facet, 2
    )
    try:
        return dolfinx.io.gmsh.model_to_mesh(
            gmsh.model, comm, 0, gdim=gdim, partitioner=partitioner
        )
    finally:
        if comm.rank == 0:
            gmsh.finalize()


def _closure(dim_tags: list[tuple[int, int]]) -> set[tuple[int, int]]:
    """The entities and every entity on their boundaries, down to points (gmsh initialized)."""
    out, todo = set(dim_tags), list(dim_tags)
    while todo:
        d, t = todo.pop()
        if d == 0:
            continue
        for e in gmsh.model.getBoundary([(d, t)], combined=False, oriented=False):
            ent = (e[0], abs(e[1]))
            if ent not in out:
                out.add(ent)
                todo.append(ent)
    return out


def _keep_only(dim: int) -> None:
    """Leave in the open gmsh model only the cells of dimension ``dim`` in named groups, the
    named groups of dimension ``dim`` and ``dim − 1``, and the mesh of their closure; the
    other entities' meshes cleared and the nodes renumbered 1…n (dolfinx reads a model whose
    nodes are all its cells'): the solids or the beams of a mixed model (rank 0)."""
    groups = gmsh.model.getPhysicalGroups()
    cells = [
        (dim, int(t))
        for d, g in groups
        if d == dim
        for t in gmsh.model.getEntitiesForPhysicalGroup(d, g)
    ]
    kept = _closure(cells)
    gmsh.model.removePhysicalGroups([(d, g) for d, g in groups if d not in (dim, dim - 1)])
    others = sorted((e for e in gmsh.model.getEntities() if e not in kept), key=lambda e: -e[0])
    gmsh.model.mesh.clear(others)
    gmsh.model.mesh.renumberNodes()
    gmsh.model.mesh.renumberElements()


def _group_nodes(dim: int, name: str) -> tuple[np.ndarray, np.ndarray]:
    """Node tags and coordinates (n, 3) of the elements of the named group (rank 0)."""
    tag = next(
        g for d, g in gmsh.model.getPhysicalGroups(dim) if gmsh.model.getPhysicalName(d, g) == name
    )
    tags, xyz = [], []
    for ent in gmsh.model.getEntitiesForPhysicalGroup(dim, tag):
        nt, x, _ = gmsh.model.mesh.getNodes(dim, int(ent), includeBoundary=True)
        tags.append(np.asarray(nt, dtype=np.int64))
        xyz.append(np.asarray(x, dtype=np.float64).reshape(-1, 3))
    return np.concatenate(tags), np.concatenate(xyz)


def _touching(names: PhysicalNames, joint_nodes: Sequence[str], path: str | Path) -> str | None:
    """A line group with a node on (or shared with) a solid's node, other than a joint's
    node: the refusal's text, or None (rank 0, the whole model open)."""
    solid = [_group_nodes(3, v) for v in names.volumes]
    s_tags = np.unique(np.concatenate([t for t, _ in solid]))
    s_xyz = np.concatenate([x for _, x in solid])
    size = float(np.max(np.ptp(s_xyz, axis=0)))
    tree = scipy.spatial.cKDTree(s_xyz)
    joints = [_group_nodes(0, j)[1] for j in joint_nodes if j in names.points]
    free = np.concatenate(joints) if joints else np.zeros((0, 3))
    for line in names.lines:
        tags, xyz = _group_nodes(1, line)
        near = np.array([bool(tree.query_ball_point(x, 1e-9 * size)) for x in xyz])
        touch = np.isin(tags, s_tags) | near
        if free.size:
            at_joint = np.min(np.linalg.norm(xyz[:, None, :] - free[None], axis=2), axis=1)
            touch &= at_joint > 1e-9 * size
        if np.any(touch):
            x = xyz[np.flatnonzero(touch)[0]]
            return (
                f"model.mesh: line group {line!r} of {Path(path).name} touches a solid at "
                f"{np.round(x, 6).tolist()}: a beam meets a solid only at a [[joint]] (its "
                "node on the face's centroid, tied by the joint's rows)"
            )
    return None


def create_gmsh_mesh(
    comm: MPI.Comm, path: str | Path, joint_nodes: Sequence[str] = ()
) -> TaggedMesh:
    """Read a user's ``.msh`` on rank 0 and distribute it with ghost cells across shared
    facets (contact and interface code reads its neighbours' cells); cell and facet groups
    by their physical names (collective).

    Raises:
        ScenarioError: the file is not a 3D tetrahedral gmsh mesh with named groups, on
            every rank.
    """
    names = read_physical_names(path)  # every rank: the same error everywhere
    error: str | None = None
    if comm.rank == 0:
        gmsh.initialize(interruptible=False)
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("General.NumThreads", 1)
        try:
            gmsh.open(str(path))
            types = {int(t) for t in gmsh.model.mesh.getElementTypes(3)}
            if types != {4}:  # 4: the 4-node tetrahedron
                error = (
                    f"model.mesh: {path} holds 3D elements of gmsh types {_type_names(types)}; "
                    "P1 tetrahedra (type 4) only (gmsh.model.mesh.generate(3), order 1)"
                )
            if error is None and names.lines:  # a mixed model: its solids only
                error = _touching(names, joint_nodes, path)
                _keep_only(3)
        except Exception as exc:  # gmsh raises bare Exception on a corrupt file
            error = f"model.mesh: gmsh cannot read {path}: {exc}"
    data = distribute_gmsh_model(comm, error)
    assert data.cell_tags is not None
    facet_tags = data.facet_tags
    if facet_tags is None:  # no surface group: an empty tag set
        tdim = data.mesh.topology.dim
        none = np.zeros(0, dtype=np.int32)
        facet_tags = dolfinx.mesh.meshtags(data.mesh, tdim - 1, none, none)
    return TaggedMesh(data.mesh, data.cell_tags, facet_tags, names.volumes, names.surfaces)


def create_frame_mesh(comm: MPI.Comm, path: str | Path, mixed: bool = False) -> TaggedMesh:
    """Read a frame's ``.msh`` (2-node lines in 3D) on rank 0 and distribute it with ghost
    cells across shared vertices (the contacts read a neighbour's cells); cell groups by the
    line groups' names, facet (vertex) groups by the point groups' (collective).

    ``mixed``: the beams of a mixed model; its solids (3D and 2D elements) are left out.

    Raises:
        ScenarioError: the file holds elements other than 2-node lines (and points), or no
            named line group, on every rank.
    """
    names = read_physical_names(path, cells=1)  # every rank: the same error everywhere
    error: str | None = None
    if comm.rank == 0:
        gmsh.initialize(interruptible=False)
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("General.NumThreads", 1)
        try:
            gmsh.open(str(path))
            if mixed:
                _keep_only(1)
            lines = {int(t) for t in gmsh.model.mesh.getElementTypes(1)}
            higher = {int(t) for d in (2, 3) for t in gmsh.model.mesh.getElementTypes(d)}
            if lines != {1} or higher:
                error = (
                    f"model.mesh: {path} holds elements of gmsh types "
                    f"{_type_names(lines | higher)}; a frame takes 2-node lines only (type 1: "
                    "gmsh.model.mesh.generate(1), order 1)"
                )
        except Exception as exc:  # gmsh raises bare Exception on a corrupt file
            error = f"model.mesh: gmsh cannot read {path}: {exc}"
    data = distribute_gmsh_model(comm, error, gdim=3)
    assert data.cell_tags is not None
    facet_tags = data.facet_tags
    if facet_tags is None:  # no point group: an empty tag set
        none = np.zeros(0, dtype=np.int32)
        facet_tags = dolfinx.mesh.meshtags(data.mesh, 0, none, none)
    return TaggedMesh(data.mesh, data.cell_tags, facet_tags, names.lines, names.points)
