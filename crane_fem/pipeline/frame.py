"""A frame's parts of the pipeline: each cell's material, section and local axes, the
supports' vertices, the point masses, and its contacts at t = 0 (their ties for the preload
and the modes), from the scenario's entries on the line mesh."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from crane_fem.contact.constraints import ContactSet, TangentRows
from crane_fem.contact.on_line import (
    LineContacts,
    LineFamily,
    element_axes,
    project_on_line,
    row_coefficients,
)
from crane_fem.contact.ropes import RopeRows, RopeSpec
from crane_fem.contact.sliding import tangents_of
from crane_fem.errors import ScenarioError
from crane_fem.formulations import CellFields, SectionFields, local_axes
from crane_fem.geometry.tagged import TaggedMesh
from crane_fem.preload import BondedPoints, Preload
from crane_fem.scenario import LineContact, PlaneContact, Scenario
from crane_fem.subdomains import PointMasses, Subdomain, global_ids

__all__ = [
    "FrameContacts",
    "LineLayout",
    "PlaneLayout",
    "carried_weight",
    "frame_bonded_points",
    "frame_contact_rows",
    "frame_contacts",
    "frame_fields",
    "frame_point_masses",
    "frame_supports",
    "group_cells",
    "line_elements",
    "rope_held_vertices",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


def group_cells(tagged: TaggedMesh, names: list[str]) -> npt.NDArray[np.int32]:
    """Local cells (owned and ghost) of the named cell groups."""
    tags = [tagged.cell_groups[g] for g in names]
    return tagged.cell_tags.indices[np.isin(tagged.cell_tags.values, tags)].astype(np.int32)


def _tangents(tagged: TaggedMesh) -> FloatArray:
    """The unit tangent of every local cell (owned and ghost), from its first to its second
    vertex."""
    import dolfinx.mesh

    msh = tagged.mesh
    imap = msh.topology.index_map(1)
    cells = np.arange(imap.size_local + imap.num_ghosts, dtype=np.int32)
    X = msh.geometry.x[dolfinx.mesh.entities_to_geometry(msh, 1, cells)]
    d = X[:, 1] - X[:, 0]
    out: FloatArray = d / np.linalg.norm(d, axis=1)[:, None]
    return out


def frame_fields(sc: Scenario, tagged: TaggedMesh) -> CellFields:
    """E, ν, ρ, the section and the local axes of every local cell of a frame (collective:
    an orientation parallel to a member is refused on every rank).

    Raises:
        ScenarioError: a section's orientation vector is parallel to one of its members.
    """
    msh = tagged.mesh
    imap = msh.topology.index_map(1)
    n = imap.size_local + imap.num_ghosts
    E, nu, rho = np.zeros(n), np.zeros(n), np.zeros(n)
    for names, mat in sc.materials:
        cells = slice(None) if names is None else group_cells(tagged, names)
        E[cells], nu[cells], rho[cells] = mat.E, mat.nu, mat.rho
    props = {k: np.zeros(n) for k in ("A", "I1", "I2", "J", "k1", "k2", "c1", "c2", "Wt")}
    circular = np.zeros(n, dtype=bool)
    rotary = np.ones(n)
    t = _tangents(tagged)
    a1, a2 = np.zeros((n, 3)), np.zeros((n, 3))
    error = None
    for i, sec in enumerate(sc.section):
        cells = group_cells(tagged, list(sec.groups))
        nu_sec = float(nu[cells[0]]) if cells.size else 0.3
        p = sec.properties(nu_sec)
        for k in props:
            props[k][cells] = getattr(p, k)
        circular[cells] = p.circular
        rotary[cells] = sec.rotary_scale
        try:
            a1[cells], a2[cells] = local_axes(t[cells], np.asarray(sec.orientation))
        except ValueError:
            error = error or (
                f"section[{i}].orientation: {sec.orientation} is parallel to a member of "
                f"group(s) {', '.join(sec.groups)} (give a vector across the members: it fixes "
                "their local axis 2)"
            )
    errors = [e for e in msh.comm.allgather(error) if e is not None]
    if errors:
        raise ScenarioError(errors[0])
    section = SectionFields(circular=circular, rotary=rotary, t=t, a1=a1, a2=a2, **props)
    return CellFields(E, nu, rho, section=section)


def frame_supports(
    sc: Scenario, tagged: TaggedMesh
) -> tuple[IntArray, IntArray, tuple[IntArray, ...]]:
    """(clamped vertices, pinned vertices, each support group's vertices), global ids
    (collective)."""
    faces = tuple(tagged.global_vertices(tagged.facet_vertices(s.group)) for s in sc.support)
    none = np.zeros(0, dtype=np.int64)
    clamped = [f for f, s in zip(faces, sc.support, strict=True) if s.dofs == "clamped"]
    pinned = [f for f, s in zip(faces, sc.support, strict=True) if s.dofs == "pinned"]
    return (
        np.unique(np.concatenate([none, *clamped])),
        np.setdiff1d(np.unique(np.concatenate([none, *pinned])), np.concatenate([none, *clamped])),
        faces,
    )


def frame_point_masses(sc: Scenario, tagged: TaggedMesh) -> PointMasses | None:
    """The ``[[mass]]`` entries of a frame: each group's mass (and rotary inertia) shared
    equally by its vertices (collective)."""
    if not sc.mass:
        return None
    values: dict[int, FloatArray] = {}
    for ms in sc.mass:
        ids = tagged.global_vertices(tagged.facet_vertices(ms.group))
        share = np.zeros(6)
        share[:3] = ms.mass / ids.size
        if ms.inertia is not None:
            share[3:] = np.asarray(ms.inertia) / ids.size
        for v in ids.tolist():
            values[v] = values.get(v, np.zeros(6)) + share
    vertices = np.array(sorted(values), dtype=np.int64)
    return PointMasses(vertices, np.array([values[int(v)] for v in vertices]))


@dataclass(frozen=True)
class LineLayout:
    """A ``point-on-line`` contact on the parent mesh at t = 0 (the same on every rank).

    Attributes:
        index: its ``[[contact]]`` entry; label: its name.
        points: (p,) sorted global ids of its points; X: (p, 3) their coordinates.
        elements: (e, 2) global vertex ids of the line group's elements; Xe: (e, 2, 3).
        normal: (3,) unit; offset, clearance (None: no flanges), friction.
        element, xi: each point's element (index into ``elements``) and abscissa at X.
        group: the contact group of its normal rows; lateral: of its flanges (in, out).
    """

    index: int
    label: str
    points: IntArray
    X: FloatArray
    elements: IntArray
    Xe: FloatArray
    normal: FloatArray
    offset: float
    clearance: float | None
    friction: float
    element: IntArray
    xi: FloatArray
    group: int
    lateral: tuple[int, int] = (-1, -1)
    #: A free-rolling wheel's friction acts across the line only.
    rolling: bool = False

    def rows_at(self, which: tuple[str, ...]) -> FloatArray:
        """The coefficients (p, len(which), 3 vertices, 6) of the rows ``which`` ("normal",
        "across", "along") of each point at its t = 0 pairing."""
        t, n, lat = element_axes(self.Xe[:, 0], self.Xe[:, 1], self.normal)
        el = self.element
        axes = {"normal": n[el], "across": lat[el], "along": t[el]}
        e = self.offset * n[el]
        return np.stack([row_coefficients(axes[w], self.xi, e) for w in which], axis=1)

    @property
    def ids(self) -> IntArray:
        """(p, 3): each point and its element's ends."""
        return np.column_stack([self.points, self.elements[self.element]]).astype(np.int64)

    def gaps(self, disp: FloatArray | None = None) -> FloatArray:
        """Each point's distance above its rail top at t = 0 (m), with the vertex
        displacements ``disp`` (n_vertices, 6) added (the preload's)."""
        x = np.zeros((self.points.size, 3, 6))
        x[:, 0, :3] = self.X
        x[:, 1:, :3] = self.Xe[self.element]
        if disp is not None:
            x = x + disp[self.ids]
        row = self.rows_at(("normal",))[:, 0]
        return np.einsum("pvc,pvc->p", row, x) - self.offset


@dataclass(frozen=True)
class PlaneLayout:
    """A ``point-on-plane`` contact: its points, their coordinates and the plane."""

    index: int
    label: str
    points: IntArray
    X: FloatArray
    origin: FloatArray
    normal: FloatArray
    friction: float
    group: int

    def gaps(self, disp: FloatArray | None = None) -> FloatArray:
        x = self.X if disp is None else self.X + disp[self.points, :3]
        return np.asarray((x - self.origin) @ self.normal)


@dataclass(frozen=True)
class FrameContacts:
    """A frame's contacts at t = 0 and their group names (normal rows of each contact, then
    its flanges'; then the ropes')."""

    lines: tuple[LineLayout, ...]
    planes: tuple[PlaneLayout, ...]
    names: tuple[str, ...]
    ropes: RopeSpec | None = None
    #: (n_ropes, 2, 3) the ropes' ends' reference coordinates.
    rope_X: FloatArray = field(default_factory=lambda: np.zeros((0, 2, 3)))

    def rope_chords(self) -> tuple[FloatArray, FloatArray]:
        """Each rope's unit direction from a to b and its length at X (m)."""
        chord = self.rope_X[:, 1] - self.rope_X[:, 0]
        length = np.linalg.norm(chord, axis=1)
        return chord / np.maximum(length, 1e-300)[:, None], length


def line_elements(tagged: TaggedMesh, group: str) -> tuple[IntArray, FloatArray]:
    """The elements of a line group as global vertex pairs (e, 2), in increasing order, and
    their ends' coordinates (e, 2, 3), the same on every rank (collective)."""
    import dolfinx.mesh

    msh = tagged.mesh
    n_own = msh.topology.index_map(1).size_local
    cells = group_cells(tagged, [group])
    cells = cells[cells < n_own]
    msh.topology.create_connectivity(1, 0)
    c2v = msh.topology.connectivity(1, 0).array.reshape(-1, 2)[cells]
    gv = np.asarray(msh.topology.index_map(0).local_to_global(c2v.ravel()), dtype=np.int64)
    X = msh.geometry.x[dolfinx.mesh.entities_to_geometry(msh, 1, cells)]
    parts = msh.comm.allgather((gv.reshape(-1, 2), X.reshape(-1, 2, 3)))
    ids = np.concatenate([p for p, _ in parts]).reshape(-1, 2)
    xyz = np.concatenate([x for _, x in parts]).reshape(-1, 2, 3)
    order = np.lexsort((ids[:, 1], ids[:, 0]))
    return ids[order], xyz[order]


def frame_contacts(sc: Scenario, tagged: TaggedMesh) -> FrameContacts:
    """The frame's ``[[contact]]`` entries on the parent mesh at t = 0 (collective).

    Raises:
        ScenarioError: a point is not over its line within reach (its projection falls
            outside the line, it sits across the line by more than its clearance, or starts
            inside the rail), on every rank.
    """
    lines: list[LineLayout] = []
    planes: list[PlaneLayout] = []
    names: list[str] = []
    for i, c in enumerate(sc.contact):
        points = tagged.global_vertices(tagged.facet_vertices(c.points))  # type: ignore[union-attr]
        X = tagged.vertex_coordinates(points)
        normal = np.asarray(c.normal, dtype=np.float64)  # type: ignore[union-attr]
        normal = normal / np.linalg.norm(normal)
        if isinstance(c, LineContact):
            elements, Xe = line_elements(tagged, c.line)
            element, xi, found = project_on_line(X, Xe[:, 0], Xe[:, 1])
            group = len(names)
            names.append(c.label)
            lateral = (-1, -1)
            if c.clearance is not None:
                lateral = (len(names), len(names) + 1)
                names += c.lateral_names
            layout = LineLayout(
                i,
                c.label,
                points,
                X,
                elements,
                Xe,
                normal,
                c.offset,
                c.clearance,
                c.friction,
                element,
                xi,
                group,
                lateral,
                c.rolling,
            )
            _check_over_line(i, c, layout, found)
            lines.append(layout)
        else:
            assert isinstance(c, PlaneContact)
            planes.append(
                PlaneLayout(
                    i,
                    c.label,
                    points,
                    X,
                    np.asarray(c.origin, dtype=np.float64),
                    normal,
                    c.friction,
                    len(names),
                )
            )
            names.append(c.label)
            gap = planes[-1].gaps()
            if np.any(gap < -1e-9 * max(1.0, float(np.abs(X).max(initial=1.0)))):
                k = int(np.argmin(gap))
                raise ScenarioError(
                    f"contact[{i}].points: vertex {int(points[k])} of group {c.points!r} "
                    f"starts {-gap[k]:.4g} m behind its plane (it must touch it or face it)"
                )
    ropes, rope_X = _ropes(sc, tagged, names)
    return FrameContacts(tuple(lines), tuple(planes), tuple(names), ropes, rope_X)


def _ropes(
    sc: Scenario, tagged: TaggedMesh, names: list[str]
) -> tuple[RopeSpec | None, FloatArray]:
    """The ``[[rope]]`` entries: their ends (the two vertices of their line's one element),
    lengths, stiffnesses and groups (appended to ``names``) (collective).

    Raises:
        ScenarioError: a rope's line has other than one element.
    """
    if not sc.rope:
        return None, np.zeros((0, 2, 3))
    ends, coords = [], []
    for i, r in enumerate(sc.rope):
        ids, X = line_elements(tagged, r.line)
        if ids.shape[0] != 1:
            raise ScenarioError(
                f"rope[{i}].line: line group {r.line!r} has {ids.shape[0]} elements; a rope is "
                "one 2-node element between its two ends"
            )
        ends.append(ids[0])
        coords.append(X[0])
    a = np.array([e[0] for e in ends], dtype=np.int64)
    b = np.array([e[1] for e in ends], dtype=np.int64)
    group = np.arange(len(names), len(names) + a.size, dtype=np.int64)
    names += [r.label for r in sc.rope]
    spec = RopeSpec(
        a,
        b,
        np.array([r.length for r in sc.rope]),
        np.array([r.stiffness for r in sc.rope]),
        group,
    )
    return spec, np.array(coords)


def rope_held_vertices(sc: Scenario, tagged: TaggedMesh) -> IntArray:
    """The global ids of the vertices on ropes only (no beam): their rotations are held
    (a rope carries no moment; a hanging load does not spin) (collective)."""
    ropes = [r.line for r in sc.rope]
    if not ropes:
        return np.zeros(0, dtype=np.int64)
    msh = tagged.mesh
    msh.topology.create_connectivity(1, 0)
    c2v = msh.topology.connectivity(1, 0).array.reshape(-1, 2)
    rope = group_cells(tagged, ropes)
    beams = np.setdiff1d(np.arange(c2v.shape[0], dtype=np.int32), rope)
    on_rope = tagged.global_vertices(np.unique(c2v[rope]).astype(np.int32))
    on_beam = tagged.global_vertices(np.unique(c2v[beams]).astype(np.int32))
    return np.setdiff1d(on_rope, on_beam).astype(np.int64)


def _check_over_line(
    i: int, c: LineContact, layout: LineLayout, found: npt.NDArray[np.bool_]
) -> None:
    """Refuse a point that is not over its line within reach."""
    Xe = layout.Xe
    length = float(np.linalg.norm(Xe[:, 1] - Xe[:, 0], axis=1).min(initial=1.0))
    tol = 1e-6 * length
    if np.any(~found):
        k = int(np.flatnonzero(~found)[0])
        where = layout.X[k].round(6).tolist()
        raise ScenarioError(
            f"contact[{i}].points: vertex {int(layout.points[k])} of group {c.points!r} at "
            f"{where} is not over line group {c.line!r} (its projection falls outside the "
            "line's ends)"
        )
    t, n, lat = element_axes(Xe[:, 0], Xe[:, 1], layout.normal)
    el = layout.element
    foot = Xe[el, 0] + layout.xi[:, None] * (Xe[el, 1] - Xe[el, 0])
    across = np.abs(np.einsum("pj,pj->p", layout.X - foot, lat[el]))
    reach = max(layout.clearance or 0.0, tol)
    gap = layout.gaps()
    bad = np.flatnonzero((across > reach) | (gap < -tol))
    if bad.size:
        k = int(bad[0])
        what = (
            f"{across[k]:.4g} m across it (at most its clearance, {reach:.4g} m)"
            if across[k] > reach
            else f"{-gap[k]:.4g} m inside its rail top (offset {layout.offset:g} m above the axis)"
        )
        raise ScenarioError(
            f"contact[{i}].points: vertex {int(layout.points[k])} of group {c.points!r} is not "
            f"over line group {c.line!r} within reach: {what}"
        )
    del t, n


def frame_bonded_points(contacts: FrameContacts) -> BondedPoints:
    """Every frame contact point tied to what it touches at t = 0 by its three rows (the
    normal, across, along), for the preload and the modes (the groups: the normal rows'); the
    points on lines loose (``BondedPoints.loose``: no tangential force at rest)."""
    ids, rows, normal, gap, group, loose = [], [], [], [], [], []
    width = 3
    for c in contacts.lines:
        r = c.rows_at(("normal", "across", "along"))
        ids.append(c.ids)
        rows.append(r)
        loose.append(np.ones(c.points.size, dtype=bool))  # set down on its line
        _, n, _ = element_axes(c.Xe[:, 0], c.Xe[:, 1], c.normal)
        normal.append(n[c.element])
        gap.append(c.gaps())
        group.append(np.full(c.points.size, c.group, dtype=np.int64))
    for pl in contacts.planes:
        p = pl.points.size
        t1, t2 = tangents_of(pl.normal)
        r = np.zeros((p, 3, width, 6))
        for d, direction in enumerate((pl.normal, t1[0], t2[0])):
            r[:, d, 0, :3] = direction
        # The plane is the ground: the other two slots are the point itself with no weight.
        ids.append(np.repeat(pl.points[:, None], width, axis=1))
        rows.append(r)
        normal.append(np.tile(pl.normal, (p, 1)))
        gap.append(pl.gaps())
        group.append(np.full(p, pl.group, dtype=np.int64))
        loose.append(np.zeros(p, dtype=bool))
    if not ids:
        z = np.zeros((0, width))
        return BondedPoints(
            z.astype(np.int64),
            z,
            np.zeros((0, 3)),
            np.zeros(0),
            np.zeros(0, np.int64),
            np.zeros((0, 3, width, 6)),
        )
    all_ids = np.concatenate(ids)
    return BondedPoints(
        all_ids,
        np.zeros(all_ids.shape),
        np.concatenate(normal),
        np.concatenate(gap),
        np.concatenate(group),
        np.concatenate(rows),
        np.concatenate(loose),
    )


def frame_contact_rows(
    contacts: FrameContacts,
    sub: Subdomain,
    preload: Preload | None,
    interface: IntArray,
    tol: float,
) -> tuple[LineContacts | None, ContactSet]:
    """The frame's contacts as the explicit side's rows (collective): the points on lines,
    re-paired as they slide (their candidate elements: those of the line with both ends in
    the explicit subdomain, and, with friction, off the interface), and the points on
    planes. Each gap starts at its distance with the preload's displacement, exactly 0 where
    the preload closed it (its penalty's interpenetration removed) and never negative.

    Raises:
        ScenarioError: a contact's points are not in the explicit subdomain, or a line has no
            element there, on every rank.
    """
    comm = sub.submesh.comm
    explicit = global_ids(comm, sub.parent_vertex[sub.parent_vertex >= 0])
    disp = preload.displacement if preload is not None else None
    closed = preload.closed if preload is not None else None
    start = 0
    families: list[LineFamily] = []
    for c in contacts.lines:
        p = c.points.size
        if not np.all(np.isin(c.points, explicit)):
            raise ScenarioError(
                f"contact[{c.index}]: its points must belong to an explicit (cd-lagrange) subdomain"
            )
        ok = np.all(np.isin(c.elements, explicit), axis=1)
        if c.friction > 0.0:
            ok &= ~np.any(np.isin(c.elements, interface), axis=1)
        if not np.any(ok):
            raise ScenarioError(
                f"contact[{c.index}]: no element of its line lies in an explicit subdomain"
                + (" off the interface (with friction)" if c.friction > 0.0 else "")
            )
        s0 = c.gaps(disp)
        shut = closed[start : start + p] if closed is not None else s0 <= tol
        shift = np.where(shut, -s0, np.maximum(0.0, -s0))
        start += p
        families.append(
            LineFamily(
                c.points,
                c.elements[ok],
                c.normal,
                c.offset,
                np.full(p, c.group, dtype=np.int64),
                shift,
                n_tangents=(1 if c.rolling else 2) if c.friction > 0.0 else 0,
                mu=c.friction,
                clearance=c.clearance,
                lateral_group=np.tile(np.asarray(c.lateral, dtype=np.int64), (p, 1)),
                label=np.arange(1, p + 1, dtype=np.int64),
            )
        )
    planes = _plane_rows(contacts, sub, disp, closed, start, explicit, tol)
    ropes = None
    if contacts.ropes is not None:
        if not np.all(np.isin(np.r_[contacts.ropes.a, contacts.ropes.b], explicit)):
            raise ScenarioError("rope: both ends of a rope must belong to an explicit subdomain")
        ropes = RopeRows(sub, contacts.ropes, list(contacts.names), contacts.rope_X)
    if not families and ropes is None:
        return None, planes
    message = (
        "point {label} of a point-on-line contact left the explicit part of its line at "
        "t = {t:.6g} s (the line's elements with both ends in an explicit subdomain, and off "
        "the interface with friction): widen the explicit subdomain around it"
    )
    names = list(contacts.names)
    lines = LineContacts(sub, families, names, tol, message, "point", static=planes, ropes=ropes)
    return lines, lines.rows()


def _plane_rows(
    contacts: FrameContacts,
    sub: Subdomain,
    disp: FloatArray | None,
    closed: npt.NDArray[np.bool_] | None,
    start: int,
    explicit: IntArray,
    tol: float,
) -> ContactSet:
    """The points on planes: g = g0 + n·u_p, with the tangents t₁, t₂ of n where frictional
    (not collective)."""
    comm = sub.submesh.comm
    g0, rows, dofs, coeffs, group, mu = [], [], [], [], [], []
    t_point, t_rows, t_dofs, t_coeffs = [], [], [], []
    p_total = 0
    nt_total = 0
    for pl in contacts.planes:
        p = pl.points.size
        if not np.all(np.isin(pl.points, explicit)):
            raise ScenarioError(
                f"contact[{pl.index}]: its points must belong to an explicit (cd-lagrange) "
                "subdomain"
            )
        ref = pl.gaps()
        s0 = pl.gaps(disp)
        shut = closed[start : start + p] if closed is not None else s0 <= tol
        start += p
        g0.append(ref + np.where(shut, -s0, np.maximum(0.0, -s0)))
        blocks, pos = sub.owned_dofs_of(pl.points)
        for d in range(3):
            rows.append(p_total + pos)
            dofs.append(blocks * sub.bs + d)
            coeffs.append(np.full(blocks.size, pl.normal[d]))
        group.append(np.full(p, pl.group, dtype=np.int64))
        mu.append(np.full(p, pl.friction))
        if pl.friction > 0.0:
            t1, t2 = tangents_of(pl.normal)
            for k, t in enumerate((t1[0], t2[0])):
                for d in range(3):
                    t_rows.append(nt_total + 2 * pos + k)
                    t_dofs.append(blocks * sub.bs + d)
                    t_coeffs.append(np.full(blocks.size, t[d]))
            t_point.append(np.repeat(p_total + np.arange(p), 2))
            nt_total += 2 * p
        p_total += p
    if not p_total:
        return ContactSet.empty(comm)
    cat = np.concatenate
    keep = cat(coeffs) != 0.0
    tangents = None
    if t_point:
        tkeep = cat(t_coeffs) != 0.0
        tangents = TangentRows(
            cat(t_point).astype(np.int64),
            cat(t_rows)[tkeep].astype(np.int64),
            cat(t_dofs)[tkeep].astype(np.int64),
            cat(t_coeffs)[tkeep],
        )
    mus = cat(mu)
    return ContactSet(
        comm,
        cat(g0),
        cat(rows)[keep].astype(np.int64),
        cat(dofs)[keep].astype(np.int64),
        cat(coeffs)[keep],
        cat(group),
        list(contacts.names),
        tol=tol,
        mu=mus if np.any(mus > 0.0) else None,
        tangents=tangents,
    )


def carried_weight(sc: Scenario, tagged: TaggedMesh, fields: CellFields) -> float:
    """The weight (N) of the frame's bodies held by contacts alone: its connected pieces
    (ropes included) with no support vertex, their beams' ρ A L and their point masses
    (collective)."""
    import dolfinx.mesh
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    msh = tagged.mesh
    n_own = msh.topology.index_map(1).size_local
    msh.topology.create_connectivity(1, 0)
    c2v = msh.topology.connectivity(1, 0).array.reshape(-1, 2)[:n_own]
    gv = np.asarray(msh.topology.index_map(0).local_to_global(c2v.ravel()), dtype=np.int64)
    X = msh.geometry.x[dolfinx.mesh.entities_to_geometry(msh, 1, np.arange(n_own, dtype=np.int32))]
    length = np.linalg.norm(X[:, 1] - X[:, 0], axis=1)
    assert fields.section is not None
    rho = np.broadcast_to(np.asarray(fields.rho, dtype=float), (fields.section.A.size,))
    mass = rho[:n_own] * fields.section.A[:n_own] * length
    parts = msh.comm.allgather((gv.reshape(-1, 2), mass))
    edges = np.concatenate([p for p, _ in parts]).reshape(-1, 2)
    cell_mass = np.concatenate([m for _, m in parts])
    n = msh.topology.index_map(0).size_global
    graph = coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    supported = (
        np.unique(
            label[
                np.concatenate(
                    [tagged.global_vertices(tagged.facet_vertices(s.group)) for s in sc.support]
                )
            ]
        )
        if sc.support
        else np.zeros(0, dtype=np.int64)
    )
    free = ~np.isin(label[edges[:, 0]], supported)
    total = float(cell_mass[free].sum())
    for ms in sc.mass:
        ids = tagged.global_vertices(tagged.facet_vertices(ms.group))
        total += ms.mass * float(np.mean(~np.isin(label[ids], supported)))
    return total * float(np.linalg.norm(sc.loading.gravity))
