"""Pipeline stage 1, scenario → mesh: the parent mesh with its named groups, the clamped
vertices and the density of every cell."""

from __future__ import annotations

from dataclasses import dataclass

import dolfinx
import numpy as np
import numpy.typing as npt
import ufl
from mpi4py import MPI

from crane_fem.contact.surface import Pairing, Surface, group_surface, pair_points
from crane_fem.errors import ScenarioError
from crane_fem.geometry import TaggedMesh, create_box_beam, create_split_bar, groups
from crane_fem.geometry.block import Block, create_block
from crane_fem.geometry.box_beam import BoxBeam
from crane_fem.geometry.crane import CraneMesh, create_crane_mesh
from crane_fem.geometry.gmsh_file import create_gmsh_mesh
from crane_fem.mesh import Segment
from crane_fem.scenario import (
    BarModel,
    BlockModel,
    BoxBeamModel,
    CraneModel,
    GmshModel,
    Scenario,
    SurfaceContact,
)

__all__ = ["MeshStage", "PointsOnSurface", "build_mesh", "create_tagged_mesh"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


@dataclass(frozen=True)
class PointsOnSurface:
    """A gmsh model's node-to-surface contact on the parent mesh (the same on every rank).

    Attributes:
        name: the contact's name (its outputs').
        points: (p,) sorted global ids of the points group's vertices.
        X: (p, 3) their reference coordinates (m).
        surface: the surface group's triangles, oriented out of their body.
        pairing: each point on its triangle at X.
        friction: Coulomb's μ.
    """

    name: str
    points: IntArray
    X: FloatArray
    surface: Surface
    pairing: Pairing
    friction: float


@dataclass(frozen=True)
class MeshStage:
    """The parent mesh of a scenario (collective objects over ``comm``).

    Attributes:
        tagged: the mesh and its named cell and facet groups.
        crane: the crane mesh's extra data (wheel/rail pairs), or None.
        fixed_vertices: global parent ids of the clamped vertices.
        density: density of every local parent cell (ρ plus a hoisted mass spread over the
            trolley frame), or None for a uniform ρ.
        surface_contacts: a gmsh model's node-to-surface contacts, in the scenario's order.
    """

    comm: MPI.Comm
    tagged: TaggedMesh
    crane: CraneMesh | None
    fixed_vertices: IntArray
    density: FloatArray | None
    surface_contacts: tuple[PointsOnSurface, ...] = ()


def create_tagged_mesh(comm: MPI.Comm, sc: Scenario) -> TaggedMesh | CraneMesh:
    """The parent mesh of the scenario with its named groups (collective)."""
    mdl = sc.model
    if isinstance(mdl, CraneModel):
        return create_crane_mesh(comm, mdl.geometry(), mdl.mesh)
    if isinstance(mdl, GmshModel):
        return create_gmsh_mesh(comm, mdl.mesh)
    if isinstance(mdl, BoxBeamModel):
        return create_box_beam(comm, BoxBeam(mdl.length, mdl.width, mdl.height, mdl.split, mdl.h))
    if isinstance(mdl, BlockModel):
        gap = next((c.gap for c in sc.contact if c.type == "plane"), 0.0)
        lx, ly, lz = mdl.size
        return create_block(comm, Block(lx, ly, lz, gap, mdl.h))
    assert isinstance(mdl, BarModel)
    x0 = next((c.gap for c in sc.contact if c.type == "wall"), 0.0)
    split = mdl.split if mdl.split is not None else mdl.length  # all cells "left"
    return create_split_bar(comm, Segment(x0, mdl.length, mdl.elements, mdl.area), split)


def _cell_density(sc: Scenario, tagged: TaggedMesh) -> FloatArray:
    """Density of every local parent cell: ρ, plus each mass carried rigidly by a group
    spread uniformly over its volume (the crane's hoisted mass on its trolley frame, a gmsh
    model's ``[[mass]]`` entries)."""
    mdl = sc.model
    carried: list[tuple[str, float]] = []
    if isinstance(mdl, CraneModel) and mdl.hoisted_mass > 0.0:
        carried.append(("trolley_frame", mdl.hoisted_mass))
    carried += [(m.group, m.mass) for m in sc.mass]
    rho = sc.material.rho
    msh = tagged.mesh
    imap = msh.topology.index_map(msh.topology.dim)
    density = np.full(imap.size_local + imap.num_ghosts, rho)
    dx = ufl.Measure("dx", domain=msh, subdomain_data=tagged.cell_tags)
    one = dolfinx.fem.Constant(msh, np.float64(1.0))
    for group, mass in carried:
        tag = tagged.cell_groups[group]
        vol = msh.comm.allreduce(
            dolfinx.fem.assemble_scalar(dolfinx.fem.form(one * dx(tag))), op=MPI.SUM
        )
        cells = tagged.cell_tags.indices[tagged.cell_tags.values == tag]
        density[cells] += mass / vol
    return density


def _surface_contacts(sc: Scenario, tagged: TaggedMesh) -> tuple[PointsOnSurface, ...]:
    """The scenario's ``[[contact]] type = "surface"`` on the parent mesh (collective).

    Raises:
        ScenarioError: a point projects onto no triangle of its surface at t = 0.
    """
    out = []
    for i, c in enumerate(sc.contact):
        assert isinstance(c, SurfaceContact)
        surface = group_surface(tagged, c.surface)
        points = tagged.global_vertices(tagged.facet_vertices(c.points))
        X = tagged.vertex_coordinates(points)
        pairing = pair_points(X, surface)
        lost = np.flatnonzero(~pairing.paired)
        if lost.size or not points.size:
            where = (
                f"vertex {int(points[lost[0]])} at {X[lost[0]].round(6).tolist()}"
                if (lost.size)
                else "no vertex"
            )
            raise ScenarioError(
                f"contact[{i}].points: {where} of group {c.points!r} projects onto no "
                f"triangle of surface group {c.surface!r} at t = 0 (each point must lie over "
                "the surface it touches)"
            )
        out.append(PointsOnSurface(c.label, points, X, surface, pairing, c.friction))
    return tuple(out)


def build_mesh(sc: Scenario, comm: MPI.Comm) -> MeshStage:
    """Mesh the scenario's model, or read its mesh file (collective)."""
    made = create_tagged_mesh(comm, sc)
    crane = made if isinstance(made, CraneMesh) else None
    tagged = made.tagged if isinstance(made, CraneMesh) else made
    mdl = sc.model
    if isinstance(mdl, CraneModel):
        clamp_local = tagged.facet_vertices("clamped")
    elif isinstance(mdl, GmshModel):
        parts = [tagged.facet_vertices(s.group) for s in sc.support]
        clamp_local = np.unique(np.concatenate([np.zeros(0, dtype=np.int32), *parts]))
    elif isinstance(mdl, BoxBeamModel):
        clamp_local = tagged.facet_vertices(groups.BEAM_CLAMPED)
    elif isinstance(mdl, BlockModel):
        clamp_local = np.zeros(0, dtype=np.int32)
    elif mdl.clamp == "right":
        clamp_local = tagged.facet_vertices(groups.BAR_RIGHT_END)
    else:
        clamp_local = np.zeros(0, dtype=np.int32)
    density = _cell_density(sc, tagged) if isinstance(mdl, CraneModel | GmshModel) else None
    surfaces = _surface_contacts(sc, tagged) if isinstance(mdl, GmshModel) else ()
    return MeshStage(comm, tagged, crane, tagged.global_vertices(clamp_local), density, surfaces)
