"""The NumPy twin of :func:`crane_fem.kernels.explicit.run_steps`, for the tests.

The same micro steps written with whole-array operations and SciPy (the stiffness product as
a block sparse matrix, the constraint rows as a sparse matrix, the impulses by
:mod:`crane_fem.contact.lcp`), serial only: it checks the compiled kernel's loops, not its MPI.
Slow; never used by a run.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import scipy.sparse

from crane_fem.contact.friction import coulomb_point, coulomb_residual, solve_coulomb, solve_point
from crane_fem.contact.lcp import solve_lcp, solve_mixed_lcp_blocks
from crane_fem.kernels import explicit as kx
from crane_fem.kernels.friction import TOL

__all__ = ["friction_impulses", "operator_matrix", "run_steps"]

FloatArray = npt.NDArray[np.float64]


def operator_matrix(op: kx.InterfaceOp, k: float) -> FloatArray:
    """A_k⁻¹ as a dense matrix, block by block (the twin of ``apply_operator``)."""
    n = op.idx.size
    out = np.zeros((n, n))
    Qall = op.Q32.astype(np.float64) if op.single else op.Q
    for b in range(op.ptr.size - 1):
        a0, a1 = op.ptr[b], op.ptr[b + 1]
        rows = op.idx[a0:a1]
        r = int(op.rank[b])
        Q = Qall[op.qptr[b] : op.qptr[b] + (a1 - a0) * r].reshape(a1 - a0, r)
        if op.k_fixed > 0.0:  # the block is A_k⁻¹ itself
            out[np.ix_(rows, rows)] = Q
            continue
        s = op.s[op.sptr[b] : op.sptr[b + 1]]
        f = 1.0 / (1.0 + 2.0 * k * op.gamma * s)
        inner = np.eye(a1 - a0) + (Q * (f - 1.0)) @ Q.T if op.lowrank else (Q * f) @ Q.T
        d = op.dis[a0:a1]
        out[np.ix_(rows, rows)] = d[:, None] * inner * d[None, :]
    return out


def friction_impulses(
    z: kx.Zone, closed: npt.NDArray[np.bool_], q_c: FloatArray, q_t: FloatArray
) -> tuple[FloatArray, FloatArray, float]:
    """The normal and tangential impulses of the frictional contact problem (the twin of
    ``contacts_friction``, with crane_fem.contact.friction), and the largest residual."""
    pc = q_c.size
    lam_c, lam_t = np.zeros(pc), np.zeros(z.nt)
    Wf = np.block([[z.W_cc, z.W_nt], [z.W_nt.T, z.W_tt]])
    qf = np.concatenate([q_c, q_t])

    def rows_of(c: int) -> list[int]:
        k0, nk = int(z.t_first[c]), int(z.t_count[c])
        return [c, *range(pc + k0, pc + k0 + nk)]

    def scatter(rows: list[int], r: FloatArray) -> None:
        for i, row in enumerate(rows):
            if row < pc:
                lam_c[row] = r[i]
            else:
                lam_t[row - pc] = r[i]

    worst = 0.0
    groups = [[int(c)] for c in np.flatnonzero(closed)]
    if not z.fric_local and groups:
        # One problem per component of the points coupled through shared DOFs.
        comps = (
            z.fric_order[z.fric_ptr[k] : z.fric_ptr[k + 1]] for k in range(z.fric_ptr.size - 1)
        )
        groups = [[int(c) for c in comp if closed[c]] for comp in comps]
        groups = [g for g in groups if g]
    for pts in groups:
        rows = [row for c in pts for row in rows_of(c)]
        if len(pts) == 1 and z.t_count[pts[0]] == 0:
            c = pts[0]
            lam_c[c] = max(0.0, -q_c[c] / z.W_cc[c, c])
            continue
        if len(pts) == 1 and z.iso[pts[0]]:
            c = pts[0]
            scatter(rows, coulomb_point(qf[rows], float(z.W_cc[c, c]), float(z.mu[c])))
            continue
        if len(pts) == 1:
            c = pts[0]
            sub = Wf[np.ix_(rows, rows)]
            r, found = solve_point(sub, qf[rows], float(z.mu[c]))
            if not found:
                ptr1, mu1 = np.array([0, len(rows)]), z.mu[[c]]
                worst = max(worst, coulomb_residual(sub, qf[rows], ptr1, mu1, r), 2 * TOL)
            scatter(rows, r)
            continue
        ptr = np.cumsum([0, *(1 + int(z.t_count[c]) for c in pts)])
        r, res, _ = solve_coulomb(Wf[np.ix_(rows, rows)], qf[rows], ptr, z.mu[pts])
        worst = max(worst, res)
        scatter(rows, r)
    return lam_c, lam_t, worst


def run_steps(
    z: kx.Zone, op: kx.InterfaceOp, st: kx.ZoneState, ctl: kx.Steps, out: kx.StepsOut
) -> None:
    """What :func:`crane_fem.kernels.explicit.run_steps` does, on one rank."""
    if z.nranks > 1:
        raise ValueError("the NumPy twin runs on one rank")
    n, p, n_g = z.n_own, z.p, z.n_g
    n_loc = st.u.size
    K = scipy.sparse.bsr_matrix((z.data, z.indices, z.indptr), shape=(n, n_loc)).tocsr()
    L = scipy.sparse.csr_matrix((z.t_coeff, (z.t_row, z.t_dof)), shape=(p, n))
    T = scipy.sparse.csr_matrix((z.f_coeff, (z.f_row, z.f_dof)), shape=(z.nt, n))
    pc = p - n_g
    out.sums[:] = 0.0
    out.impulse_trap[:] = 0.0
    out.impulse_sum[:] = 0.0
    out.flags[:] = 0
    u, vh = st.u[:n], st.vh[:n]
    for jj in range(ctl.n):
        h = ctl.h0 if jj == 0 else z.dt
        if ctl.move0 or jj > 0:
            u += z.dt * vh
        v_old = vh.copy()
        ku = K @ st.u
        f = z.load_base + ctl.coef[jj] @ z.load_shapes
        cv = z.alpha * z.mass * v_old
        if z.beta:
            cv = cv + z.beta * (K @ st.vh)
        v_free = v_old + h * z.minv * (f - ku - cv)
        lu, lo, lq = L @ u, L @ v_old, L @ v_free
        gaps = z.g0 + lu
        closed = gaps[n_g:] <= z.tol
        q_c = lq[n_g:].copy()
        lam = np.zeros(p)
        lam_t = np.zeros(z.nt)
        if ctl.mode == kx.IMPOSED:
            lam[:n_g] = z.dt * (ctl.ic[jj, 0] * ctl.imposed[0] + ctl.ic[jj, 1] * ctl.imposed[1])
            q_c += z.W_ec.T @ lam[:n_g]
        if ctl.law == kx.LAW_PENALTY:
            lam[n_g:] = h * (ctl.penalty * np.maximum(-gaps[n_g:], 0.0))
        elif ctl.law == kx.LAW_BILATERAL:
            lam[n_g:] = -z.W_cc_inv @ q_c
        elif ctl.mode == kx.SOLVED:
            w_i = ctl.tc[jj, 0] * ctl.targets[0] + ctl.tc[jj, 1] * ctl.targets[1]
            q_e = lo[:n_g] + lq[:n_g] + 2.0 * w_i
            Ainv = operator_matrix(op, float(ctl.k_op[jj]))

            def solve(x: FloatArray, A: FloatArray = Ainv) -> FloatArray:
                return np.asarray(A @ x)

            lam[:n_g], lam[n_g:] = solve_mixed_lcp_blocks(solve, z.W_ec, z.W_cc, q_e, q_c, closed)
        elif pc:
            lam[n_g:] = solve_lcp(z.W_cc, q_c, closed, bool(z.cc_diagonal))
        if z.nt and ctl.law == kx.LAW_LCP:  # (with friction the interface rows couple to none)
            lam[n_g:], lam_t, res = friction_impulses(z, closed, q_c, T @ v_free)
            if res > TOL:
                out.flags[kx.FRICTION_ERROR] = 1
        jump = L.T @ lam
        lam_c = lam.copy()
        lam_c[:n_g] = 0.0
        jump_c = L.T @ lam_c
        jump_f = T.T @ lam_t
        v_new = v_free + z.minv * (jump + jump_f)
        vh[:] = v_new
        v_mid = 0.5 * (v_old + v_new)
        out.sums[kx.EXT] += h * float(v_mid @ f)
        out.sums[kx.DAMP] += h * float(v_mid @ cv)
        out.sums[kx.CONTACT] += float(v_mid @ jump_c)
        out.sums[kx.LINK] += float(v_mid @ (jump - jump_c))
        out.sums[kx.FRICTION] += float(v_mid @ jump_f)
        out.active[jj] = bool(np.any(lam[n_g:] > 0.0))
        grp = np.arange(z.n_groups)[:, None] == z.c_group[None, :]
        out.group_impulse[jj] = grp @ lam[n_g:]
        out.group_gap[jj] = np.where(grp, gaps[None, n_g:], np.inf).min(axis=1, initial=np.inf)
        if ctl.watch.size and np.any(closed != ctl.watch):
            out.flags[kx.CHANGED] = 1
            if np.any(closed & ~ctl.watch):
                out.flags[kx.CLOSED] = 1
        if n_g:
            w = (L @ v_mid)[:n_g]
            lbar = 0.5 * (st.lam_prev + lam[:n_g])
            out.sums[kx.GC_WORK] += float(lbar @ (0.5 * (st.w_prev + w)))
            out.sums[kx.PHYS_WORK] += float(lbar @ lo[:n_g])
            out.impulse_trap[:] += lbar
            out.impulse_sum[:] += lam[:n_g]
            if ctl.keep_impulses:
                out.impulses[jj] = lam[:n_g]
            st.lam_prev[:] = lam[:n_g]
            st.w_prev[:] = w
        st.ku[:] = ku
        k = jj - ctl.probe_first
        if ctl.probe_every and 0 <= k and k % ctl.probe_every == 0 and jj < ctl.n - 1:
            out.probe_u[k // ctl.probe_every] = u[ctl.probe]
            out.probe_v[k // ctl.probe_every] = v_mid[ctl.probe]
        if jj == ctl.n - 1:
            st.v_int[:] = v_mid
            out.lam[:] = lam
            out.gaps[:] = gaps
            if out.lam_t.size:  # (a StepsOut made without it: left empty)
                out.lam_t[:] = lam_t
            out.w[:] = st.w_prev
