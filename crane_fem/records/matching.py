"""Spectral matching of seed records to a target spectrum, with reqpy-m, and the band check.

The matcher is reqpy-m's ``generate_single_component_compatible_record`` (Montejo & Suarez
2013: the seed is split by a continuous wavelet transform into detail functions, one per
scale, each scaled iteratively by the ratio of the target to the current spectrum at its
period; a 6th-order polynomial baseline correction follows). It is used as follows:

- **Time step.** The seed is resampled, by linear interpolation (the same piecewise-linear
  motion the scenes read), to ``dt = min(its step, T_min/STEPS_PER_T_MIN)``: the wavelet
  scales reach the Nyquist period 2 dt only, and the band starts at T_min. A finer step
  (T_min/4) costs 4× (reqpy's FFTs pad by 10 × its longest period, 10 s, over dt).
- **Sampling correction.** reqpy's spectrum (FFT) reads the samples as a band-limited signal;
  the scenes, and our spectrum, as a piecewise-linear one, which holds less of the content
  near the Nyquist frequency: ours is 5–10 % below reqpy's at 0.01–0.02 s for dt = 5 ms
  (measured on matched records). From its second pass on, a record is matched to the aim ×
  reqpy's spectrum of it / ours (clipped to [0.8, 1.5]), so that ours reaches the aim.
- **Matching range.** The band widened by ``WIDEN`` on each side (within the target's periods
  and the Nyquist period): a range's ends are matched less well than its inside.
- **Aim.** The target × ``AIM`` = 1.08, the band's geometric centre √(0.9 × 1.3): the band is
  asymmetric; aiming there keeps each record's dips above 0.9 and their peaks below 1.3
  (measured peaks 1.15–1.23) and lifts the mean above the target.
- **Passes.** reqpy runs ``ITERATIONS`` iterations, then the record's spectrum is checked (below);
  if it is not within the band by ``MARGIN``, reqpy runs again from the matched record (a new
  wavelet decomposition), up to ``MAX_PASSES`` times; the pass nearest the band is kept. One
  long run would serve too, but reqpy keeps every iteration's details (scales × samples ×
  iterations doubles: 100 × 10⁴ × 31 × 8 B = 250 MB for 30 iterations of a 54 s record);
  passes of 10 keep it to ~90 MB. The bundled El Centro records hold almost nothing above
  15 Hz (Fourier amplitudes 1/1000 of their 0.5–5 Hz ones at 25–50 Hz): the target's
  periods below ~0.05 s (EC8's rise from a_g S towards the plateau) are reached by growing
  that content over several passes.
- **The mean.** Each record stops as soon as it is inside the band, typically with its
  lowest ratio, 0.91–0.95, at the same short periods as the others: their mean is then below
  the target there (0.97 at 0.02 s for the default seeds). Rounds of one more pass for the
  records below the target where the mean is, up to ``MEAN_ROUNDS``, lift it to
  ``1 + MEAN_MARGIN``, each aiming higher where the mean falls short, by the shortfall.

The check, and every ratio reported, is the project's own spectrum
(:func:`crane_fem.spectra.response_spectrum`: exact for the piecewise-linear record, peaks
between samples included), not reqpy's, at ``CHECK_PER_DECADE`` periods per decade of the
band, log-spaced. Not collective.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt

from crane_fem.errors import ScenarioError
from crane_fem.records.seeds import SeedVariant
from crane_fem.records.targets import Ec8Target, Target
from crane_fem.spectra import G, response_spectrum

__all__ = [
    "AIM",
    "CHECK_PER_DECADE",
    "ITERATIONS",
    "MARGIN",
    "MAX_PASSES",
    "MAX_SCALES",
    "MEAN_MARGIN",
    "MEAN_ROUNDS",
    "SCALES",
    "STEPS_PER_T_MIN",
    "WIDEN",
    "Band",
    "MatchResult",
    "MatchedRecord",
    "check_periods",
    "longest_period",
    "match_record",
    "match_records",
    "matching_range",
    "scales",
]

FloatArray = npt.NDArray[np.float64]

AIM = 1.08  # records are matched to AIM × target: the band's geometric centre
STEPS_PER_T_MIN = 2  # the matching step is at most T_MIN / 2 (see the module docstring)
WIDEN = 1.5  # the matching range is the band widened by this factor on each side
SCALES = 100  # reqpy's wavelet scales at 5 % damping, Nyquist to 0.1 Hz (its default 300): 33
# per decade at dt = 5 ms; 60 left ±10 % ripples between scales at 0.3–0.6 s (measured).
# Lower damping narrows the spectrum's peaks (half-power width 2ζ): scales ∝ 1/ζ, ≤ 300.
MAX_SCALES = 300
ITERATIONS = 10  # reqpy iterations per pass
MAX_PASSES = 8  # reqpy passes per record at most
MARGIN = 0.01  # a pass stops within [lower + MARGIN, upper − MARGIN] of the target
MEAN_MARGIN = 0.005  # the records' mean is raised until ≥ (1 + MEAN_MARGIN) × target
MEAN_ROUNDS = 4  # rounds of one more pass for the records below the target where the mean is
#: Check periods per decade: the density of NRC SRP 3.7.1's check of matched records. Between
#: them a record's spectrum has cusps (the peak response jumps from one instant to another):
#: measured 3.7 % below the check points on either side (a record at 0.19 s).
CHECK_PER_DECADE = 100
_TABLE_PER_DECADE = 200  # the target as tabulated for reqpy (it interpolates in lin T–log PSA)


@dataclass(frozen=True)
class Band:
    """The band the codes ask for: each record's spectrum within [lower, upper] × target over
    [t_min, t_max] (s) (ASCE 4, RG 1.208: −10 % / +30 %), and the records' mean ≥ target."""

    t_min: float
    t_max: float
    lower: float = 0.9
    upper: float = 1.3

    def __post_init__(self) -> None:
        if not (0.0 < self.t_min < self.t_max and math.isfinite(self.t_max)):
            raise ScenarioError(
                f"--periods must be 0 < T_MIN < T_MAX (got {self.t_min:g} {self.t_max:g})"
            )


@dataclass(frozen=True, eq=False)
class MatchedRecord:
    """One matched record and its spectrum against the target.

    Attributes:
        variant: its seed.
        t: times (s), uniform from 0.
        a: acceleration (m/s²).
        scale: the linear scaling reqpy applied to the seed before its wavelet iterations
            (all passes' factors multiplied).
        passes: reqpy passes run.
        psa: its PSA (m/s²) at the check periods, at the target's damping.
        ratio: ``psa`` / target there.
        seconds: wall time of its matching.
        matching_range: the periods (s) reqpy matched.
        periods: the check periods (s).
    """

    variant: SeedVariant
    t: FloatArray
    a: FloatArray
    scale: float
    passes: int
    psa: FloatArray
    ratio: FloatArray
    seconds: float
    matching_range: tuple[float, float]
    periods: FloatArray

    @property
    def dt(self) -> float:
        return float(self.t[1] - self.t[0])


@dataclass(frozen=True, eq=False)
class MatchResult:
    """The records matched to a target, and the band check.

    Attributes:
        target: the target spectrum.
        band: the band.
        periods: the check periods (s).
        target_psa: the target there (m/s²).
        records: the matched records.
    """

    target: Target
    band: Band
    periods: FloatArray
    target_psa: FloatArray
    records: list[MatchedRecord]

    @property
    def mean_ratio(self) -> FloatArray:
        """The records' mean PSA over the target, at the check periods."""
        return np.asarray(np.mean([r.psa for r in self.records], axis=0) / self.target_psa)

    def within(self, rec: MatchedRecord) -> bool:
        """Whether ``rec``'s spectrum stays within the band."""
        return bool(rec.ratio.min() >= self.band.lower and rec.ratio.max() <= self.band.upper)

    @property
    def each_within(self) -> bool:
        return all(self.within(r) for r in self.records)

    @property
    def mean_not_below(self) -> bool:
        return bool(self.mean_ratio.min() >= 1.0)

    @property
    def passed(self) -> bool:
        return self.each_within and self.mean_not_below


def check_periods(band: Band) -> FloatArray:
    """The periods (s) at which records are checked: log-spaced over the band, inclusive."""
    count = max(20, math.ceil(CHECK_PER_DECADE * math.log10(band.t_max / band.t_min)) + 1)
    return np.geomspace(band.t_min, band.t_max, count)


def matching_range(target: Target, band: Band, dt: float) -> tuple[float, float]:
    """The periods (s) reqpy matches: the band widened by ``WIDEN``, within the target's
    periods and above the Nyquist period 2 ``dt``.

    Raises:
        ScenarioError: the band is not inside the target's periods.
    """
    lo, hi = target.period_range
    if band.t_min < lo or band.t_max > hi:
        raise ScenarioError(
            f"the band {band.t_min:g}–{band.t_max:g} s is not inside the target's periods "
            f"{lo:g}–{hi:g} s ({target.label}); give --periods within them"
        )
    return max(band.t_min / WIDEN, lo, 2.0 * dt), min(band.t_max * WIDEN, hi)


def longest_period(target: Target, band: Band) -> float:
    """The target's longest period (s): a table's last row; a code spectrum's longest period
    as tabulated for the matcher (the matching range's end)."""
    if isinstance(target, Ec8Target):
        return min(band.t_max * WIDEN, target.period_range[1])
    return target.period_range[1]


def _violation(ratio: FloatArray, band: Band) -> float:
    """How far ``ratio`` leaves the band narrowed by ``MARGIN`` (0 inside)."""
    low = band.lower + MARGIN - float(ratio.min())
    return max(0.0, low, float(ratio.max()) - band.upper + MARGIN)


def scales(damping: float) -> int:
    """reqpy's wavelet scales at ``damping``: ``SCALES`` at 5 %, ∝ 1/ζ below, ≤ ``MAX_SCALES``."""
    if damping >= 0.05:
        return SCALES
    return min(MAX_SCALES, math.ceil(SCALES * 0.05 / max(damping, 1e-3)))


def _reqpy_pass(
    t: FloatArray,
    a: FloatArray,
    target: Target,
    band: Band,
    boost: FloatArray | None = None,
) -> tuple[FloatArray, FloatArray, float, tuple[float, float]]:
    """One reqpy run of ``ITERATIONS`` on the record (t s, uniform; a m/s²) against
    ``AIM`` × target (× ``boost``, given at the check periods, if any): the matched record's
    t and a, reqpy's scale factor, the range matched."""
    import reqpy_M

    dt = float(t[1] - t[0])
    t1, t2 = matching_range(target, band, dt)
    count = max(20, math.ceil(_TABLE_PER_DECADE * math.log10(t2 / t1)) + 1)
    table_t = np.geomspace(t1, t2, count)
    aimed_g = AIM * target.psa(table_t) / G  # reqpy works in g
    if boost is not None:
        lp = np.log(check_periods(band))
        aimed_g *= np.interp(np.log(table_t), lp, boost)  # its end values beyond the band
    with warnings.catch_warnings():
        # reqpy warns when it clamps the matching range: ours is inside its limits.
        warnings.filterwarnings("ignore", module="reqpy_M")
        res = reqpy_M.generate_single_component_compatible_record(
            a / G,
            1.0 / dt,
            table_t,
            aimed_g,
            T1PSA=t1,
            T2PSA=t2,
            zi=target.damping,
            NS=scales(target.damping),
            nit=ITERATIONS,
        )
    tk = np.asarray(res["t"], dtype=np.float64)
    ak = G * np.asarray(res["sc"], dtype=np.float64)
    return tk, ak, float(res["scale_factor"]), (t1, t2)


def _sampling_correction(rec: MatchedRecord, damping: float) -> FloatArray:
    """reqpy's spectrum of ``rec`` over ours, at the check periods (clipped to [0.8, 1.5]):
    reqpy reads the samples as a band-limited signal, the scenes and our spectrum as a
    piecewise-linear one, which holds less of the content near the Nyquist frequency."""
    import reqpy_M

    psa_g, _, _ = reqpy_M.compute_spectrum(rec.periods, rec.a / G, damping, rec.dt)
    return np.clip(G * np.asarray(psa_g) / rec.psa, 0.8, 1.5)


def _one_more_pass(
    variant: SeedVariant,
    t: FloatArray,
    a: FloatArray,
    previous: MatchedRecord | None,
    target: Target,
    band: Band,
    boost: FloatArray | None = None,
) -> MatchedRecord:
    """The record after one more reqpy pass on (t, a) (``previous``'s record, if any, whose
    sampling correction then multiplies ``boost``), checked with the project's spectrum."""
    start = time.perf_counter()
    if previous is not None:
        fix = _sampling_correction(previous, target.damping)
        boost = fix if boost is None else boost * fix
    tk, ak, factor, mrange = _reqpy_pass(t, a, target, band, boost)
    periods = check_periods(band)
    psa = response_spectrum(tk, ak, periods, target.damping).psa
    return MatchedRecord(
        variant=variant,
        t=tk,
        a=ak,
        scale=factor * (previous.scale if previous else 1.0),
        passes=1 + (previous.passes if previous else 0),
        psa=psa,
        ratio=psa / target.psa(periods),
        seconds=time.perf_counter() - start + (previous.seconds if previous else 0.0),
        matching_range=mrange,
        periods=periods,
    )


def match_record(variant: SeedVariant, target: Target, band: Band) -> MatchedRecord:
    """Match one seed to ``target`` with reqpy-m in passes until its spectrum is within the
    band by ``MARGIN`` (at most ``MAX_PASSES``); the pass closest to the band is kept.

    Raises:
        ScenarioError: the band outside the target's periods.
    """
    seed = variant.record
    step = (seed.t[-1] - seed.t[0]) / (seed.t.size - 1)
    dt = float(min(step, band.t_min / STEPS_PER_T_MIN))
    n = math.floor(seed.duration / dt + 1e-9) + 1
    t = dt * np.arange(n, dtype=np.float64)
    rec = _one_more_pass(variant, t, seed.at(t), None, target, band)
    best = rec
    while _violation(rec.ratio, band) > 0.0 and rec.passes < MAX_PASSES:
        rec = _one_more_pass(variant, rec.t, rec.a, rec, target, band)
        if _violation(rec.ratio, band) <= _violation(best.ratio, band):
            best = rec
    # the passes run, whichever is kept: their cost
    return replace(best, passes=rec.passes, seconds=rec.seconds)


def _raise_mean(
    records: list[MatchedRecord], target: Target, band: Band
) -> tuple[list[MatchedRecord], int]:
    """One more pass for each record below the target where the records' mean is, aimed
    higher there by the mean's shortfall (``AIM`` × (1 + 2 ``MEAN_MARGIN``)/mean, ≥ ``AIM``);
    a pass is kept if the record stays as near the band and rises there. The new list and
    the number of passes kept."""
    mean = np.mean([r.ratio for r in records], axis=0)
    low = mean < 1.0 + MEAN_MARGIN
    boost = np.maximum(1.0, (1.0 + 2.0 * MEAN_MARGIN) / mean)
    out, kept = [], 0
    for rec in records:
        if rec.ratio[low].min() >= 1.0 + MEAN_MARGIN:
            out.append(rec)
            continue
        new = _one_more_pass(rec.variant, rec.t, rec.a, rec, target, band, boost)
        keep = _violation(new.ratio, band) <= _violation(rec.ratio, band) and float(
            new.ratio[low].mean()
        ) > float(rec.ratio[low].mean())
        kept += keep
        out.append(new if keep else replace(rec, passes=new.passes, seconds=new.seconds))
    return out, kept


def match_records(
    variants: list[SeedVariant],
    target: Target,
    band: Band,
    progress: Callable[[str], None] | None = None,
) -> MatchResult:
    """Match every seed variant to ``target`` (:func:`match_record`); then, while the
    records' mean is below the target somewhere (by ``MEAN_MARGIN``), up to ``MEAN_ROUNDS``
    rounds of one more pass for the records below it there. ``progress(line)`` reports.

    Raises:
        ScenarioError: the band outside the target's periods.
    """
    say = progress or (lambda line: None)
    periods = check_periods(band)
    target_psa = target.psa(periods)
    records = []
    for k, v in enumerate(variants):
        rec = match_record(v, target, band)
        records.append(rec)
        say(
            f"record {k + 1}: {v.label}, ratio {rec.ratio.min():.3f}-{rec.ratio.max():.3f}, "
            f"{rec.passes} pass{'es' if rec.passes > 1 else ''}, {rec.seconds:.0f} s"
        )
    for r in range(MEAN_ROUNDS):
        mean = np.mean([rec.ratio for rec in records], axis=0)
        if mean.min() >= 1.0 + MEAN_MARGIN:
            break
        say(
            f"mean/target {mean.min():.3f} at {periods[np.argmin(mean)]:.3g} s: one more pass "
            f"for the records below it there ({r + 1}/{MEAN_ROUNDS})"
        )
        records, kept = _raise_mean(records, target, band)
        if not kept:
            break
    return MatchResult(target, band, periods, target_psa, records)
