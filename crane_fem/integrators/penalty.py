"""Explicit central difference with penalty contact (the LS-DYNA/OpenSees baseline)."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from crane_fem.contact import ContactSet
from crane_fem.integrators.central_difference import CentralDifference
from crane_fem.kernels import explicit as kx
from crane_fem.loading.body import AffineLoad
from crane_fem.model import StructuralModel

__all__ = ["CDPenalty"]

FloatArray = npt.NDArray[np.float64]


class CDPenalty(CentralDifference):
    """Central difference with the penalty force ``f = k_p Lᵀ max(−g(U_{n+1}), 0)``.

    The spring adds ``k_p`` to the stiffness seen by the contact DOFs, hence its own stability
    limit Δt ≤ 2/ω_p, and the results depend on ``k_p`` (THEORY.md §1). ``impulse`` in the
    records is ``Δt k_p max(−g, 0)`` so that impulse/Δt is the contact force, as for the other
    schemes. The work of the penalty force is booked as ``contact_dissipated``: energy stored
    in the spring while it is compressed, and what the discrete spring failed to give back
    (negative: created) after separation. The step is the compiled kernel's with its penalty
    law.
    """

    name = "penalty"
    law = kx.LAW_PENALTY

    def __init__(
        self,
        model: StructuralModel,
        contacts: ContactSet,
        load: AffineLoad,
        dt: float,
        u0: FloatArray,
        v0: FloatArray,
        stiffness: float,
    ) -> None:
        if not stiffness > 0.0:
            raise ValueError(f"penalty stiffness must be positive, got {stiffness}")
        super().__init__(model, contacts, load, dt, u0, v0, penalty=stiffness)
        self.stiffness = float(stiffness)
