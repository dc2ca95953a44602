"""A study's tables: each sign-off quantity (crane_fem.tolerances) in every nominal case, its
statistics over the study, the combination the codes name, the governing case, its
conditioning, and the envelope of the floor response spectra.

- Statistics over the nominal cases: max, mean, mean + σ (σ the sample standard deviation),
  coefficient of variation σ / mean.
- The code combination over the records (EN 1998-1 §4.3.3.4.3, ASCE 4-16 §2.4): the mean
  of the records' peaks with at least 7 records, their maximum with fewer (at least 3 asked);
  then the maximum over the study's other axes (trolley positions, directions): the design
  value, and the case that governs it.
- Conditioning (THEORY.md §8): per quantity, the largest |member − nominal| / tolerance
  over every nominal case's ensemble (record × (1 ± ε), Δt × ½). Above 1 the scene moves by
  more than the tolerance under a perturbation it cannot resolve: the quantity is beyond
  conditioning, no single-run sign-off number; its envelope is the study's.
"""

from __future__ import annotations

import csv
import json
import math
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from crane_fem.spectra import read_spectra_csv
from crane_fem.study.cases import Case
from crane_fem.study.engine import CaseResult
from crane_fem.tolerances import TOLERANCES, Check, Quantity, signoff_quantities

__all__ = [
    "MEAN_RECORDS",
    "MIN_RECORDS",
    "StudyTables",
    "case_quantities",
    "code_combination",
    "tabulate",
]

FloatArray = npt.NDArray[np.float64]

#: With at least this many records the codes take the mean of their peaks, else the maximum.
MEAN_RECORDS = 7
#: The fewest records the codes accept.
MIN_RECORDS = 3


@dataclass
class StudyTables:
    """``quantities``: key -> its row (study.json); ``spectra``: periods and, per curve,
    each case's PSA, the max and the mean; ``warnings`` for the user."""

    quantities: dict[str, dict[str, Any]] = field(default_factory=dict)
    spectra: dict[str, Any] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)


def case_quantities(
    outdir: Path,
) -> tuple[list[Quantity], tuple[FloatArray, dict[str, Any]] | None]:
    """A run directory's sign-off quantities (``summary.json``, and the peaks of
    ``spectra.csv`` when there is one) and its spectra."""
    summary = json.loads((outdir / "summary.json").read_text())
    path = outdir / "spectra.csv"
    spectra = read_spectra_csv(path) if path.exists() else None
    return signoff_quantities(summary, spectra), spectra


def code_combination(
    values: dict[str, float], cases: dict[str, Case]
) -> tuple[float, str, str] | None:
    """(design value, rule, governing case) of one quantity's nominal values: over the
    records, their mean (≥ 7 records) or maximum; then the maximum over the other axes.
    None without a record axis."""
    groups: dict[tuple[tuple[str, str], ...], list[str]] = defaultdict(list)
    for name in values:
        labels = cases[name].labels
        if "record" not in labels:
            return None
        groups[tuple(sorted((k, v) for k, v in labels.items() if k != "record"))].append(name)
    best: tuple[float, str, str] | None = None
    for names in groups.values():
        n = len(names)
        vals = [values[m] for m in names]
        if n >= MEAN_RECORDS:
            v, rule = float(np.mean(vals)), f"mean of {n} records"
            gov = max(names, key=lambda m: values[m])
        else:
            v, rule = max(vals), f"max of {n} records"
            gov = max(names, key=lambda m: values[m])
            if n < MIN_RECORDS:
                rule += f" (the codes ask for at least {MIN_RECORDS})"
        if best is None or v > best[0]:
            others = [k for k in cases[gov].labels if k != "record"]
            where = f", max over {', '.join(others)}" if others and len(groups) > 1 else ""
            best = (v, rule + where, gov)
    return best


def _conditioning(
    per_case: dict[str, dict[str, Quantity]], cases: list[Case]
) -> dict[str, tuple[float, str]]:
    """Per quantity key: the largest member / nominal error over its tolerance, and the
    member that gives it."""
    out: dict[str, tuple[float, str]] = {}
    for c in cases:
        if c.nominal or c.name not in per_case or c.base not in per_case:
            continue
        nominal = per_case[c.base]
        for key, q in per_case[c.name].items():
            if key not in nominal:
                continue
            r = Check(q.quantity, q.where, q.value, nominal[key].value, q.unit).ratio
            if key not in out or r > out[key][0]:
                out[key] = (r, c.name)
    return out


def tabulate(root: Path, cases: list[Case], results: dict[str, CaseResult]) -> StudyTables:
    """The tables of the completed cases under ``root`` (``root/<case>/``)."""
    tables = StudyTables()
    per_case: dict[str, dict[str, Quantity]] = {}
    spectra: dict[str, tuple[FloatArray, dict[str, Any]]] = {}
    for c in cases:
        if results.get(c.name, CaseResult(c.name, "failed")).status != "completed":
            continue
        qs, sp = case_quantities(root / c.name)
        per_case[c.name] = {q.key: q for q in qs}
        if sp is not None and c.nominal:
            spectra[c.name] = sp
    nominal = [c for c in cases if c.nominal and c.name in per_case]
    by_name = {c.name: c for c in cases}
    cond = _conditioning(per_case, cases)
    keys: list[str] = []
    for c in nominal:
        keys += [k for k in per_case[c.name] if k not in keys]
    for key in keys:
        first = next(per_case[c.name][key] for c in nominal if key in per_case[c.name])
        values = {c.name: per_case[c.name][key].value for c in nominal if key in per_case[c.name]}
        v = np.array(list(values.values()))
        mean = float(v.mean())
        sigma = float(v.std(ddof=1)) if v.size > 1 else 0.0
        gov = max(values, key=lambda m: values[m])
        rel, floor = TOLERANCES[first.quantity]
        row: dict[str, Any] = {
            "quantity": first.quantity,
            "where": first.where,
            "unit": first.unit,
            "tolerance": f"{100 * rel:g} %" + (f" or {floor:g} {first.unit}" if floor else ""),
            "cases": values,
            "notes": {
                c.name: per_case[c.name][key].note
                for c in nominal
                if key in per_case[c.name] and per_case[c.name][key].note
            },
            "max": float(v.max()),
            "mean": mean,
            "mean_plus_sigma": mean + sigma,
            "cov": sigma / abs(mean) if mean else math.nan,
            "governing_case": gov,
        }
        combo = code_combination(values, by_name)
        if combo is not None:
            row["code"] = {"value": combo[0], "rule": combo[1], "governing_case": combo[2]}
        if key in cond:
            ratio, member = cond[key]
            row["conditioning"] = {
                "ratio": ratio,
                "member": member,
                "beyond": ratio > 1.0,
            }
        tables.quantities[key] = row
    tables.spectra = _envelope(spectra, tables.warnings)
    return tables


def _envelope(
    spectra: dict[str, tuple[FloatArray, dict[str, Any]]], warnings: list[str]
) -> dict[str, Any]:
    """Per curve: each nominal case's PSA, their maximum and mean, at common periods."""
    if not spectra:
        return {}
    names = list(spectra)
    periods = spectra[names[0]][0]
    same = [n for n in names if np.allclose(spectra[n][0], periods, rtol=1e-9)]
    if len(same) < len(names):
        warnings.append(
            f"spectra of {len(names) - len(same)} case(s) at other periods (another "
            "sampling) left out of the envelope"
        )
    curves: dict[str, Any] = {}
    for curve in spectra[names[0]][1]:
        each = {n: np.asarray(spectra[n][1][curve]) for n in same if curve in spectra[n][1]}
        stack = np.array(list(each.values()))
        curves[curve] = {
            "cases": {n: c.tolist() for n, c in each.items()},
            "max": stack.max(axis=0).tolist(),
            "mean": stack.mean(axis=0).tolist(),
        }
    return {"periods_s": np.asarray(periods).tolist(), "curves": curves}


def write_tables(
    out: Path,
    tables: StudyTables,
    cases: list[Case],
    results: dict[str, CaseResult],
    head: dict[str, Any],
) -> list[Path]:
    """``study.json`` (everything) and ``study.csv`` (a row per quantity: its value in every
    nominal case, the statistics, the code's design value, the governing case, the
    conditioning) and ``study_spectra.csv`` (the envelope)."""
    doc = {
        **head,
        "cases": {
            c.name: {
                "nominal": c.base,
                "member": c.member,
                "labels": c.labels,
                "settings": c.settings,
                **{k: v for k, v in vars(results[c.name]).items() if k != "name"},
            }
            for c in cases
        },
        "quantities": tables.quantities,
        "spectra": tables.spectra,
        "warnings": tables.warnings,
    }
    paths = [out / "study.json", out / "study.csv"]
    paths[0].write_text(json.dumps(doc, indent=1, allow_nan=True))
    nominal = [c.name for c in cases if c.nominal]
    head_row = ["quantity", "where", "unit", "tolerance", *nominal]
    head_row += ["max", "mean", "mean_plus_sigma", "cov", "governing_case"]
    head_row += ["code_value", "code_rule", "code_governing_case"]
    head_row += ["conditioning_ratio", "conditioning_member", "beyond_conditioning"]
    with paths[1].open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(head_row)
        for row in tables.quantities.values():
            code = row.get("code", {})
            cond = row.get("conditioning", {})
            w.writerow(
                [
                    row["quantity"],
                    row["where"],
                    row["unit"],
                    row["tolerance"],
                    *(_g(row["cases"].get(n)) for n in nominal),
                    *(_g(row[k]) for k in ("max", "mean", "mean_plus_sigma", "cov")),
                    row["governing_case"],
                    _g(code.get("value")),
                    code.get("rule", ""),
                    code.get("governing_case", ""),
                    _g(cond.get("ratio")),
                    cond.get("member", ""),
                    "" if not cond else ("yes" if cond["beyond"] else "no"),
                ]
            )
    if tables.spectra:
        paths.append(out / "study_spectra.csv")
        sp = tables.spectra
        cols = [f"{c}_{s}" for c in sp["curves"] for s in ("max", "mean")]
        with paths[-1].open("w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["period_s", *cols])
            for i, t in enumerate(sp["periods_s"]):
                vals = [sp["curves"][c][s][i] for c in sp["curves"] for s in ("max", "mean")]
                w.writerow([repr(t), *(repr(v) for v in vals)])
    return paths


def _g(x: Any) -> str:
    return "" if x is None else repr(float(x))
