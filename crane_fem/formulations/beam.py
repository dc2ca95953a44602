"""Timoshenko beams on a line mesh embedded in 3D: three translations and three rotations
per node (THEORY.md §10, docs/theory-notes.md §17).

Per cell a local frame (t, a1, a2): t the unit tangent, a2 the orientation vector of the
cell's group made orthogonal to t, a1 = a2 × t. Generalised strains (' = d/ds along t):
ε = u'·t, γ1 = u'·a1 − θ·a2, γ2 = u'·a2 + θ·a1, κt = θ'·t, κ1 = θ'·a1, κ2 = θ'·a2, with the
section's rigidities C = diag(EA, k1 GA, k2 GA, GJ, EI1, EI2). P1 for u and θ with the shear
terms integrated at the midpoint (one point: the classical locking-free linear Timoshenko
element; the axial, torsion and bending terms are constant in a cell, exact either way).

Mass: ρA u̇·û + ρ (I1 θ̇1 θ̂1 + I2 θ̇2 θ̂2 + (I1 + I2) θ̇t θ̂t), consistent for Newmark and the
reduced side; lumped for CD-Lagrange: each node takes half of each element's ρA le on its
translations and half of its rotary inertia tensor ρ le (I1 a1⊗a1 + I2 a2⊗a2 + Ip t⊗t) on its
rotations, diagonal in global axes (exact for members along the axes; for an oblique member
the tensor's diagonal, positive: the explicit step stays that of the rotary terms).
"""

from __future__ import annotations

from typing import Any

import dolfinx
import numpy as np
import numpy.typing as npt
import ufl

from crane_fem.formulations.protocol import CellFields, Forms, coefficient
from crane_fem.formulations.solid import fields_owned
from crane_fem.stress import CellStress

__all__ = ["SECTION_FORCES", "BeamStress", "TimoshenkoBeam", "local_axes"]

FloatArray = npt.NDArray[np.float64]

#: The section forces of a cell, in the order of :meth:`BeamStress.forces` (N, N·m).
SECTION_FORCES = ("N", "V1", "V2", "T", "M1", "M2")


def local_axes(tangent: FloatArray, orientation: FloatArray) -> tuple[FloatArray, FloatArray]:
    """(a1, a2) per row of unit tangents (n, 3) and orientation vectors (n, 3): a2 the
    orientation made orthogonal to t and unit, a1 = a2 × t.

    Raises:
        ValueError: an orientation vector is parallel to its tangent (within 1e-6 rad).
    """
    t = np.asarray(tangent, dtype=np.float64).reshape(-1, 3)
    v = np.broadcast_to(np.asarray(orientation, dtype=np.float64), t.shape)
    a2 = v - np.einsum("ij,ij->i", v, t)[:, None] * t
    norm = np.linalg.norm(a2, axis=1)
    scale = np.linalg.norm(v, axis=1)
    if np.any(norm <= 1e-6 * scale):
        raise ValueError("orientation vector parallel to a member")
    a2 = a2 / norm[:, None]
    return np.cross(a2, t), a2


class _Coefficients:
    """The DG0 coefficients of a beam's forms on one mesh."""

    def __init__(self, msh: dolfinx.mesh.Mesh, fields: CellFields) -> None:
        s = fields.section
        if s is None:
            raise ValueError("a beam formulation needs section fields")
        self.msh = msh
        self.E = coefficient(msh, fields.E)
        self.nu = coefficient(msh, fields.nu)
        self.rho = coefficient(msh, fields.rho)
        self.G = self.E / (2.0 * (1.0 + self.nu))
        scalars = ("A", "I1", "I2", "J", "k1", "k2")
        self.A, self.I1, self.I2, self.J, self.k1, self.k2 = (
            coefficient(msh, np.asarray(getattr(s, k), dtype=np.float64)) for k in scalars
        )
        self.R = coefficient(msh, np.asarray(s.rotary, dtype=np.float64))
        vec = [coefficient(msh, np.asarray(getattr(s, k))) for k in ("t", "a1", "a2")]
        self.t, self.a1, self.a2 = vec

    def strains(self, z: ufl.core.expr.Expr) -> tuple[ufl.core.expr.Expr, ...]:
        """(ε, γ1, γ2, κt, κ1, κ2) of a 6-component field z = (u, θ)."""
        u = ufl.as_vector([z[0], z[1], z[2]])
        th = ufl.as_vector([z[3], z[4], z[5]])
        du = ufl.grad(u) * self.t
        dth = ufl.grad(th) * self.t
        t, a1, a2 = self.t, self.a1, self.a2
        return (
            ufl.dot(du, t),
            ufl.dot(du, a1) - ufl.dot(th, a2),
            ufl.dot(du, a2) + ufl.dot(th, a1),
            ufl.dot(dth, t),
            ufl.dot(dth, a1),
            ufl.dot(dth, a2),
        )

    def rigidities(self) -> tuple[object, ...]:
        """(EA, (k1 GA)*, (k2 GA)*, GJ, EI1, EI2), the shear rigidities with the residual
        bending flexibility (MacNeal 1978): 1/(k1 GA)* = 1/(k1 GA) + le²/(12 EI2) (γ1 bends
        about a2), likewise for 2 with EI1. The one-point element then has the exact
        Timoshenko stiffness of a two-node beam (Przemieniecki's, with its shear parameter
        Φ = 12 EI/(k GA le²)): nodal displacements exact under nodal loads, the bending
        energy of the cubic deflection the linear field cannot hold restored."""
        E, G, A = self.E, self.G, self.A
        le2 = ufl.CellVolume(self.msh) ** 2

        def shear(kga: Any, ei: Any) -> Any:
            den = 12.0 * ei + kga * le2
            return ufl.conditional(ufl.gt(den, 0.0), 12.0 * ei * kga / den, 0.0)

        return (
            E * A,
            shear(self.k1 * G * A, E * self.I2),
            shear(self.k2 * G * A, E * self.I1),
            G * self.J,
            E * self.I1,
            E * self.I2,
        )


class BeamStress(CellStress):
    """Each cell's section forces (N, V1, V2, T, M1, M2) and the von Mises stress at its
    sections' extreme fibres (collective over the mesh communicator).

    The forces are the cell's (constant N, V, T; the bending moments at the midpoint). The
    moments at the element's ends, in equilibrium with its constant shear, are
    M1 ± V2 le/2 and M2 ± V1 le/2: the stress takes the larger end's, |M1| + |V2| le/2 (and
    likewise for M2). At the extreme fibre, σ = |N|/A + |M1| c2/I1 + |M2| c1/I2 (a corner of
    a rectangle or box) or |N|/A + √(M1² + M2²) c/I (a circle or tube), τ = |T| / Wt (the
    transverse shear vanishes there), σ_vm = √(σ² + 3τ²).
    """

    def __init__(self, V: dolfinx.fem.FunctionSpace, fields: CellFields) -> None:
        msh = V.mesh
        c = _Coefficients(msh, fields)
        self.u = dolfinx.fem.Function(V, name="displacement")
        strains = c.strains(self.u)
        forces = ufl.as_vector([k * e for k, e in zip(c.rigidities(), strains, strict=True)])
        W = dolfinx.fem.functionspace(msh, ("DG", 0, (6,)))
        self.section_forces = dolfinx.fem.Function(W, name="section_forces")
        self._expr = dolfinx.fem.Expression(forces, W.element.interpolation_points)
        S = dolfinx.fem.functionspace(msh, ("DG", 0))
        self.field = dolfinx.fem.Function(S, name="von_mises")
        self._n = V.dofmap.index_map.size_local * V.dofmap.index_map_bs
        self.mesh = msh
        self.n_cells = msh.topology.index_map(1).size_local
        n = self.n_cells
        s = fields.section
        assert s is not None
        self._sec = s.restrict(np.arange(n, dtype=np.int32))
        X = msh.geometry.x[dolfinx.mesh.entities_to_geometry(msh, 1, np.arange(n, dtype=np.int32))]
        self._half = 0.5 * np.linalg.norm(X[:, 1] - X[:, 0], axis=1)
        self._rows = self.section_forces.function_space.dofmap.list[:n, 0]
        self._cells = S.dofmap.list[:n, 0]
        #: The section forces of the last :meth:`evaluate` (n_owned_cells, 6).
        self.last_forces = np.zeros((n, 6))

    def forces(self, u: FloatArray | None = None) -> FloatArray:
        """(n_owned_cells, 6) section forces N, V1, V2 (N), T, M1, M2 (N·m) (collective)."""
        if u is not None:
            self.u.x.array[: self._n] = u
            self.u.x.scatter_forward()
        self.section_forces.interpolate(self._expr)
        return np.asarray(self.section_forces.x.array.reshape(-1, 6)[self._rows])

    def evaluate(self, u: FloatArray | None = None) -> FloatArray:
        f = self.last_forces = self.forces(u)
        s = self._sec
        N, V1, V2, T, M1, M2 = (np.abs(f[:, k]) for k in range(6))
        m1 = M1 + V2 * self._half
        m2 = M2 + V1 * self._half
        beam = s.A > 0.0  # (a rope's cell has no section: no stress)

        def ratio(a: FloatArray, b: FloatArray) -> FloatArray:
            return np.divide(a, b, out=np.zeros_like(a), where=beam)

        corner = ratio(m1 * s.c2, s.I1) + ratio(m2 * s.c1, s.I2)
        round_ = ratio(np.hypot(m1, m2) * s.c1, s.I1)
        sigma = ratio(N, s.A) + np.where(s.circular, round_, corner)
        tau = ratio(T, s.Wt)
        vm = np.sqrt(sigma**2 + 3.0 * tau**2)
        self.field.x.array[self._cells] = vm
        return vm


class TimoshenkoBeam:
    """The Timoshenko beam of the module docstring: 6 DOFs per node (u_x, u_y, u_z, θ_x, θ_y,
    θ_z), the first three translations."""

    name = "beam"
    bs = 6
    translations = 3

    def space(self, msh: dolfinx.mesh.Mesh) -> dolfinx.fem.FunctionSpace:
        return dolfinx.fem.functionspace(msh, ("Lagrange", 1, (6,)))

    def forms(self, V: dolfinx.fem.FunctionSpace, fields: CellFields) -> Forms:
        msh = V.mesh
        c = _Coefficients(msh, fields)
        u, w = ufl.TrialFunction(V), ufl.TestFunction(V)
        eu, ew = c.strains(u), c.strains(w)
        k = c.rigidities()
        dx = ufl.dx(domain=msh)
        # One point (the midpoint) for the shear terms: the locking-free linear element.
        dx1 = ufl.dx(domain=msh, metadata={"quadrature_degree": 1})
        stiffness = (
            sum(k[i] * eu[i] * ew[i] for i in (0, 3, 4, 5)) * dx
            + sum(k[i] * eu[i] * ew[i] for i in (1, 2)) * dx1
        )
        t, a1, a2 = c.t, c.a1, c.a2
        # The rotary inertia about each bending axis times the section's factor (1 unless a
        # member's is scaled), at most the polar moment; about the axis, the polar moment.
        Ip = c.I1 + c.I2
        I1 = ufl.min_value(c.R * c.I1, Ip)
        I2 = ufl.min_value(c.R * c.I2, Ip)

        def rotary(x: ufl.core.expr.Expr, y: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
            return (
                I1 * ufl.dot(x, a1) * ufl.dot(y, a1)
                + I2 * ufl.dot(x, a2) * ufl.dot(y, a2)
                + Ip * ufl.dot(x, t) * ufl.dot(y, t)
            )

        def parts(z: ufl.core.expr.Expr) -> tuple[ufl.core.expr.Expr, ufl.core.expr.Expr]:
            return ufl.as_vector([z[0], z[1], z[2]]), ufl.as_vector([z[3], z[4], z[5]])

        (uu, tu), (uw, tw) = parts(u), parts(w)
        rho, A = c.rho, c.A
        mass = (rho * A * ufl.dot(uu, uw) + rho * rotary(tu, tw)) * dx
        ones = ufl.as_vector([1.0, 1.0, 1.0])
        tensor = I1 * ufl.outer(a1, a1) + I2 * ufl.outer(a2, a2) + Ip * ufl.outer(t, t)
        diag = ufl.as_vector([tensor[i, i] for i in range(3)])
        lumped = (rho * A * ufl.dot(ones, uw) + rho * ufl.dot(diag, tw)) * dx
        return Forms(stiffness, mass, lumped)

    def stress(self, V: dolfinx.fem.FunctionSpace, fields: CellFields) -> BeamStress:
        return BeamStress(V, fields)

    def element_steps(self, msh: dolfinx.mesh.Mesh, fields: CellFields) -> FloatArray:
        """2/ω_max of each owned element with its lumped mass, from its three fastest
        modes: axial and antisymmetric rotation 2c/le, torsion (2/le) √(GJ/(ρ Ip)), the
        one-point shear mode √((k G A)*/(ρ I)) per plane."""
        n = msh.topology.index_map(1).size_local
        s = fields.section
        assert s is not None
        X = msh.geometry.x[dolfinx.mesh.entities_to_geometry(msh, 1, np.arange(n, dtype=np.int32))]
        le = np.linalg.norm(X[:, 1] - X[:, 0], axis=1)
        E, nu, rho = fields_owned(fields, n)
        G = E / (2.0 * (1.0 + nu))
        A, I1, I2, J = s.A[:n], s.I1[:n], s.I2[:n], s.J[:n]
        # The shear rigidities with the residual bending flexibility (see rigidities()).
        kga1 = 12.0 * E * I2 * s.k1[:n] * G * A / (12.0 * E * I2 + s.k1[:n] * G * A * le**2)
        kga2 = 12.0 * E * I1 * s.k2[:n] * G * A / (12.0 * E * I1 + s.k2[:n] * G * A * le**2)
        omega = np.max(
            [
                2.0 / le * np.sqrt(E / rho),
                2.0 / le * np.sqrt(G * J / (rho * (I1 + I2))),
                np.sqrt(kga1 / (rho * I2)),
                np.sqrt(kga2 / (rho * I1)),
            ],
            axis=0,
        )
        out: FloatArray = 2.0 / omega
        return out
