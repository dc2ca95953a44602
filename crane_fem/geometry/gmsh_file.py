"""A user's own gmsh model on disk: a ``.msh`` file whose physical groups name its bodies
(volume groups) and its supports and contact surfaces (surface groups); or a frame's line
mesh, whose line groups are its members and whose point groups its supports, masses and
contact points."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import dolfinx.io.gmsh
import dolfinx.mesh
import gmsh
import numpy as np
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


def create_gmsh_mesh(comm: MPI.Comm, path: str | Path) -> TaggedMesh:
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


def create_frame_mesh(comm: MPI.Comm, path: str | Path) -> TaggedMesh:
    """Read a frame's ``.msh`` (2-node lines in 3D) on rank 0 and distribute it with ghost
    cells across shared vertices (the contacts read a neighbour's cells); cell groups by the
    line groups' names, facet (vertex) groups by the point groups' (collective).

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
