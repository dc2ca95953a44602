"""Newmark (β, γ) on the Craig–Bampton coordinates of a linear subdomain (THEORY.md §2, §6).

The same steps as :class:`crane_fem.integrators.newmark.Newmark`, written for the reduced
coordinates x = (u_b, q, c) of :class:`crane_fem.reduction.CraigBampton`: dense operators of a
few hundred rows, factored once (Cholesky), the same on every rank, so a macro step costs
microseconds where the full side costs two sparse solves. The interface rows are the identity
on u_b (times their coefficient), so W_I = L M̃_r⁻¹ Lᵀ is a block of M̃_r⁻¹. The coupling
methods see it through the same methods as the full side; a record that needs the field
(history probes, XDMF frames) expands it, T x, on the owned DOFs.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import scipy.linalg

from crane_fem.integrators.newmark import check_newmark_parameters
from crane_fem.loading.body import AffineLoad
from crane_fem.model import StructuralModel
from crane_fem.reduction import CraigBampton

__all__ = ["ReducedNewmark"]

FloatArray = npt.NDArray[np.float64]


class ReducedNewmark:
    """Newmark on reduced coordinates (collective where it reduces over the ranks: the
    interface values are replicated, so none of its steps communicates).

    Args:
        model: the subdomain (for its communicator).
        basis: the Craig–Bampton basis and reduced M, K.
        load: the subdomain's load in reduced form (Tᵀ F(t)).
        dT: the step; u0, v0: the reduced initial state.
        beta, gamma: Newmark parameters.
    """

    def __init__(
        self,
        model: StructuralModel,
        basis: CraigBampton,
        load: AffineLoad,
        dT: float,
        u0: FloatArray,
        v0: FloatArray,
        beta: float = 0.25,
        gamma: float = 0.5,
    ) -> None:
        check_newmark_parameters(beta, gamma)
        self.model, self.basis, self.load = model, basis, load
        self.dT, self.beta, self.gamma = float(dT), float(beta), float(gamma)
        M, K = basis.M, basis.K
        alpha, beta_r = model.alpha, model.beta
        self.C = alpha * M + beta_r * K
        self.A = M + gamma * dT * self.C + beta * dT * dT * K
        # M̃_r⁻¹ kept whole: a product per solve (n_r² multiply-adds, from cache) is cheaper
        # than two triangular solves through LAPACK's call overhead at this size.
        n_r = self.A.shape[0]
        eye = np.eye(n_r)
        self._inv = np.ascontiguousarray(
            scipy.linalg.cho_solve(scipy.linalg.cho_factor(self.A), eye)
        )
        # The static vectors (the last coordinates) are massless: the initial acceleration
        # solves the rows that carry mass (the others are in static balance at the start).
        self._n_dyn = n_r - basis.n_static
        self._mass_factor = scipy.linalg.cho_factor(M[: self._n_dyn, : self._n_dyn])
        self.u = np.array(u0, dtype=np.float64)
        self.v = np.array(v0, dtype=np.float64)
        self.a = np.zeros_like(self.u)
        n_b = basis.n_b
        c = basis.coeff
        W = c[:, None] * self._inv[:n_b, :n_b] * c[None, :]
        self.W = 0.5 * (W + W.T)
        # M̃_r⁻¹ Lᵀ: the response to the link forces, a product with n_b columns.
        self._link = np.ascontiguousarray(self._inv[:, :n_b] * c[None, :])
        # Replicated vectors: rank 0 alone contributes to a sum over the ranks.
        self._first = model.comm.rank == 0

    # ------------------------------------------------------------------------------------
    def solve(self, rhs: FloatArray) -> FloatArray:
        """M̃_r⁻¹ rhs."""
        return np.asarray(self._inv @ rhs)

    def mass_action(self, x: FloatArray) -> FloatArray:
        return np.asarray(self.basis.M @ x)

    def stiffness_action(self, x: FloatArray) -> FloatArray:
        return np.asarray(self.basis.K @ x)

    def damping_action(self, x: FloatArray, mx: FloatArray | None = None) -> FloatArray:
        """C_r x = α M_r x + β K_r x (α M_r x from ``mx`` when given)."""
        m = self.model
        if m.beta == 0.0:
            return m.alpha * (self.basis.M @ x if mx is None else mx)
        return np.asarray(self.C @ x)

    def mass_and_damping(self, x: FloatArray) -> tuple[FloatArray, FloatArray]:
        mx = self.mass_action(x)
        return mx, self.damping_action(x, mx)

    def initialize(self, t0: float, link: FloatArray | None = None) -> None:
        """A_0 from M_r A_0 = F_0 − K_r U_0 − C_r V_0 (+ link force)."""
        rhs = self.load(t0) - self.stiffness_action(self.u) - self.damping_action(self.v)
        if link is not None:
            rhs = rhs + link
        k = self._n_dyn
        self.a = np.zeros_like(self.u)
        self.a[:k] = scipy.linalg.cho_solve(self._mass_factor, rhs[:k], check_finite=False)

    def free_step(self, t_new: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        """(U, V, A) at t_new with Λ = 0 at t_new; the state is not changed."""
        dT, b, g = self.dT, self.beta, self.gamma
        ut = self.u + dT * self.v + dT * dT * (0.5 - b) * self.a
        vt = self.v + dT * (1.0 - g) * self.a
        a = self.solve(self.load(t_new) - self.stiffness_action(ut) - self.damping_action(vt))
        return ut + b * dT * dT * a, vt + g * dT * a, a

    def trapezoid_free_increment(self, f0: FloatArray, f1: FloatArray) -> FloatArray:
        """ΔU of the trapezoidal rule without link force (Newmark.trapezoid_free_increment)."""
        if (self.beta, self.gamma) != (0.25, 0.5):
            raise ValueError("the trapezoidal increment needs beta = 1/4, gamma = 1/2")
        dT = self.dT
        rhs = dT * self.mass_action(self.v) + 0.25 * dT * dT * (f0 + f1)
        rhs -= 0.5 * dT * dT * self.stiffness_action(self.u)
        return self.solve(rhs)

    def accept(self, u: FloatArray, v: FloatArray, a: FloatArray) -> None:
        self.u, self.v, self.a = u, v, a

    def interface_values(self, x: FloatArray) -> FloatArray:
        """L_I x = coeff ⊙ x_b (replicated: no communication)."""
        return np.asarray(self.basis.coeff * x[: self.basis.n_b])

    def interface_force(self, force: FloatArray) -> FloatArray:
        """L_Iᵀ Λ in reduced coordinates."""
        out = np.zeros_like(self.u)
        out[: self.basis.n_b] = self.basis.coeff * force
        return out

    def local_dot(self, x: FloatArray, y: FloatArray) -> float:
        """xᵀy from rank 0 alone (the vectors are the same on every rank)."""
        return float(np.dot(x, y)) if self._first else 0.0

    def field(self, x: FloatArray) -> FloatArray:
        """T x: the subdomain's field on the owned DOFs."""
        return self.basis.expand(x)

    def refined(self, dT: float) -> ReducedNewmark:
        """The same side with the step ΔT = ``dT``, in the same state."""
        out = ReducedNewmark(
            self.model, self.basis, self.load, dT, self.u, self.v, self.beta, self.gamma
        )
        out.a = self.a.copy()
        return out

    def link_response(self, force: FloatArray) -> FloatArray:
        """M̃_r⁻¹ Lᵀ Λ."""
        return np.asarray(self._link @ force)

    def correct(self, force: FloatArray) -> None:
        """Add the response to link forces Λ applied at the current time."""
        if force.size == 0:
            return
        da = self.link_response(force)
        self.a = self.a + da
        self.v = self.v + self.gamma * self.dT * da
        self.u = self.u + self.beta * self.dT * self.dT * da

    def destroy(self) -> None:
        return None
