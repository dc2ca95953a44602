"""The axial bar: one scalar displacement per node along a 1D mesh (the verification bars)."""

from __future__ import annotations

import dolfinx
import numpy as np
import numpy.typing as npt
import ufl

from crane_fem.formulations.protocol import CellFields, Forms, coefficient
from crane_fem.formulations.solid import fields_owned
from crane_fem.stress import CellStress

__all__ = ["AxialBar", "AxialStress"]

FloatArray = npt.NDArray[np.float64]


class AxialStress(CellStress):
    """|σ| = |E u'| per cell (P1: constant in a cell), in DG0 (collective)."""

    def __init__(self, V: dolfinx.fem.FunctionSpace, E: float | dolfinx.fem.Function) -> None:
        self.u = dolfinx.fem.Function(V, name="displacement")
        W = dolfinx.fem.functionspace(V.mesh, ("DG", 0))
        self.field = dolfinx.fem.Function(W, name="axial_stress")
        self._expr = dolfinx.fem.Expression(abs(E * self.u.dx(0)), W.element.interpolation_points)
        self._n = V.dofmap.index_map.size_local
        self.mesh = V.mesh
        self.n_cells = V.mesh.topology.index_map(V.mesh.topology.dim).size_local

    def evaluate(self, u: FloatArray | None = None) -> FloatArray:
        if u is not None:
            self.u.x.array[: self._n] = u
            self.u.x.scatter_forward()
        self.field.interpolate(self._expr)
        return np.asarray(self.field.x.array[: self.n_cells])


class AxialBar:
    """∫ E A u' w' dx and ρ A on a 1D mesh along x (P1): the lumped mass splits each
    element's ρ A h in halves onto its two nodes (the row sum equals nodal quadrature)."""

    name = "bar"
    bs = 1
    translations = 1

    def space(self, msh: dolfinx.mesh.Mesh) -> dolfinx.fem.FunctionSpace:
        return dolfinx.fem.functionspace(msh, ("Lagrange", 1))

    def forms(self, V: dolfinx.fem.FunctionSpace, fields: CellFields) -> Forms:
        msh = V.mesh
        E, rho = coefficient(msh, fields.E), coefficient(msh, fields.rho)
        area = coefficient(msh, fields.area)
        u, w = ufl.TrialFunction(V), ufl.TestFunction(V)
        dx = ufl.dx(domain=msh)
        return Forms(
            E * area * ufl.inner(ufl.grad(u), ufl.grad(w)) * dx,
            rho * area * ufl.inner(u, w) * dx,
            rho * area * w * dx,
        )

    def stress(self, V: dolfinx.fem.FunctionSpace, fields: CellFields) -> AxialStress:
        return AxialStress(V, coefficient(V.mesh, fields.E))

    def element_steps(self, msh: dolfinx.mesh.Mesh, fields: CellFields) -> FloatArray:
        """h / c per owned element (c = √(E/ρ)): the lumped two-node element's 2/ω."""
        n = msh.topology.index_map(1).size_local
        X = msh.geometry.x[dolfinx.mesh.entities_to_geometry(msh, 1, np.arange(n, dtype=np.int32))]
        h = np.linalg.norm(X[:, 1] - X[:, 0], axis=1)
        E, _, rho = fields_owned(fields, n)
        out: FloatArray = h / np.sqrt(E / rho)
        return out
