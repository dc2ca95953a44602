"""Explicit central difference with penalty contact (the LS-DYNA/OpenSees baseline)."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from crane_fem.contact import ContactSet
from crane_fem.integrators.central_difference import CentralDifference
from crane_fem.model import LoadFunction, StructuralModel

__all__ = ["CDPenalty"]

FloatArray = npt.NDArray[np.float64]


class CDPenalty(CentralDifference):
    """Central difference with the penalty force ``f = k_p Lᵀ max(−g(U_{n+1}), 0)``.

    The spring adds ``k_p`` to the stiffness seen by the contact DOFs, hence its own stability
    limit Δt ≤ 2/ω_p, and the results depend on ``k_p`` (THEORY.md §1). ``impulse`` in the
    records is ``Δt k_p max(−g, 0)`` so that impulse/Δt is the contact force, as for the other
    schemes. The work of the penalty force is booked as ``contact_dissipated``: energy stored
    in the spring while it is compressed, and what the discrete spring failed to give back
    (negative: created) after separation.
    """

    name = "penalty"

    def __init__(
        self,
        model: StructuralModel,
        contacts: ContactSet,
        load: LoadFunction,
        dt: float,
        u0: FloatArray,
        v0: FloatArray,
        stiffness: float,
    ) -> None:
        super().__init__(model, contacts, load, dt, u0, v0)
        if not stiffness > 0.0:
            raise ValueError(f"penalty stiffness must be positive, got {stiffness}")
        self.stiffness = float(stiffness)

    def _contact_update(
        self, v_prev: FloatArray, rhs: FloatArray, h: float
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        m, c = self.model, self.contacts
        gaps = c.g0 + c.apply(self.u)
        force = self.stiffness * np.maximum(-gaps, 0.0)
        f_contact = c.transpose(force, m.n_owned)
        v_next = v_prev + h * m.minv * (rhs + f_contact)
        return v_next, h * force, gaps, h * f_contact
