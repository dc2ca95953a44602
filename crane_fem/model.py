"""Structural model: assembled stiffness, lumped mass, Rayleigh damping and fixed DOFs."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import dolfinx
import dolfinx.fem.petsc
import numpy as np
import numpy.typing as npt
import ufl
from mpi4py import MPI
from petsc4py import PETSc

__all__ = ["StructuralModel", "assemble_bar_operators", "assemble_structure"]

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


def assemble_bar_operators(
    V: dolfinx.fem.FunctionSpace,
    E: float,
    rho: float,
    area: dolfinx.fem.Function,
    fixed_dofs: npt.NDArray[np.int32],
) -> tuple[PETSc.Mat, FloatArray]:
    """Assemble the axial-bar stiffness ∫ E A u' w' dx and the row-sum lumped mass ∫ ρ A w dx.

    For P1 the row sum of the consistent mass equals nodal (GLL) quadrature: the element mass
    ρ A h is split in halves onto its two nodes. Collective over the mesh communicator.

    Returns:
        ``(K, mass)``: the caller owns ``K``; ``mass`` holds the owned DOFs only.
    """
    u, w = ufl.TrialFunction(V), ufl.TestFunction(V)
    dx = ufl.dx(domain=V.mesh)
    k_form = dolfinx.fem.form(E * area * ufl.inner(ufl.grad(u), ufl.grad(w)) * dx)
    m_form = dolfinx.fem.form(rho * area * w * dx)
    # Every rank builds the (possibly empty) condition: assembly with bcs is collective.
    zero = dolfinx.fem.Constant(V.mesh, np.float64(0.0))
    bcs = [dolfinx.fem.dirichletbc(zero, fixed_dofs, V)]
    K = dolfinx.fem.petsc.assemble_matrix(k_form, bcs=bcs, diag=1.0)
    K.assemble()
    mvec = dolfinx.fem.petsc.assemble_vector(m_form)
    mass = _lumped(mvec)
    mvec.destroy()
    return K, mass


LoadFunction = Callable[[float], FloatArray]


def assemble_structure(
    V: dolfinx.fem.FunctionSpace,
    E: float | dolfinx.fem.Function,
    nu: float | dolfinx.fem.Function,
    rho: float | dolfinx.fem.Function,
    area: dolfinx.fem.Function | float,
    fixed_dofs: npt.NDArray[np.int32],
    consistent_mass: bool = False,
) -> tuple[PETSc.Mat, FloatArray, PETSc.Mat | None]:
    """Stiffness, row-sum lumped mass and (optionally) consistent mass of a linear structure.

    A scalar space is an axial bar (∫ E A u' w' dx, mass ρ A); a vector space is 3D linear
    elasticity (E, ν and the mass's ρ: constants or cellwise DG0 functions). Fixed DOFs
    (local, owned and ghost) get zero rows/columns, unit diagonal in K and M. Collective over
    the mesh communicator.

    Returns:
        ``(K, lumped, M)``: the caller owns ``K`` and ``M``; ``lumped`` holds owned DOFs only.
    """
    u, w = ufl.TrialFunction(V), ufl.TestFunction(V)
    dx = ufl.dx(domain=V.mesh)
    if V.value_size == 1:
        k = E * area * ufl.inner(ufl.grad(u), ufl.grad(w)) * dx
        m = rho * area * ufl.inner(u, w) * dx
        m_row = rho * area * w * dx
        zero = dolfinx.fem.Constant(V.mesh, np.float64(0.0))
    else:
        mu = E / (2.0 * (1.0 + nu))
        lmbda = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))

        def eps(z: ufl.Argument) -> ufl.core.expr.Expr:
            return ufl.sym(ufl.grad(z))

        def sigma(z: ufl.Argument) -> ufl.core.expr.Expr:
            return 2.0 * mu * eps(z) + lmbda * ufl.tr(eps(z)) * ufl.Identity(len(z))

        k = ufl.inner(sigma(u), eps(w)) * dx
        m = rho * ufl.inner(u, w) * dx
        ones = ufl.as_vector([1.0] * V.value_size)
        m_row = rho * ufl.inner(ones, w) * dx
        zero = dolfinx.fem.Constant(V.mesh, np.zeros(V.value_size, dtype=np.float64))
    bcs = [dolfinx.fem.dirichletbc(zero, fixed_dofs, V)]
    K = dolfinx.fem.petsc.assemble_matrix(dolfinx.fem.form(k), bcs=bcs, diag=1.0)
    K.assemble()
    mvec = dolfinx.fem.petsc.assemble_vector(dolfinx.fem.form(m_row))
    lumped = _lumped(mvec)
    mvec.destroy()
    M = None
    if consistent_mass:
        M = dolfinx.fem.petsc.assemble_matrix(dolfinx.fem.form(m), bcs=bcs, diag=1.0)
        M.assemble()
    return K, lumped, M
