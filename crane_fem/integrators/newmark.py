"""Implicit Newmark (β, γ) for a linear subdomain, with link forces from an interface.

THEORY.md §2. With predictors Ũ = U_n + ΔT V_n + ΔT²(½ − β) A_n, Ṽ = V_n + ΔT(1 − γ) A_n:

    M̃ A_{n+1} = F_{n+1} − K Ũ − C Ṽ + Lᵀ Λ,   M̃ = M + γΔT C + βΔT² K,
    U_{n+1} = Ũ + βΔT² A_{n+1},   V_{n+1} = Ṽ + γΔT A_{n+1}.

M̃ is assembled once and factored once (options prefix ``crane_fem_newmark_``): a sparse
Cholesky factorisation (PETSc's own, quotient minimum degree ordering), replicated on every
rank under MPI (PCREDUNDANT). Measured on the crane's implicit side at 35.5k DOFs
(benchmarks/RESULTS.md, session 8): 4.3 ms per solve, at the memory bandwidth of its 4.3M-entry
factor, against 10 ms for MUMPS LU or Cholesky (serial) and 7 ms for distributed MUMPS on two
ranks. A step is split as in the GC coupling (THEORY.md §3): :meth:`free_step` (Λ = 0, one
solve) and :meth:`correct` (A += M̃⁻¹ Lᵀ Λ, V += γΔT …, U += βΔT² …: one solve), with the
condensed operator W = L M̃⁻¹ Lᵀ computed once (n_Γ solves). The columns M̃⁻¹ Lᵀ e_k are not
kept: as a dense n_Γ × n array they cost more memory traffic per correction than the solve
(measured on the crane: 1.0 ms against 0.8 ms per macro step at 8.7k DOFs). The initial
acceleration with a consistent mass is one conjugate-gradient solve with M (Jacobi
preconditioner, to 1e-14): no second factorisation.

Stability: unconditionally stable iff 2β ≥ γ ≥ ½; ½ ≤ γ with 2β < γ is only conditionally
stable (a RuntimeWarning says so); γ < ½ amplifies and is rejected.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np
import numpy.typing as npt
from petsc4py import PETSc

from crane_fem.contact import ContactSet
from crane_fem.errors import CraneFemError
from crane_fem.kernels import books
from crane_fem.model import LoadFunction, StructuralModel

__all__ = ["Newmark", "NewmarkSteps", "check_newmark_parameters"]

FloatArray = npt.NDArray[np.float64]


def check_newmark_parameters(beta: float, gamma: float) -> None:
    """Reject γ < ½ (ValueError); warn when 2β < γ (conditionally stable)."""
    if gamma < 0.5:
        raise ValueError(f"Newmark gamma = {gamma} < 1/2 amplifies the solution (unstable)")
    if beta < 0.0:
        raise ValueError(f"Newmark beta = {beta} must be >= 0")
    if 2.0 * beta < gamma:
        warnings.warn(
            f"Newmark beta = {beta}, gamma = {gamma}: 2β < γ is only conditionally stable "
            "(unconditional stability needs 2β ≥ γ ≥ 1/2)",
            RuntimeWarning,
            stacklevel=2,
        )


class NewmarkSteps:
    """The Newmark (β, γ) steps on a vector space of the subclass's own (THEORY.md §2): the
    predictors and the free step, the link correction, the trapezoidal increment. They reach
    the operators only through ``solve`` (M̃⁻¹), ``mass_action``, ``stiffness_action``,
    ``damping_action``, ``interface_force`` and ``load``, and ``_constrain`` clears what a
    right-hand side must not drive (a field's clamped DOFs). :class:`Newmark` (the field, sparse
    Cholesky) and crane_fem.integrators.newmark_reduced.ReducedNewmark (Craig–Bampton
    coordinates, diagonal) share them."""

    u: FloatArray
    v: FloatArray
    a: FloatArray
    dT: float
    beta: float
    gamma: float
    load: LoadFunction

    def solve(self, rhs: FloatArray) -> FloatArray:
        raise NotImplementedError

    def mass_action(self, x: FloatArray) -> FloatArray:
        raise NotImplementedError

    def stiffness_action(self, x: FloatArray) -> FloatArray:
        raise NotImplementedError

    def damping_action(self, x: FloatArray, mx: FloatArray | None = None) -> FloatArray:
        raise NotImplementedError

    def interface_force(self, force: FloatArray) -> FloatArray:
        raise NotImplementedError

    def _constrain(self, rhs: FloatArray) -> FloatArray:
        """``rhs`` with the rows no load may drive cleared (none here)."""
        return rhs

    def mass_and_damping(self, x: FloatArray) -> tuple[FloatArray, FloatArray]:
        """(M x, C x) with one mass product (collective)."""
        mx = self.mass_action(x)
        return mx, self.damping_action(x, mx)

    def free_step(self, t_new: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        """(U, V, A) at t_new with Λ = 0 at t_new; the state is not changed (collective)."""
        dT, b, g = self.dT, self.beta, self.gamma
        ut = self.u + dT * self.v + dT * dT * (0.5 - b) * self.a
        vt = self.v + dT * (1.0 - g) * self.a
        rhs = self.load(t_new) - self.stiffness_action(ut) - self.damping_action(vt)
        a = self.solve(self._constrain(rhs))
        return ut + b * dT * dT * a, vt + g * dT * a, a

    def trapezoid_free_increment(self, f0: FloatArray, f1: FloatArray) -> FloatArray:
        """ΔU over one step of the trapezoidal rule (β = ¼, γ = ½) without link force, in
        its displacement–velocity form (no acceleration, so a link force may jump at t_n):

            M̃ ΔU = ΔT M V_n + ¼ΔT² (F_n + F_n+1) − ½ΔT² K U_n,   V_n+1 = 2ΔU/ΔT − V_n.

        A constant link force G over the step adds ½ΔT² M̃⁻¹ Lᵀ G (collective)."""
        if (self.beta, self.gamma) != (0.25, 0.5):
            raise ValueError("the trapezoidal increment needs beta = 1/4, gamma = 1/2")
        dT = self.dT
        rhs = dT * self.mass_action(self.v) + 0.25 * dT * dT * (f0 + f1)
        rhs -= 0.5 * dT * dT * self.stiffness_action(self.u)
        return self.solve(self._constrain(rhs))

    def accept(self, u: FloatArray, v: FloatArray, a: FloatArray) -> None:
        self.u, self.v, self.a = u, v, a

    def state_dict(self) -> dict[str, Any]:
        """Copies of (U, V, A), this side's vectors (a checkpoint; not collective)."""
        return {"u": self.u.copy(), "v": self.v.copy(), "a": self.a.copy()}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        """Set (U, V, A) from :meth:`state_dict` of a side on the same partition."""
        for k in ("u", "v", "a"):
            src = np.array(state[k], dtype=np.float64)
            if src.shape != getattr(self, k).shape:
                raise ValueError(f"implicit side state {k!r}: shape {src.shape} does not match")
            setattr(self, k, src)

    def link_response(self, force: FloatArray) -> FloatArray:
        """M̃⁻¹ Lᵀ Λ for link forces Λ (n_Γ, global, the same on every rank) (collective)."""
        return self.solve(self.interface_force(force))

    def correct(self, force: FloatArray) -> None:
        """Add the response to link forces Λ (n_Γ, N) applied at the current time
        (collective)."""
        if force.size == 0:
            return
        da = self.link_response(force)
        self.a = self.a + da
        self.v = self.v + self.gamma * self.dT * da
        self.u = self.u + self.beta * self.dT * self.dT * da


class Newmark(NewmarkSteps):
    """Newmark (β, γ) on one subdomain; owns its operator, KSPs and vectors (``destroy``).

    Arrays are owned-DOF arrays. Collective over the model's communicator.

    Attributes:
        u, v, a: state at the current time (after :meth:`correct`).
        W: L M̃⁻¹ Lᵀ (n_Γ × n_Γ, global, identical on all ranks).
    """

    def __init__(
        self,
        model: StructuralModel,
        load: LoadFunction,
        dT: float,
        u0: FloatArray,
        v0: FloatArray,
        beta: float = 0.25,
        gamma: float = 0.5,
        interface: ContactSet | None = None,
        consistent_mass: bool = True,
    ) -> None:
        check_newmark_parameters(beta, gamma)
        if consistent_mass and model.M is None:
            raise ValueError("consistent mass requested but the model has no mass matrix")
        self.model, self.load, self.dT = model, load, float(dT)
        self.beta, self.gamma = float(beta), float(gamma)
        self.interface = interface if interface is not None else ContactSet.empty(model.comm)
        self.consistent = consistent_mass
        comm = model.comm
        alpha, beta_r = model.alpha, model.beta
        # M̃ = (1 + γΔT α) M + (βΔT² + γΔT β_R) K
        self.A = model.K.copy()
        self.A.scale(beta * dT * dT + gamma * dT * beta_r)
        self._lumped = model.create_vector(np.array(model.mass))
        if consistent_mass:
            assert model.M is not None
            self.A.axpy(1.0 + gamma * dT * alpha, model.M)
        else:
            d = model.create_vector((1.0 + gamma * dT * alpha) * model.mass)
            self.A.setDiagonal(d, addv=True)  # addv=True: ADD_VALUES
            d.destroy()
        self.ksp = self._cholesky(self.A, "crane_fem_newmark_")
        self.ksp_m = None
        if consistent_mass:
            assert model.M is not None
            self.ksp_m = self._mass_cg(model.M, "crane_fem_newmark_mass_")

        # K and M in block storage for the products of every macro step (a block size of 3:
        # about twice as fast as AIJ on the crane's implicit side); copies owned here.
        self._K = model.K.convert("baij", PETSc.Mat())
        self._M = None
        if consistent_mass and model.M is not None:
            self._M = model.M.convert("baij", PETSc.Mat())
        n = model.n_owned
        self.u = np.array(u0, dtype=np.float64)
        self.v = np.array(v0, dtype=np.float64)
        self.a = np.zeros(n)
        self._buf = {k: np.zeros(n) for k in ("x", "y")}
        self._vec = {k: model.create_vector(arr) for k, arr in self._buf.items()}
        self._fixed = model.fixed
        # Condensed operator (n_Γ solves with the factored M̃).
        p = self.interface.p
        W = np.zeros((p, p))
        for k in range(p):
            e = np.zeros(p)
            e[k] = 1.0
            W[:, k] = self.interface.apply(self.link_response(e))
        self.W = 0.5 * (W + W.T)
        self._comm = comm

    def _cholesky(self, mat: PETSc.Mat, prefix: str) -> PETSc.KSP:
        """A KSP applying mat⁻¹ by a sparse Cholesky factorisation (collective). Options under
        ``prefix`` given by the user (PETSC_OPTIONS, the command line) take precedence."""
        comm = self.model.comm
        ksp = PETSc.KSP().create(comm)  # type: ignore[arg-type]
        ksp.setOptionsPrefix(prefix)
        ksp.setOperators(mat)
        ksp.setType("preonly")
        opts = PETSc.Options()
        inner = prefix if comm.size == 1 else prefix + "redundant_"
        defaults = {
            "pc_type": "cholesky",
            "pc_factor_mat_solver_type": "petsc",
            "pc_factor_mat_ordering_type": "qmd",
        }
        if comm.size > 1 and not opts.hasName(prefix + "pc_type"):
            opts.setValue(prefix + "pc_type", "redundant")
        for key, value in defaults.items():
            if not opts.hasName(inner + key):
                opts.setValue(inner + key, value)
        ksp.setFromOptions()
        ksp.setUp()
        return ksp

    def _mass_cg(self, mat: PETSc.Mat, prefix: str) -> PETSc.KSP:
        """A KSP applying M⁻¹ by conjugate gradients (Jacobi preconditioner, relative residual
        1e-14: M is well conditioned) (collective)."""
        ksp = PETSc.KSP().create(self.model.comm)  # type: ignore[arg-type]
        ksp.setOptionsPrefix(prefix)
        ksp.setOperators(mat)
        ksp.setType("cg")
        ksp.getPC().setType("jacobi")
        ksp.setTolerances(rtol=1e-14, atol=0.0, max_it=1000)
        ksp.setFromOptions()
        return ksp

    def _apply(self, op: str, x: FloatArray) -> FloatArray:
        """K x, M x or M̃⁻¹ x (op = 'K', 'M', 'solve', 'solve_m') as a new owned array."""
        self._buf["x"][:] = x
        if op == "K":
            self._K.mult(self._vec["x"], self._vec["y"])
        elif op == "M":
            if self._M is not None:
                self._M.mult(self._vec["x"], self._vec["y"])
            else:
                self._buf["y"][:] = self.model.mass * x
        elif op == "solve":
            self.ksp.solve(self._vec["x"], self._vec["y"])
        else:
            assert self.ksp_m is not None
            self.ksp_m.solve(self._vec["x"], self._vec["y"])
            reason: Any = self.ksp_m.getConvergedReason()
            if reason <= 0:
                raise CraneFemError(
                    "Newmark: the conjugate-gradient solve with the consistent mass did not "
                    f"converge (reason {reason})"
                )
        out = self._buf["y"].copy()
        return out

    def solve(self, rhs: FloatArray) -> FloatArray:
        """M̃⁻¹ rhs (collective)."""
        return self._apply("solve", rhs)

    def mass_action(self, x: FloatArray) -> FloatArray:
        return self._apply("M", x)

    def stiffness_action(self, x: FloatArray) -> FloatArray:
        return self._apply("K", x)

    def damping_action(self, x: FloatArray, mx: FloatArray | None = None) -> FloatArray:
        """C x with C = αM + β_R K; ``mx``: M x when already computed (collective)."""
        m = self.model
        out = np.zeros_like(x)
        if m.alpha:
            out += m.alpha * (self.mass_action(x) if mx is None else mx)
        if m.beta:
            out += m.beta * self.stiffness_action(x)
        return out

    def initialize(self, t0: float, link: FloatArray | None = None) -> None:
        """A_0 from M A_0 = F_0 − K U_0 − C V_0 (+ link force) (collective)."""
        rhs = self.load(t0) - self.stiffness_action(self.u) - self.damping_action(self.v)
        if link is not None:
            rhs = rhs + link
        rhs[self._fixed] = 0.0
        if self.consistent:
            self.a = self._apply("solve_m", rhs)
        else:
            self.a = np.where(self._fixed, 0.0, rhs / np.where(self._fixed, 1.0, self.model.mass))

    def _constrain(self, rhs: FloatArray) -> FloatArray:
        """``rhs`` with the clamped DOFs' rows cleared."""
        rhs[self._fixed] = 0.0
        return rhs

    # The implicit side as the coupling methods see it (crane_fem.coupling.system): vectors of
    # its own space, read and loaded through the interface rows.
    def interface_values(self, x: FloatArray) -> FloatArray:
        """L_I x: the interface rows of a vector of this side (global, collective)."""
        return self.interface.apply(x)[: self.interface.p]

    def interface_force(self, force: FloatArray) -> FloatArray:
        """L_Iᵀ Λ for link forces Λ (global), a vector of this side (not collective)."""
        return self.interface.transpose(force, self.model.n_owned)

    def local_dot(self, x: FloatArray, y: FloatArray) -> float:
        """This rank's part of xᵀy for vectors of this side (sum it over the ranks)."""
        return float(books.dot(x, y))

    def field(self, x: FloatArray) -> FloatArray:
        """A vector of this side as a field on the subdomain's owned DOFs (itself here)."""
        return x

    def field_rows(self, x: FloatArray, rows: npt.NDArray[np.int64]) -> FloatArray:
        """:meth:`field` at owned DOFs ``rows`` only."""
        return x[rows]

    def refined(self, dT: float) -> Newmark:
        """The same side with the step ΔT = ``dT``, in the same state (its own factorisation;
        caller destroys)."""
        return Newmark(
            self.model,
            self.load,
            dT,
            self.u,
            self.v,
            self.beta,
            self.gamma,
            self.interface,
            self.consistent,
        )

    def destroy(self) -> None:
        self.ksp.destroy()
        if self.ksp_m is not None:
            self.ksp_m.destroy()
        self.A.destroy()
        self._K.destroy()
        if self._M is not None:
            self._M.destroy()
        self._lumped.destroy()
        for vec in self._vec.values():
            vec.destroy()
