"""Static preload of the crane: self-weight equilibrium with every wheel/rail pair closed.

The dynamic run must start from the crane at rest under its own weight, with the trolley
resting on its four wheels: K u = f_g + contact forces, u_z(wheel) = u_z(rail) on every pair.
Each pair is closed by a stiff spring k_p (u_z,w − u_z,r) between the two vertical DOFs. The
force balance of the trolley does not depend on k_p: whatever the stiffness, the springs carry
exactly the trolley's weight (up to the solver's round-off); k_p only sets the residual
interpenetration F/k_p, which is removed from the gaps of the dynamic run (they start at 0).

The springs act in z only, so the trolley keeps three rigid modes (x, y translation and
rotation about z). They are removed by an isostatic support, x and y at one wheel-patch vertex
and x at the diagonally opposite one (picked by position, not by number, so every mesh
distribution supports the same vertices): with gravity along z no horizontal load reaches the
trolley, so these supports carry no force (their reaction is checked and reported).
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
from crane_fem.formulations import CellFields, SolidP1, cell_function
from crane_fem.geometry.tagged import TaggedMesh
from crane_fem.model import assemble_operators

__all__ = ["Preload", "static_preload", "vertex_blocks"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


@dataclass
class Preload:
    """The preloaded state, identical on every rank.

    Attributes:
        displacement: (n_global_vertices, 3) displacement of every parent vertex, m.
        pair_force: compressive force of every wheel/rail pair, N (≥ 0 when closed).
        wheel_force: total per wheel (1–4), N.
        weight: weight of the trolley (wheels + frame + hoisted mass), N.
        support_reaction: largest force in the isostatic supports, N (≈ 0).
        penetration: largest residual interpenetration F/k_p, m (removed from the gaps).
        closed: which pairs are closed (the others carry no force and have a gap ≥ 0).
    """

    displacement: FloatArray
    pair_force: FloatArray
    wheel_force: FloatArray
    weight: float
    support_reaction: float
    penetration: float
    closed: npt.NDArray[np.bool_]

    @property
    def relative_error(self) -> float:
        """|Σ wheel forces − weight| / weight."""
        return abs(float(self.wheel_force.sum()) - self.weight) / self.weight


def vertex_blocks(V: dolfinx.fem.FunctionSpace) -> tuple[IntArray, IntArray]:
    """(global vertex id, local DOF block) of every local DOF block (owned, then ghosts) of a
    P1 space on a mesh."""
    msh = V.mesh
    tdim = msh.topology.dim
    msh.topology.create_connectivity(tdim, 0)
    c2v = msh.topology.connectivity(tdim, 0)
    imap_v = msh.topology.index_map(0)
    n_blocks = V.dofmap.index_map.size_local + V.dofmap.index_map.num_ghosts
    vertex_of = np.full(n_blocks, -1, dtype=np.int64)
    vertex_of[V.dofmap.list.ravel()] = c2v.array
    gv = np.asarray(imap_v.local_to_global(vertex_of.astype(np.int32)), dtype=np.int64)
    return gv, np.arange(n_blocks, dtype=np.int64)


def static_preload(
    tagged: TaggedMesh,
    pairs: IntArray,
    wheel_of_pair: IntArray,
    fixed_vertices: IntArray,
    E: float,
    nu: float,
    cell_density: FloatArray,
    gravity: FloatArray,
    trolley_groups: list[str],
) -> Preload:
    """Solve the self-weight equilibrium of the crane with closed wheel/rail pairs (collective).

    Args:
        pairs: (p, 2) global vertex ids (wheel, rail) of the contact pairs.
        wheel_of_pair: wheel number (1–4) of each pair.
        fixed_vertices: clamped global vertex ids.
        cell_density: density of every local parent cell (owned and ghost), kg/m³ (a hoisted
            mass is part of it).
        trolley_groups: cell groups of the trolley (for its weight).

    Raises:
        CraneFemError: a wheel is not pressed onto its rail, or the solve failed.
    """
    msh = tagged.mesh
    comm = msh.comm
    bs = 3
    solid = SolidP1()
    V = solid.space(msh)
    gv, blocks = vertex_blocks(V)
    imap = V.dofmap.index_map
    n_own = imap.size_local
    clamped = blocks[np.isin(gv, fixed_vertices)].astype(np.int32)
    clamped_dofs = (clamped[:, None].astype(np.int64) * bs + np.arange(bs)).ravel()
    fields = CellFields(E, nu, np.asarray(cell_density, dtype=np.float64))
    K, lumped, _ = assemble_operators(solid, V, fields, clamped_dofs)
    f = (lumped.reshape(-1, bs) * np.asarray(gravity, dtype=np.float64)[None, :]).ravel()
    fixed = np.zeros(n_own * bs, dtype=bool)
    own_clamped = clamped[clamped < n_own]
    fixed[(own_clamped[:, None] * bs + np.arange(bs)).ravel()] = True
    f[fixed] = 0.0

    # Global DOF blocks of the pair and support vertices.
    owned_gv = gv[:n_own]
    sel = np.isin(owned_gv, pairs.ravel())
    gblock = np.asarray(imap.local_to_global(blocks[:n_own][sel].astype(np.int32)), dtype=np.int64)
    block_of: dict[int, int] = {}
    for ids, gb in comm.allgather((owned_gv[sel], gblock)):
        block_of.update(zip(ids.tolist(), gb.tolist(), strict=True))

    # Penalty springs on the closed pairs (global DOF 3 × block + 2), added by the rank
    # owning the wheel vertex; k_p = the largest diagonal entry of K.
    diag = K.getDiagonal()
    local_max = float(np.max(diag.array_r)) if diag.array_r.size else 0.0
    diag.destroy()
    k_p = comm.allreduce(local_max, MPI.MAX)
    K.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)  # type: ignore[arg-type]
    zero = np.zeros((2, 2))
    mine = set(owned_gv[sel].tolist())
    pair_dofs = [
        [bs * block_of[int(w)] + 2, bs * block_of[int(r)] + 2] if int(w) in mine else None
        for w, r in pairs
    ]
    for idx in pair_dofs:  # the pattern of every pair, once
        if idx is not None:
            K.setValues(idx, idx, zero.ravel().tolist(), addv=True)  # addv=True: ADD_VALUES
    K.assemble()
    # Isostatic support of the trolley: x, y at the wheel-1 patch vertex of smallest x + y,
    # x at the wheel-4 patch vertex of largest x + y — chosen by position, so the same
    # vertices whatever the mesh distribution and numbering.
    own_v = np.flatnonzero(np.isin(gv[:n_own], pairs[:, 0]))
    xy = V.tabulate_dof_coordinates()[own_v, :2]
    cand: dict[int, float] = {}
    for ids, s_xy in comm.allgather((gv[:n_own][own_v], xy.sum(axis=1))):
        cand.update(zip(ids.tolist(), s_xy.tolist(), strict=True))
    w1 = [int(v) for v in pairs[wheel_of_pair == 1, 0]]
    w4 = [int(v) for v in pairs[wheel_of_pair == 4, 0]]
    a = block_of[min(w1, key=lambda v: (round(cand[v], 9), v))]
    b = block_of[max(w4, key=lambda v: (round(cand[v], 9), -v))]
    lo, hi = K.getOwnershipRange()
    own_support = np.array(
        [d for d in (bs * a, bs * a + 1, bs * b) if lo <= d < hi], dtype=np.int32
    )
    f_sup = f.copy()
    f_sup[own_support - lo] = 0.0

    def solve(active: npt.NDArray[np.bool_]) -> tuple[FloatArray, float]:
        """Displacement (n_vertices, 3) with springs on the ``active`` pairs, and the
        largest support reaction."""
        Ka = K.copy()
        ke = k_p * np.array([[1.0, -1.0], [-1.0, 1.0]])
        for i in np.flatnonzero(active):
            idx = pair_dofs[i]
            if idx is not None:
                Ka.setValues(idx, idx, ke.ravel().tolist(), addv=True)
        Ka.assemble()
        K_free = Ka.copy()  # before the supports: for their reactions
        Ka.zeroRowsColumns(own_support.tolist(), diag=1.0)
        rhs, sol = Ka.createVecRight(), Ka.createVecRight()
        rhs.array[:] = f_sup
        ksp = PETSc.KSP().create(comm)
        ksp.setOperators(Ka)
        ksp.setType("preonly")
        pc = ksp.getPC()
        pc.setType("lu")
        pc.setFactorSolverType("mumps")
        ksp.solve(rhs, sol)
        reason, failed = ksp.getConvergedReason(), ksp.is_diverged
        ksp.destroy()
        ok = comm.allreduce(bool(np.all(np.isfinite(sol.array_r))), MPI.LAND)
        if failed or not ok:
            raise CraneFemError(f"static preload: the MUMPS solve failed (KSP reason {reason})")
        ku = K_free.createVecLeft()
        K_free.mult(sol, ku)
        reaction = ku.array_r[own_support - lo] - f[own_support - lo]
        support = comm.allreduce(float(np.max(np.abs(reaction), initial=0.0)), MPI.MAX)
        u_own = sol.array_r.reshape(-1, bs).copy()
        for obj in (rhs, sol, ku, Ka, K_free):
            obj.destroy()
        disp = np.zeros((msh.topology.index_map(0).size_global, bs))
        for ids, vals in comm.allgather((owned_gv, u_own)):
            disp[ids] = vals
        return disp, support

    # Unilateral pairs by a primal–dual active set: open the pairs in tension, close the
    # open ones that interpenetrate, until both sets are stable (finite: a few passes).
    # A pair whose force is zero to round-off (1e-6 of the largest) keeps its state, so that
    # the summation order (serial or MPI) cannot pick another of two equivalent active sets.
    active = np.ones(pairs.shape[0], dtype=bool)
    for _ in range(50):
        disp, support_reaction = solve(active)
        gap = disp[pairs[:, 0], 2] - disp[pairs[:, 1], 2]
        force = np.where(active, -k_p * gap, 0.0)  # compressive force on the wheel
        tol = 1e-6 * float(np.max(np.abs(force), initial=0.0))
        new = (active & (force > -tol)) | (~active & (gap < -tol / k_p))
        if np.array_equal(new, active):
            break
        active = new
    else:
        raise CraneFemError("static preload: the contact active set did not settle in 50 passes")
    K.destroy()
    pair_force = force
    wheel_force = np.bincount(wheel_of_pair - 1, weights=pair_force, minlength=4)
    if np.any(wheel_force <= 0.0):
        k = int(np.argmin(wheel_force)) + 1
        raise CraneFemError(
            f"static preload: wheel {k} is not pressed onto its rail (force "
            f"{wheel_force[k - 1]:.4g} N): the trolley does not rest on its four wheels"
        )
    # Trolley weight: |g| Σ over its cells of ∫ ρ dx.
    dx = ufl.Measure("dx", domain=msh, subdomain_data=tagged.cell_tags)
    tags = [tagged.cell_groups[g] for g in trolley_groups]
    rho = cell_function(msh, cell_density)
    mass = sum((rho * dx(t) for t in tags[1:]), rho * dx(tags[0]))
    trolley_mass = comm.allreduce(dolfinx.fem.assemble_scalar(dolfinx.fem.form(mass)), MPI.SUM)
    return Preload(
        disp,
        pair_force,
        wheel_force,
        float(np.linalg.norm(gravity)) * float(trolley_mass),
        support_reaction,
        float(np.max(np.abs(pair_force)) / k_p) if pair_force.size else 0.0,
        active,
    )
