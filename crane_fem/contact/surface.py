"""Node-to-surface pairing: contact points against the P1 triangles of a surface, each point
on the triangle it projects into, its gap and the coefficients of its row from that
triangle's shape functions (issue 24; docs/theory-notes.md §12).

A point x is paired with the triangle T = (a, b, c) of the surface whose closest point to x
lies inside T (barycentric coordinates ξ ≥ −tol), the nearest such triangle along its normal;
its gap is g = n_T · (x − Σ ξ_i x_i), and its normal row, applied to displacements,
g(u) = g0 + n_T · (u_x − Σ ξ_i u_i): +n_T on the point's DOFs, −ξ_i n_T on each vertex's. Where
the point sits on a vertex (ξ = e_i), the row is the node-to-node row of that pair. On a flat
surface, a point crossing the edge shared by two triangles has the same ξ on the edge from
either side (linear interpolation along it): its gap and its row are continuous.

Re-pairing (:func:`pair_points`) is pure geometry on the current coordinates, called between
kernel calls at macro-step granularity; not collective (every rank holds the surface's
triangles it needs).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt
from mpi4py import MPI
from scipy.spatial import cKDTree

from crane_fem.contact.constraints import ContactSet
from crane_fem.kernels.projection import select_triangles, select_vertices

__all__ = [
    "BRUTE_FORCE_PAIRS",
    "Pairing",
    "Surface",
    "canonical",
    "facing_surface",
    "group_surface",
    "owned_terms",
    "pair_points",
    "pair_with_vertices",
    "surface_rows",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

#: Barycentric tolerance of "inside a triangle" (a point on an edge belongs to both). A
#: point on the surface's own border (a wheel as wide as its rail: its edge vertices sit on
#: the rail's edges) projects a little outside it once the surface tilts under it, by its
#: distance times the tilt (1e-6 of an edge at 0.3 mm above a slope of 3e-4): 1e-3 of an
#: edge (25 µm on the crane's rail) keeps it paired, its coordinates clipped to the edge,
#: when no triangle holds it within :data:`STRICT_TOL` (preferred: the gap of a point
#: crossing an inner edge stays continuous).
INSIDE_TOL = 1e-3
STRICT_TOL = 1e-10
#: Up to this many (point, triangle) pairs, every triangle is a candidate of every point (a
#: compiled pass over them costs less than building a search tree: the crane's 32 points on
#: 84 triangles, 10 µs); beyond, the triangles of nearest centroids.
BRUTE_FORCE_PAIRS = 200_000


@dataclass(frozen=True)
class Surface:
    """P1 triangles of a surface: vertex coordinates (n, 3), triangles (m, 3) as indices into
    them (oriented: the normal (b − a) × (c − a) points out of the body, towards its
    contact points), and the global vertex ids (n,) the rows are written on."""

    xyz: FloatArray
    triangles: IntArray
    vertex_ids: IntArray

    @property
    def normals(self) -> FloatArray:
        """Unit outward normals of the triangles (m, 3)."""
        a, b, c = (self.xyz[self.triangles[:, i]] for i in range(3))
        n = np.cross(b - a, c - a)
        return n / np.linalg.norm(n, axis=1)[:, None]


@dataclass(frozen=True)
class Pairing:
    """Each contact point's triangle (index into the surface's, −1: none), barycentric
    coordinates (p, 3), normal (p, 3) and gap (p,) (m)."""

    triangle: IntArray
    xi: FloatArray
    normal: FloatArray
    gap: FloatArray

    @property
    def paired(self) -> npt.NDArray[np.bool_]:
        return np.asarray(self.triangle >= 0)

    def row_coefficients(self, surface: Surface) -> tuple[IntArray, FloatArray]:
        """The surface vertices (p, 3) of each point's row and their coefficients (p, 3, 3):
        −ξ_i n for vertex i (the point's own coefficient is +n)."""
        verts = surface.triangles[np.maximum(self.triangle, 0)]
        coeff = -self.xi[:, :, None] * self.normal[:, None, :]
        return surface.vertex_ids[verts], coeff


def _nearest_centroids(x: FloatArray, surface: Surface, candidates: int, reach: float) -> IntArray:
    """Per point (p, k), the triangles whose centroids are nearest, in increasing index: as
    many as needed for the farthest to lie beyond the largest circumscribing radius about a
    centroid (plus the point's distance to its plane, at most ``reach``); a triangle farther
    cannot hold the point's projection (a point by a thin triangle needs more than
    ``candidates``)."""
    tri = surface.triangles
    n_p = x.shape[0]
    centroids = surface.xyz[tri].mean(axis=1)
    radius = float(np.max(np.linalg.norm(surface.xyz[tri] - centroids[:, None, :], axis=2)))
    tree = cKDTree(centroids)
    k = min(candidates, tri.shape[0])
    while True:
        dist, near = tree.query(x, k=k)
        dist = np.asarray(dist).reshape(n_p, k)
        depth = np.abs(dist[:, 0]) if np.isinf(reach) else reach
        if k == tri.shape[0] or np.all(dist[:, -1] > np.hypot(radius, depth)):
            break
        k = min(2 * k, tri.shape[0])
    return np.sort(np.asarray(near, dtype=np.int64).reshape(n_p, k), axis=1)


def pair_points(
    points: FloatArray, surface: Surface, candidates: int = 8, reach: float = np.inf
) -> Pairing:
    """Pair each point (p, 3) with the triangle it projects into (see the module docstring):
    among every triangle (up to :data:`BRUTE_FORCE_PAIRS` pairs), or the ``candidates``
    triangles whose centroids are nearest, those that contain its projection, the one
    nearest along its normal (the lowest index among equals); a point with none within
    ``reach`` (m) of its plane is left unpaired (triangle −1, gap +inf). Not collective."""
    tri = surface.triangles
    x = np.ascontiguousarray(np.asarray(points, dtype=np.float64).reshape(-1, 3))
    n_p = x.shape[0]
    out_t = np.full(n_p, -1, dtype=np.int64)
    out_xi = np.zeros((n_p, 3))
    out_n = np.zeros((n_p, 3))
    out_g = np.full(n_p, np.inf)
    if n_p == 0 or tri.shape[0] == 0:
        return Pairing(out_t, out_xi, out_n, out_g)
    if n_p * tri.shape[0] <= BRUTE_FORCE_PAIRS:
        near = np.broadcast_to(np.arange(tri.shape[0], dtype=np.int64), (n_p, tri.shape[0]))
    else:
        near = _nearest_centroids(x, surface, candidates, reach)
    select_triangles(
        x,
        np.ascontiguousarray(surface.xyz, dtype=np.float64),
        np.ascontiguousarray(tri, dtype=np.int64),
        np.ascontiguousarray(near),
        float(reach),
        INSIDE_TOL,
        STRICT_TOL,
        out_t,
        out_xi,
        out_n,
        out_g,
    )
    return Pairing(out_t, out_xi, out_n, out_g)


def pair_with_vertices(points: FloatArray, surface: Surface, allowed: IntArray) -> Pairing:
    """Pair each point (p, 3) with the vertex of ``allowed`` (indices into the surface's)
    nearest to it (the first of equals), as a point of a triangle holding that vertex (ξ its
    e_k; gap: the distance from the vertex along that triangle's normal). Not collective."""
    tri = np.ascontiguousarray(surface.triangles, dtype=np.int64)
    xyz = np.ascontiguousarray(surface.xyz, dtype=np.float64)
    x = np.ascontiguousarray(np.asarray(points, dtype=np.float64).reshape(-1, 3))
    n_p = x.shape[0]
    allowed = np.asarray(allowed, dtype=np.int64)
    if n_p * allowed.size <= BRUTE_FORCE_PAIRS:
        near = np.ascontiguousarray(np.broadcast_to(allowed, (n_p, allowed.size)))
    else:
        _, k = cKDTree(xyz[allowed]).query(x)
        near = allowed[np.asarray(k, dtype=np.int64)].reshape(n_p, 1)
    # The first triangle holding each vertex.
    holder = np.full(xyz.shape[0], -1, dtype=np.int64)
    holder[tri.ravel()[::-1]] = np.repeat(np.arange(tri.shape[0]), 3)[::-1]
    out = Pairing(
        np.zeros(n_p, dtype=np.int64), np.zeros((n_p, 3)), np.zeros((n_p, 3)), np.zeros(n_p)
    )
    select_vertices(x, xyz, tri, holder, near, out.triangle, out.xi, out.normal, out.gap)
    return out


class _OwnedDofs(Protocol):
    """What :func:`surface_rows` asks of a subdomain: its block size and owned blocks."""

    @property
    def bs(self) -> int: ...

    def owned_dofs_of(self, vertices: IntArray) -> tuple[IntArray, IntArray]: ...


def owned_terms(
    sub: _OwnedDofs, vert: IntArray, comp: IntArray
) -> tuple[npt.NDArray[np.bool_], IntArray]:
    """Which terms (global vertex ``vert``, component ``comp``) act on DOFs this rank owns,
    and those DOFs' local indices (not collective)."""
    uniq = np.unique(vert)
    blocks, pos = sub.owned_dofs_of(uniq)
    owner = np.full(uniq.size, -1, dtype=np.int64)
    owner[pos] = blocks
    b = owner[np.searchsorted(uniq, vert)]
    mine = b >= 0
    return mine, (b[mine] * sub.bs + comp[mine]).astype(np.int64)


def surface_rows(
    comm: MPI.Comm,
    sub: _OwnedDofs,
    point_ids: IntArray,
    pairing: Pairing,
    surface: Surface,
    g0: FloatArray,
    group: IntArray,
    names: list[str],
    tol: float = 0.0,
) -> ContactSet:
    """The node-to-surface rows of the paired points as a :class:`ContactSet`: row r acts on
    point ``point_ids[r]``'s DOFs with +n_r and on each vertex i of its triangle with
    −ξ_ri n_r; each rank keeps the terms of the DOFs it owns (the points and the triangles
    may lie on different ranks: the rows are global, their terms distributed, as every
    :class:`ContactSet`'s). An unpaired point's row is empty (its gap stays ``g0``: give it
    a large one). ``g0`` and ``group`` are per point. Not collective (``comm`` is the
    set's)."""
    bs = sub.bs
    p = point_ids.size
    verts, coeff = pairing.row_coefficients(surface)
    paired = pairing.paired
    # All terms: (row, vertex, component, coefficient), the point's first.
    r_all = [np.repeat(np.arange(p), bs), np.repeat(np.arange(p), 3 * bs)]
    v_all = [np.repeat(point_ids, bs), np.repeat(verts.ravel(), bs)]
    c_all = [np.tile(np.arange(bs), p), np.tile(np.arange(bs), 3 * p)]
    k_all = [pairing.normal[:, :bs].ravel(), coeff[:, :, :bs].reshape(-1)]
    rows = np.concatenate(r_all)
    vert = np.concatenate(v_all)
    comp = np.concatenate(c_all)
    val = np.concatenate(k_all)
    keep = paired[rows] & (val != 0.0)
    mine, dofs = owned_terms(sub, vert[keep], comp[keep])
    return ContactSet(
        comm,
        np.asarray(g0, dtype=np.float64),
        rows[keep][mine].astype(np.int64),
        dofs,
        val[keep][mine].astype(np.float64),
        np.asarray(group, dtype=np.int64),
        list(names),
        tol=tol,
    )


def facing_surface(sub: Any, normal: FloatArray, level: float, axis: int, tol: float) -> Surface:
    """The exterior facets of the subdomain ``sub`` whose vertices all lie at coordinate
    ``level`` along ``axis`` (within ``tol``) and whose outward normal is ``normal``: a
    rail's top (+z at the rail top) or side (±x) faces in an explicit zone, as one
    :class:`Surface` of global parent vertex ids, the same on every rank (collective: each
    rank's owned facets, gathered; a point's triangle may then be anywhere).
    """
    import dolfinx.mesh

    msh = sub.submesh
    tdim = msh.topology.dim
    msh.topology.create_connectivity(tdim - 1, tdim)
    msh.topology.create_connectivity(tdim - 1, 0)
    msh.topology.create_connectivity(tdim, 0)
    msh.topology.create_connectivity(0, tdim)
    facets = dolfinx.mesh.exterior_facet_indices(msh.topology)
    n_owned = msh.topology.index_map(tdim - 1).size_local
    facets = facets[facets < n_owned]
    f2v = msh.topology.connectivity(tdim - 1, 0)
    f2c = msh.topology.connectivity(tdim - 1, tdim)
    c2v = msh.topology.connectivity(tdim, 0)
    geo = msh.geometry.x
    v2g = dolfinx.mesh.entities_to_geometry(
        msh,
        0,
        np.arange(
            msh.topology.index_map(0).size_local + msh.topology.index_map(0).num_ghosts,
            dtype=np.int32,
        ),
    ).ravel()
    tris, coords = [], []
    want = np.asarray(normal, dtype=np.float64)
    for f in facets:
        verts = f2v.links(f)
        xyz = geo[v2g[verts]]
        if np.max(np.abs(xyz[:, axis] - level)) > tol:
            continue
        cell = f2c.links(f)[0]
        centre = geo[v2g[c2v.links(cell)]].mean(axis=0)
        n = np.cross(xyz[1] - xyz[0], xyz[2] - xyz[0])
        if np.dot(n, xyz[0] - centre) < 0.0:  # outward: away from its cell
            n, verts, xyz = -n, verts[[0, 2, 1]], xyz[[0, 2, 1]]
        if np.dot(n / np.linalg.norm(n), want) < 1.0 - 1e-9:
            continue
        tris.append(sub.vertex_global[verts])
        coords.append(xyz)
    got = sub.submesh.comm.allgather(
        (np.asarray(tris, dtype=np.int64).reshape(-1, 3), np.asarray(coords).reshape(-1, 3, 3))
    )
    all_tris = np.concatenate([t for t, _ in got])
    all_xyz = np.concatenate([c for _, c in got])
    ids, inverse = np.unique(all_tris.ravel(), return_inverse=True)
    xyz = np.zeros((ids.size, 3))
    xyz[inverse] = all_xyz.reshape(-1, 3)
    return canonical(Surface(xyz, inverse.reshape(-1, 3).astype(np.int64), ids.astype(np.int64)))


def canonical(surface: Surface) -> Surface:
    """The same triangles in an order that depends on their coordinates only: sorted by
    centroid, each starting at its lexicographically smallest vertex (orientation kept). The
    ranks gather a surface in partition order and number vertices by partition; the pairing's
    choices among equals (a point on an edge, the triangle that holds a vertex) follow the
    triangles' order, so serial and parallel runs make the same ones."""
    tri = surface.triangles
    if tri.shape[0] == 0:
        return surface
    txyz = surface.xyz[tri]  # (m, 3, 3)
    first = np.array([np.lexsort((t[:, 2], t[:, 1], t[:, 0]))[0] for t in txyz], dtype=np.int64)
    roll = (first[:, None] + np.arange(3)[None, :]) % 3
    tri = np.take_along_axis(tri, roll, axis=1)
    c = surface.xyz[tri].mean(axis=1)
    order = np.lexsort((c[:, 2], c[:, 1], c[:, 0]))
    return Surface(surface.xyz, tri[order], surface.vertex_ids)


def group_surface(tagged: Any, name: str) -> Surface:
    """The triangles of the parent mesh's facet group ``name``, each oriented out of the one
    cell it bounds, as one :class:`Surface` of global parent vertex ids, the same on every
    rank (collective: each rank's owned facets, gathered).

    Raises:
        ScenarioError: a facet of the group lies between two cells (inside a body, where
            nothing can touch it), on every rank.
    """
    import dolfinx.mesh

    from crane_fem.errors import ScenarioError

    msh = tagged.mesh
    tdim = msh.topology.dim
    for d0, d1 in ((tdim - 1, tdim), (tdim - 1, 0), (tdim, 0), (0, tdim)):
        msh.topology.create_connectivity(d0, d1)
    tags = tagged.facet_tags
    facets = tags.indices[tags.values == tagged.facet_groups[name]]
    facets = facets[facets < msh.topology.index_map(tdim - 1).size_local]
    f2v = msh.topology.connectivity(tdim - 1, 0)
    f2c = msh.topology.connectivity(tdim - 1, tdim)
    c2v = msh.topology.connectivity(tdim, 0)
    n_v = msh.topology.index_map(0).size_local + msh.topology.index_map(0).num_ghosts
    v2g = dolfinx.mesh.entities_to_geometry(msh, 0, np.arange(n_v, dtype=np.int32)).ravel()
    geo = msh.geometry.x
    verts = np.array([f2v.links(f) for f in facets], dtype=np.int32).reshape(-1, 3)
    n_cells = np.array([f2c.links(f).size for f in facets], dtype=np.int64)
    inner = msh.comm.allreduce(int(np.count_nonzero(n_cells != 1)), op=MPI.SUM)
    if inner:
        raise ScenarioError(
            f"surface group {name!r}: {inner} of its facets lie between two cells, inside a "
            "body; a contact surface is a body's boundary (mesh the two bodies apart, with "
            "their own nodes on the contact: no fragment/coherence between them)"
        )
    cells = np.array([f2c.links(f)[0] for f in facets], dtype=np.int64)
    xyz = geo[v2g[verts]]  # (m, 3, 3)
    centre = np.array([geo[v2g[c2v.links(c)]].mean(axis=0) for c in cells]).reshape(-1, 3)
    n = np.cross(xyz[:, 1] - xyz[:, 0], xyz[:, 2] - xyz[:, 0])
    flip = np.einsum("ij,ij->i", n, xyz[:, 0] - centre) < 0.0  # outward: away from its cell
    verts[flip] = verts[flip][:, [0, 2, 1]]
    xyz[flip] = xyz[flip][:, [0, 2, 1]]
    ids = np.asarray(
        msh.topology.index_map(0).local_to_global(verts.ravel()), dtype=np.int64
    ).reshape(-1, 3)
    got = msh.comm.allgather((ids, xyz.reshape(-1, 3, 3)))
    all_tris = np.concatenate([t for t, _ in got])
    all_xyz = np.concatenate([c for _, c in got])
    uniq, inverse = np.unique(all_tris.ravel(), return_inverse=True)
    coords = np.zeros((uniq.size, 3))
    coords[inverse] = all_xyz.reshape(-1, 3)
    return canonical(Surface(coords, inverse.reshape(-1, 3).astype(np.int64), uniq))
