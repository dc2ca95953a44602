"""Points sliding on the beams of a line: a frame's wheels on its girders, its flanges on the
rail sides (THEORY.md §10, docs/theory-notes.md §17), re-paired as they slide (the relation
as data updated by a hook before each macro step, as :mod:`crane_fem.contact.sliding`).

A :class:`LineFamily` is a set of points acting on the 2-node beam elements of one line. A
point p is paired with the element (i, j) its position projects into, at the abscissa ξ
(N_i = 1 − ξ, N_j = ξ). The contact surface sits a rigid offset e = offset·n above the
beam's axis (a rail top): its point under p moves as x_c = Σ N_k (x_k + u_k + θ_k × e). The
normal row is

    g = g0 + n·(u_p − Σ N_k u_k) − Σ N_k θ_k·(e × n)

(the rotation terms vanish for an offset along the normal; they do not for the tangential
rows t·(v_p − Σ N_k (v_k + ω_k × e)), nor for the flanges' lateral rows). With a clearance c
each point also has two lateral rows (flanges), frictionless, c ∓ l·(x_p − x_c) ≥ 0, l = n × t
across the line.

g0 keeps each gap the current distance across re-pairings: at every macro step the points
are projected on the current line; a point that moved to another element, or by more than
:data:`REPAIR_FRACTION` of its element along it, gets new rows (the zone's
``set_contacts``), and every other gap is set to its exact distance (``set_contact_gaps``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt
from mpi4py import MPI

from crane_fem.contact.constraints import ContactSet, TangentRows
from crane_fem.contact.ropes import RopeRows
from crane_fem.contact.sliding import SlidingError
from crane_fem.contact.surface import owned_terms

__all__ = [
    "REPAIR_FRACTION",
    "LineContacts",
    "LineFamily",
    "LinePairing",
    "element_axes",
    "project_on_line",
    "row_coefficients",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

#: A point is paired again once its abscissa moved by this fraction of its element.
REPAIR_FRACTION = 0.05
#: Below this drift along its element (a fraction of it) since the last update, a point's
#: rows and gap stay as they are (the hook does nothing: no point slides).
SLIDE_FRACTION = 1e-4


@dataclass(frozen=True)
class LineFamily:
    """Points on the elements of one line.

    Attributes:
        points: (p,) global parent vertex ids of the points.
        elements: (e, 2) global vertex ids of the line's candidate elements.
        normal: (3,) the contact normal (unit; made orthogonal to each element).
        offset: the contact surface's distance above the axis along the normal (m).
        group: (p,) contact group of each point's normal row.
        shift: (p,) c_p added to each point's normal gap, its distance above the rail top
            (the preload's closing: a point pressed in by its penalty starts at 0).
        n_tangents: tangential rows per point with friction (0, 1: across only, 2: across
            and along).
        mu: Coulomb's coefficient of the normal rows.
        clearance: the flanges' lateral clearance (m), or None: no lateral rows.
        lateral_group: (p, 2) contact groups of each point's two lateral rows (inner: the
            side of +l, outer).
        label: (p,) the body each point belongs to, for messages (a wheel's number).
    """

    points: IntArray
    elements: IntArray
    normal: FloatArray
    offset: float
    group: IntArray
    shift: FloatArray
    n_tangents: int = 0
    mu: float = 0.0
    clearance: float | None = None
    lateral_group: IntArray = field(default_factory=lambda: np.zeros((0, 2), dtype=np.int64))
    label: IntArray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))

    @property
    def p(self) -> int:
        return int(self.points.size)

    @property
    def rows_per_point(self) -> int:
        return 1 if self.clearance is None else 3


@dataclass(frozen=True)
class LinePairing:
    """Each point's element (index into the family's, −1: none) and abscissa ξ ∈ [0, 1]."""

    element: IntArray
    xi: FloatArray


def element_axes(
    a: FloatArray, b: FloatArray, normal: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Per element (e, 3) from its ends' coordinates ``a``, ``b``: its unit tangent t, the
    contact normal made orthogonal to it n, and the lateral l = n × t."""
    d = b - a
    t = d / np.linalg.norm(d, axis=1)[:, None]
    n = normal[None, :] - np.einsum("ej,j->e", t, normal)[:, None] * t
    n /= np.linalg.norm(n, axis=1)[:, None]
    return t, n, np.cross(n, t)


def project_on_line(
    x: FloatArray,
    a: FloatArray,
    b: FloatArray,
    ends: npt.NDArray[np.bool_] | None = None,
    allowed: npt.NDArray[np.bool_] | None = None,
) -> tuple[IntArray, FloatArray, npt.NDArray[np.bool_]]:
    """Each point of ``x`` (p, 3) on the elements from ``a`` to ``b`` (e, 3): the nearest
    element whose span holds its projection (else, at a kink of the line that leaves a point
    offset above it between two elements' spans, the nearest element's nearer end), its
    abscissa ξ ∈ [0, 1] along it, and whether the point is over the line: not past one of
    its ends. ``ends``: (e, 2) whether each element's first and second vertex ends the line
    (default: the line is a chain, its ends the vertices of one element only). ``allowed``:
    (p, e) the elements each point may take (default all: several lines at once, each point
    on its own)."""
    d = b - a
    length2 = np.einsum("ej,ej->e", d, d)
    rel = x[:, None, :] - a[None, :, :]  # (p, e, 3)
    s = np.einsum("pej,ej->pe", rel, d) / length2[None, :]
    inside = (s >= -1e-9) & (s <= 1.0 + 1e-9)
    foot = a[None, :, :] + np.clip(s, 0.0, 1.0)[:, :, None] * d[None, :, :]
    dist = np.linalg.norm(x[:, None, :] - foot, axis=2)
    if allowed is not None:
        inside &= allowed
        dist[~allowed] = np.inf
    held = np.where(inside, dist, np.inf)
    rows = np.arange(x.shape[0])
    element = np.argmin(held, axis=1).astype(np.int64)
    none = ~np.isfinite(held[rows, element])
    element[none] = np.argmin(dist[none], axis=1)
    xi = np.clip(s[rows, element], 0.0, 1.0)
    if ends is None:
        ends = _line_ends(a, b)
    past = (s[rows, element] < -1e-9) & ends[element, 0]
    past |= (s[rows, element] > 1.0 + 1e-9) & ends[element, 1]
    return element, xi, ~(none & past)


def _dot(a: FloatArray, b: FloatArray) -> FloatArray:
    """Row-wise dot products of two (p, 3) arrays."""
    out: FloatArray = a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1] + a[:, 2] * b[:, 2]
    return out


def _cross(a: FloatArray, b: FloatArray) -> FloatArray:
    """Row-wise cross products of two (p, 3) arrays (np.cross costs ten times more on the
    few rows the hook before each macro step takes)."""
    return np.column_stack(
        [
            a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1],
            a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2],
            a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0],
        ]
    )


def _line_ends(a: FloatArray, b: FloatArray) -> npt.NDArray[np.bool_]:
    """(e, 2): whether each element's first and second end is a vertex of no other element
    (by coordinates, to 1e-9 of the line's size)."""
    pts = np.concatenate([a, b])
    scale = max(float(np.ptp(pts, axis=0).max(initial=0.0)), 1e-300)
    key = np.round(pts / (1e-9 * scale)).astype(np.int64)
    _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    once = counts[inverse.ravel()] == 1
    return np.column_stack([once[: a.shape[0]], once[a.shape[0] :]])


def row_coefficients(
    directions: FloatArray, xi: FloatArray, offset_vector: FloatArray
) -> FloatArray:
    """The coefficients (p, 3 vertices, 6 components) of the rows d·(u_p − Σ N_k (u_k +
    θ_k × e)) for each point's direction d (p, 3), abscissa ξ and rail offset e (p, 3): on
    the point's translations d, on each end k's translations −N_k d and rotations
    −N_k (e × d)."""
    p = xi.size
    N = np.stack([1.0 - xi, xi], axis=1)
    out = np.zeros((p, 3, 6))
    out[:, 0, :3] = directions
    moment = np.cross(offset_vector, directions)
    for k in range(2):
        out[:, 1 + k, :3] = -N[:, k, None] * directions
        out[:, 1 + k, 3:] = -N[:, k, None] * moment
    return out


class LineContacts:
    """The rows of some families of points on lines, re-paired as they slide (collective
    over the subdomain's communicator).

    Args:
        sub: the explicit subdomain holding the points and the elements (6 DOFs per node).
        families: the families, whose rows are stacked in this order.
        names: the contact group names.
        tol: the set's closing tolerance (m).
        reach_message: how a point running off its line is explained (formatted with
            ``label``, ``t``).
        point_name: what a point's label numbers, in messages ("wheel").
        static: rows that do not slide (points on a fixed plane), stacked after the
            families'; their groups index ``names`` too.
        ropes: ropes (crane_fem.contact.ropes), stacked last (the kernel follows their
            chords: no update).
    """

    def __init__(
        self,
        sub: Any,
        families: list[LineFamily],
        names: list[str],
        tol: float,
        reach_message: str = "",
        point_name: str = "point",
        static: ContactSet | None = None,
        ropes: RopeRows | None = None,
    ) -> None:
        self.static = static
        self.ropes = ropes
        if sub.bs != 6:
            raise ValueError("point-on-line contact needs beams (6 DOFs per node)")
        self.sub = sub
        self.comm: MPI.Comm = sub.submesh.comm
        self.families = families
        self.names = list(names)
        self.tol = float(tol)
        self.reach_message = reach_message
        self.point_name = point_name
        ids = [f.points for f in families] + [f.elements.ravel() for f in families]
        self.ids = np.unique(np.concatenate(ids)) if ids else np.zeros(0, dtype=np.int64)
        self._blocks, self._pos = sub.owned_dofs_of(self.ids)
        self.X = self._gather(np.asarray(sub.V.tabulate_dof_coordinates(), dtype=np.float64), 3)
        self._slot_p = [np.searchsorted(self.ids, f.points) for f in families]
        self._slot_e = [np.searchsorted(self.ids, f.elements) for f in families]
        self._axes = [
            element_axes(self.X[se[:, 0]], self.X[se[:, 1]], np.asarray(f.normal, dtype=float))
            for f, se in zip(families, self._slot_e, strict=True)
        ]
        # The points of every family, flat, and where their rows sit among the rows.
        self._all_points = np.concatenate(self._slot_p) if families else np.zeros(0, dtype=np.int64)
        none = [np.zeros(0)]
        self._offset = np.concatenate([np.full(f.p, f.offset) for f in families] or none)
        self._shift = np.concatenate([np.asarray(f.shift, float) for f in families] or none)
        rpp = np.concatenate([np.full(f.p, f.rows_per_point) for f in families] or none)
        rpp = rpp.astype(np.int64)
        self._n_rows = int(rpp.sum())
        self._normal_row = np.r_[0, np.cumsum(rpp)[:-1]].astype(np.int64) if rpp.size else rpp
        self._lateral_point = rpp == 3
        self._lateral_row = self._normal_row[self._lateral_point] + 1
        self._clearance = np.concatenate(
            [np.full(f.p, f.clearance if f.clearance is not None else 0.0) for f in families]
            or none
        )
        self._ends = [_line_ends(self.X[se[:, 0]], self.X[se[:, 1]]) for se in self._slot_e]
        # Every family's elements, flat, for the hook's one projection of all points: their
        # vertex slots, axes and line ends, where each point's family starts in them, and
        # the elements each point may take (its own line's).
        n_e = [int(f.elements.shape[0]) for f in families]
        first = np.r_[0, np.cumsum(n_e)[:-1]] if n_e else np.zeros(0)
        family_e = np.repeat(np.arange(len(families)), n_e)
        family_p = np.repeat(np.arange(len(families)), [f.p for f in families])
        self._allowed = family_p[:, None] == family_e[None, :]
        self._point_first: IntArray = first[family_p].astype(np.int64)
        self._cut = np.cumsum([f.p for f in families])[:-1]
        stack_i = [np.zeros((0, 2), dtype=np.int64)]
        stack_f = [np.zeros((0, 3))]
        self._flat_slots = np.concatenate(self._slot_e or stack_i).astype(np.int64)
        self._flat_ends = np.concatenate(self._ends or [np.zeros((0, 2), dtype=bool)])
        self._flat_n = np.concatenate([ax[1] for ax in self._axes] or stack_f)
        self._flat_lat = np.concatenate([ax[2] for ax in self._axes] or stack_f)
        self.repairs = 0
        self.pairings = [self._project(j, self._reference(), 0.0) for j in range(len(families))]
        self.g0 = self._values(self.pairings, self._reference())
        self._along_ref = self._along(self._reference())
        #: The rows' values at the reference positions for the current pairings (they change
        #: with the pairings only).
        self._reference_values = self.g0

    # -- geometry (not collective: every rank holds the same coordinates) -------------------
    def _gather(self, local: FloatArray, k: int) -> FloatArray:
        """(ids, k) values of the owned blocks' rows ``local`` (one row per block), the same
        on every rank (collective)."""
        out = np.zeros((self.ids.size, k))
        out[self._pos] = local[self._blocks, :k]
        if self.comm.size > 1:  # a buffer reduction
            self.comm.Allreduce(MPI.IN_PLACE, out, op=MPI.SUM)
        return out

    def _current(self, u: FloatArray) -> FloatArray:
        """(ids, 6): x = X + u and θ of every vertex the families use (collective)."""
        U = self._gather(u.reshape(-1, 6), 6)
        U[:, :3] += self.X
        return U

    def _project(self, j: int, x: FloatArray, t: float) -> LinePairing:
        """Family ``j``'s points on the current axis of its line (``x``: (ids, 6) positions
        and rotations).

        Raises:
            SlidingError: a point projects onto no element of its line.
        """
        f = self.families[j]
        se, sp = self._slot_e[j], self._slot_p[j]
        element, xi, found = project_on_line(
            x[sp, :3], x[se[:, 0], :3], x[se[:, 1], :3], self._ends[j]
        )
        if not np.all(found):
            k = int(np.flatnonzero(~found)[0])
            label = int(f.label[k]) if f.label.size else k
            raise SlidingError(
                self.reach_message.format(label=label, t=t)
                if self.reach_message
                else f"{self.point_name} {label} left its line at t = {t:.6g} s (its point "
                "projects onto no element of the line's explicit part)"
            )
        return LinePairing(element, xi)

    def _row_terms(self, j: int, pairing: LinePairing) -> tuple[FloatArray, FloatArray, IntArray]:
        """Per point the coefficients (p, rows, 3 vertices, 6 components) of its normal (and
        lateral) rows, those of its tangential rows (p, 2, 3, 6: across, along), and its
        vertex slots (p, 3): the point, the element's ends."""
        f = self.families[j]
        t_e, n_e, l_e = self._axes[j]
        el = pairing.element
        t, n, lat = t_e[el], n_e[el], l_e[el]
        e = f.offset * n  # (p, 3)

        def coefficients(direction: FloatArray) -> FloatArray:
            return row_coefficients(direction, pairing.xi, e)

        rows = [coefficients(n)]
        if f.clearance is not None:
            rows += [-coefficients(lat), coefficients(lat)]
        tangents = np.stack([coefficients(lat), coefficients(t)], axis=1)  # across, along
        slots = np.column_stack([self._slot_p[j], self._slot_e[j][el]]).astype(np.int64)
        return np.stack(rows, axis=1), tangents, slots

    def _reference(self) -> FloatArray:
        """(ids, 6): the reference positions, no rotation."""
        return np.c_[self.X, np.zeros_like(self.X)]

    def _flat(self, pairings: list[LinePairing]) -> tuple[IntArray, FloatArray]:
        """Each point's element in the flat list of all families' and its ξ."""
        if not pairings:
            return np.zeros(0, dtype=np.int64), np.zeros(0)
        el = np.concatenate([pr.element for pr in pairings]) + self._point_first
        return el, np.concatenate([pr.xi for pr in pairings])

    def _project_all(self, x: FloatArray, t: float) -> list[LinePairing]:
        """Every family's points on the current axes of their lines (``x``: (ids, 6)), in
        one projection (as :meth:`_project` family by family).

        Raises:
            SlidingError: a point projects onto no element of its line.
        """
        sl = self._flat_slots
        element, xi, found = project_on_line(
            x[self._all_points, :3],
            x[sl[:, 0], :3],
            x[sl[:, 1], :3],
            self._flat_ends,
            self._allowed,
        )
        if not np.all(found):  # the first family with a point off its line raises
            return [self._project(j, x, t) for j in range(len(self.families))]
        element -= self._point_first
        return [
            LinePairing(e, z)
            for e, z in zip(np.split(element, self._cut), np.split(xi, self._cut), strict=True)
        ]

    def _along(self, x: FloatArray) -> FloatArray:
        """Each point's offset along its element from its paired foot, as a fraction of the
        element's length, at the positions ``x`` (ids, 6) (not collective)."""
        if not self.families:
            return np.zeros(0)
        el, xi = self._flat(self.pairings)
        ends = self._flat_slots[el]
        a, b = x[ends[:, 0], :3], x[ends[:, 1], :3]
        d = b - a
        foot = a + xi[:, None] * d
        return _dot(x[self._all_points, :3] - foot, d) / _dot(d, d)

    def _relative(
        self, pairings: list[LinePairing], x: FloatArray
    ) -> tuple[IntArray, FloatArray, FloatArray]:
        """Each point's element (in the flat list), x_p − Σ N_k x_k and Σ N_k θ_k for the
        ``pairings`` at the positions (or displacements) and rotations ``x`` (ids, 6) (not
        collective)."""
        el, xi = self._flat(pairings)
        ends, sp = self._flat_slots[el], self._all_points
        N0, N1 = (1.0 - xi)[:, None], xi[:, None]
        rel = x[sp, :3] - N0 * x[ends[:, 0], :3] - N1 * x[ends[:, 1], :3]
        theta = N0 * x[ends[:, 0], 3:] + N1 * x[ends[:, 1], 3:]
        return el, rel, theta

    def _values(self, pairings: list[LinePairing], x: FloatArray) -> FloatArray:
        """Every row's gap for the ``pairings`` at the positions and rotations ``x`` (ids,
        6): the normal rows' distance above the rail top plus c_p (``shift``), the lateral
        rows' clearance left: the rows of :meth:`rows` applied to ``x``, evaluated for all
        points at once (it runs before every macro step)."""
        if not self.families:
            return np.zeros(0)
        el, rel, theta = self._relative(pairings, x)
        n, lat = self._flat_n[el], self._flat_lat[el]
        e = self._offset[:, None] * n
        # n·(x_p − Σ N_k x_k) − Σ N_k θ_k·(e × n); the rail top is offset above the axis.
        normal = _dot(rel, n) - _dot(theta, _cross(e, n)) + self._shift - self._offset
        side = _dot(rel, lat) - _dot(theta, _cross(e, lat))
        out = np.empty(self._n_rows)
        out[self._normal_row] = normal
        has = self._lateral_point
        out[self._lateral_row] = self._clearance[has] - side[has]
        out[self._lateral_row + 1] = self._clearance[has] + side[has]
        return out

    # -- rows -------------------------------------------------------------------------------
    def rows(self) -> ContactSet:
        """The current rows of every family, stacked point by point (normal, then the two
        lateral rows of a point with clearance) (not collective)."""
        none_i, none_f = np.zeros(0, dtype=np.int64), np.zeros(0)
        r_all, v_all, c_all = [none_i], [none_i], [none_i]
        k_all, groups, mus = [none_f], [none_i], [none_f]
        tr_point: list[IntArray] = []
        tr_rows: list[IntArray] = []
        tr_vert: list[IntArray] = []
        tr_comp: list[IntArray] = []
        tr_val: list[FloatArray] = []
        start = 0
        n_t_total = 0
        for j, (f, pairing) in enumerate(zip(self.families, self.pairings, strict=True)):
            coeff, tan_coeff, slots = self._row_terms(j, pairing)
            rpp = f.rows_per_point
            row = start + np.arange(f.p * rpp).reshape(f.p, rpp)
            verts = self.ids[slots]  # (p, 3)
            r_all.append(np.broadcast_to(row[:, :, None, None], coeff.shape).ravel())
            v_all.append(np.broadcast_to(verts[:, None, :, None], coeff.shape).ravel())
            c_all.append(np.broadcast_to(np.arange(6)[None, None, None, :], coeff.shape).ravel())
            k_all.append(coeff.ravel())
            grp = np.zeros((f.p, rpp), dtype=np.int64)
            grp[:, 0] = f.group
            if f.clearance is not None:
                grp[:, 1:] = f.lateral_group
            groups.append(grp.ravel())
            mu = np.zeros((f.p, rpp))
            mu[:, 0] = f.mu if f.n_tangents else 0.0
            mus.append(mu.ravel())
            if f.n_tangents and f.mu > 0.0:
                nt = f.n_tangents
                tan = tan_coeff[:, :nt]  # (p, nt, 3, 6)
                trow = n_t_total + np.arange(f.p * nt).reshape(f.p, nt)
                tr_point.append(np.repeat(row[:, 0], nt))
                tr_rows.append(np.broadcast_to(trow[:, :, None, None], tan.shape).ravel())
                tr_vert.append(np.broadcast_to(verts[:, None, :, None], tan.shape).ravel())
                tr_comp.append(
                    np.broadcast_to(np.arange(6)[None, None, None, :], tan.shape).ravel()
                )
                tr_val.append(tan.ravel())
                n_t_total += f.p * nt
            start += f.p * rpp
        rows, vert, comp, val = (np.concatenate(a) for a in (r_all, v_all, c_all, k_all))
        keep = val != 0.0
        mine, dofs = owned_terms(self.sub, vert[keep], comp[keep])
        mu_all = np.concatenate(mus)
        tangents: TangentRows | None = None
        if tr_point:
            trv, trc, trval = (np.concatenate(a) for a in (tr_vert, tr_comp, tr_val))
            trr = np.concatenate(tr_rows)
            tkeep = trval != 0.0
            tmine, tdofs = owned_terms(self.sub, trv[tkeep], trc[tkeep])
            tangents = TangentRows(
                np.concatenate(tr_point).astype(np.int64),
                trr[tkeep][tmine].astype(np.int64),
                tdofs,
                trval[tkeep][tmine].astype(np.float64),
            )
        out = ContactSet(
            self.comm,
            self.g0.copy(),
            rows[keep][mine].astype(np.int64),
            dofs,
            val[keep][mine].astype(np.float64),
            np.concatenate(groups).astype(np.int64),
            list(self.names),
            tol=self.tol,
            mu=mu_all if np.any(mu_all > 0.0) else None,
            tangents=tangents,
        )
        parts = [
            extra
            for extra in (self.static, self.ropes.rows() if self.ropes is not None else None)
            if extra is not None and extra.p
        ]
        for extra in parts:
            both = ContactSet.stack(out, extra)
            # Both sets' groups index the one list of names (stacking would shift them).
            both.group = np.concatenate([out.group, extra.group]).astype(np.int64)
            both.group_names = list(self.names)
            both.tol = self.tol
            out = both
        return out

    # -- the hook before a macro step -------------------------------------------------------
    def update(self, zone: Any, t: float) -> bool:
        """Before a macro step (collective): pair the points on the current lines; new rows
        where a point changed element or moved along it by more than the threshold, else the
        gaps set to the current distances. Returns whether the rows changed.

        Raises:
            SlidingError: a point left its line (on every rank: the data are global).
        """
        x = self._current(zone.u)
        along = self._along(x)
        if np.all(np.abs(along - self._along_ref) <= SLIDE_FRACTION):
            # No point moved along its line since the rows and gaps were set: they hold
            # (the normal motion is in the rows; a drift this small moves a gap by the
            # line's slope times it).
            return False
        fresh = self._project_all(x, t)
        (el_old, xi_old), (el_new, xi_new) = self._flat(self.pairings), self._flat(fresh)
        repair = bool(np.any((el_old != el_new) | (np.abs(xi_new - xi_old) > REPAIR_FRACTION)))
        exact = self._values(fresh, x)
        if repair:
            self.pairings = fresh
            self.repairs += 1
            self._reference_values = self._values(fresh, self._reference())
            self._along_ref = self._along(x)
        else:
            self._along_ref = along
        # g0 + L u = the current distances, L the active rows (linear in the positions).
        lu = self._values(self.pairings, x) - self._reference_values
        self.g0 = exact - lu
        if repair:
            zone.set_contacts(self.rows())
        else:
            fixed = self.static.g0 if self.static is not None else np.zeros(0)
            rope = self.ropes.g0 if self.ropes is not None else np.zeros(0)
            zone.set_contact_gaps(np.concatenate([self.g0, fixed, rope]))
        return repair

    # -- what the monitors and the summary read -------------------------------------------
    def slip(self, u: FloatArray) -> FloatArray:
        """Each point's displacement relative to the contact surface's point under it, less
        its normal part (p_total, 3), m: u_p − Σ N_k (u_k + θ_k × e), the line's point
        carried by its section's rotation to the surface e = offset n above the axis, as the
        friction rows see it (collective)."""
        if not self.families:
            return np.zeros((0, 3))
        el, rel, theta = self._relative(self.pairings, self._gather(u.reshape(-1, 6), 6))
        n = self._flat_n[el]
        rel = rel - _cross(theta, self._offset[:, None] * n)
        out: FloatArray = rel - np.einsum("pj,pj->p", rel, n)[:, None] * n
        return out

    def slip_axes(self) -> dict[int, FloatArray]:
        """Per contact group of the families' points (index into :attr:`names`): the unit
        directions (2, 3) its slip is resolved along — its line's mean tangent t — and across,
        t × n = −l (a rail along y under a normal along z: x). Not collective."""
        out: dict[int, FloatArray] = {}
        for f, (t_e, _, _) in zip(self.families, self._axes, strict=True):
            chord = t_e.sum(axis=0)[None, :]  # the line's mean direction, as one element
            t, _, lat = element_axes(np.zeros((1, 3)), chord, np.asarray(f.normal, dtype=float))
            for g in np.unique(f.group):
                out[int(g)] = np.stack([t[0], -lat[0]])
        return out

    def reach(self) -> dict[int, float]:
        """How far each labelled body can slide along its line either way before a point
        leaves the line's candidate elements (m), from t = 0; the first family's labels."""
        if not self.families or not self.families[0].label.size:
            return {}
        f, se = self.families[0], self._slot_e[0]
        t_e = self._axes[0][0]
        a = self.X[se[:, 0]]
        axis = t_e[0]
        s_nodes = np.concatenate([a @ axis, self.X[se[:, 1]] @ axis])
        s = self.X[self._slot_p[0]] @ axis
        room = np.minimum(s_nodes.max() - s, s - s_nodes.min())
        return {int(k): float(room[f.label == k].min()) for k in np.unique(f.label)}

    def summary(self) -> dict[str, Any]:
        """How often the points were paired again."""
        return {"repairings": self.repairs, "repair_fraction": REPAIR_FRACTION}

    def state_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "repairs": self.repairs,
            "g0": self.g0.copy(),
            "along": self._along_ref.copy(),
        }

        for j, pairing in enumerate(self.pairings):
            out[f"element_{j}"] = pairing.element.copy()
            out[f"xi_{j}"] = pairing.xi.copy()
        return out

    def load_state_dict(self, state: dict[str, Any], zone: Any) -> None:
        """Restore the pairings and the gaps, and give the zone their rows (collective)."""
        self.repairs = int(state["repairs"])
        self.pairings = [
            LinePairing(
                np.asarray(state[f"element_{j}"], dtype=np.int64),
                np.asarray(state[f"xi_{j}"], dtype=np.float64),
            )
            for j in range(len(self.families))
        ]
        self.g0 = np.asarray(state["g0"], dtype=np.float64)
        self._along_ref = np.asarray(state["along"], dtype=np.float64)
        self._reference_values = self._values(self.pairings, self._reference())
        zone.set_contacts(self.rows())
