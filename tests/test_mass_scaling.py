"""Selective mass scaling (crane_fem.mass_scaling): every vertex reaches the target step, the
critical step of the scaled mesh is at least the target (Gershgorin's bound is rigorous), only
the cells around deficient vertices gain mass, and two ranks add what one does."""

from __future__ import annotations

import dolfinx
import numpy as np
import pytest
from mpi4py import MPI

from crane_fem.formulations import CellFields, SolidP1
from crane_fem.mass_scaling import scale_density
from crane_fem.model import StructuralModel, assemble_operators
from crane_fem.stability import max_frequency

pytestmark = pytest.mark.no_kernels

E, NU, RHO = 2.1e11, 0.3, 7800.0


def _thin_layer_box(comm: MPI.Comm) -> tuple[dolfinx.mesh.Mesh, dolfinx.mesh.MeshTags]:
    """A 0.36 × 0.1 × 0.1 m box of tetrahedra, 0.05 m elements except one layer of 0.01 m
    (x in [0.2, 0.21]): the layer's vertices set the explicit step. Cells tagged 1 (x < 0.2)
    and 2 (the rest)."""
    msh = dolfinx.mesh.create_box(
        comm, [[0.0, 0.0, 0.0], [0.4, 0.1, 0.1]], [8, 2, 2], dolfinx.mesh.CellType.tetrahedron
    )
    x = msh.geometry.x
    x0 = x[:, 0].copy()
    x[:, 0] = np.where(x0 <= 0.2, x0, np.where(x0 <= 0.25, 0.2 + 0.2 * (x0 - 0.2), x0 - 0.04))
    tdim = msh.topology.dim
    imap = msh.topology.index_map(tdim)
    cells = np.arange(imap.size_local + imap.num_ghosts, dtype=np.int32)
    mid = dolfinx.mesh.compute_midpoints(msh, tdim, cells)
    tags = dolfinx.mesh.meshtags(msh, tdim, cells, np.where(mid[:, 0] < 0.2, 1, 2).astype(np.int32))
    return msh, tags


def _critical_step(msh: dolfinx.mesh.Mesh, rho: np.ndarray) -> tuple[float, float]:
    """2/ω_max of the free mesh (SLEPc) and its total lumped mass."""
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    K, lumped, _ = assemble_operators(
        SolidP1(), V, CellFields(E, NU, rho), np.zeros(0, dtype=np.int64)
    )
    model = StructuralModel(V, K, lumped, np.zeros(lumped.size, dtype=bool))
    try:
        omega = max_frequency(model)
    finally:
        model.destroy()
    total = msh.comm.allreduce(float(lumped.sum()), op=MPI.SUM) / 3.0
    return 2.0 / omega, total


def _scale(comm: MPI.Comm, target: float):  # type: ignore[no-untyped-def]
    msh, tags = _thin_layer_box(comm)
    n = tags.indices.size
    rho = np.full(n, RHO)
    scaled, info = scale_density(
        msh, np.full(n, E), np.full(n, NU), rho, rho, target, tags, {"left": 1, "right": 2}
    )
    return msh, tags, rho, scaled, info


def test_mass_scaling_brings_the_critical_step_to_the_target() -> None:
    comm = MPI.COMM_WORLD
    msh, tags, rho, scaled, info = _scale(comm, 0.0)  # a target of 0: nothing to add
    assert info.added == 0.0 and info.cells == 0 and np.array_equal(scaled, rho)
    before, mass = _critical_step(msh, rho)
    # Gershgorin's vertex bound is below the true critical step.
    assert info.smallest_step <= before
    target = 1.5 * info.smallest_step
    msh, tags, rho, scaled, info = _scale(comm, target)
    after, mass_after = _critical_step(msh, scaled)
    assert after >= target  # rigorous: every vertex's Gershgorin step is >= target
    assert after > 1.2 * before  # and the step did grow
    # The added mass is the lumped mass's growth (to round-off), and the model's mass stated.
    assert info.added == pytest.approx(mass_after - mass, rel=1e-12)
    assert info.model == pytest.approx(mass, rel=1e-12)
    assert info.fraction == pytest.approx(info.added / info.model, rel=1e-15)
    # Only cells next to the thin layer gain mass; the far ends keep their density.
    mid = dolfinx.mesh.compute_midpoints(msh, 3, tags.indices)[:, 0]
    far = (mid < 0.12) | (mid > 0.3)
    assert np.array_equal(scaled[far], rho[far])
    assert set(info.by_group) <= {"left", "right"}
    assert sum(info.by_group.values()) == pytest.approx(info.added, rel=1e-12)
    # The same on one rank as on all of them (the vertex sums cross the partition).
    if comm.size > 1:
        _, _, _, _, alone = _scale(MPI.COMM_SELF, target)
        assert info.added == pytest.approx(alone.added, rel=1e-12)
        assert info.cells == alone.cells
        assert info.smallest_step == pytest.approx(alone.smallest_step, rel=1e-12)
