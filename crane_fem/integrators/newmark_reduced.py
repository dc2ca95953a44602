"""Newmark (β, γ) on the Craig–Bampton coordinates of a linear subdomain (THEORY.md §2, §6).

The same steps as :class:`crane_fem.integrators.newmark.Newmark`, on the reduced coordinates
x = (u_b, q, c) of :class:`crane_fem.reduction.CraigBampton`, stepped in the reduced system's
own modes. With its mass-carrying coordinates x_d = (u_b, q) written x_d = Ψ η, where
K_dd Ψ = M_dd Ψ Λ and ΨᵀM_ddΨ = I (the free-interface modes of the reduced system, one dense
eigendecomposition at set-up), and its massless static coordinates c = R ζ (K_cc = R κ Rᵀ),
M_r, K_r and the Rayleigh C_r are diagonal in z = (η, ζ): every Newmark step is an update
entry by entry, and M̃_r⁻¹ a division. The static coordinates are K-orthogonal to the others
(crane_fem.reduction), so K_dc is round-off and dropped. What is not diagonal are the interface
rows, L_I x = coeff ⊙ u_b = P η with P = coeff ⊙ Ψ_b (n_Γ × n_d; C Ψ_b for rows of several
terms, a rigid section's on a beam node): the interface values and
the link forces cost one product with P each, and W_I = P Ã⁻¹ Pᵀ.

The state is replicated on every rank, so no step communicates. The coupling methods see the
side through the same methods as the full one (crane_fem.coupling.system.ImplicitSide); a
record that needs the field (XDMF frames, stresses) expands it, T (Ψ η, R ζ), on the owned DOFs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import scipy.linalg

from crane_fem.integrators.newmark import NewmarkSteps, check_newmark_parameters
from crane_fem.loading.body import AffineLoad
from crane_fem.model import StructuralModel
from crane_fem.reduction import CraigBampton

__all__ = ["ReducedModes", "ReducedNewmark", "reduced_modes"]

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class ReducedModes:
    """The reduced system in its own modes (the same on every rank).

    Attributes:
        n_d: mass-carrying coordinates (interface and fixed-interface modes).
        Psi: their modes (n_d × n_d), M_dd-orthonormal; lam: their ω² (n_d).
        R: the rotation of the static coordinates (n_s × n_s); kappa: their stiffness (n_s).
        P: coeff ⊙ Ψ_b, the interface rows in modal coordinates (n_Γ × n_d); PT: Pᵀ stored
            by rows (a product with it reads memory in order).
        mass: 1 on η, 0 on ζ; stiff: (Λ, κ).
    """

    n_d: int
    Psi: FloatArray
    lam: FloatArray
    R: FloatArray
    kappa: FloatArray
    P: FloatArray
    PT: FloatArray
    mass: FloatArray
    stiff: FloatArray

    def to_modal(self, x: FloatArray, M_dd: FloatArray) -> FloatArray:
        """z = (Ψᵀ M_dd x_d, Rᵀ x_c) of reduced coordinates x."""
        k = self.n_d
        return np.concatenate([self.Psi.T @ (M_dd @ x[:k]), self.R.T @ x[k:]])

    def to_reduced(self, z: FloatArray) -> FloatArray:
        """x = (Ψ η, R ζ)."""
        k = self.n_d
        return np.concatenate([self.Psi @ z[:k], self.R @ z[k:]])


def reduced_modes(basis: CraigBampton) -> ReducedModes:
    """Diagonalise the reduced M_r, K_r (not collective: every rank holds them)."""
    k = basis.n_r - basis.n_static
    M, K = basis.M, basis.K
    lam, Psi = scipy.linalg.eigh(K[:k, :k], M[:k, :k])
    kappa, R = np.linalg.eigh(K[k:, k:]) if basis.n_static else (np.zeros(0), np.zeros((0, 0)))
    P = basis.rows_of_boundary(Psi[: basis.n_b, :])
    mass = np.concatenate([np.ones(k), np.zeros(basis.n_static)])
    PT = np.ascontiguousarray(P.T)
    return ReducedModes(k, Psi, lam, R, kappa, P, PT, mass, np.concatenate([lam, kappa]))


class ReducedNewmark(NewmarkSteps):
    """Newmark on reduced coordinates, in the reduced system's modes (no step communicates;
    the vectors it takes and returns are modal coordinates z, see the module docstring).

    Args:
        model: the subdomain (its communicator, Rayleigh α and β).
        basis: the Craig–Bampton basis and reduced M, K.
        load: the subdomain's load in reduced form (Tᵀ F(t)).
        dT: the step; u0, v0: the initial state in reduced coordinates x.
        beta, gamma: Newmark parameters.
        modes: the reduced system's modes when already computed (``refined``).
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
        modes: ReducedModes | None = None,
    ) -> None:
        check_newmark_parameters(beta, gamma)
        self.model, self.basis = model, basis
        self.dT, self.beta, self.gamma = float(dT), float(beta), float(gamma)
        md = modes if modes is not None else reduced_modes(basis)
        self.modes = md
        k = md.n_d
        M_dd = basis.M[:k, :k]
        if modes is None:  # reduced coordinates in; the state is modal
            u0, v0 = md.to_modal(u0, M_dd), md.to_modal(v0, M_dd)
            load = AffineLoad(
                self._load_to_modal(load.base),
                np.array([self._load_to_modal(f) for f in load.shapes]).reshape(
                    len(load.histories), u0.size
                ),
                load.histories,
            )
        self.load = self._modal_load = load  # (the latter typed: ``refined`` passes it on)
        alpha, beta_r = model.alpha, model.beta
        #: C_z = α M_z + β K_z and Ã = M_z + γΔT C_z + βΔT² K_z, diagonal.
        self.c = alpha * md.mass + beta_r * md.stiff
        self.A = md.mass + gamma * dT * self.c + beta * dT * dT * md.stiff
        self._inv_A = 1.0 / self.A
        self._inv_A_d = self._inv_A[:k]
        self.u = np.array(u0, dtype=np.float64)
        self.v = np.array(v0, dtype=np.float64)
        self.a = np.zeros_like(self.u)
        W = (md.P * self._inv_A_d[None, :]) @ md.P.T
        self.W = 0.5 * (W + W.T)
        #: :meth:`field_rows`' operators T[rows] (Ψ, R), per ``rows`` (shared by ``refined``).
        self._row_ops: dict[bytes, FloatArray] = {}
        # Replicated vectors: rank 0 alone contributes to a sum over the ranks.
        self._first = model.comm.rank == 0

    def _load_to_modal(self, f: FloatArray) -> FloatArray:
        """A reduced load f (work-conjugate to x) as conjugate to z: (Ψᵀ f_d, Rᵀ f_c)."""
        md = self.modes
        k = md.n_d
        return np.concatenate([md.Psi.T @ f[:k], md.R.T @ f[k:]])

    # ------------------------------------------------------------------------------------
    def solve(self, rhs: FloatArray) -> FloatArray:
        """M̃⁻¹ rhs."""
        return np.asarray(self._inv_A * rhs)

    def mass_action(self, x: FloatArray) -> FloatArray:
        return np.asarray(self.modes.mass * x)

    def stiffness_action(self, x: FloatArray) -> FloatArray:
        return np.asarray(self.modes.stiff * x)

    def damping_action(self, x: FloatArray, mx: FloatArray | None = None) -> FloatArray:
        """C x (diagonal)."""
        return np.asarray(self.c * x)

    def initialize(self, t0: float, link: FloatArray | None = None) -> None:
        """A_0 from M A_0 = F_0 − K U_0 − C V_0 (+ link force) on the coordinates that carry
        mass; the static ones are in balance at the start (their acceleration is zero)."""
        rhs = self.load(t0) - self.stiffness_action(self.u) - self.damping_action(self.v)
        if link is not None:
            rhs = rhs + link
        self.a = np.asarray(self.modes.mass * rhs)

    def interface_values(self, x: FloatArray) -> FloatArray:
        """L_I x = P η (replicated: no communication)."""
        return np.asarray(self.modes.P @ x[: self.modes.n_d])

    def interface_force(self, force: FloatArray) -> FloatArray:
        """L_Iᵀ Λ in modal coordinates: (Pᵀ Λ, 0)."""
        out = np.zeros_like(self.u)
        out[: self.modes.n_d] = self.modes.PT @ force
        return out

    def local_dot(self, x: FloatArray, y: FloatArray) -> float:
        """xᵀy from rank 0 alone (the vectors are the same on every rank)."""
        return float(np.dot(x, y)) if self._first else 0.0

    def reduced(self, z: FloatArray) -> FloatArray:
        """The reduced coordinates x of modal coordinates z."""
        return self.modes.to_reduced(z)

    def field(self, x: FloatArray) -> FloatArray:
        """T x: the subdomain's field on the owned DOFs."""
        return self.basis.expand(self.modes.to_reduced(x))

    def field_rows(self, x: FloatArray, rows: npt.NDArray[np.int64]) -> FloatArray:
        """:meth:`field` at owned DOFs ``rows`` only: one product with T[rows] (Ψ, R),
        formed at the first call for these rows (a monitor reads the same rows at every
        macro step: its cost is then that of the rows, not of T's and Ψ's)."""
        key = np.asarray(rows, dtype=np.int64).tobytes()
        op = self._row_ops.get(key)
        if op is None:
            md = self.modes
            k = md.n_d
            Tr = self.basis.T[rows]
            op = np.empty((Tr.shape[0], Tr.shape[1]))
            op[:, :k] = Tr[:, :k] @ md.Psi
            op[:, k:] = Tr[:, k:] @ md.R
            self._row_ops[key] = op
        return np.asarray(op @ x)

    def refined(self, dT: float) -> ReducedNewmark:
        """The same side with the step ΔT = ``dT``, in the same state."""
        out = ReducedNewmark(
            self.model,
            self.basis,
            self._modal_load,
            dT,
            self.u,
            self.v,
            self.beta,
            self.gamma,
            self.modes,
        )
        out.a = self.a.copy()
        out._row_ops = self._row_ops
        return out

    def destroy(self) -> None:
        return None
