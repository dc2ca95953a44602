"""The explicit micro steps, compiled: CD-Lagrange on one subdomain with its contact and
interface impulses and its energy terms, any number of micro steps per call.

THEORY.md §1 and §3, docs/theory-notes.md §5. One micro step j (Δt; h = Δt, or Δt/2 at the
start), state (U, V_{j−1/2}) on the owned DOFs and their ghosts:

    U_j       = U_{j−1} + Δt V_{j−1/2}                                            (1.1)
    V_free    = V_{j−1/2} + h M⁻¹ (F(t_j) − K U_j − C V_{j−1/2})                   (1.2)
    stacked rows r = (interface Γ, contacts c): L U_j, L V_{j−1/2}, L V_free  (one reduction)
    Λ         = interface impulses solved (GC, H_j of THEORY §3.2c in its impulse form) or
                imposed (PH, EC), contact impulses from the exact LCP (1.3), a penalty law, or
                bilateral rows (the linear probes of EC and PH)
    V_{j+1/2} = V_free + M⁻¹ Lᵀ Λ                                                  (1.4)

With Coulomb friction (THEORY.md §7) the frictional points add their tangential rows T
(n_t of them, stacked after the 3p values of the reduction: T V_free), and their impulses
(Λ_n, Λ_t) come from the frictional contact problem (crane_fem.kernels.friction) in place of
the LCP; (1.4) takes Lᵀ Λ_n + Tᵀ Λ_t. Without friction (n_t = 0) every operation is that of
the frictionless kernel.

Energy (per micro step, exact): with V̄ = ½ (V_{j−1/2} + V_{j+1/2}),
½ V_{j+1/2}ᵀ M V_{j+1/2} − ½ V_{j−1/2}ᵀ M V_{j−1/2} = V̄ᵀ M (V_{j+1/2} − V_{j−1/2})
= h V̄ᵀ (F − K U_j − C V_{j−1/2}) + V̄ᵀ Lᵀ Λ + V̄ᵀ Tᵀ Λ_t, so the impulses' work is booked
with the mean velocity: ``CONTACT`` += Λ_n · L V̄ and ``FRICTION`` += Λ_t · T V̄ =
Λ_t · ½ (v_t⁻ + v_t⁺) (v_t⁻ = T V_{j−1/2}, v_t⁺ = T V_{j+1/2}); the balance then closes to
round-off with friction_dissipated = −Σ Λ_t · ½ (v_t⁻ + v_t⁺) (crane_fem.energy).

The stiffness product is fused with (1.2) and the energy sums in one pass over K (block CSR,
local columns: owned, then ghost). Under MPI, one halo exchange of U per micro step (of V too
when C has a stiffness part), overlapped with the rows that need no ghost, and one allreduce
of the 3p stacked-row values (3p + n_t with friction). Everything here sees arrays only: the owner
(:class:`crane_fem.integrators.explicit_zone.ExplicitZone`) unpacks the PETSc and dolfinx
objects once. :mod:`crane_fem.kernels.reference` is its NumPy twin, for the tests.

The operations keep the order of the Python path they replace (PETSc's 3 × 3 block product,
NumPy's expression order) so that the histories agree to round-off.
"""

from __future__ import annotations

import numba
import numpy as np
import numpy.typing as npt

from crane_fem.kernels.interface import apply_operator, contacts_exact, solve_mixed
from crane_fem.kernels.mpi import allreduce_sum, halo_finish, halo_start
from crane_fem.kernels.stiffness import free_rows, load_at, stiffness_velocity
from crane_fem.kernels.zone import (
    CHANGED,
    CLOSED,
    CONTACT,
    DAMP,
    EXT,
    FRICTION,
    FRICTION_ERROR,
    GC_WORK,
    IMPOSED,
    LAW_BILATERAL,
    LAW_LCP,
    LAW_PENALTY,
    LCP_ERROR,
    LINK,
    MPI_ERROR,
    NONE,
    PHYS_WORK,
    SOLVED,
    InterfaceOp,
    Steps,
    StepsOut,
    Zone,
    ZoneState,
)

__all__ = [
    "CHANGED",
    "CLOSED",
    "CONTACT",
    "DAMP",
    "EXT",
    "FRICTION",
    "FRICTION_ERROR",
    "GC_WORK",
    "IMPOSED",
    "LAW_BILATERAL",
    "LAW_LCP",
    "LAW_PENALTY",
    "LCP_ERROR",
    "LINK",
    "MPI_ERROR",
    "NONE",
    "PHYS_WORK",
    "SOLVED",
    "InterfaceOp",
    "Steps",
    "StepsOut",
    "Zone",
    "ZoneState",
    "apply_operator",
    "run_steps",
]

FloatArray = npt.NDArray[np.float64]


@numba.njit(cache=True)
def _micro(
    z: Zone,
    op: InterfaceOp,
    st: ZoneState,
    ctl: Steps,
    out: StepsOut,
    jj: int,
    h: float,
    move: bool,
) -> None:
    n_own, n_g, p = z.n_own, z.n_g, z.p
    u, vh = st.u, st.vh
    last = jj == ctl.n - 1
    if move:
        for i in range(n_own):
            u[i] += z.dt * vh[i]
    for c in range(z.c_dofs.size):
        st.vold_c[c] = vh[z.c_dofs[c]]  # (before any update of V)
    if last:
        for i in range(n_own):
            st.v_int[i] = vh[i]
    row = _probe_row(ctl, jj)
    if row >= 0:  # a reading after this step: U_j now, V_{j−1/2} (V_j at the end)
        for c in range(ctl.probe.size):
            out.probe_u[row, c] = u[ctl.probe[c]]
            out.probe_v[row, c] = vh[ctl.probe[c]]
    halo = z.neighbours.size > 0
    n_nb = z.neighbours.size
    if z.beta != 0.0:  # stiffness damping: K V_{j−1/2} first (its own halo exchange)
        if halo:
            out.flags[MPI_ERROR] |= halo_start(
                vh,
                z.neighbours,
                z.send_ptr,
                z.send_idx,
                z.recv_ptr,
                st.send_buf,
                st.recv_buf,
                st.requests,
                z.mpi,
            )
            out.flags[MPI_ERROR] |= halo_finish(vh, n_nb, z.recv_idx, st.recv_buf, st.requests)
        stiffness_velocity(z, st)
    if halo:
        out.flags[MPI_ERROR] |= halo_start(
            u,
            z.neighbours,
            z.send_ptr,
            z.send_idx,
            z.recv_ptr,
            st.send_buf,
            st.recv_buf,
            st.requests,
            z.mpi,
        )
    coef = ctl.coef[jj]
    ext, damp = free_rows(z, st, z.inner, coef, h, last)
    if halo:
        out.flags[MPI_ERROR] |= halo_finish(u, n_nb, z.recv_idx, st.recv_buf, st.requests)
        e2, d2 = free_rows(z, st, z.boundary, coef, h, last)
        ext += e2
        damp += d2
    lam = st.lam
    if p == 0:
        out.sums[EXT] += 0.5 * h * ext
        out.sums[DAMP] += 0.5 * h * damp
        out.active[jj] = False
        if last:
            for i in range(n_own):
                st.v_int[i] = 0.5 * (st.v_int[i] + vh[i])
        _probe_end(ctl, out, vh, row)
        return
    # Stacked rows: L U_j, L V_{j−1/2}, L V_free (one reduction). (Arrays taken out of the
    # tuples first: the loops below then keep them in registers.)
    t_row, t_dof, t_coeff, t_pos = z.t_row, z.t_dof, z.t_coeff, z.t_pos
    c_dofs, vold_c, jump, jump_c = z.c_dofs, st.vold_c, st.jump, st.jump_c
    red = st.red
    nt = z.nt
    for r in range(3 * p + nt):
        red[r] = 0.0
    for t in range(t_row.size):
        r, d, cf = t_row[t], t_dof[t], t_coeff[t]
        red[r] += cf * u[d]
        red[p + r] += cf * vold_c[t_pos[t]]
        red[2 * p + r] += cf * vh[d]
    f_row, f_dof, f_coeff, f_pos = z.f_row, z.f_dof, z.f_coeff, z.f_pos
    for t in range(f_row.size):  # the tangential rows: T V_free, in the same reduction
        red[3 * p + f_row[t]] += f_coeff[t] * vh[f_dof[t]]
    g = st.red_out
    if z.nranks > 1:
        out.flags[MPI_ERROR] |= allreduce_sum(red, g, z.mpi)
    else:
        for r in range(3 * p + nt):
            g[r] = red[r]
    gaps = out.gaps
    for r in range(p):
        gaps[r] = z.g0[r] + g[r]
    pc = p - n_g
    closed = st.closed
    for c in range(pc):
        closed[c] = gaps[n_g + c] <= z.tol
        st.qc[c] = g[2 * p + n_g + c]
    lam_t = st.lam_t
    for k in range(nt):
        st.qt[k] = g[3 * p + k]
        lam_t[k] = 0.0
    # Impulses (with friction, contacts_exact solves the frictional problem).
    lam_c = lam[n_g:]
    if ctl.mode == SOLVED:
        for i in range(n_g):
            w_i = ctl.tc[jj, 0] * ctl.targets[0, i] + ctl.tc[jj, 1] * ctl.targets[1, i]
            st.qe[i] = (g[p + i] + g[2 * p + i]) + 2.0 * w_i
    elif ctl.mode == IMPOSED:
        for i in range(n_g):
            lam[i] = z.dt * (ctl.ic[jj, 0] * ctl.imposed[0, i] + ctl.ic[jj, 1] * ctl.imposed[1, i])
        if not z.ec_zero:
            for c in range(pc):
                for i in range(n_g):
                    st.qc[c] += z.W_ec[i, c] * lam[i]
    if ctl.law == LAW_PENALTY:  # (a lone explicit subdomain: no interface rows)
        for c in range(pc):
            lam_c[c] = h * (ctl.penalty * max(-gaps[n_g + c], 0.0))
    elif ctl.law == LAW_BILATERAL:  # every row held (the linear probes: interface imposed)
        for c in range(pc):
            s = 0.0
            for b in range(pc):
                s += z.W_cc_inv[c, b] * st.qc[b]
            lam_c[c] = -s
    else:
        if z.n_spring > 0:  # the ropes' rows take no part in the LCP
            for c in range(pc):
                if z.rope_row[c]:
                    closed[c] = False
        if ctl.mode == SOLVED:
            solve_mixed(z, op, st, ctl.k_op[jj], closed, out.flags)
        else:
            contacts_exact(z, st, closed, lam_c, out.flags)
        if z.n_spring > 0:
            _ropes(z, gaps, lam_c, closed, n_g, h)
    # V_{j+1/2} = V_free + M⁻¹ Lᵀ Λ at the constraint DOFs, and the work of Λ.
    jump_f = st.jump_f
    for c in range(c_dofs.size):
        jump[c] = 0.0
        jump_c[c] = 0.0
        jump_f[c] = 0.0
    for t in range(t_row.size):
        r = t_row[t]
        jump[t_pos[t]] += t_coeff[t] * lam[r]
        if r >= n_g:
            jump_c[t_pos[t]] += t_coeff[t] * lam[r]
    for t in range(f_row.size):
        jump_f[f_pos[t]] += f_coeff[t] * lam_t[f_row[t]]
    contact_w = 0.0
    link_w = 0.0
    fric_w = 0.0
    spring_w = 0.0
    minv, mass, alpha, beta = z.minv, z.mass, z.alpha, z.beta
    for c in range(c_dofs.size):
        d = c_dofs[c]
        dv = minv[d] * jump[c] if nt == 0 else minv[d] * (jump[c] + jump_f[c])
        v_free = vh[d]
        vh[d] = v_free + dv
        v_mid = 0.5 * (vold_c[c] + vh[d])
        if z.n_spring > 0 and z.spring_dof[c]:
            spring_w += v_mid * jump_c[c]  # a rope's work: the structure's external force
        else:
            contact_w += v_mid * jump_c[c]
        link_w += v_mid * (jump[c] - jump_c[c])
        fric_w += v_mid * jump_f[c]
        # The sums of free_rows took V_free for V_{j+1/2}: add the impulse's part.
        cv = alpha * mass[d] * vold_c[c]
        if beta != 0.0:
            cv = cv + beta * st.kv[d]
        ext += dv * load_at(z, coef, d)
        damp += dv * cv
    out.sums[EXT] += 0.5 * h * ext + spring_w
    out.sums[DAMP] += 0.5 * h * damp
    out.sums[CONTACT] += contact_w
    out.sums[LINK] += link_w
    out.sums[FRICTION] += fric_w
    active = False
    for c in range(pc):
        if lam_c[c] > 0.0 or (z.n_spring > 0 and z.rope_row[c] and lam_c[c] != 0.0):
            active = True
    out.active[jj] = active
    # Per contact group: the impulse and the smallest gap of this micro step (the peaks and
    # lift-offs are read from every micro step, whatever the output rate).
    g_imp, g_gap, c_group = out.group_impulse, out.group_gap, z.c_group
    for k in range(z.n_groups):
        g_imp[jj, k] = 0.0
        g_gap[jj, k] = np.inf
    for c in range(pc):
        if z.n_spring > 0 and z.rope_row[c]:
            continue
        k = c_group[c]
        g_imp[jj, k] += lam_c[c]
        if gaps[n_g + c] < g_gap[jj, k]:
            g_gap[jj, k] = gaps[n_g + c]
    for r in range(z.n_spring):  # a rope: its tension's impulse, its slack (−stretch)
        c = z.rope_first[r]
        k = c_group[c]
        chord = np.sqrt(gaps[n_g + c] ** 2 + gaps[n_g + c + 1] ** 2 + gaps[n_g + c + 2] ** 2)
        slack = z.rope_length[r] - chord
        g_imp[jj, k] += h * z.rope_k[r] * max(-slack, 0.0)
        if slack < g_gap[jj, k]:
            g_gap[jj, k] = slack
    if ctl.watch.size > 0 and out.flags[CLOSED] == 0:
        for c in range(pc):
            if closed[c] != ctl.watch[c]:
                out.flags[CHANGED] = 1
                if closed[c]:
                    out.flags[CLOSED] = 1
    # Interface bookkeeping: L_E V_j = ½ (L V_{j−1/2} + L V_{j+1/2}), L V_{j+1/2} = q + W Λ.
    if n_g > 0:
        gc_w = 0.0
        phys_w = 0.0
        w_gamma, lam_prev, w_prev = z.w_gamma, st.lam_prev, st.w_prev
        trap, total, keep = out.impulse_trap, out.impulse_sum, ctl.keep_impulses
        for i in range(n_g):
            wl = w_gamma[i] * lam[i]
            if z.gg_ptr.size > 0:
                for k in range(z.gg_ptr[i], z.gg_ptr[i + 1]):
                    wl += z.gg_val[k] * lam[z.gg_col[k]]
            if not z.ec_zero:
                for c in range(pc):
                    wl += z.W_ec[i, c] * lam_c[c]
            w_i = 0.5 * (g[p + i] + (g[2 * p + i] + wl))
            lbar = 0.5 * (lam_prev[i] + lam[i])
            gc_w += lbar * (0.5 * (w_prev[i] + w_i))
            phys_w += lbar * g[p + i]  # (Λ̄/Δt)·L(U_j − U_{j−1}), U_j − U_{j−1} = Δt V_{j−1/2}
            trap[i] += 0.5 * (lam_prev[i] + lam[i])
            total[i] += lam[i]
            lam_prev[i] = lam[i]
            w_prev[i] = w_i
            if keep:
                out.impulses[jj, i] = lam[i]
        out.sums[GC_WORK] += gc_w
        out.sums[PHYS_WORK] += phys_w
    if last:
        for i in range(n_own):
            st.v_int[i] = 0.5 * (st.v_int[i] + vh[i])
        for r in range(p):
            out.lam[r] = lam[r]
        for k in range(min(nt, out.lam_t.size)):  # (a StepsOut made without it: empty)
            out.lam_t[k] = lam_t[k]
        for i in range(n_g):
            out.w[i] = st.w_prev[i]
    _probe_end(ctl, out, vh, row)


@numba.njit(cache=True, inline="always")
def _probe_row(ctl: Steps, jj: int) -> int:
    """The reading taken after micro step ``jj`` (its row in ``probe_u``), or −1."""
    if ctl.probe_every == 0 or jj < ctl.probe_first or jj >= ctl.n - 1:
        return -1
    k = jj - ctl.probe_first
    if k % ctl.probe_every != 0:
        return -1
    return k // ctl.probe_every


@numba.njit(cache=True, inline="always")
def _probe_end(ctl: Steps, out: StepsOut, vh: FloatArray, row: int) -> None:
    """V_j = ½ (V_{j−1/2} + V_{j+1/2}) at the probe, as ``v_int`` is formed."""
    if row < 0:
        return
    for c in range(ctl.probe.size):
        out.probe_v[row, c] = 0.5 * (out.probe_v[row, c] + vh[ctl.probe[c]])


@numba.njit(cache=True)
def _ropes(
    z: Zone, gaps: FloatArray, lam_c: FloatArray, closed: npt.NDArray[np.bool_], n_g: int, h: float
) -> None:
    """Each rope's impulse on its three chord rows: h k max(0, ℓ − L) along −x/ℓ (its ends
    pulled together), x = x_b − x_a the chord now (the rows' values), ℓ = |x|; its rows
    count as closed while it is taut."""
    for r in range(z.n_spring):
        c = z.rope_first[r]
        x0, x1, x2 = gaps[n_g + c], gaps[n_g + c + 1], gaps[n_g + c + 2]
        length = np.sqrt(x0 * x0 + x1 * x1 + x2 * x2)
        stretch = length - z.rope_length[r]
        pull = h * z.rope_k[r] * max(stretch, 0.0) / length
        lam_c[c] = -pull * x0
        lam_c[c + 1] = -pull * x1
        lam_c[c + 2] = -pull * x2
        taut = stretch >= 0.0
        closed[c] = taut
        closed[c + 1] = taut
        closed[c + 2] = taut


@numba.njit(cache=True)
def run_steps(z: Zone, op: InterfaceOp, st: ZoneState, ctl: Steps, out: StepsOut) -> None:
    """Integrate ``ctl.n`` micro steps of the zone (collective over the zone's communicator:
    one halo exchange and one allreduce per micro step where the zone spans several ranks).

    ``out`` is reset first; ``st`` carries the state from call to call."""
    out.sums[:] = 0.0
    out.impulse_trap[:] = 0.0
    out.impulse_sum[:] = 0.0
    out.flags[:] = 0
    # One call site with the same argument types at every step: numba compiles _micro once
    # (a second call site passing the literal True compiled it twice: half of the kernels'
    # first compilation).
    h, move = ctl.h0, ctl.move0  # the first step's; every later step's: Δt, moving
    for jj in range(ctl.n):
        _micro(z, op, st, ctl, out, jj, h, move)
        h, move = z.dt, True
