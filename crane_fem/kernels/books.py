"""Serial reductions for the energy books, compiled.

NumPy's ``dot`` on vectors of more than a few thousand entries calls a threaded BLAS, whose
threads then spin on the other cores between calls (beside MPI ranks, they take cycles from
the work); the books need one pass each, in one thread.
"""

from __future__ import annotations

import numba
import numpy as np
import numpy.typing as npt

__all__ = ["dot", "shadow_energies"]

FloatArray = npt.NDArray[np.float64]


@numba.njit(cache=True)
def dot(x: FloatArray, y: FloatArray) -> float:
    """xᵀy in one serial pass."""
    s = 0.0
    for i in range(x.size):
        s += x[i] * y[i]
    return s


@numba.njit(cache=True)
def shadow_energies(
    vh: FloatArray, mass: FloatArray, u: FloatArray, ku: FloatArray, dt: float
) -> tuple[float, float]:
    """An explicit zone's local shadow kinetic and internal energies after a micro step,
    ½ V_{j+1/2}ᵀ M V_{j+1/2} and ½ U_jᵀ K U_j + ½ Δt V_{j+1/2}ᵀ K U_j, in one pass."""
    kin = 0.0
    uku = 0.0
    vku = 0.0
    for i in range(vh.size):
        kin += vh[i] * mass[i] * vh[i]
        uku += u[i] * ku[i]
        vku += vh[i] * ku[i]
    return 0.5 * kin, 0.5 * uku + 0.5 * dt * vku
