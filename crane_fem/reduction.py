"""Craig–Bampton reduction of a linear subdomain (THEORY.md §6).

The subdomain's DOFs are split into boundary ``b`` (the interface rows, kept exactly) and
interior ``i`` (the free DOFs that are not on the interface; clamped DOFs are zero and carry
nothing). The basis T = [[I, 0, 0], [Ψ, Φ, X]] holds

- the static constraint modes Ψ = −K_ii⁻¹ K_ib (one per interface row),
- the first N fixed-interface normal modes K_ii Φ = M_ii Φ Ω² (SLEPc, shift-and-invert about
  0 with a MUMPS Cholesky factorisation), M_ii-orthonormal,
- the static responses X = K_ii⁻¹ f_i of the interior to each load vector of the subdomain
  (self-weight, −M ι per ground-motion direction, a traction shape), M_ii-orthogonalised
  against Φ and each other: the residual flexibility of the loads, the part of their static
  response the N modes miss. With them the quasi-static response to every load of the
  subdomain is carried exactly, the static preload included.

The residual-flexibility coordinates are quasi-static: they carry stiffness but no inertia
(their rows and columns of M_r are zero), the mode-acceleration correction. They are
K-orthogonal to the rest of the basis (Xᵀ K_ib + Xᵀ K_ii Ψ = 0, Xᵀ K_ii Φ = Ω² Xᵀ M_ii Φ = 0),
so each follows its load's projection statically at every step. Given mass, the same vectors
become Ritz vectors of a frequency above the modes kept (4.5 kHz beside 3.3 kHz modes on the
quick crane), rung by every impact at the interface with no damping: measured on the quick
crane, that Ritz form moved the bridge's peak stress 2.8 % away from the full side even at
N = 400, where the quasi-static form is 0.2 % from it (benchmarks/RESULTS.md, session 9).

Reduced operators M_r = TᵀMT (the static vectors massless), K_r = TᵀKT and loads Tᵀf are dense
and small, the same on every rank; T itself is kept by rows of the owned DOFs, to expand a
reduced state to the subdomain's field when a record needs it.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
from mpi4py import MPI
from petsc4py import PETSc
from slepc4py import SLEPc

from crane_fem.contact import ContactSet
from crane_fem.errors import CraneFemError, ScenarioError
from crane_fem.model import StructuralModel

__all__ = ["CraigBampton", "check_modes", "create_craig_bampton", "interior_dofs"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


@dataclass
class CraigBampton:
    """A Craig–Bampton basis and the reduced operators of one subdomain.

    Attributes:
        n_b: boundary coordinates (the interface rows, in their order; coordinate k is the
            displacement of the DOF of row k; with rows of several terms, the DOFs they
            touch, see ``C``).
        coeff: the interface rows' coefficients (L_I x = coeff ⊙ x[:n_b]) when each row has
            one term (else empty).
        n_modes: fixed-interface normal modes kept; frequencies: theirs (Hz).
        n_static: static load vectors kept (after orthogonalisation), the last coordinates.
        static_missed: per load vector, the fraction of its static response (energy norm, the
            interface fixed) that the N modes alone miss: what the static vectors carry.
        T: rows of the basis on this rank's owned DOFs (n_owned × n_r).
        M, K: the reduced mass (the static vectors massless) and stiffness (n_r × n_r, the
            same on every rank).
        gram: TᵀMT whole, the Gram matrix of the basis in the mass inner product (to project a
            field on the basis).
        timings: set-up wall times (s): "constraint_modes", "eigensolve", "reduce".
    """

    n_b: int
    coeff: FloatArray
    n_modes: int
    frequencies: FloatArray
    n_static: int
    static_missed: list[float]
    T: FloatArray
    M: FloatArray
    K: FloatArray
    gram: FloatArray
    comm: MPI.Comm
    timings: dict[str, float] = field(default_factory=dict)
    #: Interface rows of several terms: L_I x = C x[:n_b] (n_Γ × n_b), the boundary
    #: coordinates the DOFs they touch; None when each row has one term (``coeff``).
    C: FloatArray | None = None

    def rows_of_boundary(self, x_b: FloatArray) -> FloatArray:
        """L_I on boundary coordinates ``x_b`` (n_b × k): the interface rows (n_Γ × k)."""
        if self.C is None:
            return np.ascontiguousarray(self.coeff[:, None] * x_b)
        return np.ascontiguousarray(self.C @ x_b)

    @property
    def n_r(self) -> int:
        return int(self.M.shape[0])

    def project(self, f: FloatArray) -> FloatArray:
        """Tᵀ f for a vector f on the owned DOFs (collective): a load in reduced form."""
        local = self.T.T @ f
        out = np.empty_like(local)
        self.comm.Allreduce(local, out)
        return out

    def expand(self, x: FloatArray) -> FloatArray:
        """T x on the owned DOFs (not collective)."""
        return np.asarray(self.T @ x)

    def coordinates(self, u: FloatArray, M: PETSc.Mat) -> tuple[FloatArray, float]:
        """The reduced coordinates of a field u (owned DOFs): u_b read off, the interior part
        projected on span(T) in the mass norm; and the relative mass-norm error of the
        projection (0 when u lies in the span) (collective)."""
        Mu = _mult(M, u)
        rhs = self.project(Mu)
        x = np.asarray(np.linalg.solve(self.gram, rhs), dtype=np.float64)
        r = u - self.expand(x)
        num = self.comm.allreduce(float(r @ _mult(M, r)), op=MPI.SUM)
        den = self.comm.allreduce(float(u @ Mu), op=MPI.SUM)
        return x, (float(np.sqrt(max(num, 0.0) / den)) if den > 0 else 0.0)


def _mult(A: PETSc.Mat, x: FloatArray) -> FloatArray:
    """A x for an owned-DOF array (collective)."""
    xv = A.createVecRight()
    xv.array[:] = x
    yv = A.createVecLeft()
    A.mult(xv, yv)
    out = np.array(yv.array_r, dtype=np.float64)
    xv.destroy()
    yv.destroy()
    return out


def _cholesky(A: PETSc.Mat, prefix: str) -> PETSc.KSP:
    """A KSP applying A⁻¹ by sparse Cholesky (MUMPS; options under ``prefix``)."""
    ksp = PETSc.KSP().create(A.getComm())
    ksp.setOptionsPrefix(prefix)
    ksp.setOperators(A)
    ksp.setType("preonly")
    pc = ksp.getPC()
    pc.setType("cholesky")
    pc.setFactorSolverType("mumps")
    ksp.setFromOptions()
    ksp.setUp()
    return ksp


def interior_dofs(model: StructuralModel, interface: ContactSet) -> tuple[IntArray, int]:
    """The owned interior DOFs (free, not on an interface row) and their global count
    (collective)."""
    boundary = np.zeros(model.n_owned, dtype=bool)
    boundary[interface.dofs] = True
    interior = np.flatnonzero(~boundary & ~model.fixed).astype(np.int64)
    return interior, int(model.comm.allreduce(int(interior.size), op=MPI.SUM))


def check_modes(modes: int | None, n_int: int) -> None:
    """Refuse more fixed-interface modes than interior DOFs (on every rank: n_int is global)."""
    if modes is not None and modes > n_int:
        raise ScenarioError(
            f"subdomain.modes = {modes} exceeds the {n_int} interior DOFs of the reduced subdomain"
        )


def create_craig_bampton(
    model: StructuralModel,
    mass: PETSc.Mat,
    interface: ContactSet,
    loads: list[FloatArray],
    modes: int | None = None,
    cutoff: float | None = None,
    static_vectors: bool = True,
) -> CraigBampton:
    """The Craig–Bampton basis of ``model`` for the interface rows ``interface`` (collective).

    Args:
        model: the subdomain (K; fixed DOFs).
        mass: the mass matrix to reduce (consistent, or the lumped diagonal as a matrix).
        interface: the interface rows L_I: one term each (a DOF and its coefficient), or
            several (the boundary is then the DOFs they touch).
        loads: the subdomain's load vectors (owned DOFs): their interior static responses join
            the basis (with ``static_vectors``; what the modes alone miss of them is reported
            either way).
        modes: N fixed-interface modes, or
        cutoff: every mode below this frequency (Hz).

    Raises:
        ScenarioError: more modes than interior DOFs, or none below the cutoff.
    """
    comm = model.comm
    n_own = model.n_owned
    r0 = model.K.getOwnershipRange()[0]
    n_b = interface.p
    # The interface rows on this rank: row k -> owned DOF.
    n_terms = np.zeros(n_b, dtype=np.int64)
    comm.Allreduce(np.bincount(interface.rows, minlength=n_b).astype(np.int64), n_terms)
    coeff: FloatArray | None = None
    C: FloatArray | None = None
    if np.all(n_terms == 1):  # one term a row: boundary coordinate k is row k's DOF
        b_dofs = np.full(n_b, -1, dtype=np.int64)
        b_dofs[interface.rows] = interface.dofs
        coeff_local = np.zeros(n_b)
        coeff_local[interface.rows] = interface.coeffs
        coeff = np.empty(n_b)
        comm.Allreduce(coeff_local, coeff)
    else:
        # Rows with several terms (a rigid section's on a beam node): the boundary is the
        # DOFs the rows touch (global order), and L_I x = C x[:n_b].
        touched = np.unique(np.concatenate(comm.allgather(r0 + np.unique(interface.dofs))))
        mine = (touched >= r0) & (touched < r0 + n_own)
        b_dofs = np.where(mine, touched - r0, -1).astype(np.int64)
        C_local = np.zeros((n_b, touched.size))
        np.add.at(
            C_local,
            (interface.rows, np.searchsorted(touched, r0 + interface.dofs)),
            interface.coeffs,
        )
        C = np.empty_like(C_local)
        comm.Allreduce(C_local, C)
        n_b = int(touched.size)
    interior, n_int = interior_dofs(model, interface)
    check_modes(modes, n_int)
    # (petsc4py's stubs want a Sequence and a PETSc.Comm: an ndarray and an mpi4py comm work.)
    iset = PETSc.IS().createGeneral(
        (r0 + interior).astype(PETSc.IntType),  # type: ignore[arg-type]
        comm=comm,  # type: ignore[arg-type]
    )
    K_ii = model.K.createSubMatrix(iset, iset)
    M_ii = mass.createSubMatrix(iset, iset)
    timings: dict[str, float] = {}
    ksp = _cholesky(K_ii, "crane_fem_reduction_")
    x_i, y_i = K_ii.createVecRight(), K_ii.createVecLeft()
    try:
        # Static constraint modes Ψ_k = −K_ii⁻¹ (K e_b,k)_i.
        t0 = time.perf_counter()
        Psi = np.zeros((interior.size, n_b))
        e = np.zeros(n_own)
        for k in range(n_b):
            e[:] = 0.0
            if b_dofs[k] >= 0:
                e[b_dofs[k]] = 1.0
            y_i.array[:] = -_mult(model.K, e)[interior]
            ksp.solve(y_i, x_i)
            Psi[:, k] = x_i.array_r
        timings["constraint_modes"] = time.perf_counter() - t0
        # Fixed-interface normal modes.
        t0 = time.perf_counter()
        Phi, omega2 = _normal_modes(K_ii, M_ii, modes, cutoff, n_int)
        timings["eigensolve"] = time.perf_counter() - t0
        # Static responses to the loads, M_ii-orthogonalised against Φ and each other.
        t0 = time.perf_counter()
        X: list[FloatArray] = []
        basis: list[FloatArray] = [Phi[:, j] for j in range(Phi.shape[1])]

        def m_dot(a: FloatArray, b: FloatArray) -> float:
            x_i.array[:] = b
            M_ii.mult(x_i, y_i)
            return float(comm.allreduce(float(a @ y_i.array_r), op=MPI.SUM))

        missed: list[float] = []
        for f in loads:
            y_i.array[:] = f[interior]
            norm_f = comm.allreduce(float(f[interior] @ f[interior]), op=MPI.SUM)
            if norm_f == 0.0:
                continue
            ksp.solve(y_i, x_i)
            chi: FloatArray = np.array(x_i.array_r, dtype=np.float64)
            # Energy norms (the modes are K_ii-orthogonal): ‖χ‖² = fᵀχ, the modes' part
            # Σ (φ_jᵀf)² / ω_j², the rest is what the modes alone miss.
            fi = f[interior]
            sums = np.empty(1 + Phi.shape[1])
            comm.Allreduce(np.concatenate([[fi @ chi], Phi.T @ fi]), sums)
            whole = float(sums[0])
            modal = float(np.sum(sums[1:] ** 2 / np.maximum(omega2, 1e-300)))
            missed.append(float(np.sqrt(max(whole - modal, 0.0) / whole)) if whole > 0 else 0.0)
            if not static_vectors:
                continue
            size0 = np.sqrt(m_dot(chi, chi))
            for _ in range(2):  # Gram–Schmidt, twice (round-off)
                for b in [*basis, *X]:
                    chi = chi - m_dot(b, chi) * b
            size = np.sqrt(m_dot(chi, chi))
            if size > 1e-8 * size0:
                X.append(chi / size)
        n_modes = Phi.shape[1]
        T = np.zeros((n_own, n_b + n_modes + len(X)))
        rows = np.flatnonzero(b_dofs >= 0)
        T[b_dofs[rows], rows] = 1.0
        T[interior, :n_b] = Psi
        T[interior, n_b : n_b + n_modes] = Phi
        for j, chi in enumerate(X):
            T[interior, n_b + n_modes + j] = chi
        # Reduced operators Tᵀ A T, summed over the ranks.
        reduced = []
        for A in (mass, model.K):
            AT = np.column_stack([_mult(A, T[:, c]) for c in range(T.shape[1])])
            local = T.T @ AT
            glob = np.empty_like(local)
            comm.Allreduce(local, glob)
            reduced.append(0.5 * (glob + glob.T))
        gram = reduced[0].copy()
        k0 = n_b + n_modes  # the static vectors: quasi-static, no inertia
        reduced[0][k0:, :] = 0.0
        reduced[0][:, k0:] = 0.0
        timings["reduce"] = time.perf_counter() - t0
    finally:
        ksp.destroy()
        for obj in (x_i, y_i, K_ii, M_ii, iset):
            obj.destroy()
    return CraigBampton(
        n_b,
        coeff if coeff is not None else np.zeros(0),
        n_modes,
        np.sqrt(np.maximum(omega2, 0.0)) / (2.0 * np.pi),
        len(X),
        missed,
        T,
        reduced[0],
        reduced[1],
        gram,
        comm,
        timings,
        C,
    )


def _normal_modes(
    K: PETSc.Mat, M: PETSc.Mat, modes: int | None, cutoff: float | None, n_int: int
) -> tuple[FloatArray, FloatArray]:
    """The lowest modes of K φ = ω² M φ (owned rows, M-orthonormal) and their ω²: ``modes``
    of them, or all below ``cutoff`` Hz (collective)."""
    want = modes if modes is not None else 32
    w2_cut = (2.0 * np.pi * cutoff) ** 2 if cutoff is not None else np.inf
    while True:
        eps = SLEPc.EPS().create(K.getComm())
        try:
            eps.setOptionsPrefix("crane_fem_modes_")
            eps.setOperators(K, M)
            eps.setProblemType(SLEPc.EPS.ProblemType.GHEP)
            eps.setDimensions(min(want, n_int))
            eps.setTarget(0.0)
            eps.setWhichEigenpairs(SLEPc.EPS.Which.TARGET_MAGNITUDE)
            st = eps.getST()
            st.setType(SLEPc.ST.Type.SINVERT)
            ksp = st.getKSP()
            ksp.setType("preonly")
            pc = ksp.getPC()
            pc.setType("cholesky")
            pc.setFactorSolverType("mumps")
            eps.setTolerances(1e-12, 1000)
            eps.setFromOptions()
            eps.solve()
            nconv = eps.getConverged()
            if nconv < min(want, n_int):
                raise CraneFemError(
                    f"Craig–Bampton: SLEPc found {nconv} of the {want} fixed-interface modes"
                )
            vals = np.array([eps.getEigenvalue(k).real for k in range(nconv)])
            order = np.argsort(vals)
            if cutoff is not None and vals[order[-1]] <= w2_cut and want < n_int:
                want = min(2 * want, n_int)  # not past the cutoff yet: more modes
                continue
            keep = order[: min(want, n_int)] if modes is not None else order[vals[order] <= w2_cut]
            if keep.size == 0:
                raise ScenarioError(
                    f"subdomain.cutoff = {cutoff} Hz is below the first fixed-interface mode "
                    f"({np.sqrt(vals[order[0]]) / (2 * np.pi):.4g} Hz)"
                )
            vr = K.createVecRight()
            Phi = np.zeros((vr.getLocalSize(), keep.size))
            for j, k in enumerate(keep):
                eps.getEigenvector(int(k), vr)
                Phi[:, j] = vr.array_r
            vr.destroy()
            return Phi, vals[keep]
        finally:
            eps.destroy()
