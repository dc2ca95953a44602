"""Bi-girder overhead-crane mock-up (gmsh OpenCASCADE): bridge, rails, trolley on four wheels.

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
made so too: gmsh meshes the region x ≥ 0 (y ≤ span/2), which :func:`_mirror_mesh` reflects
into the whole crane. An unstructured mesh of the whole crane breaks the symmetry by itself:
its preload spread the trolley weight 1360–1494 N over the wheels in a diagonal pattern, and a
vertical shake rocked and pitched the trolley (10 % of the wheel response), from the mesh alone.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import NamedTuple

import dolfinx.io.gmsh
import dolfinx.mesh
import gmsh
import numpy as np
import numpy.typing as npt
from mpi4py import MPI

from crane_fem.errors import ScenarioError
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


@dataclass(frozen=True)
class CraneGeometry:
    """Dimensions in metres; ``size`` is the coarse element size, ``fine`` the one at contacts."""

    span: float = 4.0
    girder_spacing: float = 1.0
    girder_width: float = 0.12
    girder_height: float = 0.20
    end_carriage_length: float = 1.6
    end_carriage_width: float = 0.15
    end_carriage_height: float = 0.15
    rail_width: float = 0.05
    rail_height: float = 0.04
    trolley_position: float = 2.0
    wheel_base: float = 0.6
    wheel_width: float = 0.05
    wheel_length: float = 0.08
    wheel_height: float = 0.06
    frame_overhang: float = 0.10
    frame_length: float = 0.8
    frame_thickness: float = 0.05
    zone_margin: float = 0.06
    zone_depth: float = 0.0
    size: float = 0.12
    fine: float = 0.04
    flanges: bool = False
    flange_clearance: float = 0.005
    flange_depth: float = 0.02
    flange_thickness: float = 0.02

    def validate(self) -> None:
        """Raise ScenarioError naming the first parameter out of range (before any meshing)."""
        signed = ("trolley_position", "zone_depth", "flanges", "flange_clearance")
        positive = [k for k, v in self.__dict__.items() if k not in signed and v <= 0]
        if positive:
            raise ScenarioError(
                f"geometry.{positive[0]} must be > 0, got {getattr(self, positive[0])}"
            )
        if self.wheel_width > self.rail_width:
            raise ScenarioError(
                f"geometry.wheel_width = {self.wheel_width} is wider than the rail "
                f"(geometry.rail_width = {self.rail_width})"
            )
        if self.rail_width > self.girder_width:
            raise ScenarioError("geometry.rail_width must not exceed geometry.girder_width")
        half = 0.5 * max(self.wheel_base + self.wheel_length, self.frame_length)
        if not half <= self.trolley_position <= self.span - half:
            raise ScenarioError(
                f"geometry.trolley_position = {self.trolley_position} puts the trolley off the "
                f"girders (allowed: [{half:g}, {self.span - half:g}] for span {self.span})"
            )
        if self.end_carriage_length < self.girder_spacing + self.girder_width:
            raise ScenarioError("geometry.end_carriage_length must span both girders")
        if self.girder_spacing <= self.girder_width:
            raise ScenarioError("geometry.girder_spacing must exceed geometry.girder_width")
        if not 0.0 <= self.zone_depth < self.girder_height:
            raise ScenarioError(
                f"geometry.zone_depth = {self.zone_depth} must lie in [0, girder_height = "
                f"{self.girder_height})"
            )
        if self.fine > self.size:
            raise ScenarioError("geometry.fine must not exceed geometry.size")
        if self.flange_clearance < 0.0:
            raise ScenarioError(
                f"geometry.flange_clearance = {self.flange_clearance} must be >= 0 (the lateral "
                "gap between a flange and the rail side)"
            )
        if self.flanges:
            self._validate_flanges()

    def _validate_flanges(self) -> None:
        if not self.flange_depth < self.rail_height:
            raise ScenarioError(
                f"geometry.flange_depth = {self.flange_depth} must be < geometry.rail_height = "
                f"{self.rail_height} (the flanges would reach the girder top)"
            )
        if not self.flange_reach < 0.5 * self.girder_spacing:
            raise ScenarioError(
                f"geometry.flange_thickness = {self.flange_thickness}: the inner flanges reach "
                f"{self.flange_reach:g} from their rail's axis (rail_width/2 + flange_clearance + "
                f"flange_thickness), past the crane's centre plane x = 0 "
                f"(girder_spacing/2 = {0.5 * self.girder_spacing:g})"
            )

    @property
    def rail_top(self) -> float:
        return self.end_carriage_height + self.girder_height + self.rail_height

    @property
    def flange_reach(self) -> float:
        """Distance from a rail's axis to the outer face of its wheel's flanges (m)."""
        return 0.5 * self.rail_width + self.flange_clearance + self.flange_thickness

    def mirror_planes(self) -> list[tuple[int, float]]:
        """(axis, coordinate) of the planes of symmetry the mesh is mirrored in: x = 0 always
        (the girders and the trolley are centred on it), y = span/2 with the trolley there."""
        planes = [(0, 0.0)]
        if abs(self.trolley_position - 0.5 * self.span) <= 1e-12 * self.span:
            planes.append((1, 0.5 * self.span))
        return planes

    def wheel_centres(self) -> list[tuple[float, float]]:
        """(x, y) of wheels 1–4: girder 1 (x < 0) rear/front, then girder 2."""
        xs = (-0.5 * self.girder_spacing, 0.5 * self.girder_spacing)
        ys = (
            self.trolley_position - 0.5 * self.wheel_base,
            self.trolley_position + 0.5 * self.wheel_base,
        )
        return [(x, y) for x in xs for y in ys]


class FlangePairs(NamedTuple):
    """The node pairs of one flange and the rail side facing it (gmsh node tags, sorted by the
    flange node's tag). ``normal_x`` (±1) is the x component of the unit normal pointing from
    the rail towards the flange (the rail side's outward normal); ``gap`` (m) is each pair's
    initial gap, (x_flange − x_rail)·normal_x: the clearance, to round-off."""

    wheel: int
    inner: bool
    flange_nodes: npt.NDArray[np.int64]
    rail_nodes: npt.NDArray[np.int64]
    normal_x: float
    gap: npt.NDArray[np.float64]


@dataclass
class CraneMeshInfo:
    """Names of the physical groups, the wheel/rail node pairs and, with flanges, the
    flange/rail-side node pairs (gmsh node tags)."""

    volume_groups: dict[str, int]
    surface_groups: dict[str, int]
    contact_pairs: list[tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]]
    flange_pairs: list[FlangePairs] = field(default_factory=list)


def _box(x0: float, y0: float, z0: float, dx: float, dy: float, dz: float) -> int:
    return gmsh.model.occ.addBox(x0, y0, z0, dx, dy, dz)


_IDENTITY = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]
# Order of the physical groups (and so their tags, from 1): volumes, then surfaces.
_VOLUME_NAMES = ["bridge_implicit", "trolley_frame"] + [
    f"{p}_{k}" for k in range(1, 5) for p in ("zone", "wheel")
]
_SURFACE_NAMES = ["clamped"] + [f"{p}_patch_{k}" for p in ("wheel", "rail") for k in range(1, 5)]
#: The surface groups of a crane with flanges (after those of every crane): the inner faces of
#: the flanges below the rail top, ``flange_patch_{in,out}_k``, and the rail side patches facing
#: them, ``rail_side_patch_{in,out}_k``. ``in``: the flange between the rail and the crane's
#: centre plane x = 0 (a mirror image of an inner flange is an inner flange); the wheel number
#: last, as in every group of a wheel.
FLANGE_SURFACE_NAMES = [
    f"{p}_{side}_{k}"
    for p in ("flange_patch", "rail_side_patch")
    for side in ("in", "out")
    for k in range(1, 5)
]


def _surface_names(geo: CraneGeometry) -> list[str]:
    return _SURFACE_NAMES + (FLANGE_SURFACE_NAMES if geo.flanges else [])


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


def _flange_sides(x: float) -> list[tuple[str, float]]:
    """(name, s) of the flanges of the wheel on the rail at x: s = ±1 is the side of the rail
    (the x direction from the rail to the flange); the inner flange faces x = 0."""
    towards_centre = -1.0 if x > 0.0 else 1.0
    return [("in", towards_centre), ("out", -towards_centre)]


def _add_flanged_wheel(geo: CraneGeometry, x: float, y: float) -> tuple[int, list[int]]:
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
    for _, s in _flange_sides(x):
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


def _mirror_mesh(
    geo: CraneGeometry,
    planes: list[tuple[int, float]],
    vol_groups: dict[str, list[int]],
    surf_groups: dict[str, list[int]],
) -> None:
    """Replace the current gmsh model (the meshed region) by the whole crane: the region and its
    mirror images in ``planes``, as discrete entities, one per physical group.

    A node on a mirror plane is its own image there, so the images conform along the planes;
    the scene's symmetric response is then the mesh's too (an unstructured mesh of the whole
    crane rocks and pitches the trolley on its own under a vertical load). The wheel/rail
    patches keep their periodic (node-to-node) correspondence.
    """
    tags, xyz, _ = gmsh.model.mesh.getNodes()
    tags = tags.astype(np.int64)
    xyz = xyz.reshape(-1, 3).copy()
    index = np.zeros(int(tags.max()) + 1, dtype=np.int64)
    index[tags] = np.arange(tags.size)
    on_plane = np.zeros(tags.size, dtype=np.int64)  # bit b: the node lies on plane b
    for b, (axis, c) in enumerate(planes):
        hit = np.abs(xyz[:, axis] - c) < 1e-10 * (1.0 + abs(c))
        xyz[hit, axis] = c
        on_plane[hit] |= 1 << b

    def cells(dim: int, entities: list[int]) -> npt.NDArray[np.int64]:
        etype, nper = (4, 4) if dim == 3 else (2, 3)
        conn = [gmsh.model.mesh.getElementsByType(etype, e)[1] for e in entities]
        return index[np.concatenate(conn).astype(np.int64)].reshape(-1, nper)

    region = {(3, n): cells(3, e) for n, e in vol_groups.items()}
    region |= {(2, n): cells(2, e) for n, e in surf_groups.items()}
    centres = geo.wheel_centres()

    def reflect(p: npt.NDArray[np.float64], copy: int) -> npt.NDArray[np.float64]:
        q = p.copy()
        for b, (axis, c) in enumerate(planes):
            if copy >> b & 1:
                q[..., axis] = 2.0 * c - q[..., axis]
        return q + 0.0  # no negative zeros

    def rename(name: str, copy: int) -> str:
        stem, _, k = name.rpartition("_")
        if not k.isdigit():
            return name
        image = reflect(np.array([*centres[int(k) - 1], 0.0]), copy)[:2]
        (hit,) = [j for j, c in enumerate(centres) if np.allclose(c, image, atol=1e-9)]
        return f"{stem}_{hit + 1}"

    # Node (i, copy) is node (i, copy without the planes i lies on): one new node per pair.
    n_copies = 1 << len(planes)
    keys = np.concatenate(
        [np.arange(tags.size) * n_copies + (c & ~on_plane) for c in range(n_copies)]
    )
    uniq, first, new = np.unique(keys, return_index=True, return_inverse=True)
    new = new.reshape(n_copies, tags.size)
    coords = np.concatenate([reflect(xyz, c) for c in range(n_copies)])[first]
    groups: dict[tuple[int, str], list[npt.NDArray[np.int64]]] = {}
    for c in range(n_copies):
        flip = c.bit_count() % 2 == 1  # a reflection turns the elements inside out
        for (dim, name), conn in region.items():
            img = new[c][conn]
            if flip:
                img[:, [1, 2]] = img[:, [2, 1]]
            groups.setdefault((dim, rename(name, c)), []).append(img)

    gmsh.model.remove()
    gmsh.model.add("crane")
    entity: dict[tuple[int, str], int] = {}
    for dim, names in ((3, _VOLUME_NAMES), (2, _surface_names(geo))):
        for tag, name in enumerate(names, start=1):
            if (dim, name) not in groups:
                raise RuntimeError(f"crane geometry: no mesh for the group {name}")
            entity[dim, name] = gmsh.model.addDiscreteEntity(dim, tag)
    # The wheel/rail patch nodes belong to their patch surfaces (gmsh pairs them through
    # these entities: it pairs the nodes an entity owns, and a node has one owner); every
    # other node, the flange patches' too (paired by coordinates, mesh_info), to the first
    # volume.
    owner = np.zeros(uniq.size, dtype=np.int64)
    for (dim, name), ent in entity.items():
        if dim == 2 and name in _SURFACE_NAMES and "patch" in name:
            owner[np.concatenate(groups[dim, name]).ravel()] = ent
    for ent in np.unique(owner):
        nodes = np.flatnonzero(owner == ent)
        dim, tag = (3, 1) if ent == 0 else (2, int(ent))
        gmsh.model.mesh.addNodes(dim, tag, (nodes + 1).tolist(), coords[nodes].ravel().tolist())
    next_element = 1
    for (dim, name), ent in entity.items():
        conn = np.concatenate(groups[dim, name])
        gmsh.model.mesh.addElementsByType(
            ent,
            4 if dim == 3 else 2,
            list(range(next_element, next_element + len(conn))),
            (conn.ravel() + 1).tolist(),
        )
        next_element += len(conn)
        gmsh.model.addPhysicalGroup(dim, [ent], ent, name)
    for k in range(1, 5):
        gmsh.model.mesh.setPeriodic(
            2, [entity[2, f"wheel_patch_{k}"]], [entity[2, f"rail_patch_{k}"]], _IDENTITY
        )


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

    for side, s in _flange_sides(x):
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


def build_crane_model(geo: CraneGeometry) -> CraneMeshInfo:
    """Build and mesh the crane in the current gmsh session (rank 0 only; gmsh initialised).

    Physical volume groups: ``bridge_implicit``, ``zone_1..4`` (rail + girder near each wheel),
    ``trolley_frame``, ``wheel_1..4`` (with its flanges). Surface groups: ``clamped``
    (end-carriage end faces), ``wheel_patch_k``, ``rail_patch_k`` and, with flanges,
    :data:`FLANGE_SURFACE_NAMES`.
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
            for _, s in _flange_sides(x):
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
        flanged = [_add_flanged_wheel(geo, x, y) for x, y in geo.wheel_centres()]
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
        gmsh.model.mesh.setPeriodic(2, wheel_face, rail_face, _IDENTITY)
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
    _mirror_mesh(geo, planes, vol_groups, surf_groups)
    return mesh_info()


def mesh_info() -> CraneMeshInfo:
    """Groups, wheel/rail node pairs and flange/rail-side node pairs (none without flanges) of
    the crane mesh in the current gmsh model (built by :func:`build_crane_model` or read from a
    ``.msh`` file: the physical names, the wheel/rail periodic node correspondence and the
    flange patches' coordinates are stored in it)."""
    names = {
        (dim, tag): gmsh.model.getPhysicalName(dim, tag)
        for dim, tag in gmsh.model.getPhysicalGroups()
    }
    volume_groups = {n: t for (d, t), n in names.items() if d == 3}
    surface_groups = {n: t for (d, t), n in names.items() if d == 2}
    for dim, wanted, have in (
        (3, _VOLUME_NAMES, volume_groups),
        (2, _SURFACE_NAMES, surface_groups),
    ):
        missing = [n for n in wanted if n not in have]
        if missing:
            kind = "volume" if dim == 3 else "surface"
            raise ScenarioError(
                f"not a crane mesh: no {kind} group {missing[0]!r} (a crane mesh has "
                f"{', '.join(wanted)}; write one with crane-fem mesh)"
            )
    contact_pairs = []
    for k in range(1, 5):
        name = f"wheel_patch_{k}"
        if name not in surface_groups:
            raise ScenarioError(f"crane mesh: no surface group {name!r}")
        (face,) = gmsh.model.getEntitiesForPhysicalGroup(2, surface_groups[name])
        _, nodes, master_nodes, _ = gmsh.model.mesh.getPeriodicNodes(
            2, int(face), includeHighOrderNodes=False
        )
        if len(nodes) == 0:
            raise ScenarioError(f"crane mesh: {name} has no periodic (paired) nodes")
        # gmsh lists the correspondence in no fixed order (it varies between runs): sort by
        # the wheel node's tag, so pair k is the same node pair in every run.
        wheel_nodes = np.asarray(nodes, dtype=np.int64)
        order = np.argsort(wheel_nodes, kind="stable")
        contact_pairs.append((wheel_nodes[order], np.asarray(master_nodes, dtype=np.int64)[order]))
    flange_pairs = _flange_pairs(surface_groups)
    return CraneMeshInfo(volume_groups, surface_groups, contact_pairs, flange_pairs)


def _group_nodes(
    surface_groups: dict[str, int], name: str
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64]]:
    """Tags and coordinates of the nodes of a physical surface group of the current model."""
    tags, xyz = gmsh.model.mesh.getNodesForPhysicalGroup(2, surface_groups[name])
    return np.asarray(tags, dtype=np.int64), np.asarray(xyz, dtype=np.float64).reshape(-1, 3)


def _flange_pairs(surface_groups: dict[str, int]) -> list[FlangePairs]:
    """The flange/rail-side node pairs of the current model (none without flange groups).

    Each flange patch is a copy of the rail side patch facing it translated in x (the periodic
    constraint it was meshed with); its nodes are paired with the rail's by that translation,
    one to one, to round-off. (gmsh's own correspondence cannot serve here: it pairs the nodes
    an entity owns, and the rail side patch shares its top row with the rail top patch when
    the wheel is as wide as the rail.)

    Raises:
        ScenarioError: some flange groups but not all, or patches that are not translated
            copies of each other on the right sides of their rail.
    """
    have = [n for n in FLANGE_SURFACE_NAMES if n in surface_groups]
    if not have:
        return []
    missing = [n for n in FLANGE_SURFACE_NAMES if n not in surface_groups]
    if missing:
        raise ScenarioError(f"crane mesh: flange groups without the surface group {missing[0]!r}")
    out = []
    for k in range(1, 5):
        _, wheel_xyz = _group_nodes(surface_groups, f"wheel_patch_{k}")
        axis = 0.5 * (wheel_xyz[:, 0].min() + wheel_xyz[:, 0].max())  # the rail's axis
        for side in ("in", "out"):
            f_tags, f_xyz = _group_nodes(surface_groups, f"flange_patch_{side}_{k}")
            r_tags, r_xyz = _group_nodes(surface_groups, f"rail_side_patch_{side}_{k}")
            tol = 1e-9 * (1.0 + np.abs(r_xyz).max())
            where = f"crane mesh: flange patch {side} of wheel {k}"
            if np.ptp(f_xyz[:, 0]) > tol or np.ptp(r_xyz[:, 0]) > tol:
                raise ScenarioError(f"{where} or its rail side is not a plane x = const")
            normal_x = 1.0 if r_xyz[0, 0] > axis else -1.0  # the rail side's outward normal
            if (normal_x * axis < 0.0) != (side == "in"):
                raise ScenarioError(f"{where} is on the other side of its rail")
            # Match (y, z): the translation is along x.
            dist = np.abs(f_xyz[:, None, 1:] - r_xyz[None, :, 1:]).max(axis=2)
            match = np.argmin(dist, axis=1)
            if (
                f_tags.size != r_tags.size
                or np.any(dist[np.arange(f_tags.size), match] > tol)
                or np.unique(match).size != match.size
            ):
                raise ScenarioError(f"{where} is not a translated copy of its rail side patch")
            gap = normal_x * (f_xyz[:, 0] - r_xyz[match, 0])
            if np.any(gap < -tol):
                raise ScenarioError(f"{where} lies inside its rail")
            order = np.argsort(f_tags, kind="stable")
            out.append(
                FlangePairs(
                    k, side == "in", f_tags[order], r_tags[match][order], normal_x, gap[order]
                )
            )
    return out


#: The geometry keys of the flanges, which sidecars written before them do not record.
_FLANGE_KEYS = ("flanges", "flange_clearance", "flange_depth", "flange_thickness")


def mesh_sidecar(path: str | Path) -> Path:
    """The file beside a crane mesh that records the geometry it was made from:
    ``meshes/crane.msh`` -> ``meshes/crane.json``."""
    return Path(path).with_suffix(".json")


def read_mesh_sidecar(path: str | Path) -> dict[str, float] | None:
    """The geometry (every :class:`CraneGeometry` field; ``flanges`` a bool) a crane mesh was
    written from, read from its sidecar (:func:`mesh_sidecar`), or None if it has none (not
    collective). A sidecar written before the flanges existed records none: their keys take
    their defaults (flanges off).

    Raises:
        ScenarioError: the sidecar is not one written by :func:`write_crane_mesh`.
    """
    side = mesh_sidecar(path)
    if not side.is_file():
        return None
    defaults = asdict(CraneGeometry())
    values: dict[str, float] = {}
    try:
        geometry = json.loads(side.read_text(encoding="utf-8"))["geometry"]
        for f in fields(CraneGeometry):
            if f.name in _FLANGE_KEYS:
                value = geometry.get(f.name, defaults[f.name])
            else:
                value = geometry[f.name]
            if isinstance(defaults[f.name], bool):
                if not isinstance(value, bool):
                    raise TypeError(f"{f.name} = {value!r} is not true or false")
                values[f.name] = value
            else:
                values[f.name] = float(value)
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise ScenarioError(
            f"model.mesh: {side} is not the geometry record crane-fem mesh writes ({exc!r}); "
            "write the mesh again with crane-fem mesh"
        ) from None
    return values


def write_crane_mesh(geo: CraneGeometry, path: str | Path) -> str:
    """Mesh the crane and write it as a gmsh 4.1 ``.msh`` file, with the geometry it was made
    from in its sidecar ``.json`` (:func:`mesh_sidecar`; not collective: one process).

    gmsh meshes deterministically (one thread), so the same parameters give the same file.
    Returns a one-line description (nodes, tetrahedra, contact pairs).
    """
    geo.validate()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("General.NumThreads", 1)
        gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
        gmsh.option.setNumber("Mesh.Binary", 0)
        gmsh.option.setNumber("Mesh.SaveAll", 0)
        gmsh.model.add("crane")
        info = build_crane_model(geo)
        gmsh.write(str(path))
        n_nodes = len(gmsh.model.mesh.getNodes()[0])
        n_tets = len(gmsh.model.mesh.getElementsByType(4)[0])
    finally:
        gmsh.finalize()
    n_pairs = sum(w.size for w, _ in info.contact_pairs)
    n_flange = sum(fp.flange_nodes.size for fp in info.flange_pairs)
    record = {
        "written_by": "crane-fem mesh",
        "mesh": path.name,
        "geometry": asdict(geo),
        "nodes": n_nodes,
        "tetrahedra": n_tets,
        "wheel_rail_pairs": n_pairs,
        "flange_rail_pairs": n_flange,
    }
    mesh_sidecar(path).write_text(json.dumps(record, indent=2) + "\n", encoding="utf-8")
    flange = f", {n_flange} flange/rail-side node pairs" if geo.flanges else ""
    return f"{n_nodes} nodes, {n_tets} tetrahedra, {n_pairs} wheel/rail node pairs{flange}"


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
    error = comm.bcast(error, root=0)
    if error is not None:
        if comm.rank == 0:
            gmsh.finalize()
        raise ScenarioError(error)
    partitioner = dolfinx.mesh.create_cell_partitioner(  # type: ignore[call-arg]
        dolfinx.mesh.GhostMode.shared_facet, 2
    )
    data = dolfinx.io.gmsh.model_to_mesh(gmsh.model, comm, 0, gdim=3, partitioner=partitioner)
    if comm.rank == 0:
        gmsh.finalize()
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
