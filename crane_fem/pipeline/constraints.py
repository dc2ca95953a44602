"""Pipeline stage 3, models → constraints: the duplicated interface DOFs between the explicit
and implicit subdomains, and the unilateral (and frictional) contacts of the explicit side."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from mpi4py import MPI

from crane_fem.contact import ContactSet
from crane_fem.contact.constraints import TangentRows
from crane_fem.contact.on_line import LineContacts
from crane_fem.contact.sliding import (
    Family,
    SlidingContacts,
    merge_surfaces,
    triangles_where,
    vertex_coordinates,
    without_vertices,
)
from crane_fem.contact.surface import facing_surface
from crane_fem.coupling.interface import build_interface, constraint_set
from crane_fem.errors import ScenarioError
from crane_fem.geometry import groups
from crane_fem.geometry.crane import CraneMesh
from crane_fem.pipeline.frame import frame_contact_rows
from crane_fem.pipeline.mesh import MeshStage
from crane_fem.pipeline.models import ModelStage
from crane_fem.preload import Preload
from crane_fem.scenario import BlockModel, CraneModel, GmshModel, Scenario, Wheel
from crane_fem.subdomains import Subdomain, global_ids

__all__ = ["FLANGE_GROUPS", "ConstraintStage", "build_constraints"]

IntArray = npt.NDArray[np.int64]


@dataclass(frozen=True)
class ConstraintStage:
    """The interface (sorted global parent vertices, L_E and L_I) and the contacts; with
    node-to-surface contact, ``sliding`` re-pairs them as the bodies slide (the contacts are
    its rows at t = 0)."""

    interface_vertices: IntArray
    l_explicit: ContactSet
    l_implicit: ContactSet
    contacts: ContactSet
    sliding: SlidingContacts | LineContacts | None = None
    #: A mixed model's joints: the explicit zone (connected solid) of each interface row
    #: (its ``interface_vertices`` are the beam nodes, six rows each); None otherwise.
    joint_zones: IntArray | None = None


def _wall_contacts(sc: Scenario, mesh: MeshStage, sub: Subdomain) -> ContactSet:
    """The bar's left end against the rigid wall at x = 0 (gap ``contact.gap``)."""
    tagged = mesh.tagged
    left = tagged.global_vertices(tagged.facet_vertices(groups.BAR_LEFT_END))
    blocks, _ = sub.owned_dofs_of(left)
    have = global_ids(mesh.comm, sub.parent_vertex[blocks])
    if have.size != left.size:
        raise ScenarioError(
            "contact: the wall touches the bar's left end, which must belong "
            "to an explicit (cd-lagrange) subdomain"
        )
    wall = next(c for c in sc.contact if c.type == "wall")
    return constraint_set(
        sub, left, 1.0, np.array([wall.gap]), [wall.label], np.zeros(1, dtype=np.int64)
    )


def _plane_contacts(sc: Scenario, mesh: MeshStage, sub: Subdomain) -> ContactSet:
    """Every vertex of the block's bottom face against the rigid plane z = 0 (facing +z):
    gap g = gap + u_z (row n = e_z), and with friction μ > 0 the tangential rows t₁ = e_x,
    t₂ = e_y (orthonormal: with the lumped mass each point's Delassus block is I/m, the
    closed form of crane_fem.kernels.friction). Rows are numbered by the sorted global vertex
    ids (identical on all ranks); terms live on the rank owning the vertex."""
    tagged = mesh.tagged
    bottom = tagged.global_vertices(tagged.facet_vertices(groups.BLOCK_BOTTOM))
    plane = next(c for c in sc.contact if c.type == "plane")
    n = bottom.size
    blocks, pos = sub.owned_dofs_of(bottom)
    mdl = sc.model
    assert isinstance(mdl, BlockModel)
    bs = sub.bs
    tangents = None
    mu = None
    if plane.friction > 0.0:
        mu = np.full(n, plane.friction)
        rows = (2 * pos[:, None] + np.arange(2)[None, :]).ravel()
        dofs = (blocks[:, None] * bs + np.arange(2)[None, :]).ravel()
        tangents = TangentRows(
            np.repeat(np.arange(n, dtype=np.int64), 2),
            rows.astype(np.int64),
            dofs.astype(np.int64),
            np.ones(rows.size),
        )
    return ContactSet(
        mesh.comm,
        np.full(n, plane.gap),
        pos.astype(np.int64),
        (blocks * bs + 2).astype(np.int64),
        np.ones(blocks.size),
        np.zeros(n, dtype=np.int64),
        [plane.label],
        # A point held on the plane drifts by round-off (ε |u|): 1e-12 of the block absorbs it.
        tol=1e-12 * max(mdl.size),
        mu=mu,
        tangents=tangents,
    )


def _pair_contacts(
    comm: MPI.Comm,
    sub: Subdomain,
    crane: CraneMesh,
    preload: Preload | None,
    mdl: CraneModel,
    wheel: Wheel,
) -> ContactSet:
    """Vertical node-to-node contacts g = u_z(wheel) − u_z(rail) ≥ 0 (touching at t = 0).

    With ``wheel.friction`` μ > 0 each pair also gets the tangential rows of the relative
    velocity v(wheel) − v(rail): t₁ = e_x (across the rail) and, for braked wheels only,
    t₂ = e_y (along it: a free wheel rolls, no friction along the rail). The rows sit on the
    pair's own two vertices, orthonormal, so each point's Delassus block is
    (1/m_wheel + 1/m_rail) I (the closed form of crane_fem.kernels.friction)."""
    pairs = crane.pairs
    n_t = 2 if wheel.braked else 1
    rows, dofs, coeffs = [], [], []
    t_rows, t_dofs, t_coeffs = [], [], []
    for side, coeff in ((0, 1.0), (1, -1.0)):
        order = np.argsort(pairs[:, side])
        sorted_v = pairs[order, side]
        blocks, pos = sub.owned_dofs_of(sorted_v)
        rows.append(order[pos])
        dofs.append(blocks * sub.bs + 2)
        coeffs.append(np.full(blocks.size, coeff))
        comps = np.arange(n_t)
        t_rows.append((n_t * order[pos][:, None] + comps[None, :]).ravel())
        t_dofs.append((blocks[:, None] * sub.bs + comps[None, :]).ravel())
        t_coeffs.append(np.full(blocks.size * n_t, coeff))
    have = comm.allreduce(sum(r.size for r in rows), op=MPI.SUM)
    if have != 2 * pairs.shape[0]:
        raise ScenarioError(
            "the wheels and their rail zones must belong to explicit (cd-lagrange) subdomains"
        )
    names = [f"wheel_{k}" for k in range(1, 5)]
    n = pairs.shape[0]
    g0 = np.zeros(n)
    if preload is not None:
        # Start with every gap at exactly 0: the preload's residual interpenetration
        # F/k_p is an artefact of its penalty springs (see crane_fem.preload).
        d = preload.displacement
        g0 = np.where(preload.closed, -(d[pairs[:, 0], 2] - d[pairs[:, 1], 2]), 0.0)
    mu = tangents = None
    if wheel.friction > 0.0:
        mu = np.full(n, wheel.friction)
        tangents = TangentRows(
            np.repeat(np.arange(n, dtype=np.int64), n_t),
            np.concatenate(t_rows).astype(np.int64),
            np.concatenate(t_dofs).astype(np.int64),
            np.concatenate(t_coeffs),
        )
    return ContactSet(
        comm,
        g0,
        np.concatenate(rows).astype(np.int64),
        np.concatenate(dofs).astype(np.int64),
        np.concatenate(coeffs),
        (crane.wheel - 1).astype(np.int64),
        names,
        # A pair held closed drifts by round-off (ε |u|): 1e-12 of the span absorbs it.
        tol=1e-12 * mdl.span,
        mu=mu,
        tangents=tangents,
    )


#: The flange contact groups, after the four ``wheel_k``: group 2(k − 1) + (0 inner, 1 outer).
FLANGE_GROUPS = [f"flange_{side}_{k}" for k in range(1, 5) for side in ("in", "out")]


def _flange_contacts(
    comm: MPI.Comm, sub: Subdomain, crane: CraneMesh, preload: Preload | None, span: float
) -> ContactSet:
    """Lateral node-to-node contacts of the flanges on the rail sides (frictionless):
    g = g0 + n_x (u_x(flange) − u_x(rail)) ≥ 0, n_x = ±1 from the rail towards the flange.

    g0 is the clearance (CraneMesh.flange_gap); the explicit side starts from the preload's
    displacement d, so the gap at t = 0 is g0 + n_x (d_x(flange) − d_x(rail)): the lateral
    strain of the weight, physical and kept, unless it would start closed past contact (a
    zero clearance), then g0 makes it start at exactly 0."""
    pairs = crane.flange_pairs
    nx = crane.flange_normal[:, 0]
    rows, dofs, coeffs = [], [], []
    for side, sign in ((0, 1.0), (1, -1.0)):
        order = np.argsort(pairs[:, side])
        blocks, pos = sub.owned_dofs_of(pairs[order, side])
        rows.append(order[pos])
        dofs.append(blocks * sub.bs)
        coeffs.append(sign * nx[order[pos]])
    have = comm.allreduce(sum(r.size for r in rows), op=MPI.SUM)
    if have != 2 * pairs.shape[0]:
        raise ScenarioError(
            "the flanges and the rail sides they face must belong to explicit (cd-lagrange) "
            "subdomains (wheel_k and zone_k)"
        )
    g0 = crane.flange_gap.astype(np.float64, copy=True)
    if preload is not None:
        d = preload.displacement
        shift = nx * (d[pairs[:, 0], 0] - d[pairs[:, 1], 0])
        g0 = np.maximum(0.0, g0 + shift) - shift
    group = 2 * (crane.flange_wheel - 1) + np.where(crane.flange_inner, 0, 1)
    return ContactSet(
        comm,
        g0,
        np.concatenate(rows).astype(np.int64),
        np.concatenate(dofs).astype(np.int64),
        np.concatenate(coeffs),
        group.astype(np.int64),
        list(FLANGE_GROUPS),
        tol=1e-12 * span,
    )


def _sliding_contacts(
    sub: Subdomain,
    crane: CraneMesh,
    mdl: CraneModel,
    wheel: Wheel,
    nodes: ContactSet,
    interface: IntArray,
) -> SlidingContacts:
    """The wheels' vertices on the rail tops and the flanges' on the rail sides, node to
    surface (crane_fem.contact.sliding), from their node-to-node rows ``nodes`` (wheel pairs
    then flange pairs): each point's offset c_p keeps its node-to-node gap at t = 0
    (collective). With friction, the kernel's contact rows may not share DOFs with the
    interface's: the rail tops' triangles touching the ``interface`` vertices (the zone's
    ends) are left out, so that a wheel follows its rail to one element short of the zone's
    end; the flanges act node to nearest node on the rail sides' vertices off the interface
    (the sides' triangles all reach the rail's foot)."""
    geo = mdl.geometry()
    tol = 1e-6 * geo.size
    top = facing_surface(sub, np.array([0.0, 0.0, 1.0]), geo.rail_top, 2, tol)
    if wheel.friction > 0.0:
        top = without_vertices(top, interface)
    n_pairs = crane.pairs.shape[0]
    families = [
        Family(
            crane.pairs[:, 0].astype(np.int64),
            top,
            (crane.wheel - 1).astype(np.int64),
            nodes.g0[:n_pairs].copy(),
            n_tangents=(2 if wheel.braked else 1) if wheel.friction > 0.0 else 0,
            mu=wheel.friction,
            along=1,
            label=crane.wheel.astype(np.int64),
        )
    ]
    fp = crane.flange_pairs
    if fp.shape[0]:
        ids = np.unique(fp.ravel())
        X = vertex_coordinates(sub, ids)
        Xf, Xr = X[np.searchsorted(ids, fp[:, 0])], X[np.searchsorted(ids, fp[:, 1])]
        normal = crane.flange_normal
        offset = nodes.g0[n_pairs:] - np.einsum("ij,ij->i", normal, Xf - Xr)
        group = nodes.group[n_pairs:]
        rails = sorted({x for x, _ in geo.wheel_centres()})
        for sign in (1.0, -1.0):
            mine = normal[:, 0] * sign > 0.0
            if not np.any(mine):
                continue
            sides = [
                facing_surface(
                    sub, np.array([sign, 0.0, 0.0]), x + 0.5 * sign * geo.rail_width, 0, tol
                )
                for x in rails
            ]
            side = merge_surfaces(sides)
            # The rail's sides only: the wheels, as wide as their rails, have their own sides
            # in the same planes above the rail top.
            below = side.xyz[side.triangles, 2].max(axis=1) <= geo.rail_top + tol
            side = triangles_where(side, below)
            # Each flange vertex on the nearest rail-side vertex off the interface: the rail
            # sides' triangles all reach the rail's foot, which is interface (with friction
            # the kernel's contact rows may not share its DOFs).
            allowed = np.flatnonzero(~np.isin(side.vertex_ids, interface)).astype(np.int64)
            families.append(
                Family(
                    fp[mine, 0].astype(np.int64),
                    side,
                    group[mine],
                    offset[mine],
                    along=1,
                    label=crane.flange_wheel[mine].astype(np.int64),
                    vertices=allowed if wheel.friction > 0.0 else None,
                )
            )
    names = list(nodes.group_names)
    message = (
        "wheel {label} slid {slip_mm:+.1f} mm along its rail at t = {t:.6g} s, off the end of "
        f"its explicit rail zone, which extends model.zone_margin = {geo.zone_margin * 1e3:g} "
        "mm past the wheel at each end (its contact surface one element less): raise "
        "model.zone_margin to follow it further"
    )
    sliding = SlidingContacts(
        sub, families, names, nodes.tol, message, "wheel", 'wheel.contact = "surface"'
    )
    return sliding


def _gmsh_contacts(
    sub: Subdomain, mesh: MeshStage, preload: Preload | None, interface: IntArray
) -> SlidingContacts:
    """A gmsh model's ``[[contact]] type = "surface"``: each points group on its surface's
    triangles, re-paired as they slide (collective). Each point's offset c_p makes its gap
    at t = 0 its distance at X moved by the preload's displacement, exactly 0 where the
    preload closed it (its penalty's interpenetration F/k_p removed) and never negative (a
    surface meshed a little into its neighbour touches it).

    Raises:
        ScenarioError: a contact's vertices are not all in the explicit subdomain, or, with
            friction, touch the interface.
    """
    families = []
    names = [c.name for c in mesh.surface_contacts]
    disp = preload.displacement if preload is not None else None
    start = 0
    for k, c in enumerate(mesh.surface_contacts):
        ids = np.unique(np.concatenate([c.points, c.surface.vertex_ids]))
        blocks, _ = sub.owned_dofs_of(ids)
        have = mesh.comm.allreduce(int(blocks.size), op=MPI.SUM)
        if have != ids.size:
            raise ScenarioError(
                f"contact {c.name!r}: its points and surface must belong to an explicit "
                "(cd-lagrange) subdomain"
            )
        if c.friction > 0.0 and np.any(np.isin(ids, interface)):
            raise ScenarioError(
                f"contact {c.name!r}: a frictional contact may not touch the interface "
                "between the explicit and implicit subdomains (make the bodies around it "
                "explicit)"
            )
        pr = c.pairing
        s0 = pr.gap.copy()
        closed = s0 <= 0.0
        if disp is not None:
            tri = c.surface.vertex_ids[c.surface.triangles[pr.triangle]]
            rel = disp[c.points] - np.einsum("pk,pkj->pj", pr.xi, disp[tri])
            s0 = s0 + np.einsum("pj,pj->p", pr.normal, rel)
            assert preload is not None
            closed = preload.closed[start : start + c.points.size]
        offset = np.where(closed, -s0, np.maximum(0.0, -s0))
        start += c.points.size
        families.append(
            Family(
                c.points,
                c.surface,
                np.full(c.points.size, k, dtype=np.int64),
                offset,
                n_tangents=(1 if c.rolling is not None else 2) if c.friction > 0.0 else 0,
                mu=c.friction,
                free=c.rolling,
            )
        )
    # A point held closed drifts by round-off (ε |u|): 1e-12 of the model absorbs it.
    return SlidingContacts(
        sub,
        families,
        names,
        1e-12 * mesh.extent(),
        point_name="contact point",
        surface_key="[[contact]] points/surface",
    )


def build_constraints(sc: Scenario, mesh: MeshStage, models: ModelStage) -> ConstraintStage:
    """Interface rows and contacts (collective)."""
    comm = mesh.comm
    E_sub, I_sub = models.explicit, models.implicit
    vertices = np.zeros(0, dtype=np.int64)
    le = li = ContactSet.empty(comm)
    zones = None
    on_solids = vertices
    if models.joints is not None:
        j = models.joints
        vertices, le, li, zones = j.nodes, j.l_explicit, j.l_implicit, j.zones
        on_solids = j.face_vertices  # the explicit side's interface: the joints' faces
    elif models.coupled:
        assert E_sub is not None and I_sub is not None
        vertices, le, li = build_interface(E_sub, I_sub)
        on_solids = vertices
        if vertices.size == 0:
            raise ScenarioError("subdomain: the explicit and implicit subdomains do not touch")
    contacts = ContactSet.empty(comm)
    sliding: SlidingContacts | LineContacts | None = None
    if mesh.crane is not None:
        if E_sub is None:
            raise ScenarioError("the crane's wheel/rail contacts need an explicit subdomain")
        assert isinstance(sc.model, CraneModel)
        contacts = _pair_contacts(comm, E_sub, mesh.crane, models.preload, sc.model, sc.wheel)
        if mesh.crane.flange_pairs.shape[0] > 0:
            flanges = _flange_contacts(comm, E_sub, mesh.crane, models.preload, sc.model.span)
            contacts = ContactSet.stack(contacts, flanges)
        if sc.wheel.contact == "surface":
            sliding = _sliding_contacts(E_sub, mesh.crane, sc.model, sc.wheel, contacts, vertices)
            contacts = sliding.rows()
    elif sc.contact or sc.rope:
        if E_sub is None:
            raise ScenarioError("contact: needs an explicit (cd-lagrange) subdomain")
        if mesh.frame_contacts is not None:
            # A point held closed drifts by round-off (ε |u|): 1e-12 of the model absorbs it.
            tol = 1e-12 * mesh.extent()
            sliding, contacts = frame_contact_rows(
                mesh.frame_contacts, E_sub, models.preload, vertices, tol
            )
        elif isinstance(sc.model, GmshModel):
            sliding = _gmsh_contacts(E_sub, mesh, models.preload, on_solids)
            contacts = sliding.rows()
        elif isinstance(sc.model, BlockModel):
            contacts = _plane_contacts(sc, mesh, E_sub)
        else:
            contacts = _wall_contacts(sc, mesh, E_sub)
    return ConstraintStage(vertices, le, li, contacts, sliding, zones)
