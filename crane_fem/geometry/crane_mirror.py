"""The crane's meshed region reflected in its planes of symmetry into the whole crane.

The scene is symmetric in x = 0 and, with the trolley at mid-span, in y = span/2; the mesh is
made so too: gmsh meshes the region x ≥ 0 (y ≤ span/2), which :func:`mirror_mesh` reflects
into the whole crane.
"""

from __future__ import annotations

from collections.abc import Callable

import gmsh
import numpy as np
import numpy.typing as npt

from crane_fem.geometry.crane_parameters import CraneGeometry
from crane_fem.geometry.groups import CRANE_FLANGE_SURFACES, CRANE_SURFACES, CRANE_VOLUMES

__all__ = [
    "IDENTITY",
    "meshed_region",
    "mirror_mesh",
    "reflect",
    "reflect_region",
    "snap_to_planes",
]

#: The 4×4 affine identity (row-major): the periodic map of coincident wheel/rail patches.
IDENTITY = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]


def reflect(
    p: npt.NDArray[np.float64], planes: list[tuple[int, float]], copy: int
) -> npt.NDArray[np.float64]:
    """The points ``p`` (..., 3) reflected in plane b of ``planes`` for each bit b of
    ``copy``."""
    q = p.copy()
    for b, (axis, c) in enumerate(planes):
        if copy >> b & 1:
            q[..., axis] = 2.0 * c - q[..., axis]
    return q + 0.0  # no negative zeros


def meshed_region(
    groups: dict[tuple[int, str], list[int]],
) -> tuple[npt.NDArray[np.float64], dict[tuple[int, str], npt.NDArray[np.int64]]]:
    """The current gmsh model's mesh: its nodes' coordinates (n, 3) and, per (dim, name) of
    ``groups`` (its entities of that dimension), its tetrahedra (dim 3) or triangles (dim 2)
    over them (0-based): a region for :func:`reflect_region`."""
    tags, xyz, _ = gmsh.model.mesh.getNodes()
    tags = tags.astype(np.int64)
    index = np.zeros(int(tags.max()) + 1, dtype=np.int64)
    index[tags] = np.arange(tags.size)
    region = {}
    for (dim, name), entities in groups.items():
        etype, nper = (4, 4) if dim == 3 else (2, 3)
        conn = [gmsh.model.mesh.getElementsByType(etype, e)[1] for e in entities]
        region[dim, name] = index[np.concatenate(conn).astype(np.int64)].reshape(-1, nper)
    return xyz.reshape(-1, 3).copy(), region


def snap_to_planes(
    xyz: npt.NDArray[np.float64], planes: list[tuple[int, float]]
) -> npt.NDArray[np.int64]:
    """Put the points within round-off of a mirror plane on it (in place); per point, bit b
    set when it lies on plane b."""
    on_plane = np.zeros(xyz.shape[0], dtype=np.int64)
    for b, (axis, c) in enumerate(planes):
        hit = np.abs(xyz[:, axis] - c) < 1e-10 * (1.0 + abs(c))
        xyz[hit, axis] = c
        on_plane[hit] |= 1 << b
    return on_plane


def reflect_region(
    xyz: npt.NDArray[np.float64],
    on_plane: npt.NDArray[np.int64],
    planes: list[tuple[int, float]],
    region: dict[tuple[int, str], npt.NDArray[np.int64]],
    rename: Callable[[str, int], str],
) -> tuple[npt.NDArray[np.float64], dict[tuple[int, str], list[npt.NDArray[np.int64]]]]:
    """A meshed region and its images in ``planes``: the points (n, 3) and, per (dim, group
    name), its simplices over them (0-based), a list of one array per image.

    Image ``copy`` (0 … 2^len(planes) − 1) is reflected in plane b when its bit b is set; a
    point on a plane (``on_plane``'s bit, :func:`snap_to_planes`) is its own image there, so
    the images conform along the planes. An odd number of reflections turns a simplex inside
    out: its second and third nodes are swapped. ``rename(name, copy)`` names a group's
    image."""
    n_copies = 1 << len(planes)
    n = xyz.shape[0]

    # Node (i, copy) is node (i, copy without the planes i lies on): one new node per pair.
    keys = np.concatenate([np.arange(n) * n_copies + (c & ~on_plane) for c in range(n_copies)])
    _, first, new = np.unique(keys, return_index=True, return_inverse=True)
    new = new.reshape(n_copies, n)
    coords = np.concatenate([reflect(xyz, planes, c) for c in range(n_copies)])[first]
    groups: dict[tuple[int, str], list[npt.NDArray[np.int64]]] = {}
    for c in range(n_copies):
        flip = c.bit_count() % 2 == 1
        for (dim, name), conn in region.items():
            img = new[c][conn]
            if flip:
                img[:, [1, 2]] = img[:, [2, 1]]
            groups.setdefault((dim, rename(name, c)), []).append(img)
    return coords, groups


def mirror_mesh(
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
    xyz, region = meshed_region(
        {(3, n): e for n, e in vol_groups.items()} | {(2, n): e for n, e in surf_groups.items()}
    )
    on_plane = snap_to_planes(xyz, planes)
    centres = geo.wheel_centres()

    def rename(name: str, copy: int) -> str:
        stem, _, k = name.rpartition("_")
        if not k.isdigit():
            return name
        image = reflect(np.array([*centres[int(k) - 1], 0.0]), planes, copy)[:2]
        (hit,) = [j for j, c in enumerate(centres) if np.allclose(c, image, atol=1e-9)]
        return f"{stem}_{hit + 1}"

    coords, groups = reflect_region(xyz, on_plane, planes, region, rename)

    gmsh.model.remove()
    gmsh.model.add("crane")
    entity: dict[tuple[int, str], int] = {}
    surfaces = CRANE_SURFACES + (CRANE_FLANGE_SURFACES if geo.flanges else [])
    for dim, names in ((3, CRANE_VOLUMES), (2, surfaces)):
        for tag, name in enumerate(names, start=1):
            if (dim, name) not in groups:
                raise RuntimeError(f"crane geometry: no mesh for the group {name}")
            entity[dim, name] = gmsh.model.addDiscreteEntity(dim, tag)
    # The wheel/rail patch nodes belong to their patch surfaces (gmsh pairs them through
    # these entities: it pairs the nodes an entity owns, and a node has one owner); every
    # other node, the flange patches' too (paired by coordinates, mesh_info), to the first
    # volume.
    owner = np.zeros(coords.shape[0], dtype=np.int64)
    for (dim, name), ent in entity.items():
        if dim == 2 and name in CRANE_SURFACES and "patch" in name:
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
            2, [entity[2, f"wheel_patch_{k}"]], [entity[2, f"rail_patch_{k}"]], IDENTITY
        )
