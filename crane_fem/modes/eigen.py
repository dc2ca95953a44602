"""Natural modes of the closed structure: the lowest eigenpairs of K φ = ω² M φ (SLEPc
shift-and-invert with MUMPS), mass-normalised, with their effective modal masses."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from mpi4py import MPI
from petsc4py import PETSc
from slepc4py import SLEPc

from crane_fem.errors import CraneFemError, ScenarioError
from crane_fem.modes.operators import ClosedStructure

__all__ = ["ModalBasis", "rigid_inertia", "solve_modes"]

FloatArray = npt.NDArray[np.float64]

#: Relative residual to which SLEPc converges each eigenpair.
EIGEN_TOL = 1e-10
#: An eigenvalue below this fraction of the largest diag(K)/diag(M) (about the mesh's highest
#: ω²) is a rigid mode: round-off of zero. A structure's true lowest ω² is orders of magnitude
#: above it (a 16-element beam pinned at its root only: its rigid turns at 1e-19 of that scale,
#: its first bending at 2e-7).
RIGID_TOL = 1e-13


@dataclass(frozen=True, eq=False)
class ModalBasis:
    """The ``n`` lowest modes of a :class:`ClosedStructure` (global values identical on every
    rank, but ``shapes``: this rank's owned free DOFs).

    Attributes:
        omega: circular frequencies ω_i (rad/s), increasing.
        shapes: (n, owned free DOFs) mode shapes φ_i, mass-normalised (φᵀ M φ = 1, so in
            m/√kg), each signed so that its largest participation factor is positive.
        participation: (n, 3) L_id = φ_iᵀ M r_d, r_d the unit rigid translation of the free
            DOFs along x, y, z (kg/√kg = √kg with the normalisation).
        total_mass: (3,) r_dᵀ M r_d (kg): the mass of the free DOFs in each direction (the
            consistent mass of the clamped DOFs' rows is not in it).
    """

    omega: FloatArray
    shapes: FloatArray
    participation: FloatArray
    total_mass: FloatArray

    @property
    def frequency(self) -> FloatArray:
        """f_i = ω_i / 2π (Hz)."""
        return np.asarray(self.omega / (2.0 * math.pi), dtype=np.float64)

    @property
    def gamma(self) -> FloatArray:
        """(n, 3) participation factors Γ_id = L_id / (φ_iᵀ M φ_i) = L_id (mass-normalised)."""
        return self.participation

    @property
    def effective_mass(self) -> FloatArray:
        """(n, 3) effective modal masses (φ_iᵀ M r_d)² / (φ_iᵀ M φ_i) (kg)."""
        return np.asarray(self.participation**2, dtype=np.float64)

    @property
    def effective_fraction(self) -> FloatArray:
        """(n, 3) effective masses as fractions of :attr:`total_mass`."""
        return np.asarray(self.effective_mass / self.total_mass[None, :], dtype=np.float64)

    @property
    def cumulative_fraction(self) -> FloatArray:
        """(n, 3) running sums of :attr:`effective_fraction` over the modes."""
        return np.asarray(np.cumsum(self.effective_fraction, axis=0), dtype=np.float64)


def rigid_inertia(st: ClosedStructure) -> FloatArray:
    """(3, owned free DOFs) M r_d for d = x, y, z, r_d the unit rigid translation of the
    free DOFs (collective: products with M)."""
    out = np.zeros((3, st.free.size))
    x, y = st.M.createVecRight(), st.M.createVecLeft()
    for d in range(3):
        x.array[:] = (st.free % st.bs == d).astype(np.float64)
        st.M.mult(x, y)
        out[d] = y.array_r
    x.destroy()
    y.destroy()
    return out


def _omega2_scale(st: ClosedStructure) -> float:
    """The largest diag(K)_i / diag(M)_i, 1/s² (collective)."""
    dk, dm = st.K.getDiagonal(), st.M.getDiagonal()
    k, m = dk.array_r, dm.array_r
    ratio = np.divide(k, m, out=np.zeros_like(k), where=m > 0.0)
    dk.destroy()
    dm.destroy()
    return float(st.comm.allreduce(float(np.max(ratio, initial=0.0)), op=MPI.MAX))


def solve_modes(st: ClosedStructure, n: int, prefix: str = "crane_fem_modes_") -> ModalBasis:
    """The ``n`` lowest modes of K φ = ω² M φ (collective over ``st.comm``).

    Generalized Hermitian problem, consistent mass; SLEPc Krylov–Schur on the shift-and-
    invert spectral transformation at σ = 0 (one MUMPS factorisation of K, options prefix
    ``prefix``, e.g. ``-crane_fem_modes_eps_tol``).

    Raises:
        CraneFemError: ``n`` is not between 1 and the free DOFs, or fewer than ``n`` pairs
            converged.
        ScenarioError: the supports leave the structure a rigid mode (a pinned-only frame
            that can turn): an eigenvalue at round-off of zero, on every rank.
    """
    comm = st.comm
    if not 1 <= n <= st.n_free:
        raise CraneFemError(f"modes: asked for {n} modes of a structure of {st.n_free} free DOFs")
    eps = SLEPc.EPS().create(comm)
    mr = rigid_inertia(st)
    vr = st.K.createVecRight()
    try:
        eps.setOptionsPrefix(prefix)
        eps.setOperators(st.K, st.M)
        eps.setProblemType(SLEPc.EPS.ProblemType.GHEP)
        eps.setDimensions(n)
        eps.setTolerances(EIGEN_TOL, 1000)
        eps.setWhichEigenpairs(SLEPc.EPS.Which.TARGET_MAGNITUDE)
        eps.setTarget(0.0)
        st_ = eps.getST()
        st_.setType(SLEPc.ST.Type.SINVERT)
        ksp = st_.getKSP()
        ksp.setType(PETSc.KSP.Type.PREONLY)
        pc = ksp.getPC()
        pc.setType(PETSc.PC.Type.LU)
        pc.setFactorSolverType("mumps")
        eps.setFromOptions()
        eps.solve()
        nconv = eps.getConverged()
        if nconv < n:
            raise CraneFemError(f"modes: SLEPc converged {nconv} of {n} eigenpairs")
        lam = np.array([eps.getEigenvalue(i).real for i in range(nconv)])
        rigid = int(np.count_nonzero(lam < RIGID_TOL * _omega2_scale(st)))
        if rigid:
            raise ScenarioError(
                f"modes: the supports leave the structure {rigid} rigid mode(s) (ω² ≈ 0: it moves "
                "or turns freely, as a member pinned at both ends turns about its axis); clamp "
                "or pin more of it"
            )
        order = np.argsort(lam)[:n]
        shapes = np.zeros((n, st.free.size))
        for k, i in enumerate(order):
            eps.getEigenvector(int(i), vr)
            shapes[k] = vr.array_r
    finally:
        eps.destroy()
        vr.destroy()
    # Mass-normalise (SLEPc's GHEP vectors are M-normalised already; made exact here).
    mv = st.M.createVecLeft()
    x = st.M.createVecRight()
    for k in range(n):
        x.array[:] = shapes[k]
        st.M.mult(x, mv)
        norm = comm.allreduce(float(shapes[k] @ mv.array_r), op=MPI.SUM)
        shapes[k] /= math.sqrt(norm)
    mv.destroy()
    x.destroy()
    participation = np.asarray(comm.allreduce(shapes @ mr.T, op=MPI.SUM), dtype=np.float64)
    total = np.asarray(comm.allreduce(mr.sum(axis=1), op=MPI.SUM), dtype=np.float64)
    # A sign for each shape that every rank count picks alike: its largest participation
    # positive (of two equal to round-off, as a symmetric frame's x and y, the first) or, for
    # a mode that moves no mass (torsion), its largest value.
    for k in range(n):
        size = np.abs(participation[k])
        d = int(np.flatnonzero(size >= (1.0 - 1e-9) * size.max())[0])
        sign = np.sign(participation[k, d])
        if abs(participation[k, d]) < 1e-8 * math.sqrt(float(total.max())):
            big = float(np.max(np.abs(shapes[k]), initial=0.0))
            top = comm.allreduce(big, op=MPI.MAX)
            mine = np.flatnonzero(np.abs(shapes[k]) >= top * (1.0 - 1e-9))
            val = float(shapes[k][mine[0]]) if mine.size else -math.inf
            sign = np.sign(comm.allreduce(val, op=MPI.MAX)) or 1.0
        if sign < 0:
            shapes[k] *= -1.0
            participation[k] *= -1.0
    omega = np.sqrt(np.maximum(np.sort(lam)[:n], 0.0))
    return ModalBasis(omega, shapes, participation, total)
