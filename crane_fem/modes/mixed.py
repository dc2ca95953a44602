"""A mixed model's natural modes (solids and beams in one model, tied by the rigid sections of
their joints, THEORY.md §11): each part's closed structure as for a solid or a frame
(:func:`crane_fem.modes.operators.assemble_closed_structure`: the free DOFs' K and consistent
M, touching contacts tied, supports removed), the joints' beam nodes eliminated by the rigid
section's rows, (u_P, θ_P) = B⁻¹ C u_S (:func:`crane_fem.coupling.rigid_section.face_rows`,
the rows the coupled run ties), and K φ = ω² M φ on what is left by SciPy's shift-and-invert
Lanczos; the shapes, both parts' DOFs recovered (T q), to one XDMF file per part. On one
process: under mpiexec every rank computes the same modes on its own."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from petsc4py import PETSc

from crane_fem.coupling.rigid_section import face_rows
from crane_fem.errors import CraneFemError, ScenarioError
from crane_fem.modes.eigen import RIGID_TOL, ModalBasis
from crane_fem.modes.estimate import SpectralEstimate, combine_estimate, ground_history
from crane_fem.modes.forces import ForceRecovery, Forces
from crane_fem.modes.operators import ClosedStructure, assemble_closed_structure
from crane_fem.modes.spectral import modal_damping
from crane_fem.modes.xdmf import write_mode_shapes
from crane_fem.pipeline.mesh import MeshStage
from crane_fem.scenario import Scenario

__all__ = ["MixedModes", "solve_mixed_modes"]

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class MixedModes:
    """The lowest modes of a mixed model: its :class:`ModalBasis` (shapes over the kept
    DOFs: the solids' free DOFs, then the beams' free DOFs but the joints' nodes), the kept
    DOFs' count, the whole structure's mass (kg), each mode's damping and the
    response-spectrum estimate."""

    basis: ModalBasis
    free_dofs: int
    mass_total: float
    #: ζ_i of each mode (crane_fem.modes.spectral.modal_damping).
    damping: FloatArray
    #: The response-spectrum estimate, or None (no ground motion, or no window asked).
    estimate: SpectralEstimate | None = None


def _csr(A: PETSc.Mat) -> sp.csr_matrix:
    indptr, indices, data = A.getValuesCSR()
    return sp.csr_matrix((data, indices, indptr), shape=A.getSize())


def _joint_elimination(
    sc: Scenario, mesh: MeshStage, st_s: ClosedStructure, st_b: ClosedStructure
) -> tuple[sp.csr_matrix, npt.NDArray[np.int64]]:
    """T: q = (u_S free, u_b kept) → (u_S free, u_b free), and the kept beam DOFs."""
    n_s, n_b = st_s.free.size, st_b.free.size
    free_s = {int(d): i for i, d in enumerate(st_s.free)}
    free_b = {int(d): i for i, d in enumerate(st_b.free)}
    assert mesh.beams is not None
    tagged, beams = mesh.tagged, mesh.beams.tagged
    rows, cols, vals, slaves = [], [], [], []
    for j in sc.joint:
        face = face_rows(st_s.V, tagged.facets(j.face).astype(np.int32), j.label)
        node = int(beams.global_vertices(beams.facet_vertices(j.node))[0])
        blk = int(np.flatnonzero(st_b.block_vertex == node)[0])
        C = np.zeros((6, n_s))
        for r, d, c in zip(face.rows, face.dofs, face.coeffs, strict=True):
            if int(d) in free_s:  # (a clamped face DOF adds nothing)
                C[r, free_s[int(d)]] += c
        G = np.linalg.solve(face.beam_block, C)
        for k in range(6):
            if 6 * blk + k not in free_b:
                raise ScenarioError(
                    f"modes: joint {j.label}'s beam node is supported; a joint's node moves "
                    "with its face (support the solid's face or another beam node instead)"
                )
            slave = free_b[6 * blk + k]
            slaves.append(slave)
            nz = np.flatnonzero(G[k])
            rows += [slave] * nz.size
            cols += nz.tolist()
            vals += G[k, nz].tolist()
    keep_b = np.setdiff1d(np.arange(n_b), np.asarray(slaves, dtype=np.int64))
    n_q = n_s + keep_b.size
    T_s = sp.hstack([sp.identity(n_s, format="csr"), sp.csr_matrix((n_s, keep_b.size))])
    T_keep = sp.csr_matrix(
        (np.ones(keep_b.size), (keep_b, n_s + np.arange(keep_b.size))), shape=(n_b, n_q)
    )
    T_slave = sp.csr_matrix((vals, (rows, cols)), shape=(n_b, n_q))
    return sp.vstack([T_s, T_keep + T_slave]).tocsr(), keep_b


def solve_mixed_modes(
    sc: Scenario,
    mesh: MeshStage,
    n: int,
    shapes: Path | None = None,
    damping: float | None = None,
    window: float | None = None,
) -> MixedModes:
    """The ``n`` lowest modes of a mixed model (``mesh``: its solids' stage, with its beams'
    stage as ``mesh.beams``, built on one process). Mass-normalised shapes, each signed so
    that its largest participation factor is positive, as :func:`solve_modes`. With
    ``shapes`` (a directory), their shapes over both parts (the joints' beam nodes recovered
    from their faces) are written as :func:`write_mode_shapes` writes a solid's and a
    frame's: ``modes.xdmf`` on the tetrahedra, ``modes_beams.xdmf`` on the lines. Each
    mode's damping ratio is ``damping``, or the scenario's Rayleigh damping's; with a
    ``window`` (s) and a ground motion, the response-spectrum estimate over [0, window] as a
    solid's or a frame's (:func:`_estimate`).

    Raises:
        ScenarioError: ``n`` above the free DOFs; the supports leave a rigid mode; a joint's
            beam node supported.
    """
    assert mesh.beams is not None
    mat = sc.material[0] if isinstance(sc.material, list) else sc.material
    g = np.asarray(sc.loading.gravity, dtype=np.float64)
    parts = [
        assemble_closed_structure(stage, mat.E, mat.nu, mat.rho, g) for stage in (mesh, mesh.beams)
    ]
    try:
        st_s, st_b = parts
        T, keep_b = _joint_elimination(sc, mesh, st_s, st_b)
        basis, K, MR = _eigen(st_s, st_b, T, keep_b, n)
        n_q = K.shape[0]
        zeta = modal_damping(basis.omega, mat.rayleigh_coefficients, damping)
        estimate = None
        if window is not None and sc.loading.ground_motions:
            estimate = _estimate(sc, st_s, st_b, T, K, MR, basis, zeta, window)
        if shapes is not None:
            # Each part's free DOFs, the joints' beam nodes recovered: T q.
            full = np.asarray(T @ basis.shapes.T).T
            n_s = st_s.free.size
            for st, name, cols in (
                (st_s, "modes.xdmf", slice(0, n_s)),
                (st_b, "modes_beams.xdmf", slice(n_s, None)),
            ):
                part = ModalBasis(
                    basis.omega,
                    np.ascontiguousarray(full[:, cols]),
                    basis.participation,
                    basis.total_mass,
                )
                write_mode_shapes(shapes / name, st, part)
        mass_total = sum(st.mass_total for st in parts)
    finally:
        for st in parts:
            st.destroy()
    return MixedModes(basis, n_q, float(mass_total), zeta, estimate)


def _eigen(
    st_s: ClosedStructure,
    st_b: ClosedStructure,
    T: sp.csr_matrix,
    keep_b: npt.NDArray[np.int64],
    n: int,
) -> tuple[ModalBasis, sp.csc_matrix, FloatArray]:
    """The ``n`` lowest modes of T^T diag(K_S, K_b) T q = ω² T^T diag(M_S, M_b) T q, the
    reduced K and M r_d (the kept DOFs' rigid inertia, (n_q, 3))."""
    K0 = sp.block_diag([_csr(st_s.K), _csr(st_b.K)])
    M0 = sp.block_diag([_csr(st_s.M), _csr(st_b.M)])
    K = (T.T @ K0 @ T).tocsc()
    M = (T.T @ M0 @ T).tocsc()
    K, M = 0.5 * (K + K.T), 0.5 * (M + M.T)
    # The translations' influence vectors: all the solids' DOFs of a direction, the beams'
    # translation DOFs (a rigid translation meets the joints: it lies in T's range).
    n_s = st_s.free.size
    R = np.zeros((3, T.shape[1]))
    for d in range(3):
        R[d, :n_s] = st_s.free % 3 == d
        R[d, n_s:] = st_b.free[keep_b] % 6 == d
    n_q = K.shape[0]
    if not 1 <= n <= n_q - 1:
        raise ScenarioError(f"modes: --n {n} is more than the {n_q} free DOFs allow")
    lam, phi = spla.eigsh(K, k=n, M=M, sigma=0.0, which="LM")
    if not np.all(np.isfinite(lam)):
        raise CraneFemError("modes: the mixed model's eigensolve returned non-finite values")
    order = np.argsort(lam)
    lam, phi = lam[order], phi[:, order].T.copy()
    dk, dm = K.diagonal(), M.diagonal()
    scale = float(np.max(np.divide(dk, dm, out=np.zeros_like(dk), where=dm > 0.0)))
    rigid = int(np.count_nonzero(lam < RIGID_TOL * scale))
    if rigid:
        raise ScenarioError(
            f"modes: the supports leave the structure {rigid} rigid mode(s) (ω² ≈ 0); clamp "
            "or pin more of it"
        )
    for k in range(n):
        phi[k] /= math.sqrt(float(phi[k] @ (M @ phi[k])))
    MR = np.asarray(M @ R.T)
    participation = phi @ MR
    total = np.einsum("dj,jd->d", R, MR)
    for k in range(n):
        size = np.abs(participation[k])
        d = int(np.flatnonzero(size >= (1.0 - 1e-9) * size.max())[0])
        sign = np.sign(participation[k, d])
        if abs(participation[k, d]) < 1e-8 * math.sqrt(float(total.max())):
            sign = np.sign(phi[k][int(np.argmax(np.abs(phi[k])))]) or 1.0
        if sign < 0:
            phi[k] *= -1.0
            participation[k] *= -1.0
    return ModalBasis(np.sqrt(lam), phi, participation, total), K, MR


def _estimate(
    sc: Scenario,
    st_s: ClosedStructure,
    st_b: ClosedStructure,
    T: sp.csr_matrix,
    K: sp.csc_matrix,
    MR: FloatArray,
    basis: ModalBasis,
    zeta: FloatArray,
    window: float,
) -> SpectralEstimate:
    """The response-spectrum estimate of a mixed model, as
    :func:`~crane_fem.modes.estimate.spectral_estimate` makes a solid's or a frame's: its
    static (gravity), modal and missing-mass responses solved on the kept DOFs (K q = T^T f,
    one sparse LU), each expanded to both parts (T q) and its forces recovered there — the
    supports' (and moments) on the beams' point supports where there are any, else on the
    solids' faces (as a run reports them); the wheels' on the part whose contact pairs are
    closed (the solids' first)."""
    t, ground = ground_history(sc, window)
    zpa = np.max(np.abs(ground), axis=1) if t.size else np.zeros(3)
    n_s = st_s.free.size
    lu = spla.splu(K)
    support_part = st_b if st_b.clamped.size else st_s
    wheel_part = st_s if st_s.pairs.size or not st_b.pairs.size else st_b
    on_support = ForceRecovery(support_part)
    on_wheels = on_support if wheel_part is support_part else ForceRecovery(wheel_part)

    def recover(recovery: ForceRecovery, u: FloatArray, body: bool) -> Forces:
        st = recovery.st
        mine = u[:, :n_s] if st is st_s else u[:, n_s:]
        return recovery(mine, body=st.gravity_clamped if body else None)

    def forces(q: FloatArray, body: bool = False) -> Forces:
        """The forces of kept-DOF displacements q (m, n_q): T q on each part."""
        u = np.asarray(T @ np.atleast_2d(q).T).T
        sup = recover(on_support, u, body)
        whl = sup if on_wheels is on_support else recover(on_wheels, u, body)
        return Forces(sup.support, whl.wheel, sup.moment)

    try:
        gravity = T.T @ np.concatenate([st_s.gravity_load, st_b.gravity_load])
        static = forces(lu.solve(gravity), body=True)
        modal = forces(basis.shapes)
        residual: list[Forces | None] = []
        for d in range(3):
            if zpa[d] == 0.0:
                residual.append(None)
                continue
            q = lu.solve(np.ascontiguousarray(MR[:, d]))
            q -= (basis.gamma[:, d] / basis.omega**2) @ basis.shapes
            residual.append(forces(zpa[d] * q))
        centres = on_support.centres
    finally:
        on_support.destroy()
        if on_wheels is not on_support:
            on_wheels.destroy()
    return combine_estimate(t, ground, basis, zeta, window, modal, static, residual, centres)
