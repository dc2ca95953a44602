"""Stability: the critical explicit step from λ_max(M⁻¹K) (SLEPc), and divergence detection."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from petsc4py import PETSc
from slepc4py import SLEPc

from crane_fem.contact import ContactSet
from crane_fem.errors import UnstableRunError
from crane_fem.integrators.base import StepRecord
from crane_fem.model import StructuralModel

__all__ = ["EnergyGrowthMonitor", "critical_time_step", "max_frequency"]


def max_frequency(model: StructuralModel, extra: tuple[ContactSet, float] | None = None) -> float:
    """ω_max = √λ_max(M⁻¹ K) in rad/s (collective).

    Solved as the symmetric problem D K D x = λ x with D = M^{-1/2} (zero on fixed DOFs) by
    SLEPc's Krylov–Schur (options prefix ``crane_fem_dtcrit_``). ``extra = (contacts, k)`` adds
    the penalty springs k Lᵀ L (all contacts closed).
    """
    A = model.K.copy()
    if extra is not None:
        contacts, k = extra
        # Lᵀ L for points sharing no DOF: k c² on the diagonal of each contact DOF.
        if contacts.p:
            d = np.zeros(model.n_owned)
            np.add.at(d, contacts.dofs, k * contacts.coeffs**2)
            dvec = model.create_vector(d)
            A.setDiagonal(dvec, addv=True)  # addv=True: ADD_VALUES
            dvec.destroy()
            _add_offdiagonal_penalty(A, contacts, k, model)
    s = model.create_vector(np.sqrt(model.minv))
    A.diagonalScale(s, s)
    try:
        lam = _largest_eigenvalue(model.comm, "crane_fem_dtcrit_", A, None, 1e-12)
    finally:
        s.destroy()
        A.destroy()
    return math.sqrt(max(lam, 0.0))


def _largest_eigenvalue(
    comm: Any, prefix: str, A: PETSc.Mat, B: PETSc.Mat | None, tol: float
) -> float:
    """λ_max of A x = λ x (symmetric) or A x = λ B x (B symmetric positive definite, B⁻¹
    by conjugate gradients: a mass matrix is well conditioned), by SLEPc's Krylov–Schur
    under the options ``prefix`` (collective)."""
    eps = SLEPc.EPS().create(comm)
    try:
        eps.setOptionsPrefix(prefix)
        if B is None:
            eps.setOperators(A)
            eps.setProblemType(SLEPc.EPS.ProblemType.HEP)
            eps.setWhichEigenpairs(SLEPc.EPS.Which.LARGEST_REAL)
        else:
            eps.setOperators(A, B)
            eps.setProblemType(SLEPc.EPS.ProblemType.GHEP)
            eps.setWhichEigenpairs(SLEPc.EPS.Which.LARGEST_MAGNITUDE)
            ksp = eps.getST().getKSP()
            ksp.setType("cg")
            ksp.getPC().setType("jacobi")
            ksp.setTolerances(rtol=1e-14, atol=0.0, max_it=2000)
        eps.setTolerances(tol, 10000)
        eps.setDimensions(1)
        eps.setFromOptions()
        eps.solve()
        if eps.getConverged() < 1:
            raise RuntimeError(f"SLEPc did not converge on λ_max (options prefix {prefix})")
        return float(eps.getEigenvalue(0).real)
    finally:
        eps.destroy()


def _add_offdiagonal_penalty(
    A: PETSc.Mat, contacts: ContactSet, k: float, model: StructuralModel
) -> None:
    """Cross terms k c_i c_j of node-to-node penalty springs (terms of one point on two DOFs)."""
    # Global row indices of the terms owned here, gathered so every rank knows each point's terms.
    rstart = model.K.getOwnershipRange()[0]
    local = [
        (int(r), int(d) + rstart, float(c))
        for r, d, c in zip(contacts.rows, contacts.dofs, contacts.coeffs, strict=True)
    ]
    terms = [t for part in model.comm.allgather(local) for t in part]
    A.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)  # type: ignore[arg-type]
    by_point: dict[int, list[tuple[int, float]]] = {}
    for r, g, c in terms:
        by_point.setdefault(r, []).append((g, c))
    lo, hi = model.K.getOwnershipRange()
    for items in by_point.values():
        for gi, ci in items:
            if not lo <= gi < hi:
                continue
            for gj, cj in items:
                if gj != gi:
                    A.setValue(gi, gj, k * ci * cj, addv=True)  # ADD_VALUES
    A.assemble()


def max_frequency_consistent(model: StructuralModel) -> float:
    """ω_max = √λ_max(M⁻¹ K) in rad/s with the consistent mass M (collective): the
    generalized problem K x = λ M x by SLEPc's Krylov–Schur (options prefix
    ``crane_fem_dtcrit_m_``), M⁻¹ by conjugate gradients (M is well conditioned). Fixed DOFs
    (unit rows in both) give λ = 1, below any structural λ_max."""
    if model.M is None:
        raise ValueError("the model has no consistent mass matrix")
    lam = _largest_eigenvalue(model.comm, "crane_fem_dtcrit_m_", model.K, model.M, 1e-10)
    return math.sqrt(max(lam, 0.0))


def newmark_critical_step(omega_max: float, beta: float, gamma: float) -> float:
    """Newmark (β, γ)'s largest stable step for ω_max, undamped: ΔT ω_max ≤ (γ/2 − β)^(−1/2)
    (Hughes, The Finite Element Method, §9.1.2; 2/ω_max for β = 0, γ = ½, the central
    difference); unbounded where β ≥ γ/2 (unconditionally stable)."""
    if beta >= 0.5 * gamma or omega_max <= 0.0:
        return math.inf
    return 1.0 / (math.sqrt(0.5 * gamma - beta) * omega_max)


def critical_time_step(omega_max: float, alpha: float = 0.0, beta: float = 0.0) -> float:
    """Largest stable central-difference step for ω_max with Rayleigh damping C = αM + βK.

    Central difference with the damping force lagged at V_{n-1/2} has the characteristic
    polynomial λ² − (2 − c − w) λ + (1 − c), c = (α + β ω²) Δt, w = ω² Δt²; it is stable iff
    w + 2c ≤ 4, i.e. Δt ≤ [−(α + βω²) + √((α + βω²)² + 4 ω²)] / ω² (= 2/ω undamped).
    """
    if omega_max <= 0.0:
        return math.inf
    a = alpha + beta * omega_max**2
    return (-a + math.sqrt(a * a + 4.0 * omega_max**2)) / omega_max**2


@dataclass
class EnergyGrowthMonitor:
    """Stops a diverging run: kinetic energy above ``factor`` × the energy supplied so far.

    The energy supplied is the initial energy plus the accumulated |external work|; a stable
    run with dissipative contact never exceeds it, while an unstable one grows geometrically
    and crosses any fixed factor within a few dozen steps. Non-finite values stop at once.
    """

    factor: float
    subdomain: str
    scheme: str
    dt: float
    dt_critical: float
    _supplied: float = 0.0
    _last_work: float = 0.0
    _initialized: bool = False

    def growth(self, kinetic: float, internal: float, external_work: float) -> str | None:
        """Account for one record's external work; the reason to stop if the kinetic energy
        exceeds ``factor`` × the energy supplied so far, else None."""
        if not self._initialized:
            self._supplied = abs(kinetic) + abs(internal)
            self._last_work = external_work
            self._initialized = True
        self._supplied += abs(external_work - self._last_work)
        self._last_work = external_work
        if kinetic > self.factor * max(self._supplied, 1e-300):
            return (
                f"kinetic energy {kinetic:.3e} J exceeds {self.factor:g}× the energy "
                f"supplied ({self._supplied:.3e} J)"
            )
        return None

    def state_dict(self) -> dict[str, float | bool]:
        """The running books (a checkpoint)."""
        return {
            "supplied": self._supplied,
            "last_work": self._last_work,
            "initialized": self._initialized,
        }

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self._supplied = float(state["supplied"])
        self._last_work = float(state["last_work"])
        self._initialized = bool(state["initialized"])

    def check(self, rec: StepRecord) -> None:
        """Raise :class:`UnstableRunError` on divergence (same verdict on every rank)."""
        en = rec.energy
        grown = self.growth(en.kinetic, en.internal, en.external_work)
        values = (en.kinetic, en.internal, en.external_work, en.contact_dissipated)
        if not all(math.isfinite(x) for x in values):
            reason = "non-finite energy (NaN/Inf)"
        elif grown is not None:
            reason = grown
        else:
            return
        ratio = self.dt / self.dt_critical if self.dt_critical > 0 else math.inf
        raise UnstableRunError(
            f"unstable run: subdomain '{self.subdomain}' ({self.scheme}) at step {rec.step} "
            f"(t = {rec.t:.6g} s): {reason}; Δt = {self.dt:.4e} s is {ratio:.3f}× the "
            f"critical step {self.dt_critical:.4e} s"
        )
