"""Ropes: tension-only springs between two points along their current chord (THEORY.md §10:
the unilateral law with the sign turned; slack allowed, the snap on re-tensioning an
impact).

A rope of rest length L and stiffness k between the points a and b has three rows, the
components of its chord x = x_b − x_a (g0 the chord at X, +1 on b's translation, −1 on a's).
At every micro step the kernel (crane_fem.kernels.explicit) takes the chord's length ℓ = |x|
and gives the rows the spring's impulse Δt k max(0, ℓ − L) along −x/ℓ: the ends pulled
together along the rope as it is now (no linearised direction: a pendulum swings on it),
nothing while it is slack. Its work is booked as an external force's on the structure.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from crane_fem.contact.constraints import ContactSet
from crane_fem.contact.surface import owned_terms

__all__ = ["RopeRows", "RopeSpec"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


@dataclass(frozen=True)
class RopeSpec:
    """Ropes between the global vertices ``a[r]`` and ``b[r]``: rest lengths (m),
    stiffnesses (N/m) and contact groups."""

    a: IntArray
    b: IntArray
    length: FloatArray
    stiffness: FloatArray
    group: IntArray

    @property
    def n(self) -> int:
        return int(self.a.size)


class RopeRows:
    """The chord rows of some ropes on a subdomain's translations.

    Args:
        sub: the subdomain holding both ends of every rope.
        spec: the ropes.
        names: the contact group names (``spec.group`` indexes them).
        X: (n, 2, 3) the ends' reference coordinates.
    """

    def __init__(self, sub: Any, spec: RopeSpec, names: list[str], X: FloatArray) -> None:
        self.sub = sub
        self.spec = spec
        self.names = list(names)
        X = np.asarray(X, dtype=np.float64)
        #: The chord rows' gaps at X: the components of X_b − X_a (3 per rope).
        self.g0 = (X[:, 1] - X[:, 0]).ravel()

    def rows(self) -> ContactSet:
        """The ropes' rows (not collective)."""
        n = self.spec.n
        row = np.arange(3 * n).reshape(n, 3)
        rows = np.concatenate([row.ravel(), row.ravel()])
        vert = np.concatenate([np.repeat(self.spec.b, 3), np.repeat(self.spec.a, 3)])
        comp = np.tile(np.arange(3), 2 * n)
        val = np.r_[np.ones(3 * n), -np.ones(3 * n)]
        mine, dofs = owned_terms(self.sub, vert, comp)
        return ContactSet(
            self.sub.submesh.comm,
            self.g0.copy(),
            rows[mine].astype(np.int64),
            dofs,
            val[mine],
            np.repeat(self.spec.group, 3).astype(np.int64),
            list(self.names),
            spring=np.repeat(self.spec.stiffness, 3).astype(np.float64),
            rest=np.repeat(self.spec.length, 3).astype(np.float64),
        )
