"""The energy in which the Prakash–Hjelmstad interface is lossless (docs/theory-notes.md §10).

Over one macro step of "ph" the explicit side is a linear system driven by a force that is
linear in time, F(t) = (1 − s) F_n + s F_n+1, and observed through its interface velocity at
the macro times only. Seen that way it is lossless for the trapezoidal supply

    S_E(n+1) − S_E(n) = ΔT · ½(V_n + V_n+1)ᵀ · ½(F_n + F_n+1),

V the integer-step velocity of central difference, with the storage (mode k of K φ = ω² M φ,
θ_k = 2 arcsin(ω_k Δt / 2), modal displacement x, velocity v, force f = φᵀF)

    S_E = Σ_k κ_k [ ½ v_k² + ½ ω_k² cos²(θ_k/2) (x_k + a_k f_k)² ],
    κ_k = (m sin(θ_k/2) / tan(mθ_k/2))²,   ω_k² a_k = 2 tan(mθ_k/2) / (m sin θ_k) − 1.

For m = 1, κ = cos²(θ/2) and a = Δt²/(4 cos²(θ/2)); as ω → 0, κ → 1 and
a → (ΔT² + 2Δt²)/12. The implicit side (average acceleration) is lossless for the same supply
with ½VᵀMV + ½UᵀKU, and velocity continuity at the macro times makes the two supplies
cancel: S_E + E_I is conserved exactly when nothing else acts, and it is the measure of the
PH stability argument (κ ≥ 0). It is not the physical energy: κ_k weighs each explicit mode by
how the macro step sees it (κ → ∞ when mθ_k → 2πi, κ = 0 when mθ_k = π (mod 2π)).

The storage needs the explicit subdomain's modes: a dense symmetric eigendecomposition of
M^-½ K M^-½, done once and refined in extended precision (κ varies by orders of magnitude
between neighbouring modes near a resonance, and LAPACK's eigenvectors mix neighbours by
ε‖A‖/gap: 1e-10 of S_E at m = 1000 on the split bar, 5e-16 refined), so it is offered up to
:data:`PH_MEASURE_MAX_DOFS` DOFs.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from crane_fem.model import StructuralModel

__all__ = ["PH_MEASURE_MAX_DOFS", "PHStorage", "mode_coefficients", "refined_eigh"]

FloatArray = npt.NDArray[np.float64]

#: Largest explicit subdomain (global DOFs) for which the PH measure is evaluated (the
#: extended-precision refinement is O(n³) without BLAS: 0.1 s for 161 DOFs, 16 s for 800).
PH_MEASURE_MAX_DOFS = 1000
#: Largest mode weight κ accepted: past it the float64 state's round-off, weighted by κ,
#: is no longer small against S_E (an explicit mode completes a whole number of periods
#: per macro step, where the measure is singular).
PH_KAPPA_MAX = 1e13
#: Modes with ω² below this fraction of the largest are rigid (storage ½ v²).
RIGID_TOL = 1e-10


def mode_coefficients(
    omega2: FloatArray, dt: float, m: int
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """(κ, c_xx, c_xf, c_ff) of S = ½κv² + ½c_xx x² + c_xf x f + ½c_ff f² per mode.

    c_xx = κω²cos²(θ/2), c_xf = c_xx a, c_ff = c_xx a², written without a (a is unbounded
    where κ vanishes). Needs ω Δt < 2 (the explicit step below its critical value)."""
    w2 = np.asarray(omega2, dtype=np.float64)
    rigid = w2 <= RIGID_TOL * float(np.max(w2, initial=0.0))
    w2s = np.where(rigid, 1.0, w2)
    s = np.sqrt(w2s) * dt / 2.0
    if np.any(s[~rigid] >= 1.0):
        raise ValueError("an explicit mode is above the central-difference limit (ω Δt ≥ 2)")
    theta = 2.0 * np.arcsin(s)
    cos2 = 1.0 - s * s
    T = np.tan(0.5 * m * theta)
    kappa = (m * s / T) ** 2
    g = 2.0 * T / (m * np.sin(theta)) - 1.0  # ω² a
    c_xx = kappa * w2s * cos2
    c_xf = kappa * cos2 * g
    c_ff = kappa * cos2 * g * g / w2s
    kappa = np.where(rigid, 1.0, kappa)
    zero = np.zeros_like(w2)
    return (
        kappa,
        np.where(rigid, zero, c_xx),
        np.where(rigid, zero, c_xf),
        np.where(rigid, zero, c_ff),
    )


def refined_eigh(A: FloatArray, steps: int = 2) -> tuple[FloatArray, FloatArray]:
    """Eigenpairs of the symmetric A: LAPACK's, then ``steps`` Newton refinements in
    extended precision (Ogita & Aishima, Japan J. Indust. Appl. Math. 35, 2018: with
    R = I − XᵀX, S = XᵀAX, λ_i = S_ii/(1 − R_ii), X ← X(I + E), E_ij = (S_ij + λ_j R_ij)/
    (λ_j − λ_i), E_ii = R_ii/2; within a cluster of equal λ only the orthogonality part,
    E_ij = R_ij/2, as any basis of the cluster serves)."""
    w, Q = np.linalg.eigh(A)
    A_x = np.asarray(A, dtype=np.longdouble)
    X = Q.astype(np.longdouble)
    n = w.size
    lam = w.astype(np.longdouble)  # returned as is when steps = 0
    cluster_tol = 1e-8 * max(float(np.max(np.abs(w), initial=0.0)), 1e-300)
    for _ in range(steps):
        R = np.eye(n, dtype=np.longdouble) - X.T @ X
        S = X.T @ A_x @ X
        lam = np.diag(S) / (1 - np.diag(R))
        gap = lam[None, :] - lam[:, None]
        close = np.abs(gap) <= cluster_tol
        E = np.where(close, R / 2, (S + R * lam[None, :]) / np.where(close, 1.0, gap))
        X = X + X @ E
    return lam.astype(np.float64), X.astype(np.float64)


class PHStorage:
    """S_E of the explicit subdomain ``model`` for steps Δt and ΔT = mΔt (collective).

    The stiffness is gathered to every rank (it is small: see :data:`PH_MEASURE_MAX_DOFS`),
    its modes computed once; each rank keeps the rows of its owned DOFs, and an evaluation
    is one Allreduce of the modal coordinates."""

    def __init__(self, model: StructuralModel, dt: float, m: int) -> None:
        comm = model.comm
        K = model.K
        n = int(K.getSize()[0])
        if n > PH_MEASURE_MAX_DOFS:
            raise ValueError(
                f"the PH energy measure needs the explicit subdomain's modes; {n} DOFs is "
                f"above its limit of {PH_MEASURE_MAX_DOFS}"
            )
        r0, r1 = K.getOwnershipRange()
        ai, aj, av = K.getValuesCSR()
        dense = np.zeros((n, n))
        for start, ia, ja, va in comm.allgather((r0, ai, aj, av)):
            rows = start + np.repeat(np.arange(len(ia) - 1), np.diff(ia))
            dense[rows, ja] = va
        mass = np.concatenate(comm.allgather(model.mass))
        free = ~np.concatenate(comm.allgather(model.fixed))
        d = 1.0 / np.sqrt(mass[free])
        A = d[:, None] * dense[np.ix_(free, free)] * d[None, :]
        w2, Q = refined_eigh(0.5 * (A + A.T))
        self.omega2 = w2
        with np.errstate(divide="ignore", invalid="ignore"):
            self.kappa, self.c_xx, self.c_xf, self.c_ff = mode_coefficients(w2, dt, m)
        worst = int(np.argmax(np.where(np.isfinite(self.kappa), self.kappa, np.inf)))
        if not np.isfinite(self.kappa[worst]) or self.kappa[worst] > PH_KAPPA_MAX:
            turns = m * 2.0 * np.arcsin(np.sqrt(max(w2[worst], 0.0)) * dt / 2.0) / (2 * np.pi)
            raise ValueError(
                f"explicit mode {worst} turns {turns:.6f} periods per macro step, where the "
                "PH measure is singular (weight κ = "
                f"{self.kappa[worst]:.3g} > {PH_KAPPA_MAX:g}); change Δt or the ratio slightly"
            )
        #: The range of the mode weights: S_E bounds the physical energy of mode k by S_E/κ_k.
        self.kappa_range = (float(np.min(self.kappa)), float(np.max(self.kappa)))
        # Rows of Q for this rank's owned free DOFs, scaled for x = Qᵀ M^½ u, f = Qᵀ M^-½ F.
        row_of = np.cumsum(free) - 1
        owned_free = free[r0:r1]
        q_rows = Q[row_of[r0:r1][owned_free]]
        sq = np.sqrt(model.mass[owned_free])
        self._owned_free = owned_free
        self._Qm = q_rows * sq[:, None]
        self._Qf = q_rows / sq[:, None]
        self._comm = comm

    def __call__(self, u: FloatArray, v: FloatArray, f: FloatArray) -> float:
        """S_E for the owned displacement, integer-step velocity and force (collective)."""
        of = self._owned_free
        local = np.stack([self._Qm.T @ u[of], self._Qm.T @ v[of], self._Qf.T @ f[of]])
        glob = np.empty_like(local)
        self._comm.Allreduce(local, glob)
        x, vel, frc = glob
        return float(
            np.sum(
                0.5 * self.kappa * vel * vel
                + 0.5 * self.c_xx * x * x
                + self.c_xf * x * frc
                + 0.5 * self.c_ff * frc * frc
            )
        )
