"""An explicit subdomain advanced by the compiled CD-Lagrange kernel: its arrays, built once.

The owner of :mod:`crane_fem.kernels.explicit` (dolfinx's custom-assembler pattern): it
unpacks the stiffness (block CSR with local columns), the lumped mass, the loads, the stacked
interface and contact rows, their Delassus blocks and the halo pattern of the mesh partition
into arrays once; the kernel then advances any number of micro steps per call. Its free step
and constraint update are those of THEORY.md §1 (Siconos' ``computeFreeState`` /
``updateState``), fused into one pass per micro step.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import scipy.sparse
from mpi4py import MPI
from petsc4py import PETSc
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from crane_fem.contact import ContactSet
from crane_fem.errors import CraneFemError
from crane_fem.kernels import explicit as kx
from crane_fem.kernels.books import shadow_energies
from crane_fem.kernels.mpi import comm_handle, create_requests
from crane_fem.loading.body import AffineLoad
from crane_fem.model import StructuralModel

__all__ = ["ExplicitZone", "ZoneSnapshot", "empty_operator"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


#: The kernel's state arrays a checkpoint keeps (the halo buffers and requests are rebuilt).
_STATE_FIELDS = tuple(
    k for k in kx.ZoneState._fields if k not in ("send_buf", "recv_buf", "requests")
)


@dataclass(frozen=True)
class ZoneSnapshot:
    """Copies of everything a call of the kernel changes (to redo a macro step)."""

    arrays: tuple[FloatArray, ...]


def empty_operator(n_g: int) -> kx.InterfaceOp:
    """An interface operator with no block (for calls that solve no interface row)."""
    z = np.zeros(0)
    zi = np.zeros(1, dtype=np.int64)
    return kx.InterfaceOp(
        0.5,
        np.arange(n_g, dtype=np.int64),
        zi,
        np.zeros(n_g),
        z,
        np.zeros(0, dtype=np.float32),
        zi,
        zi[:0],
        z,
        zi,
        False,
        False,
    )


@dataclass(frozen=True)
class _Friction:
    """The kernel's friction arrays (crane_fem.kernels.zone.Zone)."""

    nt: int
    rows: IntArray
    dofs: IntArray
    coeffs: FloatArray
    mu: FloatArray
    first: IntArray
    count: IntArray
    W_nt: FloatArray
    W_tt: FloatArray
    local: bool
    iso: npt.NDArray[np.bool_]
    comp_ptr: IntArray
    comp_order: IntArray


#: A point's Delassus block is taken as w I (closed form) when it is within this of it,
#: relative to w: the lumped masses of a node's components agree to round-off.
ISOTROPY_TOL = 1e-13


def _friction_arrays(
    contacts: ContactSet, minv: FloatArray, W_cc: FloatArray, interface: ContactSet
) -> _Friction:
    """The tangential rows of the frictional contact points and their Delassus blocks
    (collective: the Delassus operator is reduced over the ranks).

    Raises:
        CraneFemError: a frictional point on a DOF of an interface row (not supported: the
            interface rows are solved without the tangential ones).
    """
    pc = contacts.p
    t = contacts.tangent_rows
    nt = t.n
    first = np.full(pc, -1, dtype=np.int64)
    count = np.zeros(pc, dtype=np.int64)
    if nt:
        np.add.at(count, t.point, 1)
        starts = np.flatnonzero(np.r_[True, t.point[1:] != t.point[:-1]])
        first[t.point[starts]] = starts
    mu = np.ascontiguousarray(contacts.friction, dtype=np.float64)
    if not nt:
        z, none = np.zeros(0, dtype=np.int64), np.zeros(pc, dtype=bool)
        W_nt, W_tt = np.zeros((pc, 0)), np.zeros((0, 0))
        one = np.array([0, pc], dtype=np.int64)
        order = np.arange(pc, dtype=np.int64)
        return _Friction(0, z, z, np.zeros(0), mu, first, count, W_nt, W_tt, True, none, one, order)
    comm = contacts.comm
    shared = np.intersect1d(interface.dofs, np.concatenate([contacts.dofs, t.dofs])).size
    if comm.allreduce(shared, op=MPI.SUM):
        raise CraneFemError(
            "explicit zone: friction on contact points that share DOFs with interface rows is "
            "not supported"
        )
    Wf = contacts.with_tangents().delassus(minv)
    W_nt = np.ascontiguousarray(Wf[:pc, pc:])
    W_tt = np.ascontiguousarray(Wf[pc:, pc:])
    point = np.r_[np.arange(pc), t.point]
    other = point[:, None] != point[None, :]
    local = not bool(np.any(Wf[other] != 0.0))
    # The points coupled through shared DOFs, in components (solved one by one).
    i, j = np.nonzero(Wf)
    graph = coo_matrix((np.ones(i.size), (point[i], point[j])), shape=(pc, pc))
    n_comp, label = connected_components(graph, directed=False)
    comp_order = np.argsort(label, kind="stable").astype(np.int64)
    comp_ptr = np.searchsorted(label[comp_order], np.arange(n_comp + 1)).astype(np.int64)
    # A point is isotropic when its own block (its normal and tangential rows) is w I.
    r1, r2 = np.nonzero(point[:, None] == point[None, :])
    w_point = np.diag(W_cc)
    dev = np.abs(Wf[r1, r2] - np.where(r1 == r2, w_point[point[r1]], 0.0))
    worst = np.zeros(pc)
    np.maximum.at(worst, point[r1], dev)
    iso = worst <= ISOTROPY_TOL * w_point
    return _Friction(
        nt,
        t.rows.astype(np.int64),
        t.dofs.astype(np.int64),
        t.coeffs.astype(np.float64),
        mu,
        first,
        count,
        W_nt,
        W_tt,
        local,
        iso,
        comp_ptr,
        comp_order,
    )


def _positive_definite(W: FloatArray) -> bool:
    """Whether the symmetric ``W`` is positive definite (Cholesky)."""
    try:
        np.linalg.cholesky(0.5 * (W + W.T))
    except np.linalg.LinAlgError:
        return False
    return True


def constraint_arrays(
    model: StructuralModel, interface: ContactSet, contacts: ContactSet
) -> dict[str, Any]:
    """The kernel's constraint fields of :class:`~crane_fem.kernels.zone.Zone` for the
    interface rows and the contact rows (the relation: rows, gaps, Delassus blocks and the
    tangential rows of the frictional points), by name (collective: the Delassus operator is
    reduced over the ranks). Called at set-up, and again whenever the contact rows change
    (:meth:`ExplicitZone.set_contacts`): the kernel, compiled for these types, is reused.

    Raises:
        CraneFemError: interface rows on a fixed DOF or dependent ones (rows may share DOFs,
            a rigid section's six on one face, when their Delassus block stays positive
            definite), or friction on an interface DOF.
    """
    n_g = interface.p
    stack = ContactSet.stack(interface, contacts)
    W = stack.delassus(model.minv)
    W_gg = W[:n_g, :n_g]
    w_gamma = np.diag(W_gg).copy()
    off = W_gg - np.diag(w_gamma)
    if np.any(w_gamma <= 0.0) or (np.any(off) and not _positive_definite(W_gg)):
        raise CraneFemError(
            "explicit zone: the interface rows must act on free DOFs and be independent "
            "(their Delassus block positive definite)"
        )
    r_gg, c_gg = np.nonzero(off)  # row-major: CSR by row
    W_cc = np.ascontiguousarray(W[n_g:, n_g:])
    W_ec = np.ascontiguousarray(W[:n_g, n_g:])
    fr = _friction_arrays(contacts, model.minv, W_cc, interface)
    c_dofs = np.unique(np.concatenate([stack.dofs, fr.dofs])).astype(np.int64)
    spring = np.zeros(contacts.p) if contacts.spring is None else contacts.spring
    rest = np.zeros(contacts.p) if contacts.rest is None else contacts.rest
    spring_dof = _spring_dofs(stack, fr.dofs, spring, n_g, c_dofs)
    rope_row = spring > 0.0
    first = np.flatnonzero(rope_row)[::3].astype(np.int64)
    if first.size * 3 != np.count_nonzero(rope_row) or np.any(
        ~rope_row[first[:, None] + np.arange(3)]
    ):
        raise CraneFemError("explicit zone: a rope's rows must be three consecutive rows")
    return {
        "p": stack.p,
        "n_g": n_g,
        "t_row": stack.rows.astype(np.int64),
        "t_dof": stack.dofs.astype(np.int64),
        "t_coeff": stack.coeffs.astype(np.float64),
        "t_pos": np.searchsorted(c_dofs, stack.dofs).astype(np.int64),
        "c_dofs": c_dofs,
        "g0": stack.g0.astype(np.float64),
        "tol": float(stack.tol),
        "c_group": np.ascontiguousarray(contacts.group, dtype=np.int64),
        "n_groups": len(contacts.group_names),
        "w_gamma": w_gamma,
        "gg_ptr": np.searchsorted(r_gg, np.arange(n_g + 1)).astype(np.int64)
        if r_gg.size
        else np.zeros(0, dtype=np.int64),
        "gg_col": c_gg.astype(np.int64),
        "gg_val": np.ascontiguousarray(off[r_gg, c_gg], dtype=np.float64),
        "W_cc": W_cc,
        "W_cc_inv": np.zeros((0, 0)),
        "W_ec": W_ec,
        "cc_diagonal": bool(np.all(W_cc == np.diag(np.diag(W_cc)))),
        "ec_zero": not bool(np.any(W_ec)),
        "nt": fr.nt,
        "f_row": fr.rows,
        "f_dof": fr.dofs,
        "f_coeff": fr.coeffs,
        "f_pos": np.searchsorted(c_dofs, fr.dofs).astype(np.int64),
        "mu": fr.mu,
        "t_first": fr.first,
        "t_count": fr.count,
        "W_nt": fr.W_nt,
        "W_tt": fr.W_tt,
        "fric_local": fr.local,
        "iso": fr.iso,
        "fric_ptr": fr.comp_ptr,
        "fric_order": fr.comp_order,
        "rope_first": first,
        "rope_k": np.ascontiguousarray(spring[first], dtype=np.float64),
        "rope_length": np.ascontiguousarray(rest[first], dtype=np.float64),
        "rope_row": rope_row,
        "n_spring": int(first.size),
        "spring_dof": spring_dof,
        "_stack": stack,
        "_W": W,
    }


def _spring_dofs(
    stack: ContactSet, tangent_dofs: IntArray, spring: FloatArray, n_g: int, c_dofs: IntArray
) -> npt.NDArray[np.bool_]:
    """Which constraint DOFs the spring rows (ropes) act on (collective: a DOF shared with
    another row is refused on every rank).

    Raises:
        CraneFemError: a spring row shares a DOF with an interface, contact or tangential
            row (its impulse is not part of their problem).
    """
    is_spring = np.zeros(stack.p, dtype=bool)
    is_spring[n_g:] = spring > 0.0
    mine = is_spring[stack.rows]
    s_dofs = np.unique(stack.dofs[mine])
    others = np.unique(np.concatenate([stack.dofs[~mine], tangent_dofs]))
    shared = np.intersect1d(s_dofs, others).size
    if stack.comm.allreduce(shared, op=MPI.SUM):
        raise CraneFemError(
            "explicit zone: a rope's ends may not be contact points, nor on the interface "
            "between the explicit and implicit subdomains"
        )
    return np.isin(c_dofs, s_dofs)


def _constraint_state(rows: dict[str, Any]) -> dict[str, Any]:
    """The :class:`~crane_fem.kernels.zone.ZoneState` arrays sized by the constraint rows
    (the contact points, their DOFs, the tangential rows): fresh, as at the start of a macro
    step (the kernel recomputes them at every micro step)."""
    p, n_g, nt = rows["p"], rows["n_g"], rows["nt"]
    n_c = rows["c_dofs"].size
    return {
        "vold_c": np.zeros(n_c),
        "jump": np.zeros(n_c),
        "jump_c": np.zeros(n_c),
        "red": np.zeros(3 * p + nt),
        "red_out": np.zeros(3 * p + nt),
        "lam": np.zeros(p),
        "qc": np.zeros(p - n_g),
        "closed": np.zeros(p - n_g, dtype=bool),
        "jump_f": np.zeros(n_c),
        "qt": np.zeros(nt),
        "lam_t": np.zeros(nt),
    }


@dataclass(frozen=True)
class _Halo:
    """Neighbour ranks and, per neighbour, the owned DOFs sent and the ghost DOFs received."""

    neighbours: npt.NDArray[np.int32]
    send_ptr: IntArray
    send_idx: IntArray
    recv_ptr: IntArray
    recv_idx: IntArray


def _local_block_csr(
    model: StructuralModel,
) -> tuple[IntArray, IntArray, FloatArray, _Halo, scipy.sparse.csr_matrix]:
    """K on the owned block rows in block CSR with local columns: the owned blocks, then the
    off-process blocks the rows reference, sorted by global index (PETSc's order for its
    off-diagonal part), and the halo that brings their values (collective, setup only).

    The off-process columns are taken from K itself, not from the space's ghosts: a mesh
    without ghost cells has rows that reach vertices of cells owned elsewhere."""
    comm = model.comm
    bs = int(model.V.dofmap.index_map_bs)
    ranges = np.asarray(model.K.getOwnershipRanges(), dtype=np.int64) // bs
    start, end = int(ranges[comm.rank]), int(ranges[comm.rank + 1])
    n_own_b = end - start
    indptr, cols, vals = model.K.getValuesCSR()
    cols = np.asarray(cols, dtype=np.int64)
    gb, comp = cols // bs, cols % bs
    owned = (gb >= start) & (gb < end)
    off = np.unique(gb[~owned])
    local_b = np.where(owned, gb - start, n_own_b + np.searchsorted(off, gb))
    local = local_b * bs + comp
    csr = scipy.sparse.csr_matrix(
        (np.asarray(vals, dtype=np.float64), local, np.asarray(indptr, dtype=np.int64)),
        shape=(n_own_b * bs, (n_own_b + off.size) * bs),
    )
    csr.sort_indices()
    bsr = csr.tobsr(blocksize=(bs, bs))
    bsr.sort_indices()
    # Halo: who owns each off-process block, and which of ours each neighbour needs.
    owners = np.searchsorted(ranges, off, side="right") - 1
    size = comm.size
    want = [off[owners == r] for r in range(size)]
    recv_blocks = [n_own_b + np.flatnonzero(owners == r) for r in range(size)]
    asked = comm.alltoall(want) if size > 1 else [np.zeros(0, np.int64)]
    send_blocks = [np.asarray(a, dtype=np.int64) - start for a in asked]
    nbrs = [r for r in range(size) if r != comm.rank and (want[r].size or send_blocks[r].size)]
    comps = np.arange(bs)

    def dofs(blocks: IntArray) -> IntArray:
        return (blocks[:, None] * bs + comps[None, :]).ravel().astype(np.int64)

    def pack(lists: list[IntArray]) -> tuple[IntArray, IntArray]:
        ptr = np.zeros(len(lists) + 1, dtype=np.int64)
        ptr[1:] = np.cumsum([a.size for a in lists])
        cat = np.concatenate(lists).astype(np.int64) if lists else np.zeros(0, np.int64)
        return ptr, cat

    sp, si = pack([dofs(send_blocks[r]) for r in nbrs])
    rp, ri = pack([dofs(recv_blocks[r]) for r in nbrs])
    halo = _Halo(np.asarray(nbrs, dtype=np.int32), sp, si, rp, ri)
    # A beam's blocks are three quarters zeros (its local axes along the global ones): its
    # product runs over the scalar rows' nonzeros instead.
    scalar = csr.copy()
    scalar.eliminate_zeros()
    return (
        np.asarray(bsr.indptr, dtype=np.int64),
        np.asarray(bsr.indices, dtype=np.int64),
        np.ascontiguousarray(bsr.data, dtype=np.float64),
        halo,
        scalar,
    )


def readings(ctl: kx.Steps) -> int:
    """How many readings of its probe ``ctl``'s micro steps take: after the steps
    probe_first, probe_first + probe_every, ... before the last (:class:`kx.Steps`)."""
    if ctl.probe_every == 0 or ctl.probe_first > ctl.n - 2:
        return 0
    return (ctl.n - 2 - ctl.probe_first) // ctl.probe_every + 1


class ExplicitZone:
    """CD-Lagrange on one explicit subdomain, stepped by the compiled kernel.

    Rows of ``stack``: the n_Γ interface rows first, then the contact points. ``u``, ``vh``,
    ``v_int`` and ``ku`` are owned-DOF views of the state (U, V_{j+1/2}, V_j, K U).
    Collective over the model's communicator (construction and :meth:`advance`). The zone
    owns a duplicate of the communicator: :meth:`destroy` frees it (collective).
    """

    #: Whether construction compiles (or loads) the kernel with a call of no step; False
    #: only for crane_fem.warm, which compiles its callees itself.
    compile_on_setup = True

    def __init__(
        self,
        model: StructuralModel,
        load: AffineLoad,
        dt: float,
        u0: FloatArray,
        v0: FloatArray,
        interface: ContactSet,
        contacts: ContactSet,
    ) -> None:
        self.model, self.load, self.dt = model, load, float(dt)
        self.n_gamma = interface.p
        self.interface = interface
        self.contacts = contacts
        relation = constraint_arrays(model, interface, contacts)
        self.stack: ContactSet = relation.pop("_stack")
        self.W: FloatArray = relation.pop("_W")
        self.v0 = np.array(v0, dtype=np.float64)
        n_g = self.n_gamma
        n_own = model.n_owned
        bs = int(model.V.dofmap.index_map_bs)
        indptr, indices, data, halo, scalar = _local_block_csr(model)
        beam = bs == 6
        n_loc_b = n_own // bs + halo.recv_idx.size // bs
        has_ghost = np.zeros(indptr.size - 1, dtype=bool)
        if indices.size:
            rows = np.repeat(np.arange(indptr.size - 1), np.diff(indptr))
            has_ghost[rows[indices >= n_own // bs]] = True
        self._comm = model.comm.Dup()
        nbrs, si, ri = halo.neighbours, halo.send_idx, halo.recv_idx
        self.zone = kx.Zone(
            bs=bs,
            n_own=n_own,
            dt=self.dt,
            indptr=indptr,
            indices=indices,
            data=data,
            inner=np.flatnonzero(~has_ghost).astype(np.int64),
            boundary=np.flatnonzero(has_ghost).astype(np.int64),
            mass=np.ascontiguousarray(model.mass, dtype=np.float64),
            minv=np.ascontiguousarray(model.minv, dtype=np.float64),
            alpha=float(model.alpha),
            beta=float(model.beta),
            load_base=np.ascontiguousarray(load.base, dtype=np.float64),
            load_shapes=np.ascontiguousarray(load.shapes, dtype=np.float64),
            mpi=comm_handle(self._comm),
            nranks=int(self._comm.size),
            neighbours=nbrs,
            send_ptr=halo.send_ptr,
            send_idx=si,
            recv_ptr=halo.recv_ptr,
            recv_idx=ri,
            s_indptr=np.asarray(scalar.indptr if beam else np.zeros(0), dtype=np.int64),
            s_indices=np.asarray(scalar.indices if beam else np.zeros(0), dtype=np.int64),
            s_data=np.asarray(scalar.data if beam else np.zeros(0), dtype=np.float64),
            s_rows=np.repeat(
                np.arange(n_own if beam else 0, dtype=np.int64),
                np.diff(scalar.indptr) if beam else np.zeros(0, dtype=np.int64),
            ),
            **relation,
        )
        n_loc = n_loc_b * bs
        u = np.zeros(n_loc)
        u[:n_own] = u0
        vh = np.zeros(n_loc)
        vh[:n_own] = v0
        #: The stacked and tangential impulses of the last micro step integrated.
        self._last_impulses: tuple[FloatArray, FloatArray] | None = None
        self.state = kx.ZoneState(
            u=u,
            vh=vh,
            ku=np.zeros(n_own),
            kv=np.zeros(n_own if model.beta else 0),
            v_int=self.v0.copy(),
            lam_prev=np.zeros(n_g),
            w_prev=np.zeros(n_g),
            qe=np.zeros(n_g),
            work=np.zeros(n_g),
            fric_info=np.zeros(2),
            **_constraint_state(relation),
            send_buf=np.zeros(si.size),
            recv_buf=np.zeros(ri.size),
            requests=create_requests(2 * nbrs.size),
            load=np.zeros(n_own if beam else 0),
        )
        self._no_op = empty_operator(n_g)
        # Compile (or load from the cache) the kernel now, in the set-up: a call of no step.
        if self.compile_on_setup:
            self.advance(self.steps(0.0, 0))

    # ---------------------------------------------------------------------------------
    @property
    def u(self) -> FloatArray:
        return self.state.u[: self.zone.n_own]

    @property
    def vh(self) -> FloatArray:
        return self.state.vh[: self.zone.n_own]

    @property
    def v_int(self) -> FloatArray:
        return self.state.v_int

    @property
    def ku(self) -> FloatArray:
        return self.state.ku

    @property
    def lam_prev(self) -> FloatArray:
        """Interface impulses Λ̂ of the last micro step (global)."""
        return self.state.lam_prev

    @property
    def w_prev(self) -> FloatArray:
        """L_E V at the last integer time (global)."""
        return self.state.w_prev

    def set_contacts(self, contacts: ContactSet) -> None:
        """Replace the contact rows (the relation: a re-pairing between macro steps, the hook
        before a step, as Siconos' ``updateInteractions``), the interface rows kept
        (collective). The kernel, compiled for the zone's types, is reused; the state
        arrays sized by the contact rows start afresh (the kernel recomputes them every micro
        step), the mechanical state (U, V, K U) and the interface rows' impulses are kept."""
        rows = constraint_arrays(self.model, self.interface, contacts)
        self.stack, self.W = rows.pop("_stack"), rows.pop("_W")
        self.contacts = contacts
        self.zone = self.zone._replace(**rows)
        fresh = _constraint_state(rows)
        n_g = self.n_gamma
        fresh["lam"][:n_g] = self.state.lam[:n_g]  # the interface rows' impulses are kept
        self.state = self.state._replace(**fresh)
        self._last_impulses = None

    def set_contact_gaps(self, g0: FloatArray) -> None:
        """Replace the contact rows' gaps g0 (p_c,), the rows kept (not collective: every
        rank passes the same values)."""
        n_g = self.n_gamma
        g = np.asarray(g0, dtype=np.float64)
        self.zone.g0[n_g:] = g
        self.stack.g0[n_g:] = g
        self.contacts.g0[:] = g

    def with_bilateral_contacts(self, W_cc_inv: FloatArray) -> None:
        """Hold the contact rows as bilateral constraints (the linear probes of "ec", "ph")."""
        self.zone = self.zone._replace(W_cc_inv=np.ascontiguousarray(W_cc_inv))

    def steps(
        self,
        t0: float,
        n: int,
        *,
        h0: float | None = None,
        move0: bool = True,
        mode: int = kx.NONE,
        law: int = kx.LAW_LCP,
        penalty: float = 0.0,
        targets: tuple[FloatArray, FloatArray] | None = None,
        tc: FloatArray | None = None,
        k_op: FloatArray | None = None,
        imposed: tuple[FloatArray, FloatArray] | None = None,
        ic: FloatArray | None = None,
        watch: npt.NDArray[np.bool_] | None = None,
        keep_impulses: bool = False,
        times: npt.NDArray[np.floating[Any]] | None = None,
        probe: IntArray | None = None,
        probe_every: int = 0,
        probe_first: int = 0,
    ) -> kx.Steps:
        """The description of ``n`` micro steps from t0: t_j = t0 + jΔt, j = 1..n (or the
        given ``times``; t0 itself for a first step that does not move U)."""
        n_g = self.n_gamma
        at: FloatArray
        if times is not None:
            at = np.asarray(times, dtype=np.float64)
        elif move0:
            at = t0 + np.arange(1, n + 1, dtype=np.float64) * self.dt
        else:
            at = np.full(n, t0)
        z2 = np.zeros((n, 2))
        return kx.Steps(
            n=n,
            h0=self.dt if h0 is None else float(h0),
            move0=move0,
            coef=np.ascontiguousarray(self.load.coefficients(at)),
            mode=mode,
            law=law,
            penalty=float(penalty),
            tc=z2 if tc is None else np.ascontiguousarray(tc, dtype=np.float64),
            targets=np.zeros((2, n_g)) if targets is None else np.vstack(targets),
            k_op=np.zeros(n) if k_op is None else np.asarray(k_op, dtype=np.float64),
            ic=z2 if ic is None else np.ascontiguousarray(ic, dtype=np.float64),
            imposed=np.zeros((2, n_g)) if imposed is None else np.vstack(imposed),
            watch=np.zeros(0, dtype=bool) if watch is None else np.asarray(watch, dtype=bool),
            keep_impulses=keep_impulses,
            probe=np.zeros(0, dtype=np.int64) if probe is None else probe.astype(np.int64),
            probe_every=max(0, int(probe_every)),
            probe_first=int(probe_first),
        )

    def advance(self, ctl: kx.Steps, op: kx.InterfaceOp | None = None) -> kx.StepsOut:
        """Integrate the micro steps ``ctl`` describes (collective)."""
        n, p, n_g = ctl.n, self.stack.p, self.n_gamma
        out = kx.StepsOut(
            lam=np.zeros(p),
            gaps=np.zeros(p),
            active=np.zeros(n, dtype=bool),
            group_impulse=np.zeros((n, self.zone.n_groups)),
            group_gap=np.zeros((n, self.zone.n_groups)),
            sums=np.zeros(7),
            impulse_trap=np.zeros(n_g),
            impulse_sum=np.zeros(n_g),
            impulses=np.zeros((n if ctl.keep_impulses else 0, n_g)),
            w=np.zeros(n_g),
            flags=np.zeros(5, dtype=np.int64),
            lam_t=np.zeros(self.zone.nt),
            probe_u=np.zeros((readings(ctl), ctl.probe.size)),
            probe_v=np.zeros((readings(ctl), ctl.probe.size)),
        )
        if ctl.mode == kx.SOLVED and op is None:
            raise ValueError("solved interface rows need an interface operator")
        if ctl.mode == kx.SOLVED and op is not None and op.k_fixed > 0.0:
            if np.any(ctl.k_op != op.k_fixed):
                raise ValueError(f"the interface operator serves k = {op.k_fixed:g} only")
        kx.run_steps(self.zone, op if op is not None else self._no_op, self.state, ctl, out)
        if out.flags[kx.MPI_ERROR]:
            raise CraneFemError("explicit zone: an MPI call of the kernel failed")
        if out.flags[kx.LCP_ERROR]:
            raise ValueError(
                "contact Delassus operator is singular: two active constraints are redundant"
            )
        if out.flags[kx.FRICTION_ERROR]:
            point, res = int(self.state.fric_info[0]), float(self.state.fric_info[1])
            group = self.contacts.group_names[int(self.contacts.group[point])]
            raise CraneFemError(
                f"explicit zone: the frictional contact problem did not converge at contact "
                f"point {point} of '{group}' (residual {res:.1e} of the impulse scale)"
            )
        self._last_impulses = (out.lam, out.lam_t)
        return out

    def slipping(self) -> npt.NDArray[np.bool_]:
        """Per frictional contact point, whether it slid at the last micro step integrated:
        closed, with its tangential impulse on the Coulomb cone's surface (‖Λ_t‖ = μ Λ_n to
        round-off). Empty without friction. Not collective (this rank's impulses)."""
        z = self.zone
        if z.nt == 0 or self._last_impulses is None:
            return np.zeros(0, dtype=bool)
        lam, lam_t = self._last_impulses
        pts = np.flatnonzero(z.t_count > 0)
        lam_n = lam[self.n_gamma + pts]
        # Each point's tangential rows are contiguous: ‖Λ_t‖² from a running sum of squares.
        run = np.r_[0.0, np.cumsum(lam_t * lam_t)]
        first = z.t_first[pts]
        norm2 = run[first + z.t_count[pts]] - run[first]
        cone = (1.0 - 1e-9) * z.mu[pts] * lam_n
        return (lam_n > 0.0) & (norm2 >= cone * cone)

    def residual(self, t: float) -> FloatArray:
        """Out-of-balance force F(t) − K U of the current displacement (collective)."""
        m = self.model
        # The block (3 × 3) product sums as the kernel does (AIJ sums in another order).
        K = m.K.convert("baij", PETSc.Mat())
        x = m.create_vector(self.u.copy())
        y = x.duplicate()
        K.mult(x, y)
        ku = np.array(y.array_r, dtype=np.float64)
        for obj in (x, y, K):
            obj.destroy()
        return self.load(t) - ku

    def save(self) -> ZoneSnapshot:
        s = self.state
        return ZoneSnapshot(
            tuple(a.copy() for a in (s.u, s.vh, s.ku, s.kv, s.v_int, s.lam_prev, s.w_prev))
        )

    def restore(self, snap: ZoneSnapshot) -> None:
        s = self.state
        for dst, src in zip(
            (s.u, s.vh, s.ku, s.kv, s.v_int, s.lam_prev, s.w_prev), snap.arrays, strict=True
        ):
            dst[:] = src

    def state_dict(self) -> dict[str, Any]:
        """Copies of the state arrays (a checkpoint: U and V_{j+1/2} with their ghost entries,
        K U, V_j, the last interface impulses and the kernel's arrays that carry over between
        micro steps; the halo buffers and requests left out). Not collective."""
        s = self.state
        return {k: getattr(s, k).copy() for k in _STATE_FIELDS}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        """Set the state from :meth:`state_dict` of a zone on the same partition (not
        collective)."""
        for k in _STATE_FIELDS:
            dst, src = getattr(self.state, k), np.asarray(state[k])
            if dst.shape != src.shape:
                raise ValueError(f"explicit zone state {k!r}: shape {src.shape}, not {dst.shape}")
            dst[:] = src

    def local_energies(self) -> list[float]:
        """Local shadow kinetic and internal energy after the last micro step (THEORY.md §3:
        ½ V_{j+1/2}ᵀ M V_{j+1/2}, ½ U_{j+1}ᵀ K U_j = ½ U_jᵀ K U_j + ½ Δt V_{j+1/2}ᵀ K U_j)."""
        kin, internal = shadow_energies(self.vh, self.model.mass, self.u, self.ku, self.dt)
        return [kin, internal]

    def destroy(self) -> None:
        """Free the duplicated communicator (collective)."""
        if self._comm != MPI.COMM_NULL:
            self._comm.Free()
