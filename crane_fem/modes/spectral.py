"""The classical response-spectrum method: modal damping, spectral accelerations of the
input record, peak modal responses and their SRSS and CQC combinations.

A mode i (ω_i, mass-normalised φ_i, participation Γ_id = φ_iᵀ M r_d) under the ground
acceleration a_d(t) along d has the modal coordinate q̈ + 2ζ_i ω_i q̇ + ω_i² q = −Γ_id a_d,
whose peak is |q| = Γ_id Sd(T_i, ζ_i) = Γ_id Sa(T_i, ζ_i) / ω_i² (Sa the pseudo-acceleration
spectrum of a_d). A response X linear in u (a support force, a wheel force) peaks in mode i
at X_id = X(φ_i) Γ_id Sa_id / ω_i². The modal peaks are combined per direction by

    SRSS:  X_d = √(Σ_i X_id²),
    CQC:   X_d = √(Σ_i Σ_j ρ_ij X_id X_jd),

with Der Kiureghian's (1981) correlation for damping ratios ζ_i, ζ_j and r = ω_j / ω_i:

    ρ_ij = 8 √(ζ_i ζ_j) (ζ_i + r ζ_j) r^{3/2}
           / [(1 − r²)² + 4 ζ_i ζ_j r (1 + r²) + 4 (ζ_i² + ζ_j²) r²],

and the directions by SRSS, √(Σ_d X_d²). The modes left out move the rest of the mass
rigidly with the ground: their response, the missing-mass term u_r,d = (K⁻¹ M r_d −
Σ_i φ_i Γ_id / ω_i²) ZPA_d (ZPA the record's peak acceleration), is combined by SRSS with
the modes' (the rigid response is uncorrelated with the resonant one).

Plain NumPy, not collective.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from crane_fem.spectra import response_spectrum

__all__ = [
    "DEFAULT_DAMPING",
    "combine_cqc",
    "combine_srss",
    "cqc_correlation",
    "modal_damping",
    "spectral_accelerations",
]

FloatArray = npt.NDArray[np.float64]

#: The damping ratio of every mode when the scenario has no damping.
DEFAULT_DAMPING = 0.05
#: Modal damping ratios are kept below this (the spectra need ζ < 1).
MAX_DAMPING = 0.99


def modal_damping(
    omega: FloatArray, rayleigh: tuple[float, float], ratio: float | None = None
) -> FloatArray:
    """ζ_i of every mode (ratios): ``ratio`` for all if given, else Rayleigh's
    α / (2 ω_i) + β ω_i / 2 (C = α M + β K), else :data:`DEFAULT_DAMPING` when α = β = 0;
    capped at :data:`MAX_DAMPING`."""
    w = np.asarray(omega, dtype=np.float64)
    if ratio is not None:
        return np.full(w.shape, float(ratio))
    alpha, beta = rayleigh
    if alpha == 0.0 and beta == 0.0:
        return np.full(w.shape, DEFAULT_DAMPING)
    zeta = alpha / (2.0 * np.maximum(w, 1e-300)) + 0.5 * beta * w
    return np.asarray(np.minimum(zeta, MAX_DAMPING), dtype=np.float64)


def cqc_correlation(omega: FloatArray, zeta: FloatArray) -> FloatArray:
    """(n, n) Der Kiureghian's modal correlation coefficients ρ_ij (module docstring); 1 on
    the diagonal, symmetric, 0 between undamped distinct modes."""
    w = np.asarray(omega, dtype=np.float64)
    z = np.asarray(zeta, dtype=np.float64)
    r = w[None, :] / w[:, None]
    zi, zj = z[:, None], z[None, :]
    num = 8.0 * np.sqrt(zi * zj) * (zi + r * zj) * r**1.5
    den = (1.0 - r**2) ** 2 + 4.0 * zi * zj * r * (1.0 + r**2) + 4.0 * (zi**2 + zj**2) * r**2
    with np.errstate(invalid="ignore", divide="ignore"):
        rho = np.where(den > 0.0, num / np.where(den > 0.0, den, 1.0), 1.0)
    # Symmetric by construction for equal ζ; the general form is made symmetric exactly.
    rho = 0.5 * (rho + rho.T)
    np.fill_diagonal(rho, 1.0)
    return np.asarray(rho, dtype=np.float64)


def combine_srss(peaks: FloatArray) -> FloatArray:
    """√(Σ_i X_i²) over the first axis (the modes) of ``peaks``."""
    x = np.asarray(peaks, dtype=np.float64)
    return np.asarray(np.sqrt(np.sum(x**2, axis=0)), dtype=np.float64)


def combine_cqc(peaks: FloatArray, rho: FloatArray) -> FloatArray:
    """√(Σ_ij ρ_ij X_i X_j) over the first axis (the modes) of ``peaks``."""
    x = np.asarray(peaks, dtype=np.float64)
    flat = x.reshape(x.shape[0], -1)
    quad = np.einsum("ik,ij,jk->k", flat, rho, flat)
    # ρ is positive semi-definite: a negative sum is round-off of a zero response.
    return np.asarray(np.sqrt(np.maximum(quad, 0.0)).reshape(x.shape[1:]), dtype=np.float64)


def spectral_accelerations(
    t: FloatArray, ground: FloatArray, omega: FloatArray, zeta: FloatArray
) -> FloatArray:
    """(n, 3) Sa(T_i, ζ_i) of each component of the ground acceleration ``ground`` (3, len
    t), m/s²; zero for a component that is zero throughout (not collective)."""
    w = np.asarray(omega, dtype=np.float64)
    sa = np.zeros((w.size, 3))
    for d in range(3):
        if not np.any(ground[d]):
            continue
        for i, (wi, zi) in enumerate(zip(w.tolist(), np.asarray(zeta).tolist(), strict=True)):
            spec = response_spectrum(t, ground[d], [2.0 * math.pi / wi], zi)
            sa[i, d] = float(spec.psa[0])
    return sa
