"""Static self-weight preload of a gmsh model: its node-to-surface contact points held on
their triangles while closed.

K u = f_g with every closed point bonded to its triangle by a stiff spring
k_p |u_p − Σ ξ_i u_i|² in all three directions (the normal and two tangents at once: they are
orthonormal, so the sum of their three rank-one springs is k_p (w wᵀ ⊗ I₃) with
w = [1, −ξ_a, −ξ_b, −ξ_c]). Bonding the tangents too keeps a body that rests on another free
of rigid modes without extra supports; with friction the run starts from that tangential
force (it holds while below μ N), frictionless it is released at t = 0. The normal direction
is unilateral, settled by a primal–dual active set as the crane's preload
(crane_fem.preload.crane): a point in tension opens, an open point that penetrates closes.
The residual interpenetration F/k_p is removed from the gaps of the dynamic run.
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
from crane_fem.geometry.tagged import TaggedMesh
from crane_fem.model import assemble_structure
from crane_fem.preload.crane import Preload, vertex_blocks
from crane_fem.subdomains import cell_function

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
    """

    ids: IntArray
    weights: FloatArray
    normal: FloatArray
    gap: FloatArray
    group: IntArray


def bonded_preload(
    tagged: TaggedMesh,
    points: BondedPoints,
    n_groups: int,
    fixed_vertices: IntArray,
    E: float | FloatArray,
    nu: float | FloatArray,
    cell_density: FloatArray,
    gravity: FloatArray,
    touching: float,
) -> Preload:
    """Solve the self-weight equilibrium with the closed contact points bonded (collective).

    Args:
        n_groups: number of contact groups (the size of ``wheel_force``: per group).
        E, nu: Young's modulus (Pa) and Poisson's ratio, uniform or of every local parent
            cell (owned and ghost).
        fixed_vertices: clamped global vertex ids.
        cell_density: density of every local parent cell (owned and ghost), kg/m³.
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
    bs = 3
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (bs,)))
    rho = cell_function(msh, cell_density)
    young = cell_function(msh, E) if isinstance(E, np.ndarray) else E
    poisson = cell_function(msh, nu) if isinstance(nu, np.ndarray) else nu
    gv, blocks = vertex_blocks(V)
    imap = V.dofmap.index_map
    n_own = imap.size_local
    clamped = blocks[np.isin(gv, fixed_vertices)].astype(np.int32)
    K, lumped, _ = assemble_structure(V, young, poisson, rho, 1.0, clamped, False)
    g = np.asarray(gravity, dtype=np.float64)
    f = (lumped.reshape(-1, bs) * g[None, :]).ravel()
    own_clamped = clamped[clamped < n_own]
    f[(own_clamped[:, None] * bs + np.arange(bs)).ravel()] = 0.0

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
            K.setValues(idx, idx, np.zeros(144).tolist(), addv=True)  # addv=True: ADD_VALUES
    K.assemble()
    n_vertices = msh.topology.index_map(0).size_global

    def solve(active: npt.NDArray[np.bool_]) -> FloatArray:
        Ka = K.copy()
        for i in np.flatnonzero(active):
            idx = dofs[i]
            if idx is not None:
                w = points.weights[i]
                ke = k_p * np.kron(np.outer(w, w), np.eye(bs))
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
        rel = np.einsum("pk,pkj->pj", points.weights, disp[points.ids])  # u_p − Σ ξ u_i
        dn = np.einsum("pj,pj->p", points.normal, rel)
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
    total = comm.allreduce(dolfinx.fem.assemble_scalar(dolfinx.fem.form(rho * dx)), MPI.SUM)
    return Preload(
        disp,
        force,
        np.bincount(points.group, weights=force, minlength=n_groups),
        float(np.linalg.norm(g)) * float(total),
        0.0,
        float(np.max(np.abs(force), initial=0.0) / k_p) if k_p > 0.0 else 0.0,
        active,
    )
