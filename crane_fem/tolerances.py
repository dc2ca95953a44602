"""Criterion (b) of THEORY.md §8: a crane run's engineering quantities against the fully
explicit run of the same scene, each with its engineering tolerance.

Per wheel: the largest uplift (10 %, or 0.1 mm), the longest flight (5 %), the first
landing's impulse (5 %) and peak force (10 %), the run's peak force (10 %), the slip along
and across its rail (10 %, or 0.5 mm), a gmsh model's or a frame's contact's largest slip (the
same); per flange its peak force (15 %); the bridge's peak
von Mises stress (5 %) and, in the part where the reference peaks, the run's own peak there
(5 %: the same part, ties between mirror-symmetric parts allowed); a frame's or gmsh model's
peak von Mises stress per group (5 %); each support's peak force and peak vertical force
(10 %); the floor response spectra at the measured points (10 % at every period computed:
they start at 4 sampling intervals; a study's envelope takes each spectrum's peak, 10 %).
Lift-off counts are reported, not bounded (short chatter flights differ by ±3 between explicit
runs of ±0.5 % of record).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

__all__ = [
    "CUT_BY_THE_WINDOW",
    "TOLERANCES",
    "Check",
    "Quantity",
    "judge_dirs",
    "judge_runs",
    "lift_off_counts",
    "signoff_quantities",
    "table_lines",
    "with_spread",
    "worst",
]

#: quantity -> (relative tolerance, absolute floor in the quantity's SI unit).
TOLERANCES: dict[str, tuple[float, float]] = {
    "max uplift": (0.10, 1e-4),
    "longest flight": (0.05, 0.0),
    "first landing impulse": (0.05, 0.0),
    "first landing peak force": (0.10, 0.0),
    "peak force": (0.10, 0.0),
    "slip along": (0.10, 5e-4),
    "slip across": (0.10, 5e-4),
    "contact slip": (0.10, 5e-4),
    "flange peak force": (0.15, 0.0),
    "bridge peak von Mises": (0.05, 0.0),
    "bridge peak von Mises in the reference's part": (0.05, 0.0),
    "group peak von Mises": (0.05, 0.0),
    "support peak force": (0.10, 0.0),
    "support peak vertical force": (0.10, 0.0),
    "support low-passed peak force": (0.10, 0.0),
    "support low-passed peak vertical force": (0.10, 0.0),
    "floor response spectrum": (0.10, 0.0),
    "floor response spectrum peak": (0.10, 0.0),
}


@dataclass(frozen=True)
class Check:
    """One quantity of a run against the reference's, with its tolerance (SI units)."""

    quantity: str
    where: str
    value: float
    reference: float
    unit: str
    #: What the check was read at beyond ``where`` (a spectrum's worst period).
    note: str = ""
    #: The explicit ensemble's spread: its members' largest |member − reference| (0 without
    #: an ensemble). THEORY.md §8: each quantity is judged against max(tolerance, spread).
    spread: float = 0.0

    @property
    def tolerance(self) -> float:
        """The engineering tolerance on |value − reference|."""
        rel, floor = TOLERANCES[self.quantity]
        return max(rel * abs(self.reference), floor)

    @property
    def allowance(self) -> float:
        """The allowed |value − reference|: max(tolerance, the ensemble's spread)."""
        return max(self.tolerance, self.spread)

    @property
    def beyond_conditioning(self) -> bool:
        """The ensemble moves the quantity by more than its tolerance: the scene does not
        resolve it at that tolerance, and no single run signs it off."""
        return self.spread > self.tolerance

    @property
    def ratio(self) -> float:
        """|value − reference| / allowance (0 when equal; inf against a zero allowance)."""
        dev = abs(self.value - self.reference)
        if dev == 0.0:
            return 0.0
        tol = self.allowance
        return dev / tol if tol > 0.0 else math.inf

    @property
    def ok(self) -> bool:
        return self.ratio <= 1.0

    @property
    def rule(self) -> str:
        rel, floor = TOLERANCES[self.quantity]
        text = f"{100 * rel:g} %"
        if floor > 0.0:
            text += f" (or {1e3 * floor:g} mm)"
        if self.beyond_conditioning:
            text += f"; ensemble spread {_fmt(self.spread, self.unit)}"
        return text


def _longest_flight(wheel: dict[str, Any]) -> float:
    spans = [b - a for a, b in wheel.get("lift_offs", {}).get("intervals", [])]
    return max(spans, default=0.0)


def _first_impact(wheel: dict[str, Any]) -> dict[str, float]:
    impacts = wheel.get("impacts", [])
    return impacts[0] if impacts else {"impulse_Ns": 0.0, "peak_force_N": 0.0}


@dataclass(frozen=True)
class Quantity:
    """One sign-off quantity of one run (SI units): the uplift of a wheel, a support's peak
    force, the peak of a floor response spectrum."""

    quantity: str
    where: str
    value: float
    unit: str
    #: What the value was read at beyond ``where`` (a spectrum's peak period).
    note: str = ""

    @property
    def key(self) -> str:
        """``quantity, where``: the quantity's name in a study's tables."""
        return f"{self.quantity}, {self.where}"


def signoff_quantities(
    summary: dict[str, Any], spectra: tuple[Any, dict[str, Any]] | None = None
) -> list[Quantity]:
    """The quantities of :data:`TOLERANCES` one run's ``summary`` gives (per wheel, flange,
    group, support), and the peak of each of its floor response spectra ((periods, name ->
    PSA) of ``spectra.csv``; the input's curves left out) when given."""
    out: list[Quantity] = []

    def add(q: str, where: str, value: float, unit: str, note: str = "") -> None:
        out.append(Quantity(q, where, float(value), unit, note))

    for k, w in sorted(summary.get("wheels", {}).items()):
        where = f"wheel {k}"
        add("max uplift", where, w.get("max_uplift_m", 0.0), "m")
        add("longest flight", where, _longest_flight(w), "s")
        fi = _first_impact(w)
        add("first landing impulse", where, fi["impulse_Ns"], "N s")
        add("first landing peak force", where, fi["peak_force_N"], "N")
        add("peak force", where, w.get("peak_force_N", 0.0), "N")
        for d in ("along", "across"):
            key = f"max_slip_{d}_m"
            if key in w:
                add(f"slip {d}", where, w[key], "m")
    for name, g in sorted(summary.get("contact_groups", {}).items()):
        if "max_slip_m" in g:  # a gmsh model's or a frame's contact: its largest point slip
            add("contact slip", name, g["max_slip_m"], "m")
    for name, f in sorted(summary.get("flanges", {}).items()):
        add("flange peak force", f"flange {name}", f["peak_force_N"], "N")
    if "peak_bridge_von_mises_Pa" in summary:
        add("bridge peak von Mises", "bridge", summary["peak_bridge_von_mises_Pa"], "Pa")
    for group, g in sorted(summary.get("peak_von_mises_by_group", {}).items()):
        add("group peak von Mises", group, g["peak_Pa"], "Pa")
    for k, s in sorted(summary.get("supports", {}).items()):
        where = f"support {k}"
        add("support peak force", where, s.get("peak_force_N", 0.0), "N")
        add("support peak vertical force", where, s.get("peak_vertical_N", 0.0), "N")
        if "lowpass" in s:  # output.support_lowpass_hz (judged where the reference has it)
            at = f"{where} ({s['lowpass']['cutoff_hz']:g} Hz)"
            add("support low-passed peak force", at, s["lowpass"]["peak_force_N"], "N")
            add("support low-passed peak vertical force", at, s["lowpass"]["peak_vertical_N"], "N")
    if spectra is not None:
        periods, curves = spectra
        for name, c in sorted(curves.items()):
            if name.startswith("input_"):
                continue
            j = int(np.argmax(np.asarray(c)))
            where = name.replace("_", " ")
            add("floor response spectrum peak", where, c[j], "m/s²", f"T = {periods[j]:.3g} s")
    return out


def judge_runs(
    run: dict[str, Any],
    ref: dict[str, Any],
    run_spectra: tuple[Any, dict[str, Any]] | None = None,
    ref_spectra: tuple[Any, dict[str, Any]] | None = None,
) -> list[Check]:
    """The checks of criterion (b) of the run with summary ``run`` against the reference's
    ``ref`` (the fully explicit run of the same scene), and of their response spectra
    ((periods, name -> PSA) of ``spectra.csv``) when given. Quantities the reference lacks
    are left out; those the run lacks count as zero."""
    values = {q.key: q.value for q in signoff_quantities(run)}
    checks: list[Check] = []
    for q in signoff_quantities(ref):
        note = _cut_by_the_window(q, run, ref) if q.quantity == "max uplift" else q.note
        checks.append(Check(q.quantity, q.where, values.get(q.key, 0.0), q.value, q.unit, note))
        part = ref.get("peak_bridge_von_mises_part")
        if q.quantity == "bridge peak von Mises" and part:
            there = run.get("peak_bridge_von_mises_by_part_Pa", {}).get(part, 0.0)
            name = "bridge peak von Mises in the reference's part"
            checks.append(Check(name, part, float(there), q.value, "Pa"))
    if run_spectra is not None and ref_spectra is not None:
        checks += _spectra_checks(run_spectra, ref_spectra)
    return checks


#: How a max-uplift check's note starts when a run's flight is still rising at its end.
CUT_BY_THE_WINDOW = "still rising at the window's end"


def _cut_by_the_window(q: Quantity, run: dict[str, Any], ref: dict[str, Any]) -> str:
    """A wheel's max uplift that is a flight still rising at a run's end (``peaks``:
    ``max_uplift_at_end``) is a lower bound, not an apex: say in which run(s)."""
    key = q.where.removeprefix("wheel ")
    cut = [
        label
        for label, s in (("run", run), ("reference", ref))
        if s.get("wheels", {}).get(key, {}).get("max_uplift_at_end")
    ]
    if not cut:
        return ""
    return f"{CUT_BY_THE_WINDOW} in the {' and the '.join(cut)}: a lower bound"


def _spectra_checks(
    run: tuple[Any, dict[str, Any]], ref: tuple[Any, dict[str, Any]]
) -> list[Check]:
    """Per measured point and direction, the period where the run's spectrum is furthest
    from the reference's relative to it (the input's curves, the same in both, left out)."""
    periods, curves = run
    ref_periods, ref_curves = ref
    out: list[Check] = []
    if len(periods) != len(ref_periods) or not np.allclose(periods, ref_periods, rtol=1e-9):
        raise ValueError("the two runs' spectra are at different periods (another sampling?)")
    for name, rc in sorted(ref_curves.items()):
        if name.startswith("input_") or name not in curves:
            continue
        a, b = np.asarray(curves[name]), np.asarray(rc)
        rel = np.abs(a - b) / np.maximum(np.abs(b), 1e-300)
        j = int(np.argmax(rel))
        where, note = name.replace("_", " "), f"T = {periods[j]:.3g} s"
        out.append(Check("floor response spectrum", where, float(a[j]), float(b[j]), "m/s²", note))
    return out


def with_spread(checks: list[Check], members: list[list[Check]]) -> list[Check]:
    """``checks`` with each quantity's spread over the explicit ensemble's ``members`` (each
    judged against the same reference by :func:`judge_runs`)."""
    from dataclasses import replace

    spread: dict[tuple[str, str], float] = {}
    for m in members:
        for c in m:
            key = (c.quantity, c.where)
            spread[key] = max(spread.get(key, 0.0), abs(c.value - c.reference))
    return [replace(c, spread=spread.get((c.quantity, c.where), 0.0)) for c in checks]


def lift_off_counts(run: dict[str, Any], ref: dict[str, Any]) -> dict[str, tuple[int, int]]:
    """Per wheel (run, reference) lift-off counts: reported, not bounded."""
    return {
        f"wheel {k}": (
            int(run.get("wheels", {}).get(k, {}).get("lift_offs", {}).get("count", 0)),
            int(rw["lift_offs"]["count"]),
        )
        for k, rw in sorted(ref.get("wheels", {}).items())
    }


def worst(checks: list[Check]) -> Check | None:
    """The check with the largest ratio (None for none)."""
    return max(checks, key=lambda c: c.ratio, default=None)


def judge_dirs(run: Path, ref: Path) -> list[Check]:
    """:func:`judge_runs` of two output directories (their ``summary.json`` and, where both
    have one, ``spectra.csv``)."""
    import json

    from crane_fem.spectra import read_spectra_csv

    summaries = [json.loads((d / "summary.json").read_text()) for d in (run, ref)]
    spectra = [d / "spectra.csv" for d in (run, ref)]
    if all(p.exists() for p in spectra):
        sr, se = (read_spectra_csv(p) for p in spectra)
        return judge_runs(summaries[0], summaries[1], sr, se)
    return judge_runs(summaries[0], summaries[1])


def _fmt(value: float, unit: str) -> str:
    scale = {"N": (1e-3, "kN"), "Pa": (1e-6, "MPa"), "m": (1e3, "mm"), "s": (1e3, "ms")}
    f, u = scale.get(unit, (1.0, unit))
    return f"{f * value:.4g} {u}"


def table_lines(checks: list[Check]) -> list[str]:
    """The checks as a Markdown table (quantity, where, run, reference, error, tolerance,
    ratio, within)."""
    lines = [
        "| quantity | where | run | explicit | error | tolerance | error / tolerance | ok |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for c in checks:
        err = (
            f"{100 * (c.value - c.reference) / abs(c.reference):+.1f} %"
            if c.reference
            else _fmt(c.value - c.reference, c.unit)
        )
        where = f"{c.where} ({c.note})" if c.note else c.where
        lines.append(
            f"| {c.quantity} | {where} | {_fmt(c.value, c.unit)} | "
            f"{_fmt(c.reference, c.unit)} | {err} | {c.rule} | {c.ratio:.2f} | "
            f"{'yes' if c.ok else '**no**'} |"
        )
    return lines
