"""Response spectra (crane_fem.spectra) against closed-form SDOF responses; CSV and PNG output.

Every rank runs every test on its own data (nothing collective; files in the per-rank tmp_path).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest
import scipy.optimize

from crane_fem.spectra import (
    Spectrum,
    log_periods,
    oscillator_response,
    plot_spectra,
    read_spectra_csv,
    response_spectrum,
    write_spectra_csv,
)

pytestmark = pytest.mark.no_kernels

FloatArray = npt.NDArray[np.float64]
Response = Callable[[FloatArray], FloatArray]


def free_decay(omega: float, zeta: float, u0: float, v0: float) -> Response:
    """u(t) of ü + 2ζωu̇ + ω²u = 0 from u(0) = u0, u̇(0) = v0."""
    wd = omega * math.sqrt(1.0 - zeta**2)
    b = (v0 + zeta * omega * u0) / wd

    def u(t: FloatArray) -> FloatArray:
        return np.exp(-zeta * omega * t) * (u0 * np.cos(wd * t) + b * np.sin(wd * t))

    return u


def harmonic_response(omega: float, zeta: float, amp: float, freq: float) -> Response:
    """Exact u(t) from rest for the base acceleration a = amp sin(freq t): steady state + decay."""
    c = -amp / (omega**2 - freq**2 + 2j * zeta * omega * freq)  # u_p = Im(c e^{i freq t})
    decay = free_decay(omega, zeta, -c.imag, -freq * c.real)

    def u(t: FloatArray) -> FloatArray:
        return c.imag * np.cos(freq * t) + c.real * np.sin(freq * t) + decay(t)

    return u


def ramp_response(omega: float, zeta: float) -> Response:
    """Exact u(t) from rest for the base acceleration a = t (t ≥ 0), zero before."""
    alpha, beta = -1.0 / omega**2, 2.0 * zeta / omega**3  # u_p = α t + β
    decay = free_decay(omega, zeta, -beta, -alpha)

    def u(t: FloatArray) -> FloatArray:
        tp = np.maximum(t, 0.0)
        return np.where(t > 0.0, alpha * tp + beta + decay(tp), 0.0)

    return u


def exact_peak(u: Response, t_end: float, grid_step: float) -> float:
    """max |u| over [0, t_end]: dense grid, then the 10 largest local maxima refined (Brent)."""
    n = math.ceil(t_end / grid_step)
    t = np.linspace(0.0, t_end, n + 1)
    y = np.abs(u(t))
    inner = np.flatnonzero((y[1:-1] >= y[:-2]) & (y[1:-1] >= y[2:])) + 1
    best = float(max(y[0], y[-1]))
    for i in inner[np.argsort(y[inner])[-10:]]:
        res = scipy.optimize.minimize_scalar(
            lambda s: -abs(float(u(np.array([s]))[0])),
            bounds=(t[i - 1], t[i + 1]),
            method="bounded",
            options={"xatol": 1e-13 * t_end},
        )
        best = max(best, float(y[i]), -float(res.fun))
    return best


@pytest.mark.parametrize("zeta", [0.02, 0.05])
def test_harmonic_from_rest_matches_exact_sdof(zeta: float) -> None:
    # Acceptance (issue 17): ≤ 0.5 %. The recursion is exact for the piecewise-linear
    # interpolant of the samples, so the only error against the sine is the interpolation,
    # an amplitude error ≈ (Ωh)²/12 = 8e-5 at Ωh = 2π/200 (plus the round-off of the exact
    # peak search, ~1e-12). The asserted 5e-4 keeps the bound with a 10x margin below
    # it; a spectrum off by one sample's peak (1 − cos(πh/T), 2 % at T = 10h) would fail.
    amp, freq, h, t_end = 2.0, 2.0 * math.pi, 0.005, 10.0
    t = np.arange(0.0, t_end + h / 2, h)
    periods = np.array([0.003, 0.02, 0.1, 0.5, 0.9, 0.97, 1.0, 1.03, 1.2, 3.0])
    spec = response_spectrum(t, amp * np.sin(freq * t), periods, damping=zeta)
    exact = np.array(
        [
            (2 * math.pi / T) ** 2
            * exact_peak(harmonic_response(2 * math.pi / T, zeta, amp, freq), t[-1], T / 40)
            for T in periods
        ]
    )
    err = np.abs(spec.psa / exact - 1.0)
    assert err.max() < 5e-4, dict(zip(periods, err, strict=True))
    # resonance: from rest, the amplitude grows as (1 − e^{−ζωt})/(2ζ) towards steady state
    growth = (1.0 - math.exp(-zeta * freq * t_end)) / (2 * zeta)
    assert spec.psa[periods == 1.0][0] > 0.95 * amp * growth
    omega = 2 * math.pi / periods
    np.testing.assert_allclose(spec.psv, omega * spec.sd, rtol=1e-15)
    np.testing.assert_allclose(spec.psa, omega * spec.psv, rtol=1e-15)


@pytest.mark.parametrize("zeta", [0.0, 0.05, 0.3])
def test_step_input_peak_between_samples(zeta: float) -> None:
    # a = A from t0 on: Sd = A/ω² (1 + exp(−πζ/√(1−ζ²))), at t = π/ω_d. The steps are up to
    # 3x the period, so the samples' peak alone is far off: exactness to 1e-10 needs both the
    # substeps and the Newton search between samples.
    amp, h = 1.5, 0.01
    t = np.arange(0.0, 3.0 + h / 2, h)
    periods = np.array([0.0031, 0.0137, 0.05, 0.0777, 0.5, 1.3])
    spec = response_spectrum(t, np.full_like(t, amp), periods, damping=zeta)
    exact = amp * (1.0 + math.exp(-math.pi * zeta / math.sqrt(1.0 - zeta**2)))
    np.testing.assert_allclose(spec.psa, exact, rtol=1e-10)


def test_piecewise_linear_history_is_exact() -> None:
    # a(t) = a0 + Σ c_j (t − t_j)+ with kinks on samples: a step at t0 and a trapezoid of ramps.
    # The recursion is exact for such input, so u, u̇ and the peak agree with the closed form
    # to round-off (asserted 1e-10 of the peak).
    omega, zeta, h = 2 * math.pi / 0.37, 0.05, 0.004
    t = np.arange(0.0, 4.0 + h / 2, h)
    a0, kinks = 0.7, [(0.2, 10.0), (0.4, -10.0), (1.0, -8.0), (1.5, 8.0)]
    accel = a0 + sum(c * np.maximum(t - tj, 0.0) for tj, c in kinks)
    step = free_decay(omega, zeta, a0 / omega**2, 0.0)
    ramp = ramp_response(omega, zeta)

    def u(s: FloatArray) -> FloatArray:
        return -a0 / omega**2 + step(s) + sum(c * ramp(s - tj) for tj, c in kinks)

    resp = oscillator_response(t, accel, 2 * math.pi / omega, zeta)
    peak = exact_peak(u, t[-1], 1e-3)
    np.testing.assert_allclose(resp.u, u(t), rtol=0, atol=1e-10 * peak)
    v_fd = (u(t + 1e-6) - u(t - 1e-6)) / 2e-6  # central difference: error ~1e-12·ω³ u
    np.testing.assert_allclose(resp.v[1:], v_fd[1:], rtol=0, atol=1e-6 * omega * peak)
    spec = response_spectrum(t, accel, [2 * math.pi / omega], damping=zeta)
    assert spec.sd[0] == pytest.approx(peak, rel=1e-10)


def test_rigid_limit_is_pga() -> None:
    # Content ≤ 5 Hz, oscillators at 100-500 Hz: u ≈ −a/ω², so PSA → PGA (dynamic
    # amplification 1/(1 − (f/f_n)²) ≤ 1.0025 at f_n = 100 Hz). The record starts at a = 0:
    # a non-zero a(t0) would act as a step at t0 and double the response.
    h = 0.002
    t = np.arange(0.0, 10.0 + h / 2, h)
    accel = (
        1.2 * np.sin(2 * np.pi * 0.5 * t)
        + 0.8 * np.sin(2 * np.pi * 2.0 * t) ** 2
        - 0.5 * np.sin(2 * np.pi * 5.0 * t)
    )
    spec = response_spectrum(t, accel, [0.002, 0.005, 0.01])
    np.testing.assert_allclose(spec.psa, np.abs(accel).max(), rtol=1e-2)


def test_bad_input_is_refused() -> None:
    t = np.linspace(0.0, 1.0, 101)
    a = np.sin(t)
    bent = t.copy()
    bent[50] += 1e-4
    with pytest.raises(ValueError, match="uniformly sampled"):
        response_spectrum(bent, a, [0.1])
    with pytest.raises(ValueError, match="uniformly sampled"):
        response_spectrum(t[::-1], a, [0.1])
    nan = a.copy()
    nan[7] = np.nan
    with pytest.raises(ValueError, match=r"accel has non-finite values \(first at index 7\)"):
        response_spectrum(t, nan, [0.1])
    with pytest.raises(ValueError, match="t has non-finite"):
        response_spectrum(np.where(t > 0.5, np.inf, t), a, [0.1])
    with pytest.raises(ValueError, match="same length"):
        response_spectrum(t, a[:-1], [0.1])
    with pytest.raises(ValueError, match="periods must be finite and > 0"):
        response_spectrum(t, a, [0.1, 0.0])
    with pytest.raises(ValueError, match="damping"):
        response_spectrum(t, a, [0.1], damping=1.0)
    with pytest.raises(ValueError, match="t_min < t_max"):
        log_periods(2.0, 0.01, 10)


def test_csv_round_trip_and_png(tmp_path: Path) -> None:
    h = 0.01
    t = np.arange(0.0, 5.0 + h / 2, h)
    periods = log_periods(0.01, 2.0, 30)
    assert periods[0] == pytest.approx(0.01) and periods[-1] == pytest.approx(2.0)
    assert periods.size == 30 and np.all(np.diff(np.log(periods)) > 0)
    spectra: dict[str, Spectrum] = {
        "ground": response_spectrum(t, np.sin(2 * np.pi * t), periods),
        "trolley": response_spectrum(t, 2.0 * np.sin(6 * np.pi * t), periods),
    }
    path = write_spectra_csv(tmp_path / "spectra.csv", spectra)
    assert path.read_text().splitlines()[0] == "period_s,psa_ground,psa_trolley"
    p, psa = read_spectra_csv(path)
    assert np.array_equal(p, periods)
    assert list(psa) == ["ground", "trolley"]
    for name, spec in spectra.items():
        assert np.array_equal(psa[name], spec.psa)

    other = response_spectrum(t, np.sin(t), periods[:-1])
    with pytest.raises(ValueError, match="other periods"):
        write_spectra_csv(tmp_path / "bad.csv", {"ground": spectra["ground"], "x": other})

    png = plot_spectra(tmp_path / "spectra.png", p, psa, damping=0.05, title="ground and trolley")
    data = png.read_bytes()
    assert len(data) > 1000 and data.startswith(b"\x89PNG")
