"""A user's own gmsh model on disk: a ``.msh`` file whose physical groups name its bodies
(volume groups) and its supports and contact surfaces (surface groups)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import dolfinx.io.gmsh
import dolfinx.mesh
import gmsh
import numpy as np
from mpi4py import MPI

from crane_fem.errors import ScenarioError
from crane_fem.geometry.tagged import TaggedMesh

__all__ = ["PhysicalNames", "create_gmsh_mesh", "distribute_gmsh_model", "read_physical_names"]


@dataclass(frozen=True)
class PhysicalNames:
    """The named physical groups of a ``.msh`` file: ``{name: tag}`` per dimension."""

    volumes: dict[str, int]
    surfaces: dict[str, int]


def read_physical_names(path: str | Path) -> PhysicalNames:
    """The named physical groups of a gmsh ``.msh`` file, from its ``$PhysicalNames``
    section (ASCII in both the text and the binary formats; not collective, no gmsh).

    Raises:
        ScenarioError: the file is missing or unreadable, has no named volume group, or
            gives one name to two groups of the same dimension.
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
    found: dict[int, dict[str, int]] = {2: {}, 3: {}}
    lines = head[start:end].decode("utf-8", errors="replace").splitlines()[2:]
    for line in lines:
        dim_s, tag_s, name = line.split(maxsplit=2)
        dim, name = int(dim_s), name.strip().strip('"')
        if dim not in found:
            continue
        if name in found[dim]:
            raise ScenarioError(
                f"model.mesh: {p} names two {'volume' if dim == 3 else 'surface'} groups "
                f"{name!r}: each group needs its own name"
            )
        found[dim][name] = int(tag_s)
    if not found[3]:
        raise ScenarioError(
            f"model.mesh: {p} has no named volume (3D) physical group: name every body's "
            "volumes (gmsh.model.addPhysicalGroup(3, tags, name=...)); unnamed cells are dropped"
        )
    return PhysicalNames(found[3], found[2])


def distribute_gmsh_model(comm: MPI.Comm, error: str | None) -> dolfinx.io.gmsh.MeshData:
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
        return dolfinx.io.gmsh.model_to_mesh(gmsh.model, comm, 0, gdim=3, partitioner=partitioner)
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
            types = {t for d in (3,) for t in gmsh.model.mesh.getElementTypes(d)}
            if types != {4}:  # 4: the 4-node tetrahedron
                error = (
                    f"model.mesh: {path} holds 3D elements of gmsh types {sorted(types)}; "
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
