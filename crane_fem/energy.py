"""Energy bookkeeping: the terms of the discrete balance, and its closure."""

from __future__ import annotations

from dataclasses import dataclass, fields

__all__ = ["BALANCE_TERMS", "EnergyBalance"]


@dataclass
class EnergyBalance:
    """Energies (J) at one output time; all are global (reduced over the communicator).

    ``total = kinetic + internal - external_work + damping_dissipated + contact_dissipated
    + numerical_dissipated`` is constant for an exact discrete balance. For central
    difference, ``kinetic`` and ``internal`` are the staggered ("shadow") energies
    ``½ V_{n+1/2}ᵀ M V_{n+1/2}`` and ``½ U_{n+1}ᵀ K U_n`` that the scheme conserves exactly
    (THEORY.md §3); the dissipated terms are the work that the damping, contact and
    integrator take out of the structure, accumulated since t = 0.
    """

    kinetic: float = 0.0
    internal: float = 0.0
    external_work: float = 0.0
    damping_dissipated: float = 0.0
    contact_dissipated: float = 0.0
    numerical_dissipated: float = 0.0

    @property
    def total(self) -> float:
        return (
            self.kinetic
            + self.internal
            - self.external_work
            + self.damping_dissipated
            + self.contact_dissipated
            + self.numerical_dissipated
        )

    def as_dict(self) -> dict[str, float]:
        d = {f.name: float(getattr(self, f.name)) for f in fields(self)}
        d["total"] = self.total
        return d

    def copy(self) -> EnergyBalance:
        return EnergyBalance(**{f.name: getattr(self, f.name) for f in fields(self)})


# Column names of the balance terms, in history order (``total`` is derived from them).
BALANCE_TERMS = [f.name for f in fields(EnergyBalance)]
