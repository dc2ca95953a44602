"""Node-to-surface contacts that follow bodies sliding over each other: the contact rows as
data that a hook before each macro step updates (Siconos' ``updateInteractions``), the
relation (rows, gaps) apart from the law (unilateral, Coulomb μ: the kernel's).

A :class:`Family` is a set of contact points acting on one :class:`~crane_fem.contact.surface.
Surface` (a crane's wheel vertices on its rail tops, its flanges on the rail sides). Each
point's row is g = g0 + n·(u_p − Σ ξ_i u_i) with its triangle's normal n and barycentric
coordinates ξ (crane_fem.contact.surface); with friction, its tangential rows are
t·(v_p − Σ ξ_i v_i) for two tangents orthonormal to n (the first along x projected, the second
n × t₁), the first only for a point that slides freely along the second; a family that rolls
along a given direction d (free-rolling wheels) has t₁ = d × n (across it) only.

g0 keeps the gap of the reference configuration X continuous across re-pairings:
g0 = n·(X_p − Σ ξ_i X_i) + c_p, with c_p fixed per point at t = 0 (the preload's closing of a
wheel pair, a flange's clearance): then g = n·(x_p − Σ ξ_i x_i) + c_p, the current distance
along the normal, whichever triangle the point is on.

At every macro-step boundary :meth:`SlidingContacts.update` measures, for every point, the
tangential drift of x_p − Σ ξ_i x_i since its pairing (the rows are the tangent plane's of the
pairing). Once a point has drifted more than :data:`SLIDE_TOL` of the surface's shortest edge
(since the start, or its pairing), every boundary projects the
points on the current surface (ξ', n') and sets the gaps so that g0 + L u is the current
distance n'·(x_p − Σ ξ'_i x_i) + c_p: the gap of a point crossing an edge is continuous,
whichever rows carry it. The rows themselves are paired again, lazily, when a drift exceeds
:data:`REPAIR_FRACTION` of the surface's shortest edge
(:meth:`~crane_fem.integrators.explicit_zone.ExplicitZone.set_contacts`, no recompilation).
Until a point drifts that far, rows and gaps stay those of t = 0, where each point
sits on a surface vertex (ξ = e_i snapped exactly): the node-to-node rows of that pair, so a
scene that does not slide keeps its node-to-node history to round-off (docs/theory-notes.md
§12).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt
from mpi4py import MPI
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from crane_fem.contact.constraints import ContactSet, TangentRows
from crane_fem.contact.surface import (
    BRUTE_FORCE_PAIRS,
    INSIDE_TOL,
    STRICT_TOL,
    Pairing,
    Surface,
    canonical,
    owned_terms,
    pair_points,
    pair_with_vertices,
    surface_rows,
)
from crane_fem.errors import CraneFemError, ScenarioError
from crane_fem.kernels.projection import offsets_over_pairings, select_triangles

__all__ = [
    "REPAIR_FRACTION",
    "Family",
    "SlidingContacts",
    "SlidingError",
    "merge_surfaces",
    "tangents_of",
    "triangles_where",
    "vertex_coordinates",
    "without_vertices",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

#: A point is paired again once its tangential drift over its triangle exceeds this fraction
#: of the surface's shortest edge (the rows are the tangent plane's of the pairing: on a flat
#: surface exact, on a bent one off by its slope times the drift).
REPAIR_FRACTION = 0.05
#: A drift, as a fraction of the surface's shortest edge, below which the rows and gaps stay
#: as paired: the wheels' and rails' elastic tangential strain under vertical shaking (µm)
#: is no slide, and a scene that does not slide keeps its t = 0 rows bit for bit. Above it,
#: the gaps follow the current projection; the first refresh moves a gap by the surface's
#: slope times this drift (18 µm on the committed meshes: 2e-9 m at a slope of 1e-4).
SLIDE_TOL = 1.0e-3
#: An unpaired point's gap (m): it cannot close.
OPEN_GAP = 1.0e3
#: Barycentric coordinates within this of a vertex's are that vertex's exactly (t = 0: a
#: point on a surface vertex has the node-to-node row of that pair).
SNAP_TOL = 1e-9


@dataclass(frozen=True)
class _Batch:
    """The families whose points are projected on every triangle of their surface
    (:func:`~crane_fem.contact.surface.pair_points`' brute-force case), projected in one
    compiled call: their triangles over the set's vertex slots, one after another, each
    point a candidate of its own family's only (in increasing order, as pair_points takes
    them: the same choice, bit for bit, without a call per family)."""

    families: list[int]
    points: IntArray  # (P,) slots of the batched families' points, family after family
    triangles: IntArray  # (T, 3) slots of their triangles' vertices
    candidates: IntArray  # (P, k) global triangle indices, −1 after a family's last
    first: IntArray  # (n + 1,) each family's first point, then P
    tri0: IntArray  # (n,) each family's first triangle

    @staticmethod
    def of(families: list[Family], slot_p: list[IntArray], slot_s: list[IntArray]) -> _Batch:
        js = [
            j
            for j, f in enumerate(families)
            if f.vertices is None and f.p * f.surface.triangles.shape[0] <= BRUTE_FORCE_PAIRS
        ]
        n_tri = [families[j].surface.triangles.shape[0] for j in js]
        tri0 = np.concatenate([[0], np.cumsum(n_tri)]).astype(np.int64)
        k = max(n_tri, default=0)
        cand = np.full((sum(families[j].p for j in js), k), -1, dtype=np.int64)
        first = np.zeros(len(js) + 1, dtype=np.int64)
        for i, j in enumerate(js):
            first[i + 1] = first[i] + families[j].p
            cand[first[i] : first[i + 1], : n_tri[i]] = np.arange(tri0[i], tri0[i + 1])
        triangles = [slot_s[j][families[j].surface.triangles] for j in js]
        return _Batch(
            js,
            np.concatenate([slot_p[j] for j in js] or [np.zeros(0, np.int64)]).astype(np.int64),
            np.concatenate(triangles or [np.zeros((0, 3), np.int64)])
            .astype(np.int64)
            .reshape(-1, 3),
            cand,
            first,
            tri0[:-1],
        )

    def project(self, x: FloatArray) -> dict[int, Pairing]:
        """The batched families' pairings at the coordinates ``x`` of the set's vertices,
        by family index (not collective)."""
        n_p = self.points.size
        if n_p == 0:
            return {}
        t = np.full(n_p, -1, dtype=np.int64)
        xi, normal, gap = np.zeros((n_p, 3)), np.zeros((n_p, 3)), np.full(n_p, np.inf)
        xc = np.ascontiguousarray(x, dtype=np.float64)
        select_triangles(
            np.ascontiguousarray(xc[self.points]),
            xc,
            self.triangles,
            self.candidates,
            np.inf,
            INSIDE_TOL,
            STRICT_TOL,
            t,
            xi,
            normal,
            gap,
        )
        out = {}
        for i, j in enumerate(self.families):
            a, b = self.first[i], self.first[i + 1]
            tj = t[a:b]
            local = np.where(tj >= 0, tj - self.tri0[i], -1)
            out[j] = Pairing(local, xi[a:b], normal[a:b], gap[a:b])
        return out


class SlidingError(CraneFemError):
    """A contact point left the surface it must stay on (a wheel ran off its rail zone)."""


@dataclass(frozen=True)
class Family:
    """Contact points against one surface.

    Attributes:
        points: (p,) global parent vertex ids of the points.
        surface: the triangles they act on.
        group: (p,) contact group of each point (index into the set's names).
        offset: (p,) c_p (m), see the module docstring.
        n_tangents: tangential rows per point with friction (0: frictionless, 1: across only,
            the first tangent; 2: both).
        mu: Coulomb coefficient of the family's points.
        along: axis along which a point may leave the surface's extent only by running off it
            (a rail's length, y); −1: none (leaving it across is an overhang, the point's
            row is then empty).
        label: (p,) the body each point belongs to, for messages (a wheel's number).
        vertices: None (the points act on the triangles), or the surface vertices (indices
            into its arrays) the points act on one each, the nearest, re-paired as they move
            (node to nearest node: the crane's frictionless flanges on the rail sides, whose
            triangles all touch the interface at the rail's foot).
        free: None, or the unit direction (3,) the points roll along freely: their one
            tangential row (``n_tangents`` 1) is across it, t₁ = d × n normalised.
    """

    points: IntArray
    surface: Surface
    group: IntArray
    offset: FloatArray
    n_tangents: int = 0
    mu: float = 0.0
    along: int = -1
    label: IntArray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    vertices: IntArray | None = None
    free: FloatArray | None = None

    @property
    def p(self) -> int:
        return int(self.points.size)


@dataclass(frozen=True)
class _Flat:
    """The pairings of every family, flat (p_total points): each point's slot in
    :attr:`SlidingContacts.ids`, its triangle's vertices' slots (p_total, 3), ξ, n, whether
    it is paired, and whether it acts on a triangle (not a vertex by choice)."""

    point: IntArray
    vertex: IntArray
    xi: FloatArray
    normal: FloatArray
    paired: npt.NDArray[np.bool_]
    on_triangle: npt.NDArray[np.bool_]


def tangents_of(
    normal: FloatArray, free: FloatArray | None = None
) -> tuple[FloatArray, FloatArray]:
    """Two unit tangents (k, 3) per unit normal (k, 3): t₁ = e_x projected off n (e_y where n
    is along x), t₂ = n × t₁; for n = e_z: e_x and e_y. With a rolling direction ``free``
    (3,): t₁ = free × n normalised (across it), t₂ = n × t₁ (along it, in the plane); for
    free = e_y and n = e_z, e_x and e_y as above."""
    n = np.asarray(normal, dtype=np.float64).reshape(-1, 3)
    if free is not None:
        t1 = np.cross(np.asarray(free, dtype=np.float64), n)
        t1 /= np.linalg.norm(t1, axis=1)[:, None]
        return t1, np.cross(n, t1)
    ref = np.zeros_like(n)
    along_x = np.abs(n[:, 0]) > 0.9
    ref[~along_x, 0] = 1.0
    ref[along_x, 1] = 1.0
    t1 = ref - np.einsum("ij,ij->i", ref, n)[:, None] * n
    t1 /= np.linalg.norm(t1, axis=1)[:, None]
    return t1, np.cross(n, t1)


def _off(d: FloatArray) -> FloatArray:
    """A unit vector not along ``d`` (3,): e_z, or e_x where d is along z."""
    return np.array([1.0, 0.0, 0.0]) if abs(d[2]) > 0.9 else np.array([0.0, 0.0, 1.0])


def vertex_coordinates(sub: Any, ids: IntArray) -> FloatArray:
    """Reference coordinates (n, 3) of the subdomain's vertices of global parent ids ``ids``
    (sorted unique), the same on every rank (collective)."""
    blocks, pos = sub.owned_dofs_of(ids)
    xyz = np.asarray(sub.V.tabulate_dof_coordinates(), dtype=np.float64)
    X = np.zeros((ids.size, 3))
    X[pos] = xyz[blocks]
    out: FloatArray = sub.submesh.comm.allreduce(X, op=MPI.SUM)
    return out


def merge_surfaces(surfaces: list[Surface]) -> Surface:
    """One surface of the triangles of several (vertices shared by id)."""
    ids = np.concatenate([s.vertex_ids for s in surfaces])
    xyz = np.concatenate([s.xyz for s in surfaces])
    tris = np.concatenate([s.vertex_ids[s.triangles] for s in surfaces])
    uniq, first = np.unique(ids, return_index=True)
    return canonical(Surface(xyz[first], np.searchsorted(uniq, tris).astype(np.int64), uniq))


def without_vertices(surface: Surface, ids: IntArray) -> Surface:
    """The triangles of ``surface`` that touch none of the vertices ``ids``, with the
    vertices they use."""
    return triangles_where(
        surface, ~np.any(np.isin(surface.vertex_ids[surface.triangles], ids), axis=1)
    )


def triangles_where(surface: Surface, keep: npt.NDArray[np.bool_]) -> Surface:
    """The triangles of ``surface`` where ``keep``, with the vertices they use."""
    tris = surface.triangles[keep]
    used = np.unique(tris)
    return Surface(
        surface.xyz[used],
        np.searchsorted(used, tris).astype(np.int64),
        surface.vertex_ids[used],
    )


def _snap(pairing: Pairing) -> Pairing:
    """ξ within :data:`SNAP_TOL` of a vertex's set to it exactly."""
    xi = pairing.xi.copy()
    near = np.max(xi, axis=1) > 1.0 - SNAP_TOL
    xi[near] = np.eye(3)[np.argmax(xi[near], axis=1)]
    return Pairing(pairing.triangle, xi, pairing.normal, pairing.gap)


class SlidingContacts:
    """The node-to-surface rows of some families of points, re-paired as they slide.

    Args:
        sub: the explicit subdomain holding the points and the surfaces (its field is what
            :meth:`update` reads).
        families: the families, whose rows are stacked in this order.
        names: the contact group names.
        tol: the set's closing tolerance (m).
        reach_message: how a point running off its surface along ``along`` is explained
            (formatted with ``label``, ``slip_mm``, ``t``).
        point_name: what a point's label numbers, in messages ("wheel").
        surface_key: the scenario key that chose the surfaces, in messages.

    Collective over the subdomain's communicator.
    """

    def __init__(
        self,
        sub: Any,
        families: list[Family],
        names: list[str],
        tol: float,
        reach_message: str = "",
        point_name: str = "body",
        surface_key: str = "the contact surface",
    ) -> None:
        self.point_name = point_name
        self.surface_key = surface_key
        self.sub = sub
        self.comm: MPI.Comm = sub.submesh.comm
        self.families = families
        self.names = list(names)
        self.tol = float(tol)
        self.reach_message = reach_message
        bs = sub.bs
        if bs != 3:
            raise CraneFemError("node-to-surface contact needs a 3D displacement field")
        ids = [f.points for f in families] + [f.surface.vertex_ids for f in families]
        self.ids = np.unique(np.concatenate(ids)) if ids else np.zeros(0, dtype=np.int64)
        self._blocks, self._pos = sub.owned_dofs_of(self.ids)
        self.X = vertex_coordinates(sub, self.ids)
        self._slot_p = [np.searchsorted(self.ids, f.points) for f in families]
        self._slot_s = [np.searchsorted(self.ids, f.surface.vertex_ids) for f in families]
        self._batch = _Batch.of(families, self._slot_p, self._slot_s)
        edges = [self._shortest_edge(f.surface) for f in families]
        self.threshold = REPAIR_FRACTION * min(edges, default=np.inf)
        self.slide_tol = SLIDE_TOL * min(edges, default=np.inf)
        self._offset = np.concatenate([f.offset for f in families]).astype(np.float64)
        self.repairs = 0
        self.sliding = False
        # Each point's tangential offset over its triangle when it was paired (the first
        # update's, for the pairing of t = 0: the preload's lateral strain is not a slide).
        self.offsets: FloatArray | None = None
        self.sliding_since: float | None = None
        self._t0_pairing()
        self.g0 = self._ref_gaps.copy()
        self._extents = [
            self._piece_extent(f, pr) for f, pr in zip(families, self.pairings, strict=True)
        ]

    @property
    def pairings(self) -> list[Pairing]:
        """Each family's current pairing (its rows')."""
        return self._pairings

    @pairings.setter
    def pairings(self, pairings: list[Pairing]) -> None:
        self._pairings = list(pairings)
        self._flat = self._flatten(self._pairings)
        # The rows' distances at X: g0 + L u is the distance now when g0 = exact − (L u).
        self._ref_gaps = self._gaps(self._flat, self.X)

    @staticmethod
    def _piece_extent(f: Family, pairing: Pairing) -> FloatArray:
        """Per point (p, 2): the extent along ``f.along`` of the connected piece of its
        surface that holds its triangle at t = 0 (a rail zone's top: a crane's surface has
        one piece per zone, with gaps between them)."""
        out = np.full((f.p, 2), [-np.inf, np.inf])
        if f.along < 0:
            return out
        tri = f.surface.triangles
        n_v = f.surface.xyz.shape[0]
        edges = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
        graph = coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n_v, n_v))
        _, label = connected_components(graph, directed=False)
        coord = f.surface.xyz[:, f.along]
        n_l = int(label.max(initial=-1)) + 1
        lo = np.full(n_l, np.inf)
        hi = np.full(n_l, -np.inf)
        np.minimum.at(lo, label, coord)
        np.maximum.at(hi, label, coord)
        piece = label[tri[np.maximum(pairing.triangle, 0), 0]]
        out[:, 0], out[:, 1] = lo[piece], hi[piece]
        return out

    @staticmethod
    def _shortest_edge(s: Surface) -> float:
        tri = s.xyz[s.triangles]
        e = np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2)
        return float(e.min(initial=np.inf))

    def _t0_pairing(self) -> None:
        """The pairing of the reference configuration, ξ snapped (collective only through
        nothing: pure geometry on data every rank holds)."""
        pairings = []
        for j, (f, sp, ss) in enumerate(
            zip(self.families, self._slot_p, self._slot_s, strict=True)
        ):
            pairing = _snap(self._project(f, self.X[sp], self.X[ss]))
            self._check_paired(j, pairing, None, 0.0)
            pairings.append(pairing)
        self.pairings = pairings

    @staticmethod
    def _project(f: Family, xp: FloatArray, xs: FloatArray) -> Pairing:
        """The points at ``xp`` on their family's surface with vertices at ``xs`` (not
        collective): on the triangle that holds their projection, or on the nearest allowed
        vertex (``f.vertices``), ξ that vertex's in a triangle holding it."""
        deformed = Surface(xs, f.surface.triangles, f.surface.vertex_ids)
        if f.vertices is None:
            return pair_points(xp, deformed)
        return pair_with_vertices(xp, deformed, f.vertices)

    def _check_paired(self, j: int, pairing: Pairing, x: FloatArray | None, t: float) -> None:
        """Raise when a point of family ``j``, if it has an ``along`` axis, is off its piece
        of surface along it (at t = 0: any unpaired point is refused)."""
        f = self.families[j]
        lost = ~pairing.paired
        if not np.any(lost):
            return
        if x is None:
            k = int(np.flatnonzero(lost)[0])
            label = f"{self.point_name} {int(f.label[k])}" if f.label.size else "a contact point"
            raise ScenarioError(
                f"{label}: its vertex {int(f.points[k])} projects onto no triangle of its "
                f"contact surface at t = 0 ({self.surface_key})"
            )
        if f.along < 0:
            return
        extent = self._extents[j]
        s = x[:, f.along]
        off = lost & ((s < extent[:, 0]) | (s > extent[:, 1]))
        if np.any(off):
            k = int(np.flatnonzero(off)[0])
            slot = np.searchsorted(self.ids, f.points[k])
            slip = float(x[k, f.along] - self.X[slot, f.along])
            number = int(f.label[k]) if f.label.size else k
            raise SlidingError(
                self.reach_message.format(label=number, slip_mm=slip * 1e3, t=t)
                or f"contact point {k} ran off its surface at t = {t:.6g} s"
            )

    def rows(self) -> ContactSet:
        """The current rows of every family, stacked (not collective)."""
        sets = []
        bounds = np.cumsum([0, *(f.p for f in self.families)])
        for j, (f, pairing) in enumerate(zip(self.families, self.pairings, strict=True)):
            g0 = self.g0[bounds[j] : bounds[j + 1]]
            cs = surface_rows(
                self.comm, self.sub, f.points, pairing, f.surface, g0, f.group, self.names
            )
            if f.n_tangents and f.mu > 0.0:
                cs.mu = np.full(f.p, f.mu)
                cs.tangents = self._tangent_rows(f, pairing)
            sets.append(cs)
        out = sets[0]
        for cs in sets[1:]:
            out = ContactSet.stack(out, cs)
        # Every family's groups index the one list of names (stacking would shift them).
        out.group = np.concatenate([f.group for f in self.families]).astype(np.int64)
        out.group_names = list(self.names)
        out.tol = self.tol
        return out

    def _tangent_rows(self, f: Family, pairing: Pairing) -> TangentRows:
        """The tangential rows of a family's points: t·(v_p − Σ ξ_i v_i), terms on the ranks
        owning their DOFs (not collective)."""
        n_t = f.n_tangents
        normal = np.where(pairing.paired[:, None], pairing.normal, [0.0, 0.0, 1.0])
        if f.free is not None:  # an unpaired point's row is empty: any normal off free
            normal = np.where(pairing.paired[:, None], normal, _off(f.free))
        t1, t2 = tangents_of(normal, f.free)
        tans = np.stack([t1, t2], axis=1)[:, :n_t]  # (p, n_t, 3)
        verts = f.surface.vertex_ids[f.surface.triangles[np.maximum(pairing.triangle, 0)]]
        p = f.p
        # Terms: (row, vertex, component, coefficient), the point's first, then its vertices'.
        row = np.arange(p * n_t).reshape(p, n_t)
        r = [
            np.repeat(row.ravel(), 3),
            np.broadcast_to(row[:, None, :, None], (p, 3, n_t, 3)).ravel(),
        ]
        v = [
            np.repeat(f.points, n_t * 3),
            np.broadcast_to(verts[:, :, None, None], (p, 3, n_t, 3)).ravel(),
        ]
        c = [
            np.tile(np.arange(3), p * n_t),
            np.broadcast_to(np.arange(3)[None, None, None, :], (p, 3, n_t, 3)).ravel(),
        ]
        k = [
            tans.reshape(-1),
            (-pairing.xi[:, :, None, None] * tans[:, None, :, :]).reshape(-1),
        ]
        rows = np.concatenate(r)
        vert = np.concatenate(v)
        comp = np.concatenate(c)
        val = np.concatenate(k)
        keep = pairing.paired[rows // n_t] & (val != 0.0)
        mine, dofs = owned_terms(self.sub, vert[keep], comp[keep])
        return TangentRows(
            np.repeat(np.arange(p, dtype=np.int64), n_t),
            rows[keep][mine].astype(np.int64),
            dofs,
            val[keep][mine].astype(np.float64),
        )

    def _current(self, u: FloatArray) -> FloatArray:
        """x = X + u of every vertex the families use (collective)."""
        U = np.zeros((self.ids.size, 3))
        U[self._pos] = u.reshape(-1, 3)[self._blocks]
        if self.comm.size > 1:  # a buffer reduction: the pickled one costs 0.1 ms a call
            self.comm.Allreduce(MPI.IN_PLACE, U, op=MPI.SUM)
        return self.X + U

    def _flatten(self, pairings: list[Pairing]) -> _Flat:
        """The pairings flat over the families (not collective)."""
        fam = list(zip(self.families, pairings, self._slot_s, strict=True))
        if not fam:
            z = np.zeros((0, 3))
            none = np.zeros(0, dtype=bool)
            return _Flat(np.zeros(0, np.int64), np.zeros((0, 3), np.int64), z, z, none, none)
        return _Flat(
            np.concatenate(self._slot_p).astype(np.int64),
            np.concatenate(
                [ss[f.surface.triangles[np.maximum(pr.triangle, 0)]] for f, pr, ss in fam]
            ).astype(np.int64),
            np.ascontiguousarray(np.concatenate([pr.xi for _, pr, _ in fam])),
            np.ascontiguousarray(np.concatenate([pr.normal for _, pr, _ in fam])),
            np.concatenate([pr.paired for _, pr, _ in fam]),
            np.concatenate([pr.paired & (f.vertices is None) for f, pr, _ in fam]),
        )

    @staticmethod
    def _split(
        flat: _Flat, x: FloatArray, tangential_of: npt.NDArray[np.bool_] | None = None
    ) -> tuple[FloatArray, FloatArray]:
        """Each point's x_p − Σ ξ_i x_i at the coordinates ``x`` of :attr:`ids` (or their
        displacements), split into its component along the normal (p_total,) and its
        tangential part (p_total, 3), the latter where ``tangential_of`` (default: on a
        triangle; zeros elsewhere). Not collective."""
        along = np.empty(flat.point.size)
        tangential = np.empty((flat.point.size, 3))
        offsets_over_pairings(
            np.ascontiguousarray(x),
            flat.point,
            flat.vertex,
            flat.xi,
            flat.normal,
            flat.on_triangle if tangential_of is None else tangential_of,
            along,
            tangential,
        )
        return along, tangential

    def slip(self, u: FloatArray) -> FloatArray:
        """Each point's slip over its surface (p_total, 3), m: the tangential part of
        u_p − Σ ξ_i u_i, its displacement less the surface's where it now touches, on its
        current pairing (zeros where unpaired) — the distance it has slid, whichever
        triangle it is on (collective: ``u`` the explicit side's owned DOFs)."""
        U = self._current(u) - self.X
        return self._split(self._flat, U, self._flat.paired)[1]

    def _drift(self, tangential: FloatArray, projected: dict[int, Pairing]) -> float:
        """The largest tangential drift of a point over its triangle since its pairing (m),
        from the points' tangential offsets now; +inf when a point that acts on a vertex has
        another allowed vertex nearer. ``projected``: the families of such points projected
        now (:meth:`_vertex_projections`), by index. Not collective."""
        d = tangential - (self.offsets if self.offsets is not None else 0.0)
        worst = float(np.sqrt(np.max(np.einsum("pj,pj->p", d, d), initial=0.0)))
        for j, now in projected.items():
            pairing = self.pairings[j]
            if np.any(now.triangle != pairing.triangle) or np.any(now.xi != pairing.xi):
                worst = np.inf
        return worst

    def _vertex_projections(self, x: FloatArray) -> dict[int, Pairing]:
        """The families whose points act on a vertex (``Family.vertices``), projected at the
        coordinates ``x``, by index (not collective)."""
        return {
            j: self._project(f, x[sp], x[ss])
            for j, (f, sp, ss) in enumerate(
                zip(self.families, self._slot_p, self._slot_s, strict=True)
            )
            if f.vertices is not None
        }

    def _gaps(self, flat: _Flat, x: FloatArray) -> FloatArray:
        """Each point's distance n·(x_p − Σ ξ_i x_i) + c_p for the pairings ``flat`` at the
        coordinates ``x`` of :attr:`ids`, :data:`OPEN_GAP` where unpaired (not
        collective)."""
        return self._distances(flat, self._split(flat, x)[0])

    def _distances(self, flat: _Flat, along: FloatArray) -> FloatArray:
        """:meth:`_gaps` from the points' components along their normals (:meth:`_split`)."""
        return np.where(flat.paired, along + self._offset, OPEN_GAP)

    def update(self, zone: Any, t: float) -> bool:
        """Before a macro step (collective): once the points slide, set the gaps to the
        current distances and, when a drift exceeds the threshold, pair every point again and
        give the zone its new rows. Returns whether the rows changed.

        Raises:
            SlidingError: a point ran off its surface's extent (on every rank).
        """
        x = self._current(zone.u)
        along, tangential = self._split(self._flat, x)
        if self.offsets is None:  # the first call: the start's offsets are no slide
            self.offsets = tangential
        # The vertex families' projections serve both the drift and the new pairing.
        projected = self._vertex_projections(x)
        drift = self._drift(tangential, projected)
        if not self.sliding and drift <= self.slide_tol:
            return False
        if not self.sliding:
            self.sliding, self.sliding_since = True, float(t)
        fresh = self._pair(x, t, projected)
        # The fresh pairings' distances are their gaps (+inf where unpaired): a clipped ξ
        # moves a point's foot within its triangle's plane only.
        exact = np.concatenate([pr.gap for pr in fresh]) + self._offset
        # A point projecting onto no triangle (an overhang across) keeps its rows' distance
        # until they are paired again.
        now = self._distances(self._flat, along)
        exact = np.where(exact < OPEN_GAP, exact, now)
        repair = drift > self.threshold
        if repair:
            self.pairings = fresh
            along, self.offsets = self._split(self._flat, x)
            self.repairs += 1
            now = self._distances(self._flat, along)
        # g0 + L u = exact, with L u = (the rows' distance now) − (theirs at X).
        ref = self._ref_gaps
        self.g0 = np.where(ref < OPEN_GAP, exact - (now - ref), OPEN_GAP)
        if repair:
            zone.set_contacts(self.rows())
        else:
            zone.set_contact_gaps(self.g0)
        return repair

    def _pair(
        self, x: FloatArray, t: float, projected: dict[int, Pairing] | None = None
    ) -> list[Pairing]:
        """Every point's projection on its deformed surface at the coordinates ``x`` (those
        of ``projected``'s families taken from it; not collective: every rank holds the same
        ``x``)."""
        pairings = []
        done = self._batch.project(x) | (projected or {})
        for j, (f, sp, ss) in enumerate(
            zip(self.families, self._slot_p, self._slot_s, strict=True)
        ):
            pairing = done[j] if j in done else self._project(f, x[sp], x[ss])
            self._check_paired(j, pairing, x[sp], t)
            pairings.append(pairing)
        return pairings

    def reach(self) -> dict[int, float]:
        """How far each labelled body (a wheel) can slide along its family's ``along`` axis,
        either way, before a point leaves its piece of surface (m), from t = 0; the first
        family's labels."""
        f = self.families[0]
        if f.along < 0 or not f.label.size:
            return {}
        extent = self._extents[0]
        s = self.X[self._slot_p[0], f.along]
        room = np.minimum(extent[:, 1] - s, s - extent[:, 0])
        return {int(k): float(room[f.label == k].min()) for k in np.unique(f.label)}

    def summary(self) -> dict[str, Any]:
        """How often the points were paired again, the drift that triggers it (m), and when
        the gaps began to follow the current projection (s; None: never, the rows and gaps
        of t = 0 throughout)."""
        return {
            "repairings": self.repairs,
            "repair_drift_m": self.threshold,
            "gaps_follow_from_s": self.sliding_since,
        }

    def state_dict(self) -> dict[str, Any]:
        """Each point's triangle, barycentric coordinates and normal, the gaps (a
        checkpoint)."""
        out: dict[str, Any] = {
            "repairs": self.repairs,
            "sliding": self.sliding,
            "sliding_since": -1.0 if self.sliding_since is None else self.sliding_since,
            "g0": self.g0.copy(),
            "offsets": np.zeros((0, 3)) if self.offsets is None else self.offsets.copy(),
        }
        for j, pairing in enumerate(self.pairings):
            out[f"triangle_{j}"] = pairing.triangle.copy()
            out[f"xi_{j}"] = pairing.xi.copy()
            out[f"normal_{j}"] = pairing.normal.copy()
            out[f"gap_{j}"] = pairing.gap.copy()
        return out

    def load_state_dict(self, state: dict[str, Any], zone: Any) -> None:
        """Restore the pairing and, when it is not the reference one, the zone's rows
        (collective)."""
        self.repairs = int(state["repairs"])
        self.pairings = [
            Pairing(
                np.asarray(state[f"triangle_{j}"], dtype=np.int64),
                np.asarray(state[f"xi_{j}"], dtype=np.float64),
                np.asarray(state[f"normal_{j}"], dtype=np.float64),
                np.asarray(state[f"gap_{j}"], dtype=np.float64),
            )
            for j in range(len(self.families))
        ]
        self.sliding = bool(state["sliding"])
        since = float(state["sliding_since"])
        self.sliding_since = None if since < 0.0 else since
        self.g0 = np.asarray(state["g0"], dtype=np.float64)
        offsets = np.asarray(state["offsets"], dtype=np.float64).reshape(-1, 3)
        self.offsets = offsets if offsets.shape[0] else None
        if self.repairs:
            zone.set_contacts(self.rows())
        elif self.sliding:
            zone.set_contact_gaps(self.g0)
