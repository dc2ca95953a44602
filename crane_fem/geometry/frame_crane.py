"""The bi-girder overhead crane as a frame of Timoshenko beams (the paper's own crane model,
THEORY.md §10), drawn from the 3D mock-up's parameters, and its scene as a frame's.

Axes as the mock-up's: x along the runway (the end carriages), y along the span (the
girders), z up. Members, each a line group:

* ``end_carriage_1`` (y = w/2) and ``_2`` (y = span − w/2) along x at their mid-height,
  clamped at both ends (point groups ``support_1..4``: ends at y = w/2 first, x < 0 first);
* ``girder_1`` (x = −spacing/2) and ``girder_2`` along y at the girder's axis (with the default
  section, the centroid of the girder and its rail joined), each split into the explicit
  zones ``zone_k`` under wheel k (``zone_margin`` past the wheel either way, elements of
  ``fine``) and the rest (elements of ``size``); ``links``: vertical members from each
  girder's end down to its end carriage's axis;
* ``trolley``: a grillage in the frame plate's mid-plane (beams along y over each rail and
  across x at each wheel pair and at the trolley's centre), ``hook``: the two elements of the
  centre cross beam at the centre node, where the hoisted mass sits (``hoist = "rigid"``:
  the mass and a plate's rotary inertia) or hangs on ``rope`` (``hoist = "rope"``: a load
  node ``rope_length`` below, on a tension-only rope);
* ``wheel_k``: each wheel a vertical stub from the grillage down to the rail top, its foot
  (point group ``wheel_point_k``) a point-on-line contact on ``zone_k`` at the rail top's
  offset above the girder's axis, with the flanges' lateral rows (``flange_in_k`` towards the
  crane's centre plane x = 0, ``flange_out_k``) when ``flanges``.

The trolley grillage's members have the plate's thickness and a third of its length as width
(its bending in both directions), its density scaled so that the grillage weighs what the
plate does. With ``wheel_zones = "solid"`` and ``trolley_body = "solid"`` there is no
grillage, hook or stub: the plate is a solid glued to the wheel blocks (:func:`_solid_zones`).
"""

from __future__ import annotations

import copy
import hashlib
import itertools
import json
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mpi4py import MPI

from crane_fem.formulations import sections
from crane_fem.geometry.frame_sketch import FrameSketch

__all__ = [
    "FrameCraneLayout",
    "expand_frame_crane",
    "frame_crane_layout",
    "mesh_file",
    "write_frame_crane_mesh",
]


#: Changes with the drawing below, so that a mesh cached by an older one is not reused.
LAYOUT_VERSION = 6


@dataclass(frozen=True)
class FrameCraneLayout:
    """The frame crane's geometry: its sketch, its levels (m) and its default sections."""

    sketch: FrameSketch
    girder_axis: float
    rail_top: float
    trolley_level: float
    wheels: list[tuple[float, float]]
    girder: dict[str, Any]
    trolley_density_factor: float
    #: ``wheel_zones = "solid"``: the function adding the solid zones' meshes to the
    #: sketch's gmsh model (FrameSketch.write), else None.
    solids: Callable[[], None] | None = None


def _girder_with_rail(m: Any) -> tuple[dict[str, Any], float]:
    """The girder and its rail joined as one section (properties given directly), and the
    height of its centroid (m)."""
    hc, hg, hr = m.end_carriage_height, m.girder_height, m.rail_height
    g = sections.rectangle(m.girder_width, hg)
    r = sections.rectangle(m.rail_width, hr)
    zg, zr = hc + 0.5 * hg, hc + hg + 0.5 * hr
    A = g.A + r.A
    zc = (g.A * zg + r.A * zr) / A
    I1 = g.I1 + g.A * (zg - zc) ** 2 + r.I1 + r.A * (zr - zc) ** 2
    props = {
        "A": A,
        "I1": I1,
        "I2": g.I2 + r.I2,
        "J": g.J + r.J,
        "c1": 0.5 * m.girder_width,
        "c2": max(hc + hg + hr - zc, zc - hc),
    }
    return props, zc


def frame_crane_layout(m: Any) -> FrameCraneLayout:
    """The frame crane of the :class:`~crane_fem.scenario.frame_crane.FrameCraneModel`
    ``m`` (see the module docstring)."""
    hc, hg, hr = m.end_carriage_height, m.girder_height, m.rail_height
    rail_top = hc + hg + hr
    girder, zc = _girder_with_rail(m)
    axis = zc if m.girder is None else hc + 0.5 * hg
    ze = 0.5 * hc
    ys = (0.5 * m.end_carriage_width, m.span - 0.5 * m.end_carriage_width)
    xs = (-0.5 * m.girder_spacing, 0.5 * m.girder_spacing)
    half_ec = 0.5 * m.end_carriage_length
    s = FrameSketch()
    for k, y in enumerate(ys, start=1):
        s.member(f"end_carriage_{k}", (-half_ec, y, ze), (half_ec, y, ze), size=m.size)
    s.points("support_1", [(-half_ec, ys[0], ze)])
    s.points("support_2", [(half_ec, ys[0], ze)])
    s.points("support_3", [(-half_ec, ys[1], ze)])
    s.points("support_4", [(half_ec, ys[1], ze)])
    wheel_ys = (m.trolley_position - 0.5 * m.wheel_base, m.trolley_position + 0.5 * m.wheel_base)
    wheels = [(x, y) for x in xs for y in wheel_ys]
    reach = 0.5 * m.wheel_length + m.zone_margin
    solid = m.wheel_zones == "solid"
    # The solid zones: one segment of each girder (and its rail) under both its wheels, its
    # end faces ``solid_margin`` past the wheels (default a section depth: a joint disturbs
    # the stresses over about that, THEORY.md §11).
    depth = m.segment_margin
    seg = (wheel_ys[0] - 0.5 * m.wheel_length - depth, wheel_ys[1] + 0.5 * m.wheel_length + depth)
    for k, x in enumerate(xs, start=1):
        for y in ys:  # the links: girder end down to the end carriage
            s.member("links", (x, y, axis), (x, y, ze), size=m.size)
        if solid:
            s.member(f"girder_{k}", (x, ys[0], axis), (x, seg[0], axis), size=m.size)
            s.member(f"girder_{k}", (x, seg[1], axis), (x, ys[1], axis), size=m.size)
            s.points(f"joint_{k}_a", [(x, seg[0], axis)])
            s.points(f"joint_{k}_b", [(x, seg[1], axis)])
            continue
        cuts = [ys[0]]
        for y in wheel_ys:
            cuts += [y - reach, y + reach]
        cuts.append(ys[1])
        for j, (a, b) in enumerate(itertools.pairwise(cuts)):
            if j % 2:  # a zone: wheel 2(k − 1) + (j + 1)/2
                zone = 2 * (k - 1) + (j + 1) // 2
                s.member(f"zone_{zone}", (x, a, axis), (x, b, axis), size=m.fine)
            else:
                s.member(f"girder_{k}", (x, a, axis), (x, b, axis), size=m.size)
    level = rail_top + m.wheel_height + 0.5 * m.frame_thickness
    y0, y1 = m.trolley_position - 0.5 * m.frame_length, m.trolley_position + 0.5 * m.frame_length
    xw = 0.5 * m.girder_spacing + m.frame_overhang
    centre = (0.0, m.trolley_position, level)
    if m.trolley_body == "solid":  # the plate and the wheels: one solid body (_solid_zones)
        body = _solid_zones(m, xs, wheels, seg)
        return FrameCraneLayout(s, axis, rail_top, level, wheels, girder, 1.0, body)
    for x in xs:
        s.member("trolley", (x, y0, level), (x, y1, level), size=m.size)
    for y in wheel_ys:
        s.member("trolley", (-xw, y, level), (xw, y, level), size=m.size)
    s.member(
        "trolley", (-xw, m.trolley_position, level), (xs[0], m.trolley_position, level), size=m.size
    )
    s.member(
        "trolley", (xs[1], m.trolley_position, level), (xw, m.trolley_position, level), size=m.size
    )
    # The hook: the centre cross beam's two elements at the centre node.
    hook = min(m.size, 0.5 * m.girder_spacing)
    s.member(
        "trolley",
        (xs[0], m.trolley_position, level),
        (-hook, m.trolley_position, level),
        size=m.size,
    )
    s.member(
        "trolley",
        (hook, m.trolley_position, level),
        (xs[1], m.trolley_position, level),
        size=m.size,
    )
    s.member(
        "hook", (-hook, m.trolley_position, level), (hook, m.trolley_position, level), elements=2
    )
    s.points("trolley_centre", [centre])
    for k, (x, y) in enumerate(wheels, start=1):
        if solid:  # the stub from the wheel block's top face (a joint) up to the grillage
            s.member(f"stub_{k}", (x, y, rail_top + m.wheel_height), (x, y, level), elements=1)
            s.points(f"wheel_node_{k}", [(x, y, rail_top + m.wheel_height)])
            continue
        s.member(f"wheel_{k}", (x, y, rail_top), (x, y, level), elements=1)
        s.points(f"wheel_point_{k}", [(x, y, rail_top)])
    if m.hoist == "rope":
        load = (0.0, m.trolley_position, level - m.rope_length)
        s.member("rope", centre, load, elements=1)
        s.points("load", [load])
    plate = (2.0 * xw) * m.frame_length * m.frame_thickness
    width = m.frame_length / 3.0
    lengths = 2.0 * m.frame_length + 3.0 * (2.0 * xw)
    grillage = width * m.frame_thickness * lengths
    solids = _solid_zones(m, xs, wheels, seg) if solid else None
    return FrameCraneLayout(s, axis, rail_top, level, wheels, girder, plate / grillage, solids)


def _wheel_and_plate(
    m: Any, centre: tuple[float, float], plate: int | None
) -> tuple[int, int | None, list[tuple[str, int]]]:
    """The wheel at ``centre`` on its rail's axis (with its two flanges when ``m.flanges``,
    as the 3D mock-up's, crane_fem.geometry.crane_build.add_flanged_wheel, the flanges' faces
    below the rail top imprinted), glued to the trolley ``plate`` on its top when given
    (synchronised). Returns the wheel's volume, the plate's and, per side (``in``: facing
    x = 0), the flange's patch: its contact points."""
    import gmsh

    from crane_fem.geometry.crane_build import add_flanged_wheel, flange_sides

    occ = gmsh.model.occ
    x, y = centre
    top = m.rail_top + m.wheel_height
    if m.flanges:
        body, rects = add_flanged_wheel(m, x, y)
    else:
        wl, ww = m.wheel_length, m.wheel_width
        body = occ.addBox(x - 0.5 * ww, y - 0.5 * wl, m.rail_top, ww, wl, m.wheel_height)
        rects = []
    tools = [(2, r) for r in rects] + ([(3, plate)] if plate is not None else [])
    vols = [body]
    if tools:
        _, children = occ.fragment([(3, body)], tools)
        vols = [t for kids in (children[0], children[-1]) for d, t in kids if d == 3]
    occ.synchronize()
    above = sorted({t for t in vols if gmsh.model.getBoundingBox(3, t)[2] > top - 1e-6})
    below = sorted({t for t in vols if t not in above})
    if len(below) != 1 or len(above) != (plate is not None):
        raise RuntimeError("frame crane: a wheel and the trolley's plate not found")
    if not m.flanges:
        return below[0], (above[0] if above else None), []
    patches = []
    eps, y0, zt = 1e-6, y - 0.5 * m.wheel_length, m.rail_top
    for side, s in flange_sides(x):
        face = x + s * (0.5 * m.rail_width + m.flange_clearance)
        lo = (face - eps, y0 - eps, zt - m.flange_depth - eps)
        hi = (face + eps, y0 + m.wheel_length + eps, zt + eps)
        found = [t for _, t in gmsh.model.getEntitiesInBoundingBox(*lo, *hi, 2)]
        if len(found) != 1:
            raise RuntimeError(f"frame crane: the {side} flange's face of a wheel not found")
        patches.append((side, found[0]))
    return below[0], (above[0] if above else None), patches


def _solid_zones(
    m: Any, xs: tuple[float, float], wheels: list[tuple[float, float]], seg: tuple[float, float]
) -> Callable[[], None]:
    """The solid zones for FrameSketch.write: per girder k its segment [seg] with its rail
    (volume ``zone_k``; the rail in parts along y, the middle ones' top, ``rail_top_k``, the
    wheels' contact surface, off the end faces), its end faces ``zone_k_a``/``_b`` (girder
    and rail: the joints' faces); each wheel a block on the rail (``wheel_k``; faces
    ``wheel_bottom_k``, ``wheel_top_k``) or, with ``trolley_body = "solid"``, the four glued
    to the trolley's plate (``trolley_plate``; no ``wheel_top_k``). Elements of
    ``solid_size`` in the rails, the wheels and the plate, ``fine`` in the girders' webs.

    One quarter is meshed — girder 2's half segment on the wheel-3 side and wheel 3 — and
    reflected in the planes x = 0 and y = the trolley's centre into the four (the zones are
    symmetric in both whatever the trolley's position): the zones' meshes are mirror images,
    so a symmetric load loads the four wheels alike (an unstructured mesh of each would rock
    the trolley on its own, as the mock-up's would: crane_fem.geometry.crane_mirror)."""
    from crane_fem.geometry.crane_build import flange_sides
    from crane_fem.geometry.crane_mirror import meshed_region, reflect_region, snap_to_planes

    hc, hg, hr = m.end_carriage_height, m.girder_height, m.rail_height
    rail_top = hc + hg + hr
    y_lo = min(y for _, y in wheels) - 0.5 * m.wheel_length - m.zone_margin
    yc = 0.5 * (seg[0] + seg[1])
    x, (xw, yw) = xs[1], wheels[2]
    planes = [(0, 0.0), (1, yc)]

    def quarter() -> tuple[Any, dict[tuple[int, str], Any]]:
        """Mesh the quarter in its own gmsh model: its nodes and, per group, its simplices."""
        import gmsh

        occ = gmsh.model.occ
        girder = occ.addBox(x - 0.5 * m.girder_width, seg[0], hc, m.girder_width, yc - seg[0], hg)
        rails = [
            occ.addBox(x - 0.5 * m.rail_width, a, hc + hg, m.rail_width, b - a, hr)
            for a, b in itertools.pairwise((seg[0], y_lo, yc))
        ]
        pieces, _ = occ.fragment([(3, girder)], [(3, r) for r in rails])
        zone = [t for _, t in pieces]
        block_top = rail_top + m.wheel_height  # the wheel blocks' top: the plate's bottom
        plate = None
        if m.trolley_body == "solid":  # its quarter: x >= 0, y <= the trolley's centre
            y0 = m.trolley_position - 0.5 * m.frame_length
            width = 0.5 * m.girder_spacing + m.frame_overhang
            plate = occ.addBox(0.0, y0, block_top, width, yc - y0, m.frame_thickness)
        block, plate, patches = _wheel_and_plate(m, (xw, yw), plate)

        def faces(vols: list[int], axis: int, value: float, lo: float | None = None) -> list[int]:
            out = set()
            for v in vols:
                for d, t in gmsh.model.getBoundary([(3, v)], oriented=False):
                    b = gmsh.model.getBoundingBox(d, abs(t))
                    if abs(b[axis] - value) > 1e-6 or abs(b[axis + 3] - value) > 1e-6:
                        continue
                    if lo is not None and b[1] < lo - 1e-6:
                        continue
                    out.add(abs(t))
            return sorted(out)

        top = hc + hg - 1e-9
        plate_at = block_top - 1e-9
        plate_size = m.solid_size if m.trolley_size is None else m.trolley_size

        def size(dim: int, tag: int, px: float, py: float, pz: float, lc: float) -> float:
            if plate is not None and pz >= plate_at:
                return min(lc, plate_size)
            return min(lc, m.solid_size if pz >= top else m.fine)

        gmsh.model.mesh.setSizeCallback(size)
        gmsh.model.mesh.generate(3)
        groups = {
            (3, "zone_2"): zone,
            (2, "zone_2_a"): faces(zone, 1, seg[0]),
            (2, "rail_top_2"): faces(zone, 2, rail_top, y_lo),
            (3, "wheel_3"): [block],
            (2, "wheel_bottom_3"): faces([block], 2, rail_top),
        }
        if plate is None:  # the wheel's joint to the grillage's stub
            groups[2, "wheel_top_3"] = faces([block], 2, block_top)
        else:
            groups[3, "trolley_plate"] = [plate]
        for side, s in flange_sides(xw) if m.flanges else ():
            # The rail's side under the wheels (its middle part: the contact surface) and
            # the flange's face below the rail top (the contact points), ``clearance`` off.
            groups[2, f"rail_{side}_2"] = faces(zone, 0, x + s * 0.5 * m.rail_width, y_lo)
            groups[2, f"flange_face_{side}_3"] = [t for name, t in patches if name == side]
        return meshed_region(groups)

    def rename(name: str, copy: int) -> str:
        """The image's group: x = 0 swaps girder 2 (wheels 3, 4) for girder 1 (wheels 1, 2),
        the trolley's centre plane the wheel pair's two (3 ↔ 4, 1 ↔ 2) and the ends a ↔ b."""
        in_x, in_y = copy & 1, copy >> 1 & 1
        if name == "trolley_plate":  # one body across both planes
            return name
        if name.startswith("zone_2_a"):
            return f"zone_{2 - in_x}_{'b' if in_y else 'a'}"
        if name.startswith(("zone_", "rail_")):
            return f"{name[:-1]}{2 - in_x}"
        return f"{name[:-1]}{1 + 2 * (1 - in_x) + in_y}"

    def draw() -> None:
        import gmsh
        import numpy as np

        frame = gmsh.model.getCurrent()
        gmsh.model.add("zones")
        xyz, region = quarter()
        gmsh.model.remove()
        gmsh.model.setCurrent(frame)
        on_plane = snap_to_planes(xyz, planes)
        coords, groups = reflect_region(xyz, on_plane, planes, region, rename)
        node0 = int(gmsh.model.mesh.getMaxNodeTag())
        element = int(gmsh.model.mesh.getMaxElementTag()) + 1
        volumes = sorted(n for d, n in groups if d == 3)
        surfaces = sorted(n for d, n in groups if d == 2)
        entity = {(2, n): gmsh.model.addDiscreteEntity(2) for n in surfaces}
        # Each volume bounded by its named faces (zone_k: zone_k_a, _b, rail_top_k; wheel_k:
        # wheel_bottom_k, wheel_top_k): a reader keeping the volumes' closure keeps them.
        for v in volumes:
            stem, k = v.rsplit("_", 1)
            named = (
                ["zone_{k}_a", "zone_{k}_b", "rail_top_{k}", "rail_in_{k}", "rail_out_{k}"]
                if stem == "zone"
                else [
                    "wheel_bottom_{k}",
                    "wheel_top_{k}",
                    "flange_face_in_{k}",
                    "flange_face_out_{k}",
                ]
                if stem == "wheel"
                else []
            )
            faces = [f.format(k=k) for f in named if (2, f.format(k=k)) in entity]
            entity[3, v] = gmsh.model.addDiscreteEntity(3, -1, [entity[2, f] for f in faces])
        # Every node to the first volume (a node has one owner; the groups share them).
        first = entity[3, volumes[0]]
        ids = np.arange(coords.shape[0]) + node0 + 1
        gmsh.model.mesh.addNodes(3, first, ids.tolist(), coords.ravel().tolist())
        for (dim, name), ent in entity.items():
            conn = np.concatenate(groups[dim, name]) + node0 + 1
            etype = 4 if dim == 3 else 2
            tags = list(range(element, element + len(conn)))
            gmsh.model.mesh.addElementsByType(ent, etype, tags, conn.ravel().tolist())
            element += len(conn)
            gmsh.model.addPhysicalGroup(dim, [ent], name=name)

    return draw


def _section(
    given: Any, groups: list[str], orientation: list[float], default: dict[str, Any]
) -> dict[str, Any]:
    if given is not None:
        return dict(given.entry(groups, orientation))
    return {"groups": groups, "orientation": orientation, **default}


def _member_sections(
    m: Any, layout: FrameCraneLayout, girders: list[str], wheels: list[str] | None
) -> list[dict[str, Any]]:
    """The members' ``[[section]]`` entries: end carriages, ``girders`` and the links, and
    unless ``wheels`` is None (a solid trolley) the trolley grillage and hook and the wheel
    stubs ``wheels`` (those last two thin members with the model's ``rotary_scale``)."""
    sec = [
        _section(
            m.end_carriage,
            ["end_carriage_1", "end_carriage_2"],
            [0.0, 0.0, 1.0],
            {"shape": "rectangle", "b": m.end_carriage_width, "h": m.end_carriage_height},
        ),
        # a2 = z: I1 (about a1 = −x) is the girder's vertical bending.
        _section(m.girder, girders, [0.0, 0.0, 1.0], layout.girder),
        # The links (vertical) carry the girder's section, a1 = x as the girder's.
        _section(m.girder, ["links"], [0.0, 1.0, 0.0], layout.girder),
    ]
    if wheels is None:
        return sec
    sec += [
        _section(
            m.trolley,
            ["trolley", "hook"],
            [0.0, 0.0, 1.0],
            {"shape": "rectangle", "b": m.frame_length / 3.0, "h": m.frame_thickness},
        ),
        {
            "groups": wheels,
            "orientation": [1.0, 0.0, 0.0],
            "shape": "rectangle",
            "b": m.wheel_length,
            "h": m.wheel_width,
        },
    ]
    for member in sec[3:]:  # the trolley's and the wheels' thin members
        member["rotary_scale"] = m.rotary_scale
    return sec


def _weighed_trolley(
    mat: dict[str, Any], layout: FrameCraneLayout, others: list[str]
) -> list[dict[str, Any]]:
    """The one ``[material]`` as two entries: ``others``, and the trolley grillage (and hook)
    with its density scaled so that the grillage weighs what the plate does."""
    structure = {k: v for k, v in mat.items() if k != "groups"}
    trolley = dict(structure, rho=structure["rho"] * layout.trolley_density_factor)
    return [dict(structure, groups=others), dict(trolley, groups=["trolley", "hook"])]


def _hoisted_on_trolley(m: Any) -> dict[str, Any]:
    """The hoisted mass rigidly at the trolley's centre, with a plate's rotary inertia."""
    w = m.girder_spacing + 2.0 * m.frame_overhang
    L, t, mass = m.frame_length, m.frame_thickness, m.hoisted_mass
    inertia = [mass * (L**2 + t**2) / 12, mass * (w**2 + t**2) / 12, mass * (w**2 + L**2) / 12]
    return {"group": "trolley_centre", "mass": mass, "inertia": inertia}


def expand_frame_crane(data: dict[str, Any], m: Any, mesh_path: Path) -> dict[str, Any]:
    """The frame crane scene ``data`` (a scenario mapping with ``model.kind =
    "frame_crane"``, model ``m``) as a frame's: its mesh ``mesh_path`` (written already),
    sections, materials, supports, masses, contacts (its ``[wheel]`` friction), rope."""
    layout = frame_crane_layout(m)
    if m.wheel_zones == "solid":
        return _expand_solid_zones(data, m, mesh_path, layout)
    out = copy.deepcopy(data)
    out["model"] = {"kind": "frame", "mesh": str(mesh_path)}
    wheel = out.pop("wheel", {}) or {}
    mat = data["material"]
    girders = ["girder_1", "girder_2", *(f"zone_{k}" for k in range(1, 5))]
    wheels = [f"wheel_{k}" for k in range(1, 5)]
    out["section"] = _member_sections(m, layout, girders, wheels)
    if m.trolley is None and isinstance(mat, dict):
        others = ["end_carriage_1", "end_carriage_2", "links", *girders, *wheels]
        out["material"] = _weighed_trolley(mat, layout, others)
    out["support"] = [{"group": f"support_{k}"} for k in range(1, 5)]
    masses = []
    if m.hoisted_mass > 0.0:
        if m.hoist == "rigid":
            masses.append(_hoisted_on_trolley(m))
        else:
            masses.append({"group": "load", "mass": m.hoisted_mass})
            out["rope"] = [
                {
                    "line": "rope",
                    "length": m.rope_length,
                    "stiffness": m.rope_stiffness,
                    "name": "rope",
                }
            ]
    if masses:
        out["mass"] = masses
    friction = float(wheel.get("friction", 0.0))
    braked = bool(wheel.get("braked", True))
    contacts = []
    for k, (x, _) in enumerate(layout.wheels, start=1):
        entry: dict[str, Any] = {
            "type": "point-on-line",
            "points": f"wheel_point_{k}",
            "line": f"zone_{k}",
            "offset": layout.rail_top - layout.girder_axis,
            "normal": [0.0, 0.0, 1.0],
            "friction": friction,
            "name": f"wheel_{k}",
        }
        if friction > 0.0 and not braked:
            entry["rolling"] = True
        if m.flanges:
            entry["clearance"] = m.flange_clearance
            # The lateral rows: the −l side's first, l = n × t = −x along the girders (+y):
            # towards x = 0 for girder 1 (x < 0), away from it for girder 2.
            pair = [f"flange_in_{k}", f"flange_out_{k}"]
            entry["flange_names"] = pair if x < 0.0 else pair[::-1]
        contacts.append(entry)
    out["contact"] = contacts
    return out


def _expand_solid_zones(
    data: dict[str, Any], m: Any, mesh_path: Path, layout: FrameCraneLayout
) -> dict[str, Any]:
    """The frame crane with solid wheel zones as a mixed gmsh model's scene: the beams'
    sections and materials, the supports, the hoisted mass, the joints (each girder's
    segment at both ends, each wheel block at its stub's foot), the wheels' node-to-surface
    contacts on their rails' tops (its ``[wheel]`` friction; unbraked wheels roll along the
    rails, y: their friction across them only; their slip reported along y and across, x),
    and, unless given, the solids explicit and
    the beams implicit."""
    out = copy.deepcopy(data)
    out["model"] = {"kind": "gmsh", "mesh": str(mesh_path)}
    wheel = out.pop("wheel", {}) or {}
    friction = float(wheel.get("friction", 0.0))
    rolling = friction > 0.0 and not bool(wheel.get("braked", True))
    girders = ["girder_1", "girder_2"]
    volumes = ["zone_1", "zone_2", *(f"wheel_{k}" for k in range(1, 5))]
    out["joint"] = [
        {"face": f"zone_{k}_{e}", "node": f"joint_{k}_{e}", "name": f"girder_{k}_{e}"}
        for k in (1, 2)
        for e in ("a", "b")
    ]
    out["support"] = [{"group": f"support_{k}"} for k in range(1, 5)]
    mat = data["material"]
    if m.trolley_body == "solid":  # the plate carries the hoisted mass, as the mock-up's
        lines = ["end_carriage_1", "end_carriage_2", "links", *girders]
        volumes.append("trolley_plate")
        out["section"] = _member_sections(m, layout, girders, None)
        if m.hoisted_mass > 0.0:
            out["mass"] = [{"group": "trolley_plate", "mass": m.hoisted_mass}]
    else:
        stubs = [f"stub_{k}" for k in range(1, 5)]
        lines = ["end_carriage_1", "end_carriage_2", "links", *girders, "trolley", "hook"]
        lines += stubs
        out["section"] = _member_sections(m, layout, girders, stubs)
        if m.trolley is None and isinstance(mat, dict):
            others = [g for g in lines + volumes if g not in ("trolley", "hook")]
            out["material"] = _weighed_trolley(mat, layout, others)
        if m.hoisted_mass > 0.0:
            out["mass"] = [_hoisted_on_trolley(m)]
        out["joint"] += [{"face": f"wheel_top_{k}", "node": f"wheel_node_{k}"} for k in range(1, 5)]
    out["contact"] = [
        {
            "type": "surface",
            "points": f"wheel_bottom_{k}",
            "surface": f"rail_top_{1 if k <= 2 else 2}",
            "friction": friction,
            "name": f"wheel_{k}",
            "along": [0.0, 1.0, 0.0],  # the rails': the wheels' slip along and across them
            **({"rolling": [0.0, 1.0, 0.0]} if rolling else {}),
        }
        for k in range(1, 5)
    ]
    if m.flanges:  # frictionless, as the mock-up's and the frame's
        out["contact"] += [
            {
                "type": "surface",
                "points": f"flange_face_{side}_{k}",
                "surface": f"rail_{side}_{1 if k <= 2 else 2}",
                "name": f"flange_{side}_{k}",
            }
            for k in range(1, 5)
            for side in ("in", "out")
        ]
    if not out.get("subdomain"):
        out["subdomain"] = [
            {"name": "wheel_zones", "groups": volumes, "scheme": "cd-lagrange"},
            {"name": "beams", "groups": lines, "scheme": "newmark"},
        ]
    return out


def mesh_file(m: Any) -> Path:
    """Where the frame crane of the model ``m`` is meshed: a file named by the hash of its
    geometry, in the system's temporary directory (the same on every rank)."""
    keys = m.model_dump(exclude={"hoisted_mass", "girder", "end_carriage", "trolley"})
    keys["layout"] = LAYOUT_VERSION
    digest = hashlib.sha256(json.dumps(keys, sort_keys=True).encode()).hexdigest()[:16]
    return Path(tempfile.gettempdir()) / "crane_fem_frames" / f"frame_crane_{digest}.msh"


def write_frame_crane_mesh(m: Any, comm: MPI.Comm) -> Path:
    """Mesh the frame crane on rank 0 (unless its file exists) and return the file's path
    (collective)."""
    path = mesh_file(m)
    error = None
    if comm.rank == 0 and not path.is_file():
        try:
            tmp = path.with_suffix(f".{id(m)}.msh")
            layout = frame_crane_layout(m)
            layout.sketch.write(tmp, layout.solids)
            tmp.replace(path)
        except Exception as exc:  # gmsh raises bare Exception
            error = f"model: the frame crane could not be meshed: {exc}"
    error = comm.bcast(error, root=0)
    if error is not None:
        from crane_fem.errors import ScenarioError

        raise ScenarioError(error)
    return path
