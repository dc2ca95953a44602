"""The response-spectrum estimate of a scenario's seismic loads on the closed structure: the
supports' and the wheels' forces (and a beam support's moments), static (gravity) plus the
modes' combined peaks (:mod:`crane_fem.modes.spectral` gives the formulas)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from crane_fem.modes.eigen import ModalBasis, rigid_inertia
from crane_fem.modes.forces import ForceRecovery, Forces, StiffnessSolver
from crane_fem.modes.operators import ClosedStructure
from crane_fem.modes.spectral import (
    combine_cqc,
    combine_srss,
    cqc_correlation,
    spectral_accelerations,
)
from crane_fem.scenario import Scenario

__all__ = [
    "Envelope",
    "SpectralEstimate",
    "combine_estimate",
    "ground_history",
    "spectral_estimate",
]

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class Envelope:
    """One value per force (global): ``support`` (faces, 3) N, ``wheel`` (wheels,) N,
    ``moment`` (faces, 3) N·m about each face's centre, or (faces, 0) without rotational
    DOFs (:class:`~crane_fem.modes.forces.Forces`)."""

    support: FloatArray
    wheel: FloatArray
    moment: FloatArray


@dataclass(frozen=True, eq=False)
class SpectralEstimate:
    """The response-spectrum estimate (global values, identical on every rank).

    Attributes:
        window: the record's window [0, window] s whose spectra are used (the run's).
        damping: ζ_i of each mode.
        sa: (n, 3) pseudo-accelerations Sa(T_i, ζ_i) of the ground's x, y, z components,
            m/s².
        zpa: (3,) peak ground acceleration of each component, m/s².
        static: the gravity forces (with the contacts closed).
        srss, cqc: the modes' peaks combined by SRSS and by CQC over the modes, then by SRSS
            over the directions.
        residual: the missing-mass (rigid) response of the modes left out, SRSS over the
            directions.
        support_centres: (faces, 3) centre of each clamped face, m.
    """

    window: float
    damping: FloatArray
    sa: FloatArray
    zpa: FloatArray
    static: Envelope
    srss: Envelope
    cqc: Envelope
    residual: Envelope
    support_centres: FloatArray

    def dynamic(self, method: str = "cqc") -> Envelope:
        """The seismic part: the modal combination (``"cqc"`` or ``"srss"``) and the
        residual, by SRSS."""
        modal = self.cqc if method == "cqc" else self.srss
        return Envelope(
            np.hypot(modal.support, self.residual.support),
            np.hypot(modal.wheel, self.residual.wheel),
            np.hypot(modal.moment, self.residual.moment),
        )

    def peak(self, method: str = "cqc") -> Envelope:
        """Static plus seismic, each component |static| + dynamic (N): the estimate of the
        largest force a time history would reach."""
        dyn = self.dynamic(method)
        return Envelope(
            np.abs(self.static.support) + dyn.support,
            self.static.wheel + dyn.wheel,
            np.abs(self.static.moment) + dyn.moment,
        )


def ground_history(sc: Scenario, end: float) -> tuple[FloatArray, FloatArray]:
    """(t, a) the ground acceleration vector a (3, len t), m/s², as the run applies it over
    [0, end], sampled at the finest step of the records (not collective).

    Raises:
        ScenarioError: a record cannot be read or is shorter than ``end``.
    """
    from crane_fem.pipeline.loads import ground_motion

    parts = []
    for gm in sc.loading.ground_motions:
        d = np.asarray(gm.direction, dtype=np.float64)
        parts.append((ground_motion(gm, end), d / np.linalg.norm(d)))
    if not parts:
        return np.zeros(0), np.zeros((3, 0))
    h = min(float(np.min(np.diff(p.record.t))) for p, _ in parts)
    steps = max(2, math.ceil(end / h - 1e-9))
    t = np.linspace(0.0, end, steps + 1)
    a = np.zeros((3, t.size))
    for history, d in parts:
        a += d[:, None] * history.at(t)[None, :]
    return t, a


def _combine(modal: Forces, factor: FloatArray, rho: FloatArray, method: str) -> Envelope:
    """The modal forces scaled by ``factor`` (n, 3) per direction, combined over the modes
    by ``method`` and over the directions by SRSS."""
    parts = (modal.support, modal.wheel, modal.moment)
    sums = [np.zeros(x.shape[1:]) for x in parts]
    for d in range(3):
        if not np.any(factor[:, d]):
            continue
        for total, x in zip(sums, parts, strict=True):
            xd = x * factor[:, d].reshape((-1,) + (1,) * (x.ndim - 1))
            c = combine_cqc(xd, rho) if method == "cqc" else combine_srss(xd)
            total += c**2
    return Envelope(*(np.sqrt(x) for x in sums))


def spectral_estimate(
    st: ClosedStructure,
    basis: ModalBasis,
    sc: Scenario,
    damping: FloatArray,
    window: float,
) -> SpectralEstimate:
    """The response-spectrum estimate of the scenario's ground motion over [0, ``window``]
    (collective over ``st.comm``: static and missing-mass solves, force recovery).

    Args:
        st: the closed structure (its operators).
        basis: its lowest modes.
        sc: the scenario (its ground motions and gravity).
        damping: ζ_i of each mode.
        window: the end of the record's window, s.
    """
    t, ground = ground_history(sc, window)
    zpa = np.max(np.abs(ground), axis=1) if t.size else np.zeros(3)
    recovery = ForceRecovery(st)
    solver = StiffnessSolver(st)
    try:
        modal = recovery(basis.shapes)
        static = recovery(solver.solve(st.gravity_load), body=st.gravity_clamped)
        # Missing mass: the rigid response of what the modes leave out, per unit ZPA.
        mr = rigid_inertia(st)
        residual: list[Forces | None] = []
        for d in range(3):
            if zpa[d] == 0.0:
                residual.append(None)
                continue
            u = solver.solve(mr[d]) - (basis.gamma[:, d] / basis.omega**2) @ basis.shapes
            residual.append(recovery(zpa[d] * u))
        centres = recovery.centres
    finally:
        solver.destroy()
        recovery.destroy()
    return combine_estimate(t, ground, basis, damping, window, modal, static, residual, centres)


def combine_estimate(
    t: FloatArray,
    ground: FloatArray,
    basis: ModalBasis,
    damping: FloatArray,
    window: float,
    modal: Forces,
    static: Forces,
    residual: list[Forces | None],
    centres: FloatArray,
) -> SpectralEstimate:
    """The estimate from the forces of a structure's modes (``modal``: one row per mode), of
    gravity (``static``) and of the missing mass per ground direction (``residual[d]``, at
    its ZPA; None where that component is zero), the ground history (t, a) of
    :func:`ground_history` (not collective)."""
    omega = basis.omega
    sa = spectral_accelerations(t, ground, omega, damping)
    zpa = np.max(np.abs(ground), axis=1) if t.size else np.zeros(3)
    res_s = np.zeros(static.support.shape[1:])
    res_w = np.zeros(static.wheel.shape[1:])
    res_m = np.zeros(static.moment.shape[1:])
    for f in residual:
        if f is not None:
            res_s += f.support[0] ** 2
            res_w += f.wheel[0] ** 2
            res_m += f.moment[0] ** 2
    factor = basis.gamma * sa / (omega**2)[:, None]
    rho = cqc_correlation(omega, damping)
    srss = _combine(modal, factor, rho, "srss")
    cqc = _combine(modal, factor, rho, "cqc")
    return SpectralEstimate(
        window=float(window),
        damping=np.asarray(damping, dtype=np.float64),
        sa=sa,
        zpa=zpa,
        static=Envelope(static.support[0], static.wheel[0], static.moment[0]),
        srss=srss,
        cqc=cqc,
        residual=Envelope(np.sqrt(res_s), np.sqrt(res_w), np.sqrt(res_m)),
        support_centres=centres,
    )
