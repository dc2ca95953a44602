"""The protocol of an element formulation, and the per-cell fields it reads.

A formulation (3D solid P1 tetrahedra, the axial bar, Timoshenko beams) owns what is specific
to one kind of element: its function space, its stiffness, consistent and lumped mass forms,
which components of a node are translations (the gravity and ground-motion loads act on those
only), its stress recovery and its element estimate of the stable explicit step. The rest of
the pipeline (subdomains, loads, integrators, couplings, contacts) sees DOF blocks of size
``bs`` and owned arrays only.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Protocol

import dolfinx
import numpy as np
import numpy.typing as npt
import ufl

__all__ = ["CellFields", "Forms", "Formulation", "SectionFields", "StressRecovery"]

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class SectionFields:
    """A beam's section properties and local axes, per local cell (owned, then ghost).

    Attributes:
        A: area (m²); I1, I2: second moments about the local axes a1 and a2 (m⁴); J: torsion
            constant (m⁴); k1, k2: shear factors along a1 and a2; c1, c2: extreme-fibre
            distances along a1 and a2 (m).
        circular: True where the section is a circle or a tube (the extreme-fibre bending
            stress is √(M1² + M2²) c / I), False for the corner sum of a rectangle or box.
        Wt: torsional section modulus (m³): the largest torsional shear stress is T / Wt.
        rotary: the factor on the section's rotary inertia about its bending axes in the
            masses, each at most the polar moment I1 + I2 (1: the section's own; more: the
            explicit step's lever on a thin member's thickness-shear mode, THEORY.md §10).
        t, a1, a2: (n, 3) the unit tangent and the local axes (a right-handed frame).
    """

    A: FloatArray
    I1: FloatArray
    I2: FloatArray
    J: FloatArray
    k1: FloatArray
    k2: FloatArray
    c1: FloatArray
    c2: FloatArray
    circular: npt.NDArray[np.bool_]
    Wt: FloatArray
    rotary: FloatArray
    t: FloatArray
    a1: FloatArray
    a2: FloatArray

    def restrict(self, cells: npt.NDArray[np.int32]) -> SectionFields:
        return SectionFields(**{k: getattr(self, k)[cells] for k in self.__dataclass_fields__})


@dataclass(frozen=True)
class CellFields:
    """Material (and section) of every local cell of a mesh (owned, then ghost).

    ``E``, ``nu`` and ``rho`` are a number where uniform over the model (compiled into the
    forms as constants), else one value per cell (DG0 functions). ``area`` is the axial bar's
    cross-section (m²), uniform or per cell; ``section`` a beam's (None otherwise).
    """

    E: float | FloatArray
    nu: float | FloatArray
    rho: float | FloatArray
    area: float | FloatArray = 1.0
    section: SectionFields | None = None

    def restrict(self, cells: npt.NDArray[np.int32]) -> CellFields:
        """The fields of the local cells ``cells`` (a submesh's parents), in that order."""

        def pick(x: float | FloatArray) -> float | FloatArray:
            return float(x) if np.ndim(x) == 0 else np.asarray(x)[cells]

        return replace(
            self,
            E=pick(self.E),
            nu=pick(self.nu),
            rho=pick(self.rho),
            area=pick(self.area),
            section=None if self.section is None else self.section.restrict(cells),
        )


def cell_function(
    msh: dolfinx.mesh.Mesh, values: FloatArray, name: str | None = None
) -> dolfinx.fem.Function:
    """A DG0 function on ``msh`` of the given value per local cell (owned and ghost); a
    vector DG0 function for values of shape (n, k)."""
    values = np.asarray(values, dtype=np.float64)
    shape = () if values.ndim == 1 else (values.shape[1],)
    f = dolfinx.fem.Function(dolfinx.fem.functionspace(msh, ("DG", 0, shape)), name=name)
    bs = f.function_space.dofmap.index_map_bs
    cells = f.function_space.dofmap.list[:, 0]
    if bs == 1:
        f.x.array[cells] = values
    else:
        f.x.array.reshape(-1, bs)[cells] = values
    return f


def coefficient(msh: dolfinx.mesh.Mesh, x: float | FloatArray) -> float | dolfinx.fem.Function:
    """``x`` as a form coefficient: the number itself, or a DG0 function of its values."""
    return float(x) if np.ndim(x) == 0 else cell_function(msh, np.asarray(x))


@dataclass(frozen=True)
class Forms:
    """The bilinear forms of a formulation on one space, and the linear form whose assembled
    vector is its lumped (diagonal) mass."""

    stiffness: ufl.Form
    mass: ufl.Form
    lumped: ufl.Form


class StressRecovery(Protocol):
    """The von Mises stress of a displacement field, one value per cell (Pa)."""

    n_cells: int

    def evaluate(self, u: FloatArray | None = None) -> FloatArray:
        """σ_vm of the owned cells for the owned-DOF displacement ``u`` (collective)."""
        ...


class Formulation(Protocol):
    """One kind of element (see the module docstring).

    Attributes:
        name: its name in messages ("solid", "bar", "beam").
        bs: DOFs per node.
        translations: the first ``translations`` components of a node are its translations
            (in x, y, z order); the rest (a beam's rotations) take no body load.
    """

    name: str
    bs: int
    translations: int

    def space(self, msh: dolfinx.mesh.Mesh) -> dolfinx.fem.FunctionSpace:
        """The displacement space on ``msh``."""
        ...

    def forms(self, V: dolfinx.fem.FunctionSpace, fields: CellFields) -> Forms:
        """K, M and the lumped mass's linear form on ``V`` (``fields`` per cell of V's mesh)."""
        ...

    def stress(self, V: dolfinx.fem.FunctionSpace, fields: CellFields) -> StressRecovery:
        """The stress recovery on ``V``."""
        ...

    def element_steps(self, msh: dolfinx.mesh.Mesh, fields: CellFields) -> FloatArray:
        """An estimate of each owned cell's stable explicit step (s), from its own lumped
        element alone (the global step comes from λ_max(M⁻¹K), crane_fem.stability)."""
        ...
