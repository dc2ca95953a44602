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
``BondedPoints.rows``; the spring is then k_p Σ_d r_d r_dᵀ.
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

from crane_fem.errors import CraneFemError
from crane_fem.formulations import CellFields, Formulation, coefficient
from crane_fem.geometry.tagged import TaggedMesh
from crane_fem.model import assemble_operators
from crane_fem.preload.crane import Preload, vertex_blocks
from crane_fem.subdomains import PointMasses

__all__ = ["BondedPoints", "bonded_preload"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


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
    """

    ids: IntArray
    weights: FloatArray
    normal: FloatArray
    gap: FloatArray
    group: IntArray
    rows: FloatArray | None = None

    def spring(self, i: int, k_p: float, bs: int) -> FloatArray:
        """k_p times the sum of point ``i``'s rows' outer products (k bs × k bs)."""
        if self.rows is None:
            w = self.weights[i]
            ke = np.asarray(k_p * np.kron(np.outer(w, w), np.eye(bs)), dtype=np.float64)
            return ke
        r = self.rows[i].reshape(3, -1)
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
    sel = np.isin(owned_gv, points.ids.ravel())
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
    K.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)  # type: ignore[arg-type]
    for idx in dofs:
        if idx is not None:
            zeros = np.zeros(len(idx) ** 2).tolist()
            K.setValues(idx, idx, zeros, addv=True)  # addv=True: ADD_VALUES
    K.assemble()
    n_vertices = msh.topology.index_map(0).size_global

    def solve(active: npt.NDArray[np.bool_]) -> FloatArray:
        Ka = K.copy()
        for i in np.flatnonzero(active):
            idx = dofs[i]
            if idx is not None:
                ke = points.spring(int(i), k_p, bs)
                Ka.setValues(idx, idx, ke.ravel().tolist(), addv=True)
        Ka.assemble()
        rhs, sol = Ka.createVecRight(), Ka.createVecRight()
        rhs.array[:] = f
        ksp = PETSc.KSP().create(comm)
        ksp.setOptionsPrefix("crane_fem_bonded_preload_")
        ksp.setOperators(Ka)
        ksp.setType("preonly")
        pc = ksp.getPC()
        pc.setType("lu")
        pc.setFactorSolverType("mumps")
        ksp.setErrorIfNotConverged(False)
        try:
            ksp.solve(rhs, sol)
            failed = bool(ksp.is_diverged)
        except PETSc.Error:
            failed = True
        ok = not failed and bool(np.all(np.isfinite(sol.array_r)))
        ok = comm.allreduce(ok, MPI.LAND)
        u_own = sol.array_r.reshape(-1, bs).copy()
        for obj in (ksp, rhs, sol, Ka):
            obj.destroy()
        if not ok:
            raise CraneFemError(
                "static preload: the self-weight solve failed: a body is held neither by a "
                "[[support]] nor by a closed contact (check the supports and that every body "
                "rests on another with its contact surfaces touching at t = 0)"
            )
        disp = np.zeros((n_vertices, bs))
        for ids, vals in comm.allgather((owned_gv, u_own)):
            disp[ids] = vals
        return disp

    active = points.gap <= touching
    force = np.zeros(points.gap.size)
    disp = np.zeros((n_vertices, bs))
    for _ in range(50):
        disp = solve(active)
        dn = points.normal_motion(disp)
        force = np.where(active, -k_p * dn, 0.0)  # compressive on the point
        tol = 1e-6 * float(np.max(np.abs(force), initial=0.0))
        new = (active & (force > -tol)) | (~active & (points.gap + dn < -tol / k_p))
        if np.array_equal(new, active):
            break
        active = new
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
    return Preload(
        disp,
        force,
        np.bincount(points.group, weights=force, minlength=n_groups),
        float(np.linalg.norm(g)) * float(total),
        0.0,
        float(np.max(np.abs(force), initial=0.0) / k_p) if k_p > 0.0 else 0.0,
        active,
    )
