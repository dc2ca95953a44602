"""Exact solutions of the 1D impact benchmarks (THEORY.md §5), for verification.

All functions are plain NumPy, not collective. Coordinates: the bar's material coordinate
X ∈ [0, L] from its contact end; displacements along +x; the wall is at x = 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import scipy.optimize

__all__ = [
    "BouncingBar",
    "WallImpact",
    "renard_chouly_contact_end",
    "renard_chouly_displacement",
]

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class WallImpact:
    """Free bar (length L, wave speed c) at uniform velocity v0 < 0, contact end at x = gap.

    d'Alembert: contact starts at t_c = gap/|v0|, a compression front (stress ρ c v0) runs to
    the free end and back; at t_c + 2L/c the bar is unstressed and leaves at −v0.
    """

    length: float
    c: float
    v0: float
    gap: float

    @property
    def t_contact(self) -> float:
        return self.gap / abs(self.v0)

    @property
    def duration(self) -> float:
        return 2.0 * self.length / self.c

    def displacement(self, X: FloatArray, t: float) -> FloatArray:
        """u(X, t)."""
        L, c, v0, tc = self.length, self.c, self.v0, self.t_contact
        X = np.asarray(X, dtype=np.float64)
        if t <= tc:
            return np.full_like(X, v0 * t)
        tau = t - tc
        stopped = v0 * (tc + X / c)  # position frozen when the front passed
        if tau <= L / c:
            return np.where(X < c * tau, stopped, v0 * t)
        rebound = 2.0 * v0 * (tc + L / c) - v0 * t  # after the reflected front passed
        if tau <= 2.0 * L / c:
            front = L - c * (tau - L / c)
            return np.where(X > front, rebound, stopped)
        return np.full_like(X, rebound)

    def velocity(self, X: FloatArray, t: float) -> FloatArray:
        """∂u/∂t (X, t), away from the fronts."""
        L, c, v0, tc = self.length, self.c, self.v0, self.t_contact
        X = np.asarray(X, dtype=np.float64)
        if t <= tc:
            return np.full_like(X, v0)
        tau = t - tc
        if tau <= L / c:
            return np.where(X < c * tau, 0.0, v0)
        if tau <= 2.0 * L / c:
            return np.where(X > L - c * (tau - L / c), -v0, 0.0)
        return np.full_like(X, -v0)


def renard_chouly_contact_end(t: FloatArray) -> FloatArray:
    """u(0, t) of the clamped bar (c = 1, L = 1, u0 = ½ − x/2, v0 = 0) on the obstacle u ≥ 0.

    Derived by d'Alembert (docs/verification.md): free flight u(0,t) = ½ − t/2 on [0, 1],
    persistent contact on [1, 2] (reaction ½), release u(0,t) = (t − 2)/2 on [2, 3]; period 3.
    """
    tm = np.mod(np.asarray(t, dtype=np.float64), 3.0)
    return np.where(tm < 1.0, 0.5 - 0.5 * tm, np.where(tm < 2.0, 0.0, 0.5 * (tm - 2.0)))


def renard_chouly_displacement(x: FloatArray) -> FloatArray:
    """The field at every multiple of the period 3 (it equals the initial one)."""
    return 0.5 - 0.5 * np.asarray(x, dtype=np.float64)


@dataclass
class BouncingBar:
    """Modal-series solution of the bar falling on a rigid ground under gravity.

    Doyen, Ern & Piperno (SIAM J. Sci. Comput. 2011): L = 10, E = 900, ρ = 1, g = 10. The bar
    (free-free in flight, fixed-free in contact) is expanded on the eigenmodes of the current
    phase: in flight cos(kπX/L) plus the rigid mode (which alone feels gravity); in contact the
    static gravity profile u_s = (g/c²)(X²/2 − L X) plus sin((2k−1)πX/(2L)). A phase's initial
    state is projected on the next phase's modes with Gauss–Legendre quadrature. Contact starts
    when the contact end reaches the ground and ends when the reaction R = dP/dt + ρ A g L
    (P the momentum), i.e. R = −E A ∂u/∂X at the end, would become tensile.

    Attributes:
        n_modes: modes per phase (the contact-end displacement converges like 1/n_modes).
    """

    length: float = 10.0
    E: float = 900.0
    rho: float = 1.0
    g: float = 10.0
    height: float = 5.0
    v0: float = 0.0
    n_modes: int = 4000

    def __post_init__(self) -> None:
        self.c = math.sqrt(self.E / self.rho)
        # Composite 8-point Gauss–Legendre on 2 n_modes panels: each panel spans at most a
        # quarter wavelength of the highest mode, where 8 points integrate to round-off.
        xg, wg = np.polynomial.legendre.leggauss(8)
        n_panels = 2 * self.n_modes
        edges = np.linspace(0.0, self.length, n_panels + 1)
        half = 0.5 * np.diff(edges)
        mid = 0.5 * (edges[1:] + edges[:-1])
        self._x = (mid[:, None] + half[:, None] * xg[None, :]).ravel()
        self._w = (half[:, None] * wg[None, :]).ravel()
        self.phases: list[tuple[str, float, float, FloatArray, FloatArray]] = []

    # --- modal projections -------------------------------------------------------------
    def _free_modes(self) -> tuple[FloatArray, FloatArray]:
        k = np.arange(1, self.n_modes + 1, dtype=np.float64)
        kappa = k * math.pi / self.length
        return kappa, self.c * kappa

    def _fixed_modes(self) -> tuple[FloatArray, FloatArray]:
        k = np.arange(1, self.n_modes + 1, dtype=np.float64)
        kappa = (2 * k - 1) * math.pi / (2.0 * self.length)
        return kappa, self.c * kappa

    def _static(self, X: FloatArray) -> FloatArray:
        return (self.g / self.c**2) * (0.5 * X**2 - self.length * X)

    def _project(self, f: FloatArray, basis: FloatArray) -> FloatArray:
        return (2.0 / self.length) * (basis * (self._w * f)).sum(axis=1)

    # --- phases ------------------------------------------------------------------------
    def _flight(self, u: FloatArray, v: FloatArray) -> tuple[Any, Any]:
        kappa, omega = self._free_modes()
        basis = np.cos(np.outer(kappa, self._x))
        a, b = self._project(u, basis), self._project(v, basis)
        q0 = float((self._w * u).sum()) / self.length
        p0 = float((self._w * v).sum()) / self.length

        def end_disp(tau: FloatArray) -> FloatArray:
            tau = np.atleast_1d(tau)
            cs, sn = np.cos(np.outer(tau, omega)), np.sin(np.outer(tau, omega))
            return q0 + p0 * tau - 0.5 * self.g * tau**2 + cs @ a + sn @ (b / omega)

        def state(tau: float) -> tuple[FloatArray, FloatArray]:
            cs, sn = np.cos(omega * tau), np.sin(omega * tau)
            qk = a * cs + b / omega * sn
            dq = -a * omega * sn + b * cs
            u_ = q0 + p0 * tau - 0.5 * self.g * tau**2 + qk @ basis
            v_ = p0 - self.g * tau + dq @ basis
            return u_, v_

        return end_disp, state

    def _contact(self, u: FloatArray, v: FloatArray) -> tuple[Any, Any]:
        kappa, omega = self._fixed_modes()
        basis = np.sin(np.outer(kappa, self._x))
        us = self._static(self._x)
        a, b = self._project(u + self.height - us, basis), self._project(v, basis)

        # Lanczos σ-factors tame the Gibbs oscillation of the end stress at wave fronts.
        k = np.arange(1, self.n_modes + 1, dtype=np.float64)
        sigma = np.sinc(k / (self.n_modes + 1.0))

        def reaction(tau: FloatArray) -> FloatArray:
            """R = −E A u_x(0, τ) = ρ g L − E Σ κ_k q_k(τ) (A = 1), σ-smoothed."""
            tau = np.atleast_1d(tau)
            q = np.cos(np.outer(tau, omega)) * a + np.sin(np.outer(tau, omega)) * (b / omega)
            return self.rho * self.g * self.length - self.E * (q @ (sigma * kappa))

        def state(tau: float) -> tuple[FloatArray, FloatArray]:
            cs, sn = np.cos(omega * tau), np.sin(omega * tau)
            u_ = -self.height + us + (a * cs + b / omega * sn) @ basis
            v_ = (-a * omega * sn + b * cs) @ basis
            return u_, v_

        return reaction, state

    def solve(self, t_end: float) -> BouncingBar:
        """Compute the phases up to ``t_end`` (initial state: rest shape, velocity v0)."""
        u = np.zeros_like(self._x)
        v = np.full_like(self._x, self.v0)
        t = 0.0
        self.phases = []
        T = 2.0 * self.length / self.c
        while t < t_end:
            end_disp, fstate = self._flight(u, v)
            # First time the contact end reaches the ground, on a grid finer than the
            # shortest flight-mode period that matters, then refined by Brent's method.
            dtau = T / 400.0
            tau_max = t_end - t
            taus = np.arange(0.0, tau_max + dtau, dtau)
            gap = self.height + end_disp(taus)
            hit = np.flatnonzero((gap[1:] <= 0.0) & (np.arange(1, taus.size) > 0))
            if hit.size == 0:
                self.phases.append(("flight", t, t_end, u.copy(), v.copy()))
                break
            i = int(hit[0])
            tau_c = (
                scipy.optimize.brentq(
                    lambda s, f=end_disp: float(self.height + f(np.array([s]))[0]),
                    taus[i],
                    taus[i + 1],
                    xtol=1e-13,
                )
                if gap[i] > 0.0
                else taus[i]
            )
            self.phases.append(("flight", t, t + tau_c, u.copy(), v.copy()))
            u, v = fstate(tau_c)
            t += tau_c
            reaction, cstate = self._contact(u, v)
            # Release at the first sign change of the reaction to tension, searched after
            # 1 % of a wave round trip (the σ-smoothed series is unreliable right at τ = 0).
            taus = np.linspace(0.01 * T, min(2.5 * T, t_end - t), 4001)
            R = reaction(taus)
            neg = np.flatnonzero(R < 0.0)
            if neg.size == 0:
                tau_r = float(taus[-1])
            else:
                j = int(neg[0])
                tau_r = scipy.optimize.brentq(
                    lambda s, f=reaction: float(f(np.array([s]))[0]),
                    taus[j - 1],
                    taus[j],
                    xtol=1e-12,
                )
            self.phases.append(("contact", t, t + tau_r, u.copy(), v.copy()))
            u, v = cstate(tau_r)
            t += tau_r
        return self

    def contact_intervals(self) -> list[tuple[float, float]]:
        return [(a, b) for kind, a, b, _, _ in self.phases if kind == "contact"]

    def contact_end_height(self, t: FloatArray) -> FloatArray:
        """Height of the contact end above the ground (the gap), at times ``t``."""
        t = np.asarray(t, dtype=np.float64)
        out = np.zeros_like(t)
        for kind, a, b, u, v in self.phases:
            sel = (t >= a) & (t <= b)
            if not np.any(sel) or kind == "contact":
                continue
            end_disp, _ = self._flight(u, v)
            out[sel] = self.height + end_disp(t[sel] - a)
        return out
