"""The micro-step interface operator A_k = W_E,ΓΓ + 2kγ W_I and its inverse, by blocks.

With a lumped explicit mass the interface block of W_E is diagonal, D, so
A_k = D^½ (I + 2kγ S) D^½ with S = D^-½ W_I D^-½ = Q diag(s) Qᵀ: one symmetric
eigendecomposition serves every k (docs/theory-notes.md §5), and each solve costs two dense
n_Γ × r products. Structure makes it cheaper:

- blocks by body (exact, always on): interface rows on different connected bodies of the
  implicit side do not interact through M̃⁻¹ at all (W_I is block diagonal between them);
- ``zones`` (a key): one block per pair (implicit body, connected explicit zone), the coupling
  of zones through the implicit side within a macro step dropped;
- ``single`` (a key): Q stored in single precision (half the memory traffic), sums in double;
- ``truncation`` ε > 0 (a key): the modes with 2mγ s ≤ ε taken as unaffected by the implicit
  side (1/(1 + 2kγ s) replaced by 1, a relative change ≤ ε of those components for every
  k ≤ m), leaving D^-½ (I + Q_r diag(1/(1 + 2kγ s_r) − 1) Q_rᵀ) D^-½.

Each approximation's error against the exact operator is measured in
``benchmarks/interface_operator.py`` (benchmarks/RESULTS.md).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import scipy.linalg

from crane_fem.kernels.explicit import InterfaceOp

__all__ = ["OperatorReport", "create_interface_operator"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


@dataclass(frozen=True)
class OperatorReport:
    """What the operator keeps: blocks, modes kept of all, the multiply-adds per solve against
    the exact operator's on one block, the largest entry of W_I dropped between blocks
    relative to the largest entry of W_I, and the precision of Q."""

    blocks: int
    modes_kept: int
    modes: int
    work: int
    work_one_block: int
    dropped_coupling: float
    precision: str


def create_interface_operator(
    w_gamma: FloatArray,
    W_I: FloatArray,
    gamma: float,
    m: int,
    blocks: IntArray | None = None,
    truncation: float = 0.0,
    single: bool = False,
    fixed: bool = False,
) -> tuple[InterfaceOp, OperatorReport]:
    """Diagonalise A_k once, block by block (not collective: every rank holds the inputs).

    With interface rows that share DOFs (a rigid section's six on one face) W_E,ΓΓ is block
    diagonal, not diagonal: on each block W_E = C Cᵀ (Cholesky) and A_k = C (I + 2kγ S) Cᵀ
    with S = C⁻¹ W_I C⁻ᵀ = Q diag(s) Qᵀ, so A_k⁻¹ = Q̃ diag(1/(1 + 2kγ s)) Q̃ᵀ with Q̃ = C⁻ᵀ Q:
    the same products, with the scaling folded into Q̃ (``dis`` = 1). Its blocks must hold
    each group of coupled rows whole.

    Args:
        w_gamma: the diagonal of W_E,ΓΓ (n_Γ), positive; or W_E,ΓΓ itself (n_Γ × n_Γ),
            symmetric positive definite, when it is not diagonal.
        W_I: L_I M̃⁻¹ L_Iᵀ (n_Γ × n_Γ), symmetric.
        gamma: Newmark γ of the implicit side.
        m: the largest k the operator is used with (the ratio).
        blocks: a block label per interface row, or None for one block.
        truncation: ε ≥ 0 (0 keeps every mode).
        single: store Q in single precision.
        fixed: the operator serves k = m only (gc-mean): each block stored as A_m⁻¹ itself,
            one product per solve instead of two (without truncation, which it makes moot).
    """
    W_E = None
    if w_gamma.ndim == 2:
        W_E, w_gamma = w_gamma, np.diag(w_gamma).copy()
        if not np.any(W_E - np.diag(w_gamma)):
            W_E = None  # diagonal after all
    n_g = w_gamma.size
    if not 0.0 <= truncation < 1.0:
        raise ValueError(f"interface truncation must be in [0, 1), got {truncation}")
    labels = np.zeros(n_g, dtype=np.int64) if blocks is None else np.asarray(blocks, np.int64)
    if W_E is not None:
        if truncation > 0.0:
            raise ValueError("interface truncation needs interface rows on distinct DOFs")
        if np.any(W_E[labels[:, None] != labels[None, :]]):
            raise ValueError("interface blocks split rows that share DOFs")
    dis = 1.0 / np.sqrt(w_gamma) if W_E is None else np.ones(n_g)
    order = np.argsort(labels, kind="stable")
    uniq, starts = np.unique(labels[order], return_index=True)
    ptr = np.append(starts, n_g).astype(np.int64)
    Qs, ss, ranks = [], [], []
    outside = W_I.copy()
    for b in range(uniq.size):
        rows = order[ptr[b] : ptr[b + 1]]
        outside[np.ix_(rows, rows)] = 0.0
        ds = dis[rows]
        if W_E is None:
            S = ds[:, None] * W_I[np.ix_(rows, rows)] * ds[None, :]
        else:
            C = np.linalg.cholesky(W_E[np.ix_(rows, rows)])
            Ci = scipy.linalg.solve_triangular(C, np.eye(rows.size), lower=True)
            S = Ci @ W_I[np.ix_(rows, rows)] @ Ci.T
        s, Q = np.linalg.eigh(0.5 * (S + S.T))
        if W_E is not None:
            Q = Ci.T @ Q  # Q̃ = C⁻ᵀ Q (ds = 1)
        if fixed:
            f = 1.0 / (1.0 + 2.0 * m * gamma * s)
            B = ds[:, None] * ((Q * f) @ Q.T) * ds[None, :]
            Qs.append(np.ascontiguousarray(0.5 * (B + B.T)).ravel())
            ss.append(np.zeros(0))
            ranks.append(rows.size)
            continue
        keep = 2.0 * m * gamma * s > truncation if truncation > 0.0 else np.ones(s.size, bool)
        Q, s = Q[:, keep], s[keep]
        Qs.append(np.ascontiguousarray(Q).ravel())
        ss.append(s)
        ranks.append(s.size)
    qptr = np.zeros(len(Qs) + 1, dtype=np.int64)
    qptr[1:] = np.cumsum([q.size for q in Qs])
    sptr = np.zeros(len(ss) + 1, dtype=np.int64)
    sptr[1:] = np.cumsum(ranks)
    Qcat = np.concatenate(Qs) if Qs else np.zeros(0)
    op = InterfaceOp(
        gamma=float(gamma),
        idx=order.astype(np.int64),
        ptr=ptr,
        dis=np.ascontiguousarray(dis[order]),
        Q=np.zeros(0) if single else Qcat,
        Q32=Qcat.astype(np.float32) if single else np.zeros(0, dtype=np.float32),
        qptr=qptr,
        rank=np.asarray(ranks, dtype=np.int64),
        s=np.concatenate(ss) if ss else np.zeros(0),
        sptr=sptr,
        lowrank=truncation > 0.0 and not fixed,
        single=single,
        k_fixed=float(m) if fixed else 0.0,
    )
    scale = float(np.max(np.abs(W_I), initial=0.0))
    report = OperatorReport(
        blocks=int(uniq.size),
        modes_kept=int(sum(ranks)),
        modes=n_g,
        work=int((1 if fixed else 2) * sum(r * (ptr[b + 1] - ptr[b]) for b, r in enumerate(ranks))),
        work_one_block=2 * n_g * n_g,
        dropped_coupling=float(np.max(np.abs(outside), initial=0.0)) / scale if scale else 0.0,
        precision="single" if single else "double",
    )
    return op, report
