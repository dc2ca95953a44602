"""Static self-weight preload of a mixed model: its solids and its beams, each on its own mesh,
held together by the joints' rows (crane_fem.coupling.rigid_section), the solids' closed
contact points bonded as in crane_fem.preload.bonded.

One saddle-point system on the two subdomains' DOFs and the joints' multipliers,

    [ K_s + K_p   0     L_Eᵀ ] [u_s]   [f_s]
    [ 0           K_b   L_Iᵀ ] [u_b] = [f_b]
    [ L_E         L_I   0    ] [ μ ]   [ 0 ]

(K_p the bonded points' springs, their normal direction unilateral by the same active set as
the bonded preload), factorised by MUMPS (LU: indefinite). The solids need no support of their
own: the joints hold them. Each rank owns a contiguous block of the unknowns: its solid DOFs,
then its beam DOFs, then (rank 0) the multipliers.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from mpi4py import MPI
from petsc4py import PETSc

from crane_fem.contact import ContactSet
from crane_fem.errors import CraneFemError
from crane_fem.preload.bonded import BondedPoints, lu_solve
from crane_fem.preload.crane import Preload
from crane_fem.subdomains import Subdomain

__all__ = ["mixed_preload"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


class _Layout:
    """Where each unknown of the saddle-point system lives: rank r owns
    [start_r, start_r + n_s,r + n_b,r + n_Γ,r) — its solid DOFs, its beam DOFs and (rank 0)
    the multipliers."""

    def __init__(self, solid: Subdomain, beams: Subdomain, n_gamma: int) -> None:
        comm = solid.model.comm
        self.comm = comm
        self.n_s, self.n_b = solid.model.n_owned, beams.model.n_owned
        self.n_g = n_gamma if comm.rank == 0 else 0
        self.local = self.n_s + self.n_b + self.n_g
        sizes = np.array(comm.allgather((self.n_s, self.n_b, self.n_g)), dtype=np.int64)
        starts = np.concatenate([[0], np.cumsum(sizes.sum(axis=1))])
        self.start = int(starts[comm.rank])
        self.size = int(starts[-1])
        # The first global index of each rank in K_s's and K_b's own numbering.
        self.s_first = np.concatenate([[0], np.cumsum(sizes[:, 0])])
        self.b_first = np.concatenate([[0], np.cumsum(sizes[:, 1])])
        self.starts = starts
        self.sizes = sizes
        self.gamma0 = int(starts[0] + sizes[0, 0] + sizes[0, 1])  # the multipliers' first

    def solid(self, g: IntArray) -> IntArray:
        """Global indices of K_s's global rows/columns ``g``."""
        r = np.searchsorted(self.s_first, g, side="right") - 1
        return (self.starts[r] + g - self.s_first[r]).astype(np.int64)

    def beam(self, g: IntArray) -> IntArray:
        r = np.searchsorted(self.b_first, g, side="right") - 1
        return (self.starts[r] + self.sizes[r, 0] + g - self.b_first[r]).astype(np.int64)


def _entries(K: PETSc.Mat, mapping: object) -> tuple[IntArray, IntArray, FloatArray]:
    """(rows, columns, values) of this rank's rows of K, in the saddle system's numbering."""
    indptr, cols, vals = K.getValuesCSR()
    r0 = K.getOwnershipRange()[0]
    rows = r0 + np.repeat(np.arange(indptr.size - 1), np.diff(indptr))
    f = mapping  # a _Layout method
    return f(rows.astype(np.int64)), f(cols.astype(np.int64)), np.asarray(vals)  # type: ignore[operator]


def mixed_preload(
    solid: Subdomain,
    beams: Subdomain,
    l_explicit: ContactSet,
    l_implicit: ContactSet,
    points: BondedPoints,
    n_groups: int,
    gravity: FloatArray,
    touching: float,
) -> tuple[Preload, Preload]:
    """The self-weight equilibrium of the solids and the beams joined by their joints
    (collective).

    Returns:
        ``(solids, beams)``: each one's preload on its own parent mesh's vertices (the
        contacts' forces on the solids', none on the beams'); both carry the whole
        structure's weight.

    Raises:
        CraneFemError: the solve failed (a part held neither by a support, a joint nor a
            closed contact), or the contact active set did not settle.
    """
    comm = solid.model.comm
    lay = _Layout(solid, beams, l_explicit.p)
    g = np.asarray(gravity, dtype=np.float64)
    bs_s, bs_b = solid.bs, beams.bs

    def load(sub: Subdomain) -> FloatArray:
        gb = np.zeros(sub.bs)
        gb[: sub.formulation.translations] = g[: sub.formulation.translations]
        f = (sub.model.mass.reshape(-1, sub.bs) * gb[None, :]).ravel()
        f[sub.model.fixed] = 0.0
        return f

    f_s, f_b = load(solid), load(beams)
    weight = float(np.linalg.norm(g)) * comm.allreduce(
        float(solid.model.mass[0::bs_s].sum() + beams.model.mass[0::bs_b].sum()), op=MPI.SUM
    )
    # K_s and K_b, and the joints' rows both ways (the multipliers' rows owned by rank 0).
    rs, cs, vs = _entries(solid.model.K, lay.solid)
    rb, cb, vb = _entries(beams.model.K, lay.beam)
    s0, b0 = solid.model.K.getOwnershipRange()[0], beams.model.K.getOwnershipRange()[0]
    lam_e = lay.gamma0 + l_explicit.rows
    col_e = lay.solid(s0 + l_explicit.dofs)
    lam_i = lay.gamma0 + l_implicit.rows
    col_i = lay.beam(b0 + l_implicit.dofs)
    rows = np.concatenate([rs, rb, lam_e, col_e, lam_i, col_i])
    cols = np.concatenate([cs, cb, col_e, lam_e, col_i, lam_i])
    vals = np.concatenate(
        [vs, vb, l_explicit.coeffs, l_explicit.coeffs, l_implicit.coeffs, l_implicit.coeffs]
    )
    # The bonded points' DOFs (solid vertex → its global index in the saddle numbering).
    owned = solid.parent_vertex[: solid.n_owned_blocks]
    sel = np.isin(owned, points.ids.ravel())
    gidx = lay.solid(s0 + bs_s * np.flatnonzero(sel).astype(np.int64))
    where: dict[int, int] = {}
    for ids, gi in comm.allgather((owned[sel], gidx)):
        where.update(zip(ids.tolist(), gi.tolist(), strict=True))
    mine = set(owned[sel].tolist())
    p_dofs = [
        np.array([where[int(v)] + c for v in row for c in range(bs_s)], dtype=np.int64)
        if int(row[0]) in mine
        else None
        for row in points.ids
    ]
    diag = solid.model.K.getDiagonal()
    k_p = comm.allreduce(float(np.max(diag.array_r, initial=0.0)), MPI.MAX)
    diag.destroy()
    n_vs = solid.submesh.topology.index_map(0).size_global
    n_vb = beams.submesh.topology.index_map(0).size_global

    def solve(active: npt.NDArray[np.bool_]) -> tuple[FloatArray, FloatArray]:
        r, c, v = [rows], [cols], [vals]
        for i in np.flatnonzero(active):
            idx = p_dofs[i]
            if idx is not None:
                ke = points.spring(int(i), k_p, bs_s, static=True)
                r.append(np.repeat(idx, idx.size))
                c.append(np.tile(idx, idx.size))
                v.append(ke.ravel())
        R, C, V = np.concatenate(r), np.concatenate(c), np.concatenate(v)
        # COO: repeated entries add, entries of rows another rank owns are sent there.
        # (petsc4py's stubs want Sequences and a PETSc.Comm: ndarrays and an mpi4py comm work.)
        A = PETSc.Mat().create(comm=comm)  # type: ignore[arg-type]
        A.setSizes(((lay.local, lay.size), (lay.local, lay.size)))
        A.setType(PETSc.Mat.Type.AIJ)
        A.setPreallocationCOO(R.astype(PETSc.IntType), C.astype(PETSc.IntType))  # type: ignore[arg-type]
        A.setValuesCOO(V.astype(PETSc.ScalarType), addv=True)  # type: ignore[arg-type]
        A.assemble()
        rhs = np.zeros(lay.local)
        rhs[: lay.n_s] = f_s
        rhs[lay.n_s : lay.n_s + lay.n_b] = f_b
        x = lu_solve(A, rhs, "crane_fem_mixed_preload_")
        A.destroy()
        if x is None:
            raise CraneFemError(
                "static preload: the self-weight solve failed: a part is held neither by a "
                "[[support]], a [[joint]] nor a closed contact"
            )
        d_s = np.zeros((n_vs, bs_s))
        d_b = np.zeros((n_vb, bs_b))
        u_s = x[: lay.n_s].reshape(-1, bs_s)
        u_b = x[lay.n_s : lay.n_s + lay.n_b].reshape(-1, bs_b)
        ob = beams.parent_vertex[: beams.n_owned_blocks]
        for (ids_s, vs_), (ids_b, vb_) in comm.allgather(((owned, u_s), (ob, u_b))):
            d_s[ids_s] = vs_
            d_b[ids_b] = vb_
        return d_s, d_b

    active = points.gap <= touching
    force = np.zeros(points.gap.size)
    for _ in range(50):
        d_s, d_b = solve(active)
        dn = points.normal_motion(d_s)
        force = np.where(active, -k_p * dn, 0.0)  # compressive on the point
        tol = 1e-6 * float(np.max(np.abs(force), initial=0.0))
        new = (active & (force > -tol)) | (~active & (points.gap + dn < -tol / k_p))
        if np.array_equal(new, active):
            break
        active = new
    else:
        raise CraneFemError("static preload: the contact active set did not settle in 50 passes")
    groups = np.bincount(points.group, weights=force, minlength=n_groups)
    pen = float(np.max(np.abs(force), initial=0.0) / k_p) if k_p > 0.0 else 0.0
    none = np.zeros(0)
    return (
        Preload(d_s, force, groups, weight, 0.0, pen, active),
        Preload(d_b, none, np.zeros(n_groups), weight, 0.0, 0.0, np.zeros(0, dtype=bool)),
    )
