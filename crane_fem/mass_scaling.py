"""Selective mass scaling: mass added where a mesh's few smallest elements would set the
explicit step (docs/theory-notes.md §15; LS-DYNA's DT2MS < 0, Abaqus' fixed mass scaling).

Each vertex i has a stable step of its own from Gershgorin's bound on M⁻¹K with the lumped
mass: λ_max(M⁻¹K) ≤ max_i r_i / m_i, r_i the largest absolute row sum Σ_j |K_ij| of the
vertex's three rows (bounded here by the sum over its cells of the element rows' absolute
sums), so that the critical step Δt_crit = 2/ω_max ≥ min_i 2 √(m_i / r_i). A vertex below the
target T needs the mass m_i ≥ T² r_i / 4. It gets it through the density of the cells around
it: each cell's material density is multiplied by 1 + max over its deficient vertices of
(deficit / that vertex's material mass), so every vertex reaches its need (each cell around
it scales at least as much as it asks). The added mass is the model's own: inertia, weight
and seismic load alike, in every subdomain, so that the fully explicit and the coupled runs
of a scene integrate the same structure. The critical step is then computed as before; it is
at least T on the whole mesh and in practice larger (Gershgorin's bound is conservative).

P1 tetrahedra (the crane and gmsh models) only.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import dolfinx
import numpy as np
import numpy.typing as npt
from mpi4py import MPI

__all__ = ["MassScaling", "scale_density"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int32]


@dataclass(frozen=True)
class MassScaling:
    """What :func:`scale_density` added (the same on every rank).

    Attributes:
        target: the stable step every vertex is brought to (s).
        smallest_step: the smallest vertex step before scaling (Gershgorin, s).
        added: the added mass (kg); ``model``: the model's mass before it (kg).
        cells: the number of cells whose density was raised; ``largest_factor``: the largest
            density factor.
        by_group: the added mass of each volume group that gained some (kg), and
            ``group_fraction`` as a fraction of that group's mass.
    """

    target: float
    smallest_step: float
    added: float
    model: float
    cells: int
    largest_factor: float
    by_group: dict[str, float] = field(default_factory=dict)
    group_fraction: dict[str, float] = field(default_factory=dict)

    @property
    def fraction(self) -> float:
        return self.added / self.model if self.model > 0.0 else 0.0

    def describe(self) -> str:
        """One line for the run's log."""
        groups = ", ".join(
            f"{g} {1e3 * m:.3g} g ({100 * self.group_fraction[g]:.2g} %)"
            for g, m in self.by_group.items()
        )
        return (
            f"mass scaling to a {self.target:.4g} s vertex step (smallest before: "
            f"{self.smallest_step:.4g} s): {self.added:.4g} kg added to {self.cells} cells "
            f"({100 * self.fraction:.3g} % of the model's {self.model:.4g} kg; largest density "
            f"factor {self.largest_factor:.3g})" + (f": {groups}" if groups else "")
        )

    def summary(self) -> dict[str, object]:
        return {
            "target_step_s": self.target,
            "smallest_vertex_step_before_s": self.smallest_step,
            "added_kg": self.added,
            "added_fraction": self.fraction,
            "cells": self.cells,
            "largest_density_factor": self.largest_factor,
            "added_kg_by_group": dict(self.by_group),
            "added_fraction_by_group": dict(self.group_fraction),
        }


def _element_rows(X: FloatArray, E: FloatArray, nu: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Volumes (n,) and absolute row sums (n, 4, 3) of P1 tetrahedra's stiffness matrices."""
    J = np.stack([X[:, 1] - X[:, 0], X[:, 2] - X[:, 0], X[:, 3] - X[:, 0]], axis=1)
    vol = np.abs(np.linalg.det(J)) / 6.0
    G = np.linalg.inv(J)  # column k: the gradient of barycentric coordinate k + 1
    dN = np.empty((X.shape[0], 4, 3))
    dN[:, 1:, :] = np.transpose(G, (0, 2, 1))
    dN[:, 0, :] = -dN[:, 1:, :].sum(axis=1)
    B = np.zeros((X.shape[0], 6, 12))
    for a in range(4):
        gx, gy, gz = dN[:, a, 0], dN[:, a, 1], dN[:, a, 2]
        B[:, 0, 3 * a], B[:, 1, 3 * a + 1], B[:, 2, 3 * a + 2] = gx, gy, gz
        B[:, 3, 3 * a + 1], B[:, 3, 3 * a + 2] = gz, gy
        B[:, 4, 3 * a], B[:, 4, 3 * a + 2] = gz, gx
        B[:, 5, 3 * a], B[:, 5, 3 * a + 1] = gy, gx
    lam = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))
    mu = E / (2.0 * (1.0 + nu))
    D = np.zeros((X.shape[0], 6, 6))
    D[:, :3, :3] = lam[:, None, None]
    for k in range(3):
        D[:, k, k] += 2.0 * mu
        D[:, 3 + k, 3 + k] = mu
    Ke = np.einsum("eji,ejk,ekl->eil", B, D, B) * vol[:, None, None]
    return vol, np.abs(Ke).sum(axis=2).reshape(-1, 4, 3)


def _vertex_sum(V: dolfinx.fem.FunctionSpace, dofs: IntArray, values: FloatArray) -> FloatArray:
    """Σ over the owned cells of ``values`` (n_owned_cells, 4[, 3]) at their vertices, owned
    and ghost vertices complete (collective)."""
    f = dolfinx.fem.Function(V)
    bs = V.dofmap.index_map_bs
    idx = dofs if bs == 1 else (bs * dofs[:, :, None] + np.arange(bs)).reshape(dofs.shape[0], -1)
    np.add.at(f.x.array, idx.ravel(), values.ravel())
    f.x.scatter_reverse(dolfinx.la.InsertMode.add)
    f.x.scatter_forward()
    return np.asarray(f.x.array.copy())


def scale_density(
    msh: dolfinx.mesh.Mesh,
    E: FloatArray,
    nu: FloatArray,
    rho_material: FloatArray,
    rho: FloatArray,
    target: float,
    cell_tags: dolfinx.mesh.MeshTags,
    cell_groups: dict[str, int],
) -> tuple[FloatArray, MassScaling]:
    """The density of every local cell (owned and ghost) with the mass that brings every
    vertex's stable step to ``target`` (collective).

    Args:
        E, nu: each local cell's Young's modulus and Poisson ratio.
        rho_material: each local cell's material density (the part that is scaled).
        rho: each local cell's density with the masses it carries (kg/m³).
        target: the vertex step to reach (s).
    """
    comm = msh.comm
    imap = msh.topology.index_map(msh.topology.dim)
    n_own = imap.size_local
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1))
    Vv = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    dofs = V.dofmap.list
    X = msh.geometry.x[msh.geometry.dofmaps[0]]
    vol, rows = _element_rows(X, E, nu)
    own = slice(0, n_own)
    quarter = np.repeat(vol[:, None] / 4.0, 4, axis=1)
    r = _vertex_sum(Vv, dofs[own], rows[own]).reshape(-1, 3).max(axis=1)
    m = _vertex_sum(V, dofs[own], (rho[:, None] * quarter)[own])
    mu = _vertex_sum(V, dofs[own], (rho_material[:, None] * quarter)[own])
    n_vert = V.dofmap.index_map.size_local
    used = r > 0.0
    step = np.full(r.size, np.inf)
    step[used] = 2.0 * np.sqrt(m[used] / r[used])
    smallest = comm.allreduce(float(step[:n_vert].min(initial=np.inf)), op=MPI.MIN)
    deficit = 0.25 * target * target * r - m
    ratio = np.where((deficit > 0.0) & (mu > 0.0), deficit / np.where(mu > 0.0, mu, 1.0), 0.0)
    factor = 1.0 + ratio[dofs].max(axis=1)
    out = rho + (factor - 1.0) * rho_material
    gained = (factor - 1.0) * rho_material * vol
    by_tag: dict[str, float] = {}
    fraction: dict[str, float] = {}
    tag_of = np.full(factor.size, -1, dtype=np.int64)
    tag_of[cell_tags.indices] = cell_tags.values
    for name, tag in cell_groups.items():
        cells = tag_of[own] == tag
        g = comm.allreduce(float(gained[own][cells].sum()), op=MPI.SUM)
        if g > 0.0:
            by_tag[name] = g
            fraction[name] = g / comm.allreduce(float((rho * vol)[own][cells].sum()), op=MPI.SUM)
    info = MassScaling(
        target=target,
        smallest_step=smallest,
        added=comm.allreduce(float(gained[own].sum()), op=MPI.SUM),
        model=comm.allreduce(float((rho * vol)[own].sum()), op=MPI.SUM),
        cells=comm.allreduce(int(np.count_nonzero(factor[own] > 1.0)), op=MPI.SUM),
        largest_factor=comm.allreduce(float(factor[own].max(initial=1.0)), op=MPI.MAX),
        by_group=by_tag,
        group_fraction=fraction,
    )
    return out, info
