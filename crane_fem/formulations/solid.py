"""3D linear elasticity on P1 tetrahedra: the crane mock-up's, a box beam's, a block's and a
user's gmsh model's formulation."""

from __future__ import annotations

import dolfinx
import numpy as np
import numpy.typing as npt
import ufl

from crane_fem.formulations.protocol import CellFields, Forms, coefficient
from crane_fem.stress import CellStress

__all__ = ["SolidP1", "SolidVonMises"]

FloatArray = npt.NDArray[np.float64]


def _lame(E: object, nu: object) -> tuple[object, object]:
    """(μ, λ) of E and ν (numbers or DG0 functions)."""
    mu = E / (2.0 * (1.0 + nu))  # type: ignore[operator]
    lmbda = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))  # type: ignore[operator]
    return mu, lmbda


def _strain(z: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    return ufl.sym(ufl.grad(z))


def _stress(z: ufl.core.expr.Expr, mu: object, lmbda: object) -> ufl.core.expr.Expr:
    eps = _strain(z)
    return 2.0 * mu * eps + lmbda * ufl.tr(eps) * ufl.Identity(len(z))  # type: ignore[operator]


class SolidVonMises(CellStress):
    """σ_vm = √(3/2 s:s) of the displacement on ``V`` (a vector P1 space), in DG0 (P1
    strains are constant in a tetrahedron). Collective over the mesh communicator
    (:meth:`evaluate` scatters the ghosts)."""

    def __init__(
        self,
        V: dolfinx.fem.FunctionSpace,
        E: float | dolfinx.fem.Function,
        nu: float | dolfinx.fem.Function,
    ) -> None:
        mu, lmbda = _lame(E, nu)
        self.u = dolfinx.fem.Function(V, name="displacement")
        sigma = _stress(self.u, mu, lmbda)
        dev = sigma - ufl.tr(sigma) / 3.0 * ufl.Identity(len(self.u))
        W = dolfinx.fem.functionspace(V.mesh, ("DG", 0))
        self.field = dolfinx.fem.Function(W, name="von_mises")
        self._expr = dolfinx.fem.Expression(
            ufl.sqrt(1.5 * ufl.inner(dev, dev)), W.element.interpolation_points
        )
        self._n = V.dofmap.index_map.size_local * V.dofmap.index_map_bs
        self.mesh = V.mesh
        self.n_cells = V.mesh.topology.index_map(V.mesh.topology.dim).size_local

    def evaluate(self, u: FloatArray | None = None) -> FloatArray:
        if u is not None:
            self.u.x.array[: self._n] = u
            self.u.x.scatter_forward()
        self.field.interpolate(self._expr)
        return np.asarray(self.field.x.array[: self.n_cells])


class SolidP1:
    """Linear elastic P1 tetrahedra (E, ν and ρ per cell or uniform): 3 translations per
    node; the lumped mass is the consistent mass's row sum."""

    name = "solid"
    bs = 3
    translations = 3

    def space(self, msh: dolfinx.mesh.Mesh) -> dolfinx.fem.FunctionSpace:
        return dolfinx.fem.functionspace(msh, ("Lagrange", 1, (msh.geometry.dim,)))

    def forms(self, V: dolfinx.fem.FunctionSpace, fields: CellFields) -> Forms:
        msh = V.mesh
        mu, lmbda = _lame(coefficient(msh, fields.E), coefficient(msh, fields.nu))
        rho = coefficient(msh, fields.rho)
        u, w = ufl.TrialFunction(V), ufl.TestFunction(V)
        dx = ufl.dx(domain=msh)
        ones = ufl.as_vector([1.0] * V.value_size)
        return Forms(
            ufl.inner(_stress(u, mu, lmbda), _strain(w)) * dx,
            rho * ufl.inner(u, w) * dx,
            rho * ufl.inner(ones, w) * dx,
        )

    def stress(self, V: dolfinx.fem.FunctionSpace, fields: CellFields) -> SolidVonMises:
        msh = V.mesh
        return SolidVonMises(V, coefficient(msh, fields.E), coefficient(msh, fields.nu))

    def element_steps(self, msh: dolfinx.mesh.Mesh, fields: CellFields) -> FloatArray:
        """L_e / c_d per owned tetrahedron: L_e = 3 V / (largest face area), its smallest
        altitude, and c_d = √((λ + 2μ)/ρ) the dilatational wave speed."""
        n = msh.topology.index_map(3).size_local
        cells = np.arange(n, dtype=np.int32)
        X = msh.geometry.x[dolfinx.mesh.entities_to_geometry(msh, 3, cells)]
        e1, e2, e3 = (X[:, k] - X[:, 0] for k in (1, 2, 3))
        vol = np.abs(np.einsum("ij,ij->i", np.cross(e1, e2), e3)) / 6.0
        faces = [(0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3)]
        area = np.max(
            [
                0.5 * np.linalg.norm(np.cross(X[:, b] - X[:, a], X[:, c] - X[:, a]), axis=1)
                for a, b, c in faces
            ],
            axis=0,
        )
        E, nu, rho = (
            np.broadcast_to(np.asarray(x, dtype=float), (n,)) for x in fields_owned(fields, n)
        )
        c = np.sqrt(E * (1.0 - nu) / ((1.0 + nu) * (1.0 - 2.0 * nu) * rho))
        out: FloatArray = 3.0 * vol / area / c
        return out


def fields_owned(fields: CellFields, n: int) -> tuple[FloatArray, FloatArray, FloatArray]:
    """(E, ν, ρ) of the first ``n`` (owned) cells as arrays."""

    def own(x: float | FloatArray) -> FloatArray:
        return np.full(n, float(x)) if np.ndim(x) == 0 else np.asarray(x)[:n]

    return own(fields.E), own(fields.nu), own(fields.rho)
