"""Bi-girder overhead-crane mock-up built and meshed by gmsh OpenCASCADE: bridge, rails, trolley.

Axes: x along the runway (end carriages), y along the span (girders), z up. The bridge (two end
carriages, two girders on them, one rail on each girder) is one glued body; the trolley (frame +
four wheel blocks) is a second body resting on the rails. Each wheel's bottom face and the
matching patch imprinted on the rail top are distinct, coincident surfaces with identical meshes
(gmsh periodic constraint), so the wheel/rail contact pairs are node-to-node pairs given by
gmsh's node correspondence, not by coordinates. Explicit zones are the wheels plus the rail and
girder material inside a box around each contact; the rest is implicit.

With ``flanges`` on, each wheel carries two flanges (guide plates) hanging down either side of
its rail, ``flange_clearance`` away from the rail's sides, ``flange_depth`` below the rail top:
the horizontal impacts of the guiding devices. Each flange's inner face below the rail top and
the patch imprinted on the rail side facing it are meshed alike by a periodic constraint (a
translation by the clearance in x); their node pairs are found by that translation.

The scene is symmetric in x = 0 and, with the trolley at mid-span, in y = span/2; the mesh is
made so too: gmsh meshes the region x ≥ 0 (y ≤ span/2), which
:func:`.crane_mirror.mirror_mesh` reflects into the whole crane. An unstructured mesh of the
whole crane breaks the symmetry by itself: its preload spread the trolley weight 1360–1494 N
over the wheels in a diagonal pattern, and a vertical shake rocked and pitched the trolley
(10 % of the wheel response), from the mesh alone.
"""

from __future__ import annotations

from typing import Protocol

import gmsh
import numpy as np
import numpy.typing as npt

from crane_fem.geometry.crane_mirror import IDENTITY, mirror_mesh
from crane_fem.geometry.crane_pairs import CraneMeshInfo, mesh_info
from crane_fem.geometry.crane_parameters import CraneGeometry

__all__ = ["WheelGeometry", "add_flanged_wheel", "build_crane_model", "flange_sides"]


def _box(x0: float, y0: float, z0: float, dx: float, dy: float, dz: float) -> int:
    return gmsh.model.occ.addBox(x0, y0, z0, dx, dy, dz)


def _translation_x(dx: float) -> list[float]:
    """The 4×4 affine map (row-major) x -> x + dx e_x."""
    return [1, 0, 0, dx, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]


def _rectangle_x(x: float, y0: float, z0: float, dy: float, dz: float) -> int:
    """An OCC rectangle in the plane x = const (to imprint on a face there)."""
    occ = gmsh.model.occ
    corners = [(y0, z0), (y0 + dy, z0), (y0 + dy, z0 + dz), (y0, z0 + dz)]
    points = [occ.addPoint(x, y, z) for y, z in corners]
    lines = [occ.addLine(points[i], points[(i + 1) % 4]) for i in range(4)]
    return occ.addPlaneSurface([occ.addCurveLoop(lines)])


def flange_sides(x: float) -> list[tuple[str, float]]:
    """(name, s) of the flanges of the wheel on the rail at x: s = ±1 is the side of the rail
    (the x direction from the rail to the flange); the inner flange faces x = 0."""
    towards_centre = -1.0 if x > 0.0 else 1.0
    return [("in", towards_centre), ("out", -towards_centre)]


class WheelGeometry(Protocol):
    """What a flanged wheel is built from: the 3D mock-up's geometry, or the frame crane's
    model with solid wheel zones (m)."""

    @property
    def rail_top(self) -> float: ...
    @property
    def rail_width(self) -> float: ...
    @property
    def wheel_width(self) -> float: ...
    @property
    def wheel_length(self) -> float: ...
    @property
    def wheel_height(self) -> float: ...
    @property
    def flange_clearance(self) -> float: ...
    @property
    def flange_depth(self) -> float: ...
    @property
    def flange_thickness(self) -> float: ...
    @property
    def flange_reach(self) -> float: ...


def add_flanged_wheel(geo: WheelGeometry, x: float, y: float) -> tuple[int, list[int]]:
    """The wheel block at (x, y) fused with its two flanges (one OCC volume), and the
    rectangles to imprint on the flanges' inner faces below the rail top (not synchronised).

    Each flange is a plate ``flange_thickness`` thick, its inner face ``flange_clearance`` off
    the rail side, from ``flange_depth`` below the rail top up to the frame, joined to the
    wheel by a web over the upper half of the wheel height (clear of the rail top).
    """
    occ = gmsh.model.occ
    zt, hw = geo.rail_top, geo.wheel_height
    y0, wl = y - 0.5 * geo.wheel_length, geo.wheel_length
    wheel = _box(x - 0.5 * geo.wheel_width, y0, zt, geo.wheel_width, wl, hw)
    parts, imprints = [], []
    for _, s in flange_sides(x):
        face = x + s * (0.5 * geo.rail_width + geo.flange_clearance)  # the face at the rail
        outer = x + s * geo.flange_reach
        parts.append(
            _box(
                min(face, outer),
                y0,
                zt - geo.flange_depth,
                geo.flange_thickness,
                wl,
                geo.flange_depth + hw,
            )
        )
        # The web spans the wheel to the flange's outer face: one volume, no sliver between.
        parts.append(_box(min(x, outer), y0, zt + 0.5 * hw, abs(outer - x), wl, 0.5 * hw))
        imprints.append(_rectangle_x(face, y0, zt - geo.flange_depth, wl, geo.flange_depth))
    out, _ = occ.fuse([(3, wheel)], [(3, t) for t in parts])
    if len(out) != 1:
        raise RuntimeError("crane geometry: a wheel and its flanges do not fuse into one body")
    return out[0][1], imprints


def _in_region(p: tuple[float, ...], planes: list[tuple[int, float]]) -> bool:
    """Whether the point lies in the meshed region: x ≥ 0 and, with a second plane, y ≤ its
    coordinate (the region holds wheel 3; the mirror images give wheels 1, 2 and 4)."""
    return all(p[a] >= c if a == 0 else p[a] <= c for a, c in planes)


def _is_trolley(geo: CraneGeometry, tag: int) -> bool:
    """Whether an OCC volume is part of the trolley: it rises half a wheel height above the
    rail top, where the bridge ends (a flanged wheel also reaches below it)."""
    return gmsh.model.occ.getBoundingBox(3, tag)[5] > geo.rail_top + 0.5 * geo.wheel_height


def _cut_to_region(geo: CraneGeometry, planes: list[tuple[int, float]]) -> None:
    """Cut the OCC volumes (not synchronised) by the mirror planes and keep the region.

    The bridge and the trolley are cut apart, so that the wheel bottoms and the rail patches
    stay distinct coincident faces (one fragment of both would glue them).
    """
    occ = gmsh.model.occ
    big = 10.0 * (geo.span + geo.end_carriage_length + geo.girder_spacing)
    lo, hi = [-big] * 3, [big] * 3
    for axis, c in planes:
        (lo if axis == 0 else hi)[axis] = c
    for trolley in (False, True):
        vols = [dt for dt in occ.getEntities(3) if _is_trolley(geo, dt[1]) == trolley]
        box = occ.addBox(*lo, *(b - a for a, b in zip(lo, hi, strict=True)))
        out, children = occ.fragment(vols, [(3, box)])
        pieces = {dt for kids in children[: len(vols)] for dt in kids}
        drop = [
            dt for dt in out if dt not in pieces or not _in_region(occ.getCenterOfMass(*dt), planes)
        ]
        occ.remove(drop, recursive=True)


def _flange_patches(geo: CraneGeometry, k: int, on_wheels: set[int]) -> dict[str, list[int]]:
    """The surface groups of wheel k + 1's flange patches and the rail side patches facing
    them (synchronised model), the former made periodic copies of the latter."""
    eps = 1e-6
    x, y = geo.wheel_centres()[k]
    y0, y1 = y - 0.5 * geo.wheel_length, y + 0.5 * geo.wheel_length
    zt = geo.rail_top
    groups = {}

    def faces_at(xp: float) -> list[int]:
        box = (xp - eps, y0 - eps, zt - geo.flange_depth - eps, xp + eps, y1 + eps, zt + eps)
        return [t for _, t in gmsh.model.getEntitiesInBoundingBox(*box, 2)]

    for side, s in flange_sides(x):
        x_rail = x + s * 0.5 * geo.rail_width
        x_flange = x_rail + s * geo.flange_clearance
        flange_face = [t for t in faces_at(x_flange) if t in on_wheels]
        rail_face = [t for t in faces_at(x_rail) if t not in on_wheels]
        if len(flange_face) != 1 or len(rail_face) != 1:
            raise RuntimeError(f"crane geometry: flange patch {side} of wheel {k + 1} not found")
        groups[f"flange_patch_{side}_{k + 1}"] = flange_face
        groups[f"rail_side_patch_{side}_{k + 1}"] = rail_face
        gmsh.model.mesh.setPeriodic(2, flange_face, rail_face, _translation_x(x_flange - x_rail))
    return groups


def _plate_field(geo: CraneGeometry, zt: float) -> int:
    """A gmsh Box size field of ``trolley_size`` over the trolley's plate (its bending locks
    P1 tetrahedra: a few elements through its thickness), graded to ``size`` outside."""
    assert geo.trolley_size is not None
    field = gmsh.model.mesh.field
    b = field.add("Box")
    field.setNumber(b, "VIn", geo.trolley_size)
    field.setNumber(b, "VOut", geo.size)
    half = 0.5 * geo.girder_spacing + geo.frame_overhang
    field.setNumber(b, "XMin", -half)
    field.setNumber(b, "XMax", half)
    field.setNumber(b, "YMin", geo.trolley_position - 0.5 * geo.frame_length)
    field.setNumber(b, "YMax", geo.trolley_position + 0.5 * geo.frame_length)
    field.setNumber(b, "ZMin", zt + geo.wheel_height)
    field.setNumber(b, "ZMax", zt + geo.wheel_height + geo.frame_thickness)
    field.setNumber(b, "Thickness", geo.zone_margin)
    return b


def build_crane_model(geo: CraneGeometry) -> CraneMeshInfo:
    """Build and mesh the crane in the current gmsh session (rank 0 only; gmsh initialised).

    Physical volume groups: ``bridge_implicit``, ``zone_1..4`` (rail + girder near each wheel),
    ``trolley_frame``, ``wheel_1..4`` (with its flanges). Surface groups: ``clamped``
    (end-carriage end faces), ``wheel_patch_k``, ``rail_patch_k`` and, with flanges,
    :data:`.groups.CRANE_FLANGE_SURFACES`.
    """
    geo.validate()
    occ = gmsh.model.occ
    hc, hg, hr = geo.end_carriage_height, geo.girder_height, geo.rail_height
    half_l = 0.5 * geo.end_carriage_length
    bridge = []
    for y in (0.0, geo.span - geo.end_carriage_width):
        bridge.append(_box(-half_l, y, 0.0, geo.end_carriage_length, geo.end_carriage_width, hc))
    for xc in (-0.5 * geo.girder_spacing, 0.5 * geo.girder_spacing):
        bridge.append(_box(xc - 0.5 * geo.girder_width, 0.0, hc, geo.girder_width, geo.span, hg))
        bridge.append(_box(xc - 0.5 * geo.rail_width, 0.0, hc + hg, geo.rail_width, geo.span, hr))
    # Zone boxes around each contact, and imprint rectangles for the rail patches.
    zt = geo.rail_top
    m = geo.zone_margin
    depth = geo.zone_depth
    zones, imprints = [], []
    for x, y in geo.wheel_centres():
        zones.append(
            _box(
                x - 0.5 * geo.girder_width - 1e-3,
                y - 0.5 * geo.wheel_length - m,
                hc + hg - depth,
                geo.girder_width + 2e-3,
                geo.wheel_length + 2 * m,
                depth + hr + 1e-3,
            )
        )
        imprints.append(
            occ.addRectangle(
                x - 0.5 * geo.wheel_width,
                y - 0.5 * geo.wheel_length,
                zt,
                geo.wheel_width,
                geo.wheel_length,
            )
        )
        if geo.flanges:  # the rail sides facing the flanges
            for _, s in flange_sides(x):
                imprints.append(
                    _rectangle_x(
                        x + s * 0.5 * geo.rail_width,
                        y - 0.5 * geo.wheel_length,
                        zt - geo.flange_depth,
                        geo.wheel_length,
                        geo.flange_depth,
                    )
                )
    tool = [(3, z) for z in zones] + [(2, r) for r in imprints]
    _, children = occ.fragment([(3, b) for b in bridge], tool)
    # Keep only the pieces of the bridge: the parts of the zone boxes outside it are air.
    keep = {dt for kids in children[: len(bridge)] for dt in kids if dt[0] == 3}
    air = [dt for dt in occ.getEntities(3) if dt not in keep]
    if air:
        occ.remove(air, recursive=True)
    # Trolley: frame plate on four wheel blocks (one glued body, apart from the bridge).
    frame_x0 = -0.5 * geo.girder_spacing - geo.frame_overhang
    frame = _box(
        frame_x0,
        geo.trolley_position - 0.5 * geo.frame_length,
        zt + geo.wheel_height,
        geo.girder_spacing + 2 * geo.frame_overhang,
        geo.frame_length,
        geo.frame_thickness,
    )
    if geo.flanges:
        flanged = [add_flanged_wheel(geo, x, y) for x, y in geo.wheel_centres()]
        wheels = [w for w, _ in flanged]
        flange_imprints = [(2, r) for _, rects in flanged for r in rects]
    else:
        wheels = [
            _box(
                x - 0.5 * geo.wheel_width,
                y - 0.5 * geo.wheel_length,
                zt,
                geo.wheel_width,
                geo.wheel_length,
                geo.wheel_height,
            )
            for x, y in geo.wheel_centres()
        ]
        flange_imprints = []
    occ.fragment([(3, frame)], [(3, w) for w in wheels] + flange_imprints)
    planes = geo.mirror_planes()
    _cut_to_region(geo, planes)
    occ.synchronize()

    def com(dim: int, tag: int) -> npt.NDArray[np.float64]:
        return np.array(occ.getCenterOfMass(dim, tag))

    eps = 1e-6
    centres = geo.wheel_centres()
    kept = [k for k, c in enumerate(centres) if _in_region(c, planes)]  # the others: images
    vol_groups: dict[str, list[int]] = {"bridge_implicit": [], "trolley_frame": []}
    for k in kept:
        vol_groups[f"zone_{k + 1}"] = []
        vol_groups[f"wheel_{k + 1}"] = []
    for _, tag in gmsh.model.getEntities(3):
        c = com(3, tag)
        if _is_trolley(geo, tag):  # a wheel (with its flanges: one volume) or the frame
            hit = [
                k
                for k, (x, y) in enumerate(centres)
                if abs(c[0] - x) < 0.5 * geo.wheel_width + eps
                and abs(c[1] - y) < 0.5 * geo.wheel_length + eps
                and c[2] < zt + geo.wheel_height
            ]
            vol_groups[f"wheel_{hit[0] + 1}" if hit else "trolley_frame"].append(tag)
            continue
        hit = [
            k
            for k, (x, y) in enumerate(centres)
            if abs(c[0] - x) < 0.5 * geo.girder_width + 2e-3
            and abs(c[1] - y) < 0.5 * geo.wheel_length + m + eps
            and c[2] > hc + hg - depth - eps
        ]
        vol_groups[f"zone_{hit[0] + 1}" if hit else "bridge_implicit"].append(tag)
    for name, tags in vol_groups.items():
        if not tags:
            raise RuntimeError(f"crane geometry: no volume classified as {name}")

    # Surfaces: clamped end faces, wheel bottoms and rail patches (coincident, distinct).
    wheel_tags = {t for k in kept for t in vol_groups[f"wheel_{k + 1}"]}
    on_wheels = {s for w in wheel_tags for _, s in gmsh.model.getBoundary([(3, w)], oriented=False)}
    surf_groups: dict[str, list[int]] = {
        "clamped": [
            t for _, t in gmsh.model.getEntities(2) if abs(abs(com(2, t)[0]) - half_l) < eps
        ]
    }
    for k in kept:
        x, y = centres[k]
        at = [
            t
            for _, t in gmsh.model.getEntitiesInBoundingBox(
                x - 0.5 * geo.wheel_width - eps,
                y - 0.5 * geo.wheel_length - eps,
                zt - eps,
                x + 0.5 * geo.wheel_width + eps,
                y + 0.5 * geo.wheel_length + eps,
                zt + eps,
                2,
            )
        ]
        wheel_face = [t for t in at if t in on_wheels]
        rail_face = [t for t in at if t not in wheel_face]
        if len(wheel_face) != 1 or len(rail_face) != 1:
            raise RuntimeError(f"crane geometry: contact patch {k + 1} not found")
        surf_groups[f"wheel_patch_{k + 1}"] = wheel_face
        surf_groups[f"rail_patch_{k + 1}"] = rail_face
        gmsh.model.mesh.setPeriodic(2, wheel_face, rail_face, IDENTITY)
        if geo.flanges:
            surf_groups |= _flange_patches(geo, k, on_wheels)

    # Graded sizes: fine within the zone boxes, coarse elsewhere.
    field = gmsh.model.mesh.field
    boxes = []
    for x, y in centres:
        b = field.add("Box")
        field.setNumber(b, "VIn", geo.fine)
        field.setNumber(b, "VOut", geo.size)
        half = 0.5 * geo.girder_width
        if geo.flanges:
            half = max(half, geo.flange_reach)
        field.setNumber(b, "XMin", x - half)
        field.setNumber(b, "XMax", x + half)
        field.setNumber(b, "YMin", y - 0.5 * geo.wheel_length - m)
        field.setNumber(b, "YMax", y + 0.5 * geo.wheel_length + m)
        field.setNumber(b, "ZMin", hc + hg - depth)
        field.setNumber(b, "ZMax", zt + geo.wheel_height)
        field.setNumber(b, "Thickness", m)
        boxes.append(b)
    if geo.trolley_size is not None:
        boxes.append(_plate_field(geo, zt))
    fmin = field.add("Min")
    field.setNumbers(fmin, "FieldsList", boxes)
    field.setAsBackgroundMesh(fmin)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
    # Netgen's optimiser removes the worst slivers: the explicit step is set by them
    # (measured on the quick crane: Δt_crit 8.0e-7 -> 1.2e-6 s).
    gmsh.option.setNumber("Mesh.OptimizeNetgen", 1)
    gmsh.model.mesh.generate(3)
    mirror_mesh(geo, planes, vol_groups, surf_groups)
    return mesh_info()
