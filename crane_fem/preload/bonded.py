"""Static self-weight preload of a structure of the user's own (a gmsh model, a frame): its
contact points held on what they touch while closed.

K u = f_g with every closed point bonded to its triangle by a stiff spring
k_p |u_p − Σ ξ_i u_i|² in all three directions (the normal and two tangents at once: they are
orthonormal, so the sum of their three rank-one springs is k_p (w wᵀ ⊗ I₃) with
w = [1, −ξ_a, −ξ_b, −ξ_c]). Bonding the tangents too keeps a body that rests on another free
of rigid modes without extra supports; with friction the run starts from that tangential
force (it holds while below μ N), frictionless it is released at t = 0. The normal direction
is unilateral, settled by a primal–dual active set as the crane's preload
(crane_fem.preload.crane): a point in tension opens, an open point that penetrates closes.
The residual interpenetration F/k_p is removed from the gaps of the dynamic run.

A frame's points (on a beam's line, on a plane) are tied the same way by their own three
rows (the normal, the two tangents), each a combination of the 6 DOFs of the point and of
the element's ends (the rail top's offset makes the tangential rows turn with the beam):
``BondedPoints.rows``; the spring is then k_p Σ_d r_d r_dᵀ. A point on a line (a wheel set
down on its rail) carries no tangential force at rest: its tangential rows are tied at
:data:`LOOSE_TIE` k_p only, enough to hold the trolley's rigid sliding (``BondedPoints.loose``;
``crane-fem modes`` keeps them tied as firmly as the normal). A gmsh model's rolling points
(``[[contact]] rolling``: free-rolling wheels) are likewise tied at :data:`LOOSE_TIE` k_p along
their rolling direction only (``BondedPoints.free``).
"""

from __future__ import annotations

from dataclasses import dataclass

import dolfinx
import dolfinx.fem.petsc
import numpy as np
import numpy.typing as npt
import ufl
from mpi4py import MPI
from petsc4py import PETSc

from crane_fem.contact.ropes import RopeSpec
from crane_fem.errors import CraneFemError
from crane_fem.formulations import CellFields, Formulation, coefficient
from crane_fem.geometry.tagged import TaggedMesh
from crane_fem.model import assemble_operators
from crane_fem.preload.crane import Preload, vertex_blocks
from crane_fem.subdomains import PointMasses

__all__ = ["LOOSE_TIE", "BondedPoints", "bonded_preload", "lu_solve"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

#: A loose point's tangential tie in the static preload, relative to k_p. Tied as firmly as
#: its normal, a trolley's four wheels resist the rail tops' shortening as the girders sag
#: (2.3 kN along each wheel of demos/frame_crane.toml, above its 1.4 kN weight) and the run
#: releases that force at t = 0: the wheels lift. At 1e-9 k_p the tie only removes the
#: trolley's rigid sliding (a 0.3 Hz spring for it) and holds 1e-9 of that force.
LOOSE_TIE = 1e-9


@dataclass(frozen=True)
class BondedPoints:
    """Contact points on their triangles in the reference configuration.

    Attributes:
        ids: (p, 4) global parent vertex ids: the point, then its triangle's vertices.
        weights: (p, 4) the row's weights [1, −ξ_a, −ξ_b, −ξ_c].
        normal: (p, 3) unit normals of the triangles (out of the surface's body).
        gap: (p,) gap at X (m).
        group: (p,) contact group of each point.
        rows: None (the relative displacement u_p − Σ ξ_i u_i, the weights times I₃), or
            (p, 3, k, bs) the coefficients of each point's three rows on the DOFs of its
            vertices, the normal row first.
        loose: per point, whether it carries no tangential force at rest (a frame's point on
            a line: a wheel set down on its rail), so that the static preload ties its
            tangential rows only weakly (:data:`LOOSE_TIE`); None: none.
        free: (p, 3) per point (``rows`` None), the unit direction it rolls along freely (a
            zero row: none), along which the static preload ties it only weakly
            (:data:`LOOSE_TIE`: no force at rest along it); None: none.
    """

    ids: IntArray
    weights: FloatArray
    normal: FloatArray
    gap: FloatArray
    group: IntArray
    rows: FloatArray | None = None
    loose: npt.NDArray[np.bool_] | None = None
    free: FloatArray | None = None

    def spring(self, i: int, k_p: float, bs: int, static: bool = False) -> FloatArray:
        """k_p times the sum of point ``i``'s rows' outer products (k bs × k bs); in the
        static preload (``static``), a loose point's tangential rows, or a rolling point's
        direction, at :data:`LOOSE_TIE` k_p."""
        if self.rows is None:
            w = self.weights[i]
            tie = np.eye(bs)
            if static and self.free is not None and np.any(self.free[i]):
                n = self.normal[i]
                d = self.free[i] - (self.free[i] @ n) * n  # in the triangle's plane
                d /= np.linalg.norm(d)
                tie = tie - (1.0 - LOOSE_TIE) * np.outer(d, d)
            ke = np.asarray(k_p * np.kron(np.outer(w, w), tie), dtype=np.float64)
            return ke
        r = self.rows[i].reshape(3, -1)
        if static and self.loose is not None and self.loose[i]:
            r = r * np.sqrt([1.0, LOOSE_TIE, LOOSE_TIE])[:, None]
        out: FloatArray = k_p * (r.T @ r)
        return out

    def normal_motion(self, disp: FloatArray) -> FloatArray:
        """Each point's motion along its normal (p,) for the vertex displacements ``disp``
        (n_vertices, bs): n·(u_p − Σ ξ_i u_i), or its normal row's value."""
        if self.rows is None:
            rel = np.einsum("pk,pkj->pj", self.weights, disp[self.ids])  # u_p − Σ ξ u_i
            out: FloatArray = np.einsum("pj,pj->p", self.normal, rel)
            return out
        return np.asarray(np.einsum("pkc,pkc->p", self.rows[:, 0], disp[self.ids]))


def bonded_preload(
    tagged: TaggedMesh,
    points: BondedPoints,
    n_groups: int,
    formulation: Formulation,
    fields: CellFields,
    fixed_vertices: IntArray,
    gravity: FloatArray,
    touching: float,
    pinned_vertices: IntArray | None = None,
    point_masses: PointMasses | None = None,
    ropes: tuple[RopeSpec, FloatArray] | None = None,
    held_rotations: IntArray | None = None,
) -> Preload:
    """Solve the self-weight equilibrium with the closed contact points bonded (collective).

    Args:
        n_groups: number of contact groups (the size of ``wheel_force``: per group).
        formulation, fields: the model's element formulation and the material (and section)
            of every local parent cell (owned and ghost).
        fixed_vertices: clamped global vertex ids; ``pinned_vertices``: those whose
            translations only are fixed.
        point_masses: masses carried at vertices (their weight is part of the load).
        touching: a point whose gap at X is at most this (m) starts closed.
        ropes: a frame's ropes and their ends' coordinates (n, 2, 3): a rope taut at X
            (within ``touching`` of its length) holds as a linear spring k between its ends'
            translations while in tension (its force along it joins its group's).

    Returns:
        The preload; ``pair_force`` per point and ``wheel_force`` per contact group (N,
        compressive), ``weight`` the structure's weight, ``support_reaction`` 0 (no
        auxiliary support).

    Raises:
        CraneFemError: the solve failed (a body held neither by a support nor by a closed
            contact), or the active set did not settle.
    """
    msh = tagged.mesh
    comm = msh.comm
    V = formulation.space(msh)
    bs = formulation.bs
    n_t = formulation.translations
    gv, blocks = vertex_blocks(V)
    imap = V.dofmap.index_map
    n_own = imap.size_local
    clamped = blocks[np.isin(gv, fixed_vertices)].astype(np.int64)
    fixed_dofs = (clamped[:, None] * bs + np.arange(bs)).ravel()
    if pinned_vertices is not None and pinned_vertices.size:
        pinned = blocks[np.isin(gv, pinned_vertices)].astype(np.int64)
        fixed_dofs = np.union1d(fixed_dofs, (pinned[:, None] * bs + np.arange(n_t)).ravel())
    if held_rotations is not None and held_rotations.size:
        held = blocks[np.isin(gv, held_rotations)].astype(np.int64)
        comps = np.arange(n_t, bs)
        fixed_dofs = np.union1d(fixed_dofs, (held[:, None] * bs + comps).ravel())
    extra = None
    if point_masses is not None and point_masses.vertices.size:
        owned = gv[:n_own]
        at = np.flatnonzero(np.isin(owned, point_masses.vertices))
        extra = np.zeros(n_own * bs)
        extra.reshape(-1, bs)[at] = point_masses.values[
            np.searchsorted(point_masses.vertices, owned[at]), :bs
        ]
    K, lumped, _ = assemble_operators(formulation, V, fields, fixed_dofs, False, extra)
    g = np.asarray(gravity, dtype=np.float64)
    gb = np.zeros(bs)
    gb[:n_t] = g[:n_t]
    f = (lumped.reshape(-1, bs) * gb[None, :]).ravel()
    f[fixed_dofs[fixed_dofs < n_own * bs]] = 0.0

    owned_gv = gv[:n_own]
    rope_ends = np.zeros(0, dtype=np.int64) if ropes is None else np.r_[ropes[0].a, ropes[0].b]
    sel = np.isin(owned_gv, np.r_[points.ids.ravel(), rope_ends])
    gblock = np.asarray(imap.local_to_global(blocks[:n_own][sel].astype(np.int32)), dtype=np.int64)
    block_of: dict[int, int] = {}
    for ids, gb in comm.allgather((owned_gv[sel], gblock)):
        block_of.update(zip(ids.tolist(), gb.tolist(), strict=True))
    diag = K.getDiagonal()
    k_p = comm.allreduce(float(np.max(diag.array_r, initial=0.0)), MPI.MAX)
    diag.destroy()
    # Each point's 12 DOFs, added by the rank owning the point's vertex.
    mine = set(owned_gv[sel].tolist())
    dofs = [
        [bs * block_of[int(v)] + c for v in row for c in range(bs)] if int(row[0]) in mine else None
        for row in points.ids
    ]
    rope = _RopeSprings(ropes, block_of, mine, bs, touching)
    f += rope.pretension(owned_gv)
    K.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)  # type: ignore[arg-type]
    for idx in [*dofs, *rope.dofs]:
        if idx is not None:
            zeros = np.zeros(len(idx) ** 2).tolist()
            K.setValues(idx, idx, zeros, addv=True)  # addv=True: ADD_VALUES
    K.assemble()
    n_vertices = msh.topology.index_map(0).size_global

    def solve(active: npt.NDArray[np.bool_], taut: npt.NDArray[np.bool_]) -> FloatArray:
        Ka = K.copy()
        for i in np.flatnonzero(active):
            idx = dofs[i]
            if idx is not None:
                ke = points.spring(int(i), k_p, bs, static=True)
                Ka.setValues(idx, idx, ke.ravel().tolist(), addv=True)
        rope.add(Ka, taut)
        Ka.assemble()
        x = lu_solve(Ka, f, "crane_fem_bonded_preload_")
        Ka.destroy()
        if x is None:
            raise CraneFemError(
                "static preload: the self-weight solve failed: a body is held neither by a "
                "[[support]] nor by a closed contact (check the supports and that every body "
                "rests on another with its contact surfaces touching at t = 0)"
            )
        u_own = x.reshape(-1, bs)
        disp = np.zeros((n_vertices, bs))
        for ids, vals in comm.allgather((owned_gv, u_own)):
            disp[ids] = vals
        return disp

    active = points.gap <= touching
    taut = rope.taut0.copy()
    force = np.zeros(points.gap.size)
    tension = np.zeros(taut.size)
    disp = np.zeros((n_vertices, bs))
    for _ in range(50):
        disp = solve(active, taut)
        dn = points.normal_motion(disp)
        force = np.where(active, -k_p * dn, 0.0)  # compressive on the point
        tension = rope.tension(disp, taut)
        tol = 1e-6 * float(np.max(np.abs(np.r_[force, tension]), initial=0.0))
        new = (active & (force > -tol)) | (~active & (points.gap + dn < -tol / k_p))
        new_taut = (taut & (tension > -tol)) | (~taut & (rope.stretch(disp) > tol / rope.k_max))
        if np.array_equal(new, active) and np.array_equal(new_taut, taut):
            break
        active, taut = new, new_taut
    else:
        K.destroy()
        raise CraneFemError("static preload: the contact active set did not settle in 50 passes")
    K.destroy()
    dx = ufl.dx(domain=msh)
    area = fields.section.A if fields.section is not None else 1.0
    rho = coefficient(msh, fields.rho) * coefficient(msh, area)
    total = comm.allreduce(dolfinx.fem.assemble_scalar(dolfinx.fem.form(rho * dx)), MPI.SUM)
    if point_masses is not None:
        total += float(point_masses.values[:, 0].sum())
    groups = np.bincount(points.group, weights=force, minlength=n_groups)
    if ropes is not None:
        np.add.at(groups, ropes[0].group, tension)
    return Preload(
        disp,
        force,
        groups,
        float(np.linalg.norm(g)) * float(total),
        0.0,
        float(np.max(np.abs(force), initial=0.0) / k_p) if k_p > 0.0 else 0.0,
        active,
    )


def lu_solve(A: PETSc.Mat, rhs: FloatArray, prefix: str) -> FloatArray | None:
    """A⁻¹ rhs on this rank's rows by MUMPS LU (options under ``prefix``), or None on every
    rank when the factorisation fails or the solution is not finite (collective)."""
    comm = A.getComm().tompi4py()
    b, x = A.createVecRight(), A.createVecRight()
    b.array[:] = rhs
    ksp = PETSc.KSP().create(A.getComm())
    ksp.setOptionsPrefix(prefix)
    ksp.setOperators(A)
    ksp.setType("preonly")
    pc = ksp.getPC()
    pc.setType("lu")
    pc.setFactorSolverType("mumps")
    ksp.setFromOptions()
    ksp.setErrorIfNotConverged(False)
    try:
        ksp.solve(b, x)
        failed = bool(ksp.is_diverged)
    except PETSc.Error:
        failed = True
    out = np.array(x.array_r, dtype=np.float64)
    ok = comm.allreduce(not failed and bool(np.all(np.isfinite(out))), MPI.LAND)
    for obj in (ksp, b, x):
        obj.destroy()
    return out if ok else None


class _RopeSprings:
    """A frame's ropes in the preload: a taut rope is the spring k d dᵀ between its ends'
    translations (d from a to b at X), with the pretension k (ℓ_X − L) where its length at X
    exceeds its rest length."""

    def __init__(
        self,
        ropes: tuple[RopeSpec, FloatArray] | None,
        block_of: dict[int, int],
        mine: set[int],
        bs: int,
        touching: float,
    ) -> None:
        self.spec = ropes[0] if ropes is not None else None
        n = 0 if self.spec is None else self.spec.n
        X = ropes[1] if ropes is not None else np.zeros((0, 2, 3))
        chord = X[:, 1] - X[:, 0]
        self.length = np.linalg.norm(chord, axis=1)
        self.d = chord / np.maximum(self.length, 1e-300)[:, None]
        self.bs = bs
        rest = self.spec.length if self.spec is not None else np.zeros(0)
        self.s0 = np.maximum(self.length - rest, 0.0)
        self.taut0 = self.length >= rest - touching
        self.k = self.spec.stiffness if self.spec is not None else np.zeros(0)
        self.k_max = float(self.k.max(initial=1.0))
        self.dofs: list[list[int] | None] = []
        for r in range(n):
            assert self.spec is not None
            a, b = int(self.spec.a[r]), int(self.spec.b[r])
            self.dofs.append(
                [bs * block_of[v] + c for v in (a, b) for c in range(3)] if a in mine else None
            )

    def pretension(self, owned_gv: IntArray) -> FloatArray:
        """The pretension's nodal forces on the owned DOFs (N)."""
        out = np.zeros(owned_gv.size * self.bs)
        if self.spec is None:
            return out
        for r in np.flatnonzero(self.taut0 & (self.s0 > 0.0)):
            pull = self.k[r] * self.s0[r] * self.d[r]
            for v, sign in ((self.spec.a[r], 1.0), (self.spec.b[r], -1.0)):
                at = np.flatnonzero(owned_gv == v)
                for blk in at:
                    out[self.bs * blk : self.bs * blk + 3] += sign * pull
        return out

    def add(self, K: PETSc.Mat, taut: npt.NDArray[np.bool_]) -> None:
        """Add the taut ropes' springs (not collective: each by the rank owning its a), in
        all three directions: a hanging load has no lateral stiffness of its own in the
        linear statics (a pendulum's is its tension's), and under gravity the lateral ties
        carry nothing (as a contact's tangential ties)."""
        for r in np.flatnonzero(taut):
            idx = self.dofs[r]
            if idx is None:
                continue
            D = np.eye(3)
            ke = self.k[r] * np.block([[D, -D], [-D, D]])
            K.setValues(idx, idx, ke.ravel().tolist(), addv=True)  # addv=True: ADD_VALUES

    def stretch(self, disp: FloatArray) -> FloatArray:
        """Each rope's length less its rest length for the vertex displacements (m)."""
        if self.spec is None:
            return np.zeros(0)
        du = disp[self.spec.b, :3] - disp[self.spec.a, :3]
        return np.asarray(self.length - self.spec.length + np.einsum("rj,rj->r", self.d, du))

    def tension(self, disp: FloatArray, taut: npt.NDArray[np.bool_]) -> FloatArray:
        """The taut ropes' tension (N; 0 for a slack one)."""
        return np.where(taut, self.k * self.stretch(disp), 0.0)
