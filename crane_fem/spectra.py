"""Pseudo-acceleration response spectra of an acceleration history (ground or floor motion).

A linear oscillator of period ``T`` and damping ratio ``ζ`` on a base moving with the
absolute acceleration ``a(t)`` has the relative displacement ``u``:

    ü + 2ζω u̇ + ω² u = −a(t),    u(t0) = u̇(t0) = 0,    ω = 2π/T.

Its spectral displacement is ``Sd = max_t |u|`` over the record, the pseudo-velocity
``PSV = ω Sd`` and the pseudo-acceleration ``PSA = ω² Sd``. The same function gives the
spectrum of the ground motion and the floor (in-structure) spectrum of the absolute
acceleration at a point of the structure: only the input history differs.

Method: the excitation is the piecewise-linear interpolant of the samples, and the response to
it is computed exactly (Nigam & Jennings 1968), in modal form: with ``λ = ω(−ζ + i√(1−ζ²))``
and ``u = 2 Re q``, ``u̇ = 2 Re(λ q)``, the complex mode ``q̇ = λ q − a/(λ − λ̄)`` advances over
a step ``h`` with ``a`` linear from ``a_k`` to ``a_{k+1}`` as

    q_{k+1} = e^{λh} q_k − κ h [(φ1 − φ2)(λh) a_k + φ2(λh) a_{k+1}],    κ = 1/(λ − λ̄),

with ``φ1(z) = (e^z − 1)/z`` and ``φ2(z) = (e^z − 1 − z)/z²`` (Taylor series for small ``|z|``).
This first-order recursion runs in ``scipy.signal.lfilter`` (one call per period, no Python
loop over time steps, memory O(number of samples)). The classical real 2×2 form of the
Nigam–Jennings matrices subtracts terms of size ``1/(ω³h)`` to form results of size ``h²``: its
coefficients lose about ``3 log10(1/(ωh))`` digits (a 30 % error in one at T = 10 s,
h = 1e-5 s), errors that largely cancel in the spectrum of a smooth record (measured 7.5e-7
there); the φ-function form has no such cancellation.

The peak is the peak of the continuous response, not of its samples: where ``u̇`` changes sign
within a step, the extremum is located by Newton's method on the exact intra-step solution.
Periods shorter than ``SUBSTEPS_PER_PERIOD`` steps are computed on the input subdivided
(linear interpolation leaves the piecewise-linear excitation unchanged), so that a step spans
at most 1/20 of the period and holds one extremum at most, but for near-flat stretches of ``u``
that cannot hold the peak. The spectrum is therefore exact, to round-off, for the piecewise-linear
excitation; its only error against a smooth motion is the interpolation of that motion
between samples (relative ``(Ωh)²/12`` at frequency Ω), however short the period.

Library decision (issue 17): the PyPI candidates were checked first. ``pyrotd`` 0.6.1 (2023,
MIT) works in the frequency domain (FFT of the record, periodic extension, an approximation,
not the piecewise-exact recursion) and fails to import on this stack (``pkg_resources``).
``eqsig`` 1.2.17 (2024-09, MIT, numpy ≥ 1.16, scipy) imports with numpy 2.5 and implements
Nigam–Jennings, but in the real form above, with a Python loop over time steps that stores
the full (periods × samples) histories (1.6 s for 5 periods × 2·10⁵ samples; gigabytes for a
solver history of 10⁶ steps), 2π truncated to 6.2831853, the samples' peak only, and the PSA
replaced by the PGA for every ``T < 6 h`` (46 % low for a step input at T = 2h). None fits,
so the recursion is written here (about sixty lines, verified in ``tests/test_spectra.py``
against closed-form SDOF responses).

All functions are plain NumPy and not collective: compute on any rank, write files on one.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt
import scipy.signal

__all__ = [
    "SUBSTEPS_PER_PERIOD",
    "G",
    "OscillatorResponse",
    "Spectrum",
    "log_periods",
    "oscillator_response",
    "plot_spectra",
    "read_spectra_csv",
    "response_spectrum",
    "write_spectra_csv",
]

FloatArray = npt.NDArray[np.float64]
ComplexArray = npt.NDArray[np.complex128]

G = 9.80665  # m/s²: standard gravity, the plots' unit of acceleration
SUBSTEPS_PER_PERIOD = 20  # a period spans at least this many (sub)steps of the recursion
UNIFORM_RTOL = 1e-6  # time steps may differ from the mean step by this fraction
_NEWTON_ITERATIONS = 6  # quadratic convergence from the linear estimate of u̇'s zero
_SERIES_RADIUS = 0.5  # |z| below which φ1, φ2 are summed as Taylor series
_SERIES_TERMS = 20  # 0.5**20 / 20! ≈ 4e-25: the truncated tail is far below round-off


@dataclass(frozen=True, eq=False)
class Spectrum:
    """Response spectrum of one acceleration history (arrays read-only, one value per period).

    Attributes:
        periods: oscillator periods T (s), increasing or not, all > 0.
        psa: pseudo-acceleration ω² Sd (m/s²).
        sd: spectral displacement, the peak |relative displacement| (m).
        psv: pseudo-velocity ω Sd (m/s).
        damping: the oscillators' damping ratio ζ.
    """

    periods: FloatArray
    psa: FloatArray
    sd: FloatArray
    psv: FloatArray
    damping: float


@dataclass(frozen=True, eq=False)
class OscillatorResponse:
    """Relative response of one oscillator at the input's sample times.

    Attributes:
        u: relative displacement (m).
        v: relative velocity (m/s).
    """

    u: FloatArray
    v: FloatArray


@dataclass(frozen=True)
class _Oscillator:
    """Modal constants of ü + 2ζωu̇ + ω²u = −a."""

    omega: float
    zeta: float

    @property
    def lam(self) -> complex:
        return self.omega * complex(-self.zeta, math.sqrt(1.0 - self.zeta**2))

    @property
    def kappa(self) -> complex:
        return 1.0 / (2j * self.lam.imag)  # 1/(λ − λ̄)


def _phi12(z: npt.ArrayLike) -> tuple[ComplexArray, ComplexArray]:
    """φ1(z) = (e^z − 1)/z and φ2(z) = (e^z − 1 − z)/z², elementwise, without cancellation."""
    zc = np.asarray(z, dtype=np.complex128)
    phi1 = np.empty_like(zc)
    phi2 = np.empty_like(zc)
    small = np.abs(zc) < _SERIES_RADIUS
    zs = zc[small]
    # φ_p(z) = Σ_k z^k / (k + p)!, summed by Horner from the last term
    s1 = np.zeros_like(zs)
    s2 = np.zeros_like(zs)
    for k in range(_SERIES_TERMS, -1, -1):
        s1 = s1 * zs + 1.0 / math.factorial(k + 1)
        s2 = s2 * zs + 1.0 / math.factorial(k + 2)
    phi1[small] = s1
    phi2[small] = s2
    zl = zc[~small]
    ez = np.exp(zl)
    phi1[~small] = (ez - 1.0) / zl
    phi2[~small] = (ez - 1.0 - zl) / zl**2
    return phi1, phi2


def _step_to(
    osc: _Oscillator, q0: ComplexArray, a0: FloatArray, a1: FloatArray, s: FloatArray
) -> ComplexArray:
    """The mode after a time ``s`` from ``q0``, the acceleration linear from ``a0`` to ``a1``."""
    z = osc.lam * s
    phi1, phi2 = _phi12(z)
    return np.exp(z) * q0 - osc.kappa * s * ((phi1 - phi2) * a0 + phi2 * a1)


def _mode_history(osc: _Oscillator, h: float, accel: FloatArray) -> ComplexArray:
    """The mode q at every sample, from rest at the first one (exact recursion, lfilter)."""
    z = np.array([osc.lam * h])
    phi1, phi2 = _phi12(z)
    b0 = -osc.kappa * h * phi2[0]
    b1 = -osc.kappa * h * (phi1[0] - phi2[0])
    # q_k = e^{λh} q_{k−1} + b0 a_k + b1 a_{k−1}; the initial filter state −b0 a_0 makes
    # q_0 = 0 (at rest) with a(t0) = a_0, rather than a ramp from 0 before t0.
    zi = np.array([-b0 * accel[0]])
    q, _ = scipy.signal.lfilter([b0, b1], [1.0, -np.exp(z[0])], accel.astype(complex), zi=zi)
    return np.asarray(q, dtype=np.complex128)


def _subdivide(accel: FloatArray, r: int) -> FloatArray:
    """The piecewise-linear interpolant of ``accel`` at ``r`` points per step (same function)."""
    if r == 1:
        return accel
    w = np.arange(r) / r
    inner = accel[:-1, None] * (1.0 - w) + accel[1:, None] * w
    return np.append(inner.ravel(), accel[-1])


def _peak_displacement(osc: _Oscillator, h: float, accel: FloatArray) -> float:
    """max_t |u(t)| of the continuous response to the piecewise-linear ``accel``."""
    r = max(1, math.ceil(SUBSTEPS_PER_PERIOD * h * osc.omega / (2.0 * math.pi)))
    a = _subdivide(accel, r)
    hs = h / r
    q = _mode_history(osc, hs, a)
    u = 2.0 * q.real
    v = 2.0 * (osc.lam * q).real
    peak = float(np.max(np.abs(u)))
    # An interior extremum of u lies in each step where u̇ changes sign; Newton on u̇(s) = 0
    # from the linear estimate. Every evaluated u(s) is an exact value of the response inside
    # the step, so the refined peak can only approach the true maximum from below.
    k = np.flatnonzero(v[:-1] * v[1:] < 0.0)
    if k.size == 0:
        return peak
    q0, a0, da = q[k], a[k], (a[k + 1] - a[k]) / hs
    s = hs * v[k] / (v[k] - v[k + 1])
    for _ in range(_NEWTON_ITERATIONS):
        qs = _step_to(osc, q0, a0, a0 + da * s, s)
        us = 2.0 * qs.real
        vs = 2.0 * (osc.lam * qs).real
        peak = max(peak, float(np.max(np.abs(us))))
        acc = -(a0 + da * s) - 2.0 * osc.zeta * osc.omega * vs - osc.omega**2 * us
        with np.errstate(divide="ignore", invalid="ignore"):
            s = np.clip(s - np.where(acc != 0.0, vs / acc, 0.0), 0.0, hs)
    qs = _step_to(osc, q0, a0, a0 + da * s, s)
    return max(peak, float(np.max(np.abs(2.0 * qs.real))))


def _check_history(t: npt.ArrayLike, accel: npt.ArrayLike) -> tuple[float, FloatArray]:
    """The time step of a uniform sampling and the acceleration as float64 (ValueError if not)."""
    t = np.asarray(t, dtype=np.float64)
    a = np.asarray(accel, dtype=np.float64)
    if t.ndim != 1 or a.ndim != 1 or t.size != a.size:
        raise ValueError(
            f"t and accel must be 1-D arrays of the same length (got shapes {t.shape}, {a.shape})"
        )
    if t.size < 2:
        raise ValueError(f"an acceleration history needs at least 2 samples (got {t.size})")
    if not np.all(np.isfinite(t)):
        raise ValueError(f"t has non-finite values (first at index {np.argmin(np.isfinite(t))})")
    if not np.all(np.isfinite(a)):
        raise ValueError(
            f"accel has non-finite values (first at index {np.argmin(np.isfinite(a))})"
        )
    h = (t[-1] - t[0]) / (t.size - 1)
    dev = np.abs(np.diff(t) - h)
    if not h > 0.0 or dev.max() > UNIFORM_RTOL * h:
        i = int(np.argmax(dev))
        raise ValueError(
            f"t must be uniformly sampled and increasing to {UNIFORM_RTOL:g} relative: step {i}"
            f" is {t[i + 1] - t[i]!r} s against a mean step of {h!r} s"
        )
    return float(h), a


def _check_damping(damping: float) -> float:
    zeta = float(damping)
    if not 0.0 <= zeta < 1.0:
        raise ValueError(f"damping must be a ratio in [0, 1) (got {damping!r})")
    return zeta


def _check_periods(periods: npt.ArrayLike) -> FloatArray:
    p = np.array(periods, dtype=np.float64, ndmin=1)
    if p.ndim != 1 or p.size == 0:
        raise ValueError(f"periods must be a non-empty 1-D array (got shape {p.shape})")
    if not np.all(np.isfinite(p) & (p > 0.0)):
        raise ValueError(f"periods must be finite and > 0 (got min {np.nanmin(p)!r})")
    return p


def oscillator_response(
    t: npt.ArrayLike, accel: npt.ArrayLike, period: float, damping: float = 0.05
) -> OscillatorResponse:
    """Relative response, at the sample times, of one oscillator to a base acceleration.

    Exact for the piecewise-linear interpolant of ``accel``, starting from rest at ``t[0]``.
    Not collective.

    Args:
        t: sample times (s), uniform to 1e-6 relative.
        accel: absolute base acceleration (m/s²) at ``t``.
        period: the oscillator's period T (s), > 0.
        damping: its damping ratio ζ in [0, 1).

    Returns:
        u (m) and u̇ (m/s) at ``t``.

    Raises:
        ValueError: non-uniform or non-increasing ``t``, non-finite values, bad period or
            damping.
    """
    h, a = _check_history(t, accel)
    period = float(_check_periods(period)[0])
    osc = _Oscillator(2.0 * math.pi / period, _check_damping(damping))
    q = _mode_history(osc, h, a)
    return OscillatorResponse(u=2.0 * q.real, v=2.0 * (osc.lam * q).real)


def response_spectrum(
    t: npt.ArrayLike, accel: npt.ArrayLike, periods: npt.ArrayLike, damping: float = 0.05
) -> Spectrum:
    """Pseudo-acceleration response spectrum of an acceleration history.

    The peaks are those of the continuous responses to the piecewise-linear interpolant of
    ``accel``, from rest at ``t[0]`` to ``t[-1]`` (see the module docstring). A non-zero
    ``accel[0]`` acts as a step applied at ``t[0]`` (records start at 0, or are tapered).
    Append zeros to ``accel`` to include the free vibration after the record. Not collective.

    Args:
        t: sample times (s), uniform to 1e-6 relative.
        accel: absolute acceleration (m/s²) of the ground or of a point of the structure.
        periods: oscillator periods (s), all > 0.
        damping: the oscillators' damping ratio ζ in [0, 1).

    Returns:
        The spectrum at ``periods``.

    Raises:
        ValueError: non-uniform or non-increasing ``t``, non-finite values, periods ≤ 0,
            damping outside [0, 1).
    """
    h, a = _check_history(t, accel)
    p = _check_periods(periods)
    zeta = _check_damping(damping)
    omega = 2.0 * np.pi / p
    sd = np.array([_peak_displacement(_Oscillator(float(w), zeta), h, a) for w in omega])
    arrays = {"periods": p, "sd": sd, "psv": omega * sd, "psa": omega**2 * sd}
    for arr in arrays.values():
        arr.setflags(write=False)
    return Spectrum(damping=zeta, **arrays)


def log_periods(t_min: float, t_max: float, count: int) -> FloatArray:
    """``count`` periods (s) log-spaced from ``t_min`` to ``t_max`` inclusive."""
    if not 0.0 < t_min < t_max or not math.isfinite(t_max):
        raise ValueError(f"need 0 < t_min < t_max (got {t_min!r}, {t_max!r})")
    if count < 2:
        raise ValueError(f"count must be at least 2 (got {count!r})")
    return np.geomspace(t_min, t_max, int(count))


def write_spectra_csv(path: str | Path, spectra: Mapping[str, Spectrum]) -> Path:
    """Write named spectra side by side: ``period_s``, then one ``psa_<name>`` column (m/s²) each.

    Values are written with 17 significant digits (exact round trip). Not collective: call it
    on one rank.

    Args:
        path: the CSV file.
        spectra: name -> spectrum; all at the same periods and damping. Names must not contain
            commas, quotes or line breaks.

    Returns:
        ``path``.

    Raises:
        ValueError: no spectra, a bad name, different periods or damping.
    """
    if not spectra:
        raise ValueError("no spectra to write")
    first = next(iter(spectra.values()))
    for name, spec in spectra.items():
        if not name or any(c in name for c in ',"\n\r'):
            raise ValueError(f'spectrum name {name!r} must be non-empty, without , " or newlines')
        if not np.array_equal(spec.periods, first.periods):
            raise ValueError(f"spectrum {name!r} has other periods than the first one")
        if spec.damping != first.damping:
            raise ValueError(f"spectrum {name!r} has damping {spec.damping}, not {first.damping}")
    header = ",".join(["period_s", *(f"psa_{name}" for name in spectra)])
    table = np.column_stack([first.periods, *(s.psa for s in spectra.values())])
    path = Path(path)
    np.savetxt(
        path, table, fmt="%.17g", delimiter=",", header=header, comments="", encoding="utf-8"
    )
    return path


def read_spectra_csv(path: str | Path) -> tuple[FloatArray, dict[str, FloatArray]]:
    """Read a file of :func:`write_spectra_csv`: the periods (s) and name -> PSA (m/s²)."""
    path = Path(path)
    with path.open(encoding="utf-8") as f:
        header = f.readline().strip().split(",")
    if header[0] != "period_s" or not all(c.startswith("psa_") for c in header[1:]):
        raise ValueError(f"{path}: header must be period_s,psa_<name>,... (got {header})")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2, encoding="utf-8")
    if data.shape[1] != len(header):
        raise ValueError(f"{path}: {data.shape[1]} columns for a header of {len(header)}")
    return data[:, 0], {c.removeprefix("psa_"): data[:, i + 1] for i, c in enumerate(header[1:])}


def plot_spectra(
    path_png: str | Path,
    periods: npt.ArrayLike,
    curves: Mapping[str, npt.ArrayLike],
    damping: float,
    title: str,
) -> Path:
    """Plot PSA curves (given in m/s², drawn in g) against the period on a log axis, as a PNG.

    Uses matplotlib's Agg canvas directly (no pyplot state, no display). Not collective.

    Args:
        path_png: the image file.
        periods: periods (s), shared by the curves.
        curves: legend label -> PSA (m/s²) at ``periods``.
        damping: the damping ratio, shown in the title.
        title: the figure's title.

    Returns:
        ``path_png``.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    p = np.asarray(periods, dtype=np.float64)
    fig = Figure(figsize=(8.0, 5.0), dpi=120)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    for label, psa in curves.items():
        y = np.asarray(psa, dtype=np.float64)
        if y.shape != p.shape:
            raise ValueError(f"curve {label!r} has shape {y.shape}, the periods {p.shape}")
        ax.plot(p, y / G, lw=1.6, label=label)
    ax.set_xscale("log")
    ax.set_xlabel("period T (s)", fontsize=12)
    ax.set_ylabel("pseudo-acceleration PSA (g)", fontsize=12)
    ax.set_title(f"{title} (damping {100 * damping:g} %)", fontsize=13)
    ax.tick_params(labelsize=11)
    ax.grid(True, which="both", alpha=0.35)
    if curves:
        ax.legend(fontsize=11)
    fig.tight_layout()
    path = Path(path_png)
    fig.savefig(path)
    return path
