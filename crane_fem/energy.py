"""Energy bookkeeping: the terms of the discrete balance, and its closure."""

from __future__ import annotations

from dataclasses import dataclass, fields

__all__ = ["BALANCE_TERMS", "EnergyBalance"]


@dataclass
class EnergyBalance:
    """Energies (J) at one output time; all are global (reduced over the communicator).

    ``total = kinetic + internal - external_work + damping_dissipated + contact_dissipated
    + numerical_dissipated + friction_dissipated`` is constant for an exact discrete balance.
    For central difference, ``kinetic`` and ``internal`` are the staggered ("shadow") energies
    ``½ V_{n+1/2}ᵀ M V_{n+1/2}`` and ``½ U_{n+1}ᵀ K U_n`` that the scheme conserves exactly
    (THEORY.md §3); the dissipated terms are the work that the damping, contact, integrator
    and friction take out of the structure, accumulated since t = 0.

    Contact and friction are booked with the mean velocity of the micro step, the only form
    that closes the balance of CD-Lagrange exactly (crane_fem.kernels.explicit): with
    V̄ = ½ (V_{j−1/2} + V_{j+1/2}), the kinetic energy changes by V̄ᵀ M (V_{j+1/2} − V_{j−1/2}),
    whose impulse part is V̄ᵀ (Lᵀ Λ_n + Tᵀ Λ_t), so

        contact_dissipated  = −Σ_j Λ_n,j · L V̄_j
        friction_dissipated = −Σ_j Λ_t,j · ½ (v_t,j⁻ + v_t,j⁺),  v_t⁻ = T V_{j−1/2},
                              v_t⁺ = T V_{j+1/2}                                   (7.2)

    (T the tangential rows, Λ_t their impulses). Coulomb's law makes −Λ_t · v_t⁺ ≥ 0 at every
    point; the −Λ_t · v_t⁻ half is not signed step by step (v_t⁻ is not the free velocity),
    but the sum tends to ∫ μ r_n ‖v_t‖ dt ≥ 0 of the continuum as Δt → 0.
    """

    kinetic: float = 0.0
    internal: float = 0.0
    external_work: float = 0.0
    damping_dissipated: float = 0.0
    contact_dissipated: float = 0.0
    numerical_dissipated: float = 0.0
    friction_dissipated: float = 0.0

    @property
    def total(self) -> float:
        return (
            self.kinetic
            + self.internal
            - self.external_work
            + self.damping_dissipated
            + self.contact_dissipated
            + self.numerical_dissipated
            + self.friction_dissipated
        )

    def as_dict(self) -> dict[str, float]:
        d = {f.name: float(getattr(self, f.name)) for f in fields(self)}
        d["total"] = self.total
        return d

    def copy(self) -> EnergyBalance:
        return EnergyBalance(**{f.name: getattr(self, f.name) for f in fields(self)})


# Column names of the balance terms, in history order (``total`` is derived from them).
BALANCE_TERMS = [f.name for f in fields(EnergyBalance)]
