"""The files of a matching: the records as the scenes read them, match.json, the figure.

``record_<k>.csv`` (k from 1): a comment line, the header ``t_s,a_m_s2`` and rows ``t, a``
(s, m/s²), the CSV that ``loading.ground_motion.record = "record_1.csv"`` reads (units m/s²,
the default). ``match_spectra.csv``: the check periods and the PSA of the target, of each
record and of their mean (the columns of :func:`crane_fem.spectra.read_spectra_csv`).
``match.json``: the target, the band, each record's seed, scaling and ratios to the target,
the check's verdict and the matcher's settings. ``match.png``: the spectra against the
target and the band. Not collective: call on one rank.
"""

from __future__ import annotations

import json
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np

from crane_fem.records import matching
from crane_fem.records.matching import MatchedRecord, MatchResult
from crane_fem.spectra import G

__all__ = ["plot_match", "record_file", "summary", "write_outputs"]


def record_file(k: int) -> str:
    """The file name of record ``k`` (from 0)."""
    return f"record_{k + 1}.csv"


def _write_record(path: Path, rec: MatchedRecord, target_label: str) -> None:
    header = (
        f"# crane-fem records match: seed {rec.variant.label}, matched to {target_label}\n"
        "t_s,a_m_s2"
    )
    # 12 significant digits keep t uniform to 1e-9 relative (the spectra need 1e-6).
    np.savetxt(
        path,
        np.column_stack([rec.t, rec.a]),
        fmt="%.12g",
        delimiter=",",
        header=header,
        comments="",
        encoding="utf-8",
    )


def _ratios(ratio: np.ndarray, periods: np.ndarray) -> dict[str, float]:
    return {
        "ratio_min": float(ratio.min()),
        "ratio_min_period_s": float(periods[np.argmin(ratio)]),
        "ratio_max": float(ratio.max()),
        "ratio_max_period_s": float(periods[np.argmax(ratio)]),
        "ratio_mean": float(ratio.mean()),
    }


def summary(result: MatchResult) -> dict[str, Any]:
    """The content of ``match.json``."""
    band = result.band
    records = []
    for k, rec in enumerate(result.records):
        records.append(
            {
                "file": record_file(k),
                "seed": rec.variant.seed,
                "reversed": rec.variant.reversed,
                "scale": rec.scale,
                "passes": rec.passes,
                "dt_s": rec.dt,
                "duration_s": float(rec.t[-1]),
                "pga_m_s2": float(np.max(np.abs(rec.a))),
                "matching_range_s": list(rec.matching_range),
                **_ratios(rec.ratio, result.periods),
                "within_band": result.within(rec),
                "seconds": rec.seconds,
            }
        )
    return {
        "target": result.target.describe(),
        "damping": result.target.damping,
        "band": {
            "periods_s": [band.t_min, band.t_max],
            "lower": band.lower,
            "upper": band.upper,
            "check_periods": int(result.periods.size),
            "check_periods_per_decade": matching.CHECK_PER_DECADE,
            "rule": "each record's spectrum within [lower, upper] x target over the band, "
            "and the records' mean not below the target (ASCE 4, RG 1.208)",
        },
        "records": records,
        "mean": _ratios(result.mean_ratio, result.periods),
        "check": {
            "each_within_band": result.each_within,
            "mean_not_below_target": result.mean_not_below,
            "passed": result.passed,
        },
        "spectra": "match_spectra.csv",
        "matcher": {
            "library": "reqpy-m",
            "version": metadata.version("reqpy-m"),
            "function": "generate_single_component_compatible_record",
            "aim": matching.AIM,
            "scales": matching.scales(result.target.damping),
            "iterations_per_pass": matching.ITERATIONS,
            "max_passes": matching.MAX_PASSES,
            "mean_rounds": matching.MEAN_ROUNDS,
            "steps_per_t_min": matching.STEPS_PER_T_MIN,
            "baseline": "sixth_order",
            "spectra_checked_with": "crane_fem.spectra.response_spectrum",
        },
    }


def plot_match(path: Path, result: MatchResult) -> Path:
    """Each record's spectrum, their mean, the target and the band, in g on log periods."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    p = result.periods
    tgt = result.target_psa / G
    fig = Figure(figsize=(8.0, 5.0), dpi=120)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    for k, rec in enumerate(result.records):
        ax.plot(p, rec.psa / G, lw=0.9, alpha=0.6, label=f"record {k + 1}" if k == 0 else None)
    if len(result.records) > 1:
        ax.lines[0].set_label(f"records 1–{len(result.records)}")
    mean = np.mean([r.psa for r in result.records], axis=0) / G
    ax.plot(p, mean, color="black", lw=2.0, label="mean")
    ax.plot(p, tgt, color="tab:red", lw=2.0, label="target")
    band = result.band
    ax.plot(p, band.lower * tgt, color="tab:red", lw=1.2, ls="--", label="band −10 % / +30 %")
    ax.plot(p, band.upper * tgt, color="tab:red", lw=1.2, ls="--")
    ax.set_xscale("log")
    ax.set_xlabel("period T (s)", fontsize=12)
    ax.set_ylabel("pseudo-acceleration PSA (g)", fontsize=12)
    verdict = "passed" if result.passed else "NOT passed"
    ax.set_title(
        f"{len(result.records)} records matched to {result.target.label} — band {verdict}",
        fontsize=11,
    )
    ax.tick_params(labelsize=11)
    ax.grid(True, which="both", alpha=0.35)
    ax.legend(fontsize=10)
    fig.tight_layout()
    fig.savefig(path)
    return path


def write_outputs(outdir: Path, result: MatchResult) -> list[Path]:
    """Write the records, ``match_spectra.csv``, ``match.json`` and ``match.png`` into
    ``outdir`` (created); the paths written."""
    outdir.mkdir(parents=True, exist_ok=True)
    paths = []
    for k, rec in enumerate(result.records):
        path = outdir / record_file(k)
        _write_record(path, rec, result.target.label)
        paths.append(path)
    names = ["target", *(f"record_{k + 1}" for k in range(len(result.records))), "mean"]
    columns = [result.target_psa, *(r.psa for r in result.records)]
    columns.append(np.mean([r.psa for r in result.records], axis=0))
    spectra = outdir / "match_spectra.csv"
    np.savetxt(
        spectra,
        np.column_stack([result.periods, *columns]),
        fmt="%.17g",
        delimiter=",",
        header=",".join(["period_s", *(f"psa_{n}" for n in names)]),
        comments="",
        encoding="utf-8",
    )
    js = outdir / "match.json"
    js.write_text(json.dumps(summary(result), indent=2) + "\n", encoding="utf-8")
    png = plot_match(outdir / "match.png", result)
    return [*paths, spectra, js, png]
