"""Node-to-surface pairing (crane_fem/contact/surface.py, issue 24's geometry): a point on a
vertex gives the node-to-node row; a point crossing triangle edges keeps its gap and its row's
value continuous (no jump above 1e-9 m); a point off the surface is left unpaired."""

import numpy as np
import pytest

from crane_fem.contact.surface import Surface, pair_points


def _rail_top(nx: int = 12, ny: int = 2, length: float = 0.3, width: float = 0.05, seed: int = 0):
    """A rail's top face z = 0.39: an nx × ny grid of squares split into triangles, its inner
    vertices shifted in the plane (an unstructured mesh's irregular triangles), normal +z."""
    rng = np.random.default_rng(seed)
    xs, ys = np.linspace(0.0, length, nx + 1), np.linspace(-width / 2, width / 2, ny + 1)
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    xyz = np.column_stack([X.ravel(), Y.ravel(), np.full(X.size, 0.39)])
    inner = (X.ravel() > 0) & (X.ravel() < length) & (np.abs(Y.ravel()) < width / 2)
    h = min(length / nx, width / ny)
    xyz[inner, :2] += rng.uniform(-0.2 * h, 0.2 * h, (int(inner.sum()), 2))
    idx = np.arange(X.size).reshape(nx + 1, ny + 1)
    tris = []
    for i in range(nx):
        for j in range(ny):
            a, b, c, d = idx[i, j], idx[i + 1, j], idx[i + 1, j + 1], idx[i, j + 1]
            tris += [[a, b, c], [a, c, d]]
    return Surface(xyz, np.array(tris, dtype=np.int64), 1000 + np.arange(X.size))


def test_a_point_on_a_vertex_gives_the_node_to_node_row() -> None:
    """Above vertex v: ξ = e_v, normal +z, gap = its height; the row's surface part is −n on
    v alone (the node-to-node pair's row)."""
    s = _rail_top()
    v = 20
    pairing = pair_points(s.xyz[v] + [0.0, 0.0, 2e-4], s)
    assert pairing.paired.all()
    assert pairing.gap[0] == pytest.approx(2e-4, abs=1e-15)
    np.testing.assert_allclose(pairing.normal[0], [0.0, 0.0, 1.0], atol=1e-15)
    verts, coeff = pairing.row_coefficients(s)
    on_v = verts[0] == s.vertex_ids[v]
    assert on_v.sum() == 1
    np.testing.assert_allclose(coeff[0][on_v][0], [0.0, 0.0, -1.0], atol=1e-12)
    np.testing.assert_allclose(coeff[0][~on_v], 0.0, atol=1e-12)


def test_a_point_crossing_edges_keeps_its_gap_and_row_continuous() -> None:
    """A wheel point sliding 0.3 m along the rail (12 element lengths, across every edge of
    its path) 0.1 mm above it, while the rail deforms (a smooth vertical field on its
    vertices): the gap of the deformed surface, g = z_p − Σ ξ_i (z_i + u_i), changes by less
    than 1e-9 m from one position to the next (1e5 positions, 3 µm apart) beyond what the
    field's slope gives."""
    s = _rail_top()
    u = 1e-4 * np.sin(20.0 * s.xyz[:, 0]) * np.cos(30.0 * s.xyz[:, 1])  # a smooth deflection
    xs = np.linspace(0.001, 0.299, 100_000)
    pts = np.column_stack([xs, 0.004 + 0.002 * np.sin(40 * xs), np.full(xs.size, 0.3901)])
    pairing = pair_points(pts, s)
    assert pairing.paired.all()
    tri = s.triangles[pairing.triangle]
    surf = np.einsum("ij,ij->i", pairing.xi, s.xyz[tri, 2] + u[tri])
    g = pts[:, 2] - surf
    np.testing.assert_allclose(pairing.gap, 1e-4, rtol=0, atol=1e-12)  # the flat rail's gap
    # The field's slope (|∇u| ≤ 3.6e-3) moves g by at most 1.1e-8 m over 3 µm; a jump at an
    # edge would add to that.
    dg = np.abs(np.diff(g))
    assert np.max(dg) <= 3.6e-3 * np.max(np.diff(xs)) * 1.05 + 1e-9
    assert len(np.unique(pairing.triangle)) >= 24  # it crossed the triangles of its path
    np.testing.assert_allclose(pairing.xi.sum(axis=1), 1.0, rtol=0, atol=1e-12)


def test_a_point_off_the_surface_is_unpaired() -> None:
    """Beyond the rail's end, or farther from its plane than the reach: no triangle."""
    s = _rail_top()
    pairing = pair_points(np.array([[0.35, 0.0, 0.3901], [0.1, 0.0, 0.45]]), s, reach=0.01)
    assert not pairing.paired.any()
    assert np.all(np.isinf(pairing.gap))


class _AllOwned:
    """A serial subdomain owning every vertex: block i is vertex id i."""

    bs = 3

    def __init__(self, n: int) -> None:
        self.n = n

    def owned_dofs_of(self, vertices):
        v = np.asarray(vertices, dtype=np.int64)
        mine = v < self.n
        return v[mine], np.flatnonzero(mine).astype(np.int64)


def test_surface_rows_apply_the_pairing() -> None:
    """The rows of :func:`surface_rows` applied to a displacement u give n·(u_p − Σ ξ_i u_i):
    the pairing's gap change, point by point; a point over a vertex has the node-to-node row
    (two terms in z)."""
    from mpi4py import MPI

    from crane_fem.contact.surface import surface_rows

    s = _rail_top()
    n_v = s.xyz.shape[0]
    surf = Surface(s.xyz, s.triangles, np.arange(n_v))  # vertex ids = blocks 0..n_v−1
    rng = np.random.default_rng(3)
    pts = np.column_stack([rng.uniform(0.01, 0.29, 20), rng.uniform(-0.02, 0.02, 20)])
    pts = np.column_stack([pts, np.full(20, 0.3901)])
    pts[0] = s.xyz[20] + [0.0, 0.0, 1e-4]  # over a vertex
    pairing = pair_points(pts, surf)
    point_ids = n_v + np.arange(20)  # the points are the next vertices
    rows = surface_rows(
        MPI.COMM_SELF,
        _AllOwned(n_v + 20),
        point_ids,
        pairing,
        surf,
        pairing.gap,
        np.zeros(20, dtype=np.int64),
        ["wheel"],
    )
    u = rng.standard_normal((n_v + 20) * 3) * 1e-4
    U = u.reshape(-1, 3)
    tri = surf.triangles[pairing.triangle]
    expected = np.einsum(
        "ij,ij->i", pairing.normal, U[point_ids] - np.einsum("ik,ikj->ij", pairing.xi, U[tri])
    )
    np.testing.assert_allclose(rows.apply(u), expected, rtol=0, atol=1e-16)
    np.testing.assert_allclose(rows.g0, pairing.gap)
    on_vertex = rows.dofs[rows.rows == 0]
    assert sorted(on_vertex.tolist()) == [3 * 20 + 2, 3 * point_ids[0] + 2]


def test_crane_rail_tops_pair_the_wheels_on_their_vertices(shared_tmp) -> None:
    """The quick crane's explicit zones: their rail-top triangles (exterior facets at the
    rail top, facing +z; the wheels' soles there face −z and are left out) cover the four
    rail zones — area 4 × rail width × zone length —, hold every rail vertex of the wheel/
    rail pairs, and pair each wheel vertex on its own rail vertex at t = 0 (ξ = e_i, gap 0):
    the node-to-node rows of today, the same on every rank."""
    from pathlib import Path

    from conftest import COMM

    from crane_fem.contact.surface import facing_surface
    from crane_fem.pipeline.mesh import build_mesh
    from crane_fem.pipeline.models import build_models
    from crane_fem.scenario import load_scenario

    sc = load_scenario(Path(__file__).parent.parent / "demos" / "crane_quick.toml")
    mesh = build_mesh(sc, COMM)
    models = build_models(sc, mesh)
    try:
        geo = sc.model.geometry()
        sub = models.explicit
        top = facing_surface(sub, np.array([0.0, 0.0, 1.0]), geo.rail_top, 2, 1e-9)
        a, b, c = (top.xyz[top.triangles[:, i]] for i in range(3))
        area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1).sum()
        np.testing.assert_allclose(top.normals, np.tile([0.0, 0.0, 1.0], (len(top.triangles), 1)))
        crane = mesh.crane
        assert np.all(np.isin(crane.pairs[:, 1], top.vertex_ids))
        # The wheels' vertices sit on their rail vertices: the pairing snaps to them.
        rail_xyz = top.xyz[np.searchsorted(top.vertex_ids, crane.pairs[:, 1])]
        pairing = pair_points(rail_xyz + np.array([0.0, 0.0, 1e-12]), top)
        assert pairing.paired.all()
        tri = top.triangles[pairing.triangle]
        vert = top.vertex_ids[tri[np.arange(len(tri)), np.argmax(pairing.xi, axis=1)]]
        assert np.array_equal(vert, crane.pairs[:, 1])
        assert np.max(np.abs(1.0 - pairing.xi.max(axis=1))) <= 1e-9
        # Four rail zones, one per wheel: a rail width × (wheel length + 2 zone margins).
        zone = geo.wheel_length + 2.0 * geo.zone_margin
        assert area == pytest.approx(4 * geo.rail_width * zone, rel=1e-9)
        areas = COMM.allgather(area)
        assert all(x == areas[0] for x in areas)
    finally:
        models.destroy()


def test_every_triangle_or_the_nearest_centroids_pair_alike(monkeypatch) -> None:
    """The two candidate sets of :func:`pair_points` (every triangle up to
    ``BRUTE_FORCE_PAIRS`` pairs, else those of nearest centroids) choose the same triangle
    with the same ξ, normal and gap, bit for bit (the same compiled choice over the same
    holders, the lowest index among equals): points above vertices (held by up to six
    triangles), on edges, inside, beyond the rail's end and out of reach."""
    from crane_fem.contact import surface as surface_mod

    s = _rail_top(seed=4)
    rng = np.random.default_rng(5)
    pts = np.column_stack(
        [rng.uniform(-0.01, 0.31, 400), rng.uniform(-0.03, 0.03, 400), rng.uniform(0.389, 0.4, 400)]
    )
    pts[:30] = s.xyz[rng.integers(0, s.xyz.shape[0], 30)] + [0.0, 0.0, 1e-4]
    a_, b_ = s.xyz[s.triangles[:30, 0]], s.xyz[s.triangles[:30, 1]]
    pts[30:60] = 0.5 * (a_ + b_) + [0.0, 0.0, 2e-4]  # on edges
    assert pts.shape[0] * s.triangles.shape[0] <= surface_mod.BRUTE_FORCE_PAIRS
    every = pair_points(pts, s, reach=0.005)
    monkeypatch.setattr(surface_mod, "BRUTE_FORCE_PAIRS", 0)
    nearest = pair_points(pts, s, reach=0.005)
    np.testing.assert_array_equal(every.triangle, nearest.triangle)
    for name in ("xi", "normal", "gap"):
        np.testing.assert_array_equal(getattr(every, name), getattr(nearest, name))
    assert 0 < every.paired.sum() < pts.shape[0]  # some beyond the end or out of reach
    # On a vertex held by several triangles: the lowest index that holds it.
    v = 20
    one = pair_points(s.xyz[v][None, :] + [0.0, 0.0, 1e-4], s)
    holders = np.flatnonzero(np.any(s.triangles == v, axis=1))
    assert holders.size >= 3 and one.triangle[0] == holders.min()


def test_pair_with_vertices_takes_the_nearest_allowed_vertex(monkeypatch) -> None:
    """:func:`pair_with_vertices` puts each point on the nearest of the allowed vertices (by
    every distance, or by a search tree beyond ``BRUTE_FORCE_PAIRS``: the same vertex), as
    that vertex's ξ in a triangle holding it, its gap along that triangle's normal."""
    from crane_fem.contact import surface as surface_mod
    from crane_fem.contact.surface import pair_with_vertices

    s = _rail_top(seed=6)
    allowed = np.arange(0, s.xyz.shape[0], 2)
    rng = np.random.default_rng(7)
    pts = np.column_stack(
        [rng.uniform(0.0, 0.3, 200), rng.uniform(-0.025, 0.025, 200), np.full(200, 0.3905)]
    )
    d = np.linalg.norm(pts[:, None, :] - s.xyz[allowed][None, :, :], axis=2)
    expected = allowed[np.argmin(d, axis=1)]
    for limit in (surface_mod.BRUTE_FORCE_PAIRS, 0):
        monkeypatch.setattr(surface_mod, "BRUTE_FORCE_PAIRS", limit)
        pr = pair_with_vertices(pts, s, allowed)
        tri = s.triangles[pr.triangle]
        vert = tri[np.arange(200), np.argmax(pr.xi, axis=1)]
        np.testing.assert_array_equal(vert, expected)
        np.testing.assert_array_equal(pr.xi.sum(axis=1), 1.0)
        np.testing.assert_allclose(pr.normal, np.tile([0.0, 0.0, 1.0], (200, 1)), atol=1e-15)
        np.testing.assert_allclose(pr.gap, 5e-4, rtol=0, atol=1e-12)
