"""The arrays the explicit kernel works on, as typed tuples: an explicit subdomain's static data
(:class:`Zone`), its evolving state (:class:`ZoneState`), the interface operator
(:class:`InterfaceOp`), what one call integrates (:class:`Steps`) and returns
(:class:`StepsOut`), and the constants that select the kernel's branches."""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt

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
    "UPPER_TRIANGLE",
    "InterfaceOp",
    "Steps",
    "StepsOut",
    "Zone",
    "ZoneState",
    "upper_blocks",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]

#: Interface rows: none (a lone explicit subdomain), solved each micro step, or imposed.
NONE, SOLVED, IMPOSED = 0, 1, 2
#: Contact law: the exact LCP (CD-Lagrange), a penalty spring, or bilateral rows.
LAW_LCP, LAW_PENALTY, LAW_BILATERAL = 0, 1, 2
#: Indices of :attr:`StepsOut.sums` (FRICTION: the work of the tangential impulses).
EXT, DAMP, CONTACT, LINK, GC_WORK, PHYS_WORK, FRICTION = range(7)
#: Indices of :attr:`StepsOut.flags` (CHANGED: a watched point changed state; CLOSED: a
#: watched open point closed).
CHANGED, MPI_ERROR, LCP_ERROR, FRICTION_ERROR, CLOSED = range(5)


class _ZoneFields(NamedTuple):
    """The static arrays of an explicit subdomain (built once): :class:`Zone`'s fields."""

    bs: int
    n_own: int
    dt: float
    #: K in block CSR over the owned block rows; ``data`` is (nnzb, bs, bs) row-major.
    indptr: IntArray
    indices: IntArray
    data: FloatArray
    #: Block rows with owned columns only, and those with a ghost column.
    inner: IntArray
    boundary: IntArray
    mass: FloatArray
    minv: FloatArray
    alpha: float
    beta: float
    #: F(t) = base + Σ_k c_k(t) shapes[k].
    load_base: FloatArray
    load_shapes: FloatArray
    #: Stacked constraint rows: n_g interface rows, then p − n_g contact points; terms
    #: (row, owned DOF, coefficient), and the position of each term's DOF in ``c_dofs``.
    p: int
    n_g: int
    t_row: IntArray
    t_dof: IntArray
    t_coeff: FloatArray
    t_pos: IntArray
    c_dofs: IntArray
    g0: FloatArray
    tol: float
    #: The contact group of each contact point (p − n_g), and the number of groups: the
    #: kernel sums each group's impulses and takes its smallest gap at every micro step.
    c_group: IntArray
    n_groups: int
    #: Delassus blocks: diag of W_ΓΓ (its terms off the diagonal, where interface rows
    #: share DOFs, in ``gg_*``), W_cc (and its inverse for bilateral rows), W_Γc.
    w_gamma: FloatArray
    W_cc: FloatArray
    W_cc_inv: FloatArray
    W_ec: FloatArray
    cc_diagonal: bool
    ec_zero: bool
    #: MPI: (comm, MPI_DOUBLE, MPI_SUM) handles, size, neighbours, and the halo pattern in
    #: DOFs (values sent from ``send_idx``, received into ``recv_idx``).
    mpi: IntArray
    nranks: int
    neighbours: npt.NDArray[np.int32]
    send_ptr: IntArray
    send_idx: IntArray
    recv_ptr: IntArray
    recv_idx: IntArray
    #: Coulomb friction (crane_fem.kernels.friction): n_t tangential rows of the contact
    #: points with μ > 0, terms (row, owned DOF, coefficient, position in ``c_dofs``); per
    #: contact point its friction coefficient, first tangential row and row count (0: none);
    #: the Delassus blocks W_nt (p_c × n_t) and W_tt of the tangential rows; whether no two
    #: points share a DOF (``fric_local``: point by point) and which points' blocks are w I;
    #: otherwise the points coupled through shared DOFs, component by component (the
    #: points of component k: ``fric_order[fric_ptr[k]:fric_ptr[k + 1]]``), each solved as
    #: one problem.
    nt: int
    f_row: IntArray
    f_dof: IntArray
    f_coeff: FloatArray
    f_pos: IntArray
    mu: FloatArray
    t_first: IntArray
    t_count: IntArray
    W_nt: FloatArray
    W_tt: FloatArray
    fric_local: bool
    iso: BoolArray
    fric_ptr: IntArray
    fric_order: IntArray
    #: Ropes (tension-only springs): each rope's three contact rows are the components of
    #: its chord x_b − x_a (rows rope_first[r] + 0, 1, 2), its stiffness (N/m) and rest
    #: length (m); per contact point whether it is a rope's row (no part of the LCP); the
    #: number of ropes, and which constraint DOFs (``c_dofs``) they act on (no other row
    #: acts there). A rope's impulse is h k max(0, ℓ − L) along its current chord.
    rope_first: IntArray = np.zeros(0, dtype=np.int64)
    rope_k: FloatArray = np.zeros(0)
    rope_length: FloatArray = np.zeros(0)
    rope_row: BoolArray = np.zeros(0, dtype=np.bool_)
    n_spring: int = 0
    spring_dof: BoolArray = np.zeros(0, dtype=np.bool_)
    #: K over the owned DOF rows as scalar CSR without its zeros (local columns as
    #: ``indices``'), for beams (bs = 6); empty otherwise.
    s_indptr: IntArray = np.zeros(0, dtype=np.int64)
    s_indices: IntArray = np.zeros(0, dtype=np.int64)
    s_data: FloatArray = np.zeros(0)
    #: The row of each of those nonzeros (the serial beam product runs over them in one
    #: loop: a frame's rows hold 1–12 nonzeros, too few for a loop per row).
    s_rows: IntArray = np.zeros(0, dtype=np.int64)
    #: K's upper block triangle, for a serial zone with bs = 3 and no stiffness damping: the
    #: product then reads half of K (stiffness.py). The blocks right of the diagonal as block
    #: CSR in column order, ``u_data`` flat, 12 values a block (its rows, each padded to 4:
    #: crane_fem.kernels.vector); the diagonal blocks in ``u_diag``, 9 values a row,
    #: row-major. Derived by :class:`Zone` from ``indptr``, ``indices``, ``data``; empty
    #: otherwise.
    u_indptr: IntArray = np.zeros(0, dtype=np.int64)
    u_indices: npt.NDArray[np.int32] = np.zeros(0, dtype=np.int32)
    u_data: FloatArray = np.zeros(0)
    u_diag: FloatArray = np.zeros(0)
    #: W_ΓΓ's terms off its diagonal by row (CSR: ``gg_ptr`` (n_g + 1), columns, values)
    #: where interface rows share DOFs (a rigid section's six rows on one face,
    #: crane_fem.coupling.rigid_section); empty when W_ΓΓ is diagonal (rows on distinct
    #: DOFs, the shared-vertex interface).
    gg_ptr: IntArray = np.zeros(0, dtype=np.int64)
    gg_col: IntArray = np.zeros(0, dtype=np.int64)
    gg_val: FloatArray = np.zeros(0)


#: Whether :class:`Zone` derives K's upper block triangle where it can (False: every zone
#: takes the full block CSR product, in PETSc's order: bit for bit the Python path's).
UPPER_TRIANGLE = True


def upper_blocks(
    indptr: IntArray, indices: IntArray, data: FloatArray
) -> tuple[IntArray, npt.NDArray[np.int32], FloatArray, FloatArray] | None:
    """K's upper block triangle in the layout of :attr:`Zone.u_indptr` (``indices`` local
    block columns; ``data`` (nnzb, 3, 3)): the off-diagonal blocks' row pointers, columns and
    padded values, and the diagonal blocks; or None where a row has no diagonal block or a
    column is a ghost's (a zone that spans ranks). K's two triangles agree to round-off
    (the assembled element matrices are symmetric to round-off): the product of the upper
    one and its transpose is K's to round-off."""
    nb = indptr.size - 1
    rows = np.repeat(np.arange(nb, dtype=np.int64), np.diff(indptr))
    if indices.size == 0 or int(indices.max()) >= nb:
        return None
    blocks = np.asarray(data, dtype=np.float64).reshape(-1, 3, 3)
    on = indices == rows
    if np.count_nonzero(on) != nb or np.any(rows[on] != np.arange(nb)):
        return None
    diag = np.zeros((nb, 3, 3))
    diag[rows[on]] = blocks[on]
    keep = indices > rows
    r, c, a = rows[keep], indices[keep], blocks[keep]
    order = np.lexsort((c, r))
    r, c, a = r[order], c[order], a[order]
    ptr = np.zeros(nb + 1, dtype=np.int64)
    ptr[1:] = np.cumsum(np.bincount(r, minlength=nb))
    padded = _aligned(12 * c.size).reshape(-1, 3, 4)
    padded[:, :, :3] = a
    return ptr, c.astype(np.int32), padded.reshape(-1), diag.reshape(-1)


def _aligned(n: int, align: int = 64) -> FloatArray:
    """n zeros starting on an ``align``-byte boundary (a cache line: a 4-wide row of a block
    then never straddles two; NumPy's own allocations start on 16 bytes)."""
    raw = np.zeros(n + align // 8)
    first = (-raw.ctypes.data % align) // 8
    return raw[first : first + n]


class Zone(_ZoneFields):
    """The static arrays of an explicit subdomain (built once). A serial zone with bs = 3
    and no stiffness damping gets K's upper block triangle (``u_*``) at construction, unless
    given."""

    __slots__ = ()

    def __new__(cls, *args: Any, **kwargs: Any) -> Zone:
        self = super().__new__(cls, *args, **kwargs)
        eligible = UPPER_TRIANGLE and self.bs == 3 and self.beta == 0.0 and self.nranks == 1
        if eligible and self.u_indptr.size == 0 and self.boundary.size == 0:
            upper = upper_blocks(self.indptr, self.indices, self.data)
            if upper is not None:
                self = self._replace(
                    u_indptr=upper[0], u_indices=upper[1], u_data=upper[2], u_diag=upper[3]
                )
        return self


class ZoneState(NamedTuple):
    """The evolving arrays of an explicit subdomain and the kernel's scratch space."""

    u: FloatArray  # U, owned then ghost DOFs
    vh: FloatArray  # V_{j+1/2}, owned then ghost DOFs
    ku: FloatArray  # K U of the last micro step (owned)
    kv: FloatArray  # K V_{j−1/2} (owned; size 0 without stiffness damping)
    v_int: FloatArray  # V_j = ½ (V_{j−1/2} + V_{j+1/2}) of the last micro step (owned)
    lam_prev: FloatArray  # interface impulses Λ̂ of the previous micro step (n_g)
    w_prev: FloatArray  # L_E V at the previous micro step (n_g)
    vold_c: FloatArray  # V_{j−1/2} at the constraint DOFs
    jump: FloatArray  # Lᵀ Λ at the constraint DOFs
    jump_c: FloatArray  # its contact part
    red: FloatArray  # (3p) local L U, L V_{j−1/2}, L V_free
    red_out: FloatArray  # the same, global
    lam: FloatArray  # (p)
    qe: FloatArray  # (n_g) interface right-hand side
    qc: FloatArray  # (p − n_g) contact right-hand side
    work: FloatArray  # (n_g) operator scratch
    closed: BoolArray  # (p − n_g) contact points closed this micro step
    jump_f: FloatArray  # the tangential impulses' part of Lᵀ Λ at the constraint DOFs
    qt: FloatArray  # (n_t) free tangential velocities
    lam_t: FloatArray  # (n_t) tangential impulses
    fric_info: FloatArray  # (2) a friction problem not solved: its point and residual
    send_buf: FloatArray
    recv_buf: FloatArray
    requests: npt.NDArray[Any]
    #: F(t_j) on the owned DOFs: the serial beam product's scratch (empty otherwise).
    load: FloatArray = np.zeros(0)


class InterfaceOp(NamedTuple):
    """The micro-step interface operator A_k = W_E,ΓΓ + 2kγ W_I, inverted through blocks
    ``b`` of rows ``idx[ptr[b]:ptr[b+1]]``: A_k⁻¹ = D^-½ Q_b diag(1/(1 + 2kγ s_b)) Q_bᵀ D^-½,
    or with ``lowrank``, D^-½ (I + Q_b diag(1/(1 + 2kγ s_b) − 1) Q_bᵀ) D^-½ with the modes of
    negligible s dropped (crane_fem.coupling.operator). With ``k_fixed`` > 0 the operator
    serves that k only and each block of ``Q`` (``Q32``) is A_k⁻¹ itself, n_b × n_b with
    D^-½ folded in: one product instead of two (gc-mean's, whose k is the ratio)."""

    gamma: float
    idx: IntArray
    ptr: IntArray
    dis: FloatArray  # D^-½ in ``idx`` order
    Q: FloatArray  # per block, n_b × r_b row-major, flattened
    Q32: npt.NDArray[np.float32]  # the same in single precision, when ``single``
    qptr: IntArray
    rank: IntArray
    s: FloatArray
    sptr: IntArray
    lowrank: bool
    single: bool
    k_fixed: float = 0.0


class Steps(NamedTuple):
    """What one call integrates: ``n`` micro steps; the first with ``h0`` (Δt or Δt/2) and
    moving U or not (the start). Interface: ``mode``; targets w_I,j = tc[j,0] targets[0] +
    tc[j,1] targets[1] and operator step k_op[j] (SOLVED), or impulses Δt (ic[j,0] imposed[0]
    + ic[j,1] imposed[1]) (IMPOSED). ``watch``: the contact points closed at the start (flag
    a change), or empty."""

    n: int
    h0: float
    move0: bool
    coef: FloatArray  # (n, n_shape) load coefficients at t_j
    mode: int
    law: int
    penalty: float
    tc: FloatArray  # (n, 2)
    targets: FloatArray  # (2, n_g)
    k_op: FloatArray  # (n,)
    ic: FloatArray  # (n, 2)
    imposed: FloatArray  # (2, n_g)
    watch: BoolArray
    keep_impulses: bool
    #: Readings between the records: the owned DOFs ``probe`` read after the micro steps
    #: jj = probe_first, probe_first + probe_every, ... before the last (U_j and
    #: V_j = ½ (V_{j−1/2} + V_{j+1/2}) there, into :attr:`StepsOut.probe_u`, ``probe_v``);
    #: none when ``probe_every`` is 0. (Under MPI every rank takes the same readings, of its
    #: own DOFs, maybe none.)
    probe: IntArray = np.zeros(0, dtype=np.int64)
    probe_every: int = 0
    probe_first: int = 0


class StepsOut(NamedTuple):
    """What a call returns: the last micro step's impulses and gaps (all stacked rows), per
    micro step whether a contact impulse acted and, per contact group, the summed contact
    impulse and the smallest gap (``group_impulse``, ``group_gap``: (n, groups)), the energy
    sums (local: external, damping, contact and link work; global: the GC-measure and
    physical interface work), the interface impulses summed (trapezoid and plain), each
    micro step's (``keep_impulses``), L_E V at the last micro step, flags (contact set
    changed, MPI error, singular LCP, friction problem not solved, an open point closed),
    the last micro step's tangential impulses (``lam_t``, n_t; empty without friction), and
    the readings of :attr:`Steps.probe` (``probe_u``, ``probe_v``)."""

    lam: FloatArray
    gaps: FloatArray
    active: BoolArray
    group_impulse: FloatArray
    group_gap: FloatArray
    sums: FloatArray
    impulse_trap: FloatArray
    impulse_sum: FloatArray
    impulses: FloatArray
    w: FloatArray
    flags: IntArray
    lam_t: FloatArray = np.zeros(0)  # (shared default: written only when n_t > 0)
    #: (readings, probe size): U_j and V_j at :attr:`Steps.probe` (shared defaults, empty:
    #: written only with a probe).
    probe_u: FloatArray = np.zeros((0, 0))
    probe_v: FloatArray = np.zeros((0, 0))
