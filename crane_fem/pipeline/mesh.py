"""Pipeline stage 1, scenario → mesh: the parent mesh with its named groups, the clamped
vertices and the density of every cell."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import dolfinx
import numpy as np
import numpy.typing as npt
import ufl
from mpi4py import MPI

from crane_fem.contact.surface import Pairing, Surface, group_surface, pair_points
from crane_fem.errors import ScenarioError
from crane_fem.formulations import AxialBar, CellFields, Formulation, SolidP1, TimoshenkoBeam
from crane_fem.geometry import TaggedMesh, create_box_beam, create_split_bar, groups
from crane_fem.geometry.block import Block, create_block
from crane_fem.geometry.box_beam import BoxBeam
from crane_fem.geometry.crane import CraneMesh, create_crane_mesh
from crane_fem.geometry.gmsh_file import create_frame_mesh, create_gmsh_mesh
from crane_fem.mass_scaling import MassScaling, scale_density
from crane_fem.mesh import Segment
from crane_fem.pipeline.frame import (
    FrameContacts,
    frame_contacts,
    frame_fields,
    frame_point_masses,
    frame_supports,
    rope_held_vertices,
)
from crane_fem.pipeline.mixed import scenario_views
from crane_fem.pipeline.scale import check_mesh_scale
from crane_fem.scenario import (
    BarModel,
    BlockModel,
    BoxBeamModel,
    CraneModel,
    FrameModel,
    GmshModel,
    Scenario,
    SurfaceContact,
)
from crane_fem.subdomains import PointMasses

__all__ = [
    "CellMaterial",
    "MeshStage",
    "PointsOnSurface",
    "build_mesh",
    "create_tagged_mesh",
    "support_groups",
]

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
        rolling: the unit direction the points roll along freely (friction across it only),
            or None.
        along: the unit direction the points' slip is resolved along (and across, along × n):
            the contact's ``along``, else ``rolling``; or None.
    """

    name: str
    points: IntArray
    X: FloatArray
    surface: Surface
    pairing: Pairing
    friction: float
    rolling: FloatArray | None = None
    along: FloatArray | None = None


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
        materials: E, ν, ρ of every local parent cell where they vary by group (a gmsh
            model's ``[[material]]`` entries), else None (``density`` holds ρ).
        support_faces: a gmsh model's supports: the global vertex ids of each ``[[support]]``
            group, in order (its reactions are reported per group); empty for the built-in
            models (the crane's clamped ends are told apart by position).
        mass_scaling: the mass ``time.mass_scaling`` added (included in ``density``), or None.
        formulation: the element formulation of the model's cells (crane_fem.formulations).
        fields: the material (and a beam's section) of every local parent cell.
        pinned_vertices: global parent ids of the vertices whose translations only are fixed
            (a frame's pinned supports).
        point_masses: masses and rotary inertias carried at vertices (a frame's
            ``[[mass]]`` entries), or None.
        frame_contacts: a frame's contacts at t = 0 (crane_fem.pipeline.frame), or None.
        held_rotations: global parent ids of the vertices whose rotations are fixed (a
            frame's vertices on ropes only).
    """

    comm: MPI.Comm
    tagged: TaggedMesh
    crane: CraneMesh | None
    fixed_vertices: IntArray
    density: FloatArray | None
    surface_contacts: tuple[PointsOnSurface, ...] = ()
    materials: CellMaterial | None = None
    support_faces: tuple[IntArray, ...] = ()
    mass_scaling: MassScaling | None = None
    formulation: Formulation = field(default_factory=SolidP1)
    fields: CellFields = field(default_factory=lambda: CellFields(1.0, 0.0, 1.0))
    pinned_vertices: IntArray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    point_masses: PointMasses | None = None
    frame_contacts: FrameContacts | None = None
    held_rotations: IntArray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    #: A mixed gmsh model's beams (their own line mesh, a frame's stage; this stage holds
    #: the solids), or None.
    beams: MeshStage | None = None

    def extent(self) -> float:
        """The largest side of the whole mesh's bounding box (m; collective: the same on
        every rank, whatever the partition)."""
        x = self.tagged.mesh.geometry.x
        lo = x.min(axis=0, initial=np.inf)
        hi = x.max(axis=0, initial=-np.inf)
        lo = np.array([self.comm.allreduce(float(v), op=MPI.MIN) for v in lo])
        hi = np.array([self.comm.allreduce(float(v), op=MPI.MAX) for v in hi])
        return float(np.max(hi - lo))


def create_tagged_mesh(comm: MPI.Comm, sc: Scenario) -> TaggedMesh | CraneMesh:
    """The parent mesh of the scenario with its named groups (collective)."""
    mdl = sc.model
    if isinstance(mdl, CraneModel):
        return create_crane_mesh(comm, mdl.geometry(), mdl.mesh)
    if isinstance(mdl, GmshModel):
        return create_gmsh_mesh(comm, mdl.mesh, [j.node for j in sc.joint])
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


@dataclass(frozen=True)
class CellMaterial:
    """E (Pa), ν and ρ (kg/m³) of every local parent cell (owned and ghost); ρ includes the
    masses carried rigidly by a group."""

    E: FloatArray
    nu: FloatArray
    rho: FloatArray


#: The most mass ``time.mass_scaling`` may add, as a fraction of the model's mass and of any
#: volume group's: beyond it the scaling changes the structure, not only its few smallest
#: elements (practice in explicit codes: a few per cent at most).
MAX_ADDED_FRACTION = 0.02
MAX_ADDED_GROUP_FRACTION = 0.05


def _cell_material(sc: Scenario, tagged: TaggedMesh) -> tuple[CellMaterial, MassScaling | None]:
    """Each cell's material (its groups' ``[[material]]`` entry, or the one ``[material]``),
    plus each mass carried rigidly by a group spread uniformly over its volume (the crane's
    hoisted mass on its trolley frame, a gmsh model's ``[[mass]]`` entries), plus the mass
    ``time.mass_scaling`` adds (collective).

    Raises:
        ScenarioError: the scaling would add more than :data:`MAX_ADDED_FRACTION` of the
            model's mass.
    """
    mdl = sc.model
    msh = tagged.mesh
    imap = msh.topology.index_map(msh.topology.dim)
    n = imap.size_local + imap.num_ghosts
    E, nu, rho = np.zeros(n), np.zeros(n), np.zeros(n)
    for names, mat in sc.materials:
        if names is None:
            cells: npt.NDArray[np.int32] | slice = slice(None)
        else:
            tags = [tagged.cell_groups[g] for g in names]
            cells = tagged.cell_tags.indices[np.isin(tagged.cell_tags.values, tags)]
        E[cells], nu[cells], rho[cells] = mat.E, mat.nu, mat.rho
    rho_material = rho.copy()
    carried: list[tuple[str, float]] = []
    if isinstance(mdl, CraneModel) and mdl.hoisted_mass > 0.0:
        carried.append(("trolley_frame", mdl.hoisted_mass))
    carried += [(m.group, m.mass) for m in sc.mass]
    dx = ufl.Measure("dx", domain=msh, subdomain_data=tagged.cell_tags)
    one = dolfinx.fem.Constant(msh, np.float64(1.0))
    for group, mass in carried:
        tag = tagged.cell_groups[group]
        vol = msh.comm.allreduce(
            dolfinx.fem.assemble_scalar(dolfinx.fem.form(one * dx(tag))), op=MPI.SUM
        )
        rho[tagged.cell_tags.indices[tagged.cell_tags.values == tag]] += mass / vol
    target = sc.time.mass_scaling
    if target is None:
        return CellMaterial(E, nu, rho), None
    rho, info = scale_density(
        msh, E, nu, rho_material, rho, target, tagged.cell_tags, tagged.cell_groups
    )
    if info.fraction > MAX_ADDED_FRACTION:
        raise ScenarioError(
            f"time.mass_scaling = {target:g} s would add {info.added:.4g} kg, "
            f"{100 * info.fraction:.3g} % of the model's {info.model:.4g} kg (at most "
            f"{100 * MAX_ADDED_FRACTION:g} %): give a smaller step, or mesh the finest "
            f"features coarser"
        )
    worst = max(info.group_fraction, key=lambda g: info.group_fraction[g], default=None)
    if worst is not None and info.group_fraction[worst] > MAX_ADDED_GROUP_FRACTION:
        raise ScenarioError(
            f"time.mass_scaling = {target:g} s would add {1e3 * info.by_group[worst]:.4g} g "
            f"to group {worst!r}, {100 * info.group_fraction[worst]:.3g} % of its mass (at "
            f"most {100 * MAX_ADDED_GROUP_FRACTION:g} %): give a smaller step, or mesh the "
            "finest features coarser"
        )
    return CellMaterial(E, nu, rho), info


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
        # A point inside the other body by more than a mesh's chordal error on a curved
        # surface (h²/8R: 1 % of h at R = 12 h) is a wrong group, not a contact.
        edges = surface.xyz[surface.triangles] - surface.xyz[np.roll(surface.triangles, 1, 1)]
        depth = 0.05 * float(np.linalg.norm(edges, axis=2).mean())
        buried = np.flatnonzero(pairing.gap < -depth)
        if buried.size:
            k = int(buried[np.argmin(pairing.gap[buried])])
            raise ScenarioError(
                f"contact[{i}].points: vertex {int(points[k])} of group {c.points!r} starts "
                f"{-pairing.gap[k]:.4g} m inside surface group {c.surface!r} (more than 5 % "
                "of its element size): the points must touch the surface or face it across a "
                "gap"
            )
        rolling, along = (
            _in_plane(getattr(c, key), f"contact[{i}].{key}", pairing, points, c.surface)
            for key in ("rolling", "along")
        )
        out.append(
            PointsOnSurface(
                c.label,
                points,
                X,
                surface,
                pairing,
                c.friction,
                rolling,
                along if along is not None else rolling,
            )
        )
    return tuple(out)


def _in_plane(
    vector: list[float] | None, key: str, pairing: Pairing, points: IntArray, surface: str
) -> FloatArray | None:
    """A contact's direction in its surface's plane (``rolling``, ``along``), unit, or None.

    Raises:
        ScenarioError: it is nearer the normal than the plane at one of the points (a wrong
            vector, not a direction a wheel rolls or a rail runs along).
    """
    if vector is None:
        return None
    d = np.asarray(vector, dtype=np.float64)
    d /= np.linalg.norm(d)
    steep = np.abs(pairing.normal @ d) > np.sqrt(0.5)
    if np.any(steep):
        k = int(np.flatnonzero(steep)[0])
        raise ScenarioError(
            f"{key} = {list(vector)} is nearer the normal "
            f"{(pairing.normal[k].round(6) + 0.0).tolist()} of surface group {surface!r} "
            f"(at vertex {int(points[k])}) than its plane: give a direction in the surface's "
            "plane"
        )
    return d


def support_groups(sc: Scenario) -> list[str]:
    """The facet groups clamped to the ground: a gmsh model's ``[[support]]`` entries, and
    each built-in model's own (the crane's end-carriage faces, the box beam's root face, the
    bar's right end with ``model.clamp = "right"``; a block has none)."""
    mdl = sc.model
    if isinstance(mdl, GmshModel):
        return [s.group for s in sc.support]
    if isinstance(mdl, CraneModel):
        return [groups.CRANE_SURFACES[0]]  # "clamped"
    if isinstance(mdl, BoxBeamModel):
        return [groups.BEAM_CLAMPED]
    if isinstance(mdl, BarModel) and mdl.clamp == "right":
        return [groups.BAR_RIGHT_END]
    return []


def _frame_stage(sc: Scenario, comm: MPI.Comm, mdl: FrameModel, mixed: bool = False) -> MeshStage:
    """A frame's line mesh, its cells' materials, sections and axes, its supports and point
    masses (collective); ``mixed``: a mixed model's beams (its solids left out)."""
    tagged = create_frame_mesh(comm, mdl.mesh, mixed)
    fields = frame_fields(sc, tagged)
    assert fields.section is not None
    check_mesh_scale(mdl.mesh, tagged.mesh, fields.rho, fields.section.A)
    clamped, pinned, faces = frame_supports(sc, tagged)
    assert not isinstance(fields.rho, float)
    return MeshStage(
        comm,
        tagged,
        None,
        clamped,
        np.asarray(fields.rho),
        support_faces=faces,
        formulation=TimoshenkoBeam(),
        fields=fields,
        pinned_vertices=pinned,
        point_masses=frame_point_masses(sc, tagged),
        frame_contacts=frame_contacts(sc, tagged),
        held_rotations=rope_held_vertices(sc, tagged),
    )


def build_mesh(sc: Scenario, comm: MPI.Comm) -> MeshStage:
    """Mesh the scenario's model, or read its mesh file (collective). A mixed gmsh model's
    stage is its solids', its beams' stage attached."""
    if isinstance(sc.model, FrameModel):
        return _frame_stage(sc, comm, sc.model)
    if isinstance(sc.model, GmshModel) and sc.model.mixed:
        solids, beams = scenario_views(sc)
        assert isinstance(beams.model, FrameModel)
        solid = _solid_stage(solids, comm)  # first: it refuses a beam touching a solid
        return replace(solid, beams=_frame_stage(beams, comm, beams.model, mixed=True))
    return _solid_stage(sc, comm)


def _solid_stage(sc: Scenario, comm: MPI.Comm) -> MeshStage:
    """The stage of a solid (or bar) model (collective)."""
    made = create_tagged_mesh(comm, sc)
    crane = made if isinstance(made, CraneMesh) else None
    tagged = made.tagged if isinstance(made, CraneMesh) else made
    mdl = sc.model
    parts = [tagged.facet_vertices(g) for g in support_groups(sc)]
    clamp_local = np.unique(np.concatenate([np.zeros(0, dtype=np.int32), *parts]))
    material, scaling = (
        _cell_material(sc, tagged) if isinstance(mdl, CraneModel | GmshModel) else (None, None)
    )
    density = material.rho if material is not None else None
    if isinstance(mdl, GmshModel):  # a user's mesh: drawn in metres? (before pairing on it)
        assert density is not None
        check_mesh_scale(mdl.mesh, tagged.mesh, density)
    # Per-cell E and ν only where they vary (a gmsh model's [[material]] entries).
    cells = material if material is not None and len(sc.materials) > 1 else None
    surfaces = _surface_contacts(sc, tagged) if isinstance(mdl, GmshModel) else ()
    faces = tuple(
        tagged.global_vertices(tagged.facet_vertices(s.group))
        for s in (sc.support if isinstance(mdl, GmshModel) else [])
    )
    mat = sc.materials[0][1]  # where uniform
    fields = CellFields(
        cells.E if cells is not None else mat.E,
        cells.nu if cells is not None else mat.nu,
        density if density is not None else mat.rho,
        mdl.area if isinstance(mdl, BarModel) else 1.0,
    )
    formulation: Formulation = AxialBar() if isinstance(mdl, BarModel) else SolidP1()
    return MeshStage(
        comm,
        tagged,
        crane,
        tagged.global_vertices(clamp_local),
        density,
        surfaces,
        cells,
        faces,
        scaling,
        formulation,
        fields,
    )
