"""Structural model: assembled stiffness, lumped mass, Rayleigh damping and fixed DOFs, of any
element formulation (crane_fem.formulations)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import dolfinx
import dolfinx.fem.petsc
import numpy as np
import numpy.typing as npt
from mpi4py import MPI
from petsc4py import PETSc

from crane_fem.formulations import CellFields, Formulation

__all__ = ["LoadFunction", "StructuralModel", "assemble_operators", "fixed_conditions"]

FloatArray = npt.NDArray[np.float64]


@dataclass
class StructuralModel:
    """Linear elastic structure ``M a + C v + K u = f`` on one function space.

    Arrays (``mass``, ``minv``, ``fixed``) hold the DOFs owned by this rank only, in the
    PETSc/dolfinx owned ordering. ``minv`` is zero on fixed (clamped) DOFs, so any explicit
    update leaves them at rest. The model owns ``K``: call :meth:`destroy` (collective).

    Attributes:
        V: function space of the displacement.
        K: assembled stiffness (rows/columns of fixed DOFs zeroed, unit diagonal), N/m.
        mass: row-sum lumped mass, kg (ghost contributions accumulated before use).
        fixed: True on clamped DOFs.
        alpha, beta: Rayleigh coefficients, C = alpha M + beta K.
        M: consistent mass (rows/columns of fixed DOFs zeroed) or None; owned by the model.
    """

    V: dolfinx.fem.FunctionSpace
    K: PETSc.Mat
    mass: FloatArray
    fixed: npt.NDArray[np.bool_]
    alpha: float = 0.0
    beta: float = 0.0
    M: PETSc.Mat | None = None
    minv: FloatArray = field(init=False)

    def __post_init__(self) -> None:
        if np.any(self.mass[~self.fixed] <= 0.0):
            raise ValueError("lumped mass has a non-positive entry on a free DOF")
        self.minv = np.where(self.fixed, 0.0, 1.0 / np.where(self.fixed, 1.0, self.mass))

    @property
    def comm(self) -> MPI.Comm:
        return self.V.mesh.comm

    @property
    def n_owned(self) -> int:
        return int(self.mass.size)

    @property
    def damped(self) -> bool:
        return self.alpha != 0.0 or self.beta != 0.0

    def create_vector(self, array: FloatArray) -> PETSc.Vec:
        """A PETSc Vec that shares memory with the owned-DOF ``array`` (caller destroys)."""
        n_global = self.K.getSize()[0]
        # petsc4py stubs want a Sequence and a PETSc.Comm; an ndarray and an mpi4py comm work.
        vec = PETSc.Vec()
        args: dict[str, Any] = {"size": (array.size, n_global), "comm": self.comm}
        return vec.createWithArray(array, **args)  # type: ignore[arg-type]

    def destroy(self) -> None:
        """Destroy the PETSc objects (collective)."""
        self.K.destroy()
        if self.M is not None:
            self.M.destroy()


def _lumped(vec: PETSc.Vec) -> FloatArray:
    vec.ghostUpdate(addv=True, mode="reverse")  # addv=True: ADD_VALUES
    return np.array(vec.array_r, dtype=np.float64)


LoadFunction = Callable[[float], FloatArray]


def fixed_conditions(
    V: dolfinx.fem.FunctionSpace, fixed_dofs: npt.NDArray[np.int64]
) -> list[dolfinx.fem.DirichletBC]:
    """Zero Dirichlet conditions on the local DOFs ``fixed_dofs`` (block × bs + component,
    owned and ghost): one condition on their blocks where every component of each is fixed
    (a clamped vertex), else one per component (a beam's pinned vertex: translations only)."""
    bs = V.dofmap.index_map_bs
    fixed_dofs = np.asarray(fixed_dofs, dtype=np.int64)
    if bs == 1:
        zero = dolfinx.fem.Constant(V.mesh, np.float64(0.0))
        return [dolfinx.fem.dirichletbc(zero, fixed_dofs.astype(np.int32), V)]
    comp = [np.sort(fixed_dofs[fixed_dofs % bs == c] // bs) for c in range(bs)]
    if all(np.array_equal(comp[0], c) for c in comp[1:]):
        # dirichletbc on a blocked space takes block indices.
        zero = dolfinx.fem.Constant(V.mesh, np.zeros(bs, dtype=np.float64))
        return [dolfinx.fem.dirichletbc(zero, comp[0].astype(np.int32), V)]
    return [
        dolfinx.fem.dirichletbc(np.float64(0.0), (blocks * bs + c).astype(np.int32), V.sub(c))
        for c, blocks in enumerate(comp)
    ]


def assemble_operators(
    formulation: Formulation,
    V: dolfinx.fem.FunctionSpace,
    fields: CellFields,
    fixed_dofs: npt.NDArray[np.int64],
    consistent_mass: bool = False,
    point_mass: FloatArray | None = None,
) -> tuple[PETSc.Mat, FloatArray, PETSc.Mat | None]:
    """Stiffness, lumped mass and (optionally) consistent mass of a linear structure of one
    formulation (crane_fem.formulations). Fixed DOFs (local, owned and ghost: block × bs +
    component) get zero rows/columns and a unit diagonal in K and M. ``point_mass`` (owned
    DOFs, kg or kg·m²) is added to both masses' diagonals: masses and rotary inertias carried
    at nodes. Collective over the mesh communicator.

    Returns:
        ``(K, lumped, M)``: the caller owns ``K`` and ``M``; ``lumped`` holds owned DOFs only.
    """
    forms = formulation.forms(V, fields)
    bcs = fixed_conditions(V, fixed_dofs)
    K = dolfinx.fem.petsc.assemble_matrix(dolfinx.fem.form(forms.stiffness), bcs=bcs, diag=1.0)
    K.assemble()
    mvec = dolfinx.fem.petsc.assemble_vector(dolfinx.fem.form(forms.lumped))
    lumped = _lumped(mvec)
    mvec.destroy()
    M = None
    if consistent_mass:
        M = dolfinx.fem.petsc.assemble_matrix(dolfinx.fem.form(forms.mass), bcs=bcs, diag=1.0)
        M.assemble()
    if point_mass is not None and np.any(point_mass != 0.0):
        n_own = lumped.size
        fixed = np.zeros(n_own, dtype=bool)
        own = fixed_dofs[fixed_dofs < n_own]
        fixed[own] = True
        added = np.where(fixed, 0.0, point_mass)
        lumped = lumped + added
        if M is not None:
            vec = M.createVecRight()
            vec.array[:] = added
            M.setDiagonal(vec, addv=True)  # addv=True: ADD_VALUES
            vec.destroy()
    return K, lumped, M
