"""The results table of a run: the peaks an engineer reads (wheels, impacts, bridge stress,
supports) as ``results.csv`` and as lines to print, from the summary."""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Any

__all__ = ["flange_impacts", "results_lines", "results_rows", "write_results_csv"]

COLUMNS = ["quantity", "where", "value", "unit", "time_s", "x_m", "y_m", "z_m"]


def results_rows(summary: dict[str, Any]) -> list[dict[str, Any]]:
    """One row per reported peak (global values; not collective)."""
    rows: list[dict[str, Any]] = []

    def add(q: str, where: str, value: float, unit: str, t: float | None = None, at=None) -> None:
        xyz = list(at) if at is not None else [None, None, None]
        rows.append(dict(zip(COLUMNS, [q, where, value, unit, t, *xyz], strict=True)))

    groups = summary.get("wheels") or summary.get("contact_groups") or {}
    label = "wheel" if "wheels" in summary else "contact"
    for name, w in groups.items():
        where = f"{label} {name}"
        add("peak_contact_force", where, w["peak_force_N"], "N", w["peak_force_time_s"])
        add("max_uplift", where, w["max_uplift_m"], "m")
        add("lift_offs", where, w["lift_offs"]["count"], "count")
        for k, imp in enumerate(w.get("impacts", []), start=1):
            add(f"impact_{k}_impulse", where, imp["impulse_Ns"], "N s", imp["t_s"])
            add(f"impact_{k}_peak_force", where, imp["peak_force_N"], "N", imp["t_s"])
        if "max_slip_across_m" in w:
            add("max_slip_across", where, w["max_slip_across_m"], "m", w["max_slip_across_time_s"])
            add("max_slip_along", where, w["max_slip_along_m"], "m", w["max_slip_along_time_s"])
    for name, f in summary.get("flanges", {}).items():
        where = f"flange {name}"
        add("peak_contact_force", where, f["peak_force_N"], "N", f["peak_force_time_s"])
        add("impacts", where, len(f.get("impacts", [])), "count")
        for k, imp in enumerate(f.get("impacts", []), start=1):
            add(f"impact_{k}_impulse", where, imp["impulse_Ns"], "N s", imp["t_s"])
            add(f"impact_{k}_peak_force", where, imp["peak_force_N"], "N", imp["t_s"])
    if "peak_bridge_von_mises_Pa" in summary:
        add(
            "peak_von_mises",
            "bridge",
            summary["peak_bridge_von_mises_Pa"],
            "Pa",
            summary["peak_bridge_von_mises_t"],
            summary.get("peak_bridge_von_mises_location_m"),
        )
    for name, s in summary.get("supports", {}).items():
        where = f"support {name}"
        c = s["centre_m"]
        add("peak_support_force", where, s["peak_force_N"], "N", s["peak_force_time_s"], c)
        add("peak_support_vertical", where, s["peak_vertical_N"], "N", s["peak_vertical_time_s"], c)
    return rows


def write_results_csv(path: str | Path, summary: dict[str, Any]) -> None:
    """Write :func:`results_rows` as CSV (rank 0 only: not collective)."""
    with open(path, "w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=COLUMNS)
        writer.writeheader()
        for row in results_rows(summary):
            writer.writerow({k: ("" if v is None else v) for k, v in row.items()})


def results_lines(summary: dict[str, Any]) -> list[str]:
    """The table in a few lines to print at the end of a run."""
    lines: list[str] = []
    ms = summary.get("mass_scaling")
    if ms:
        lines.append(
            f"mass scaling: {ms['added_kg']:.4g} kg added to {ms['cells']} cells "
            f"({100 * ms['added_fraction']:.3g} % of the model's mass) for a "
            f"{ms['target_step_s']:.4g} s vertex step"
        )
    groups = summary.get("wheels") or summary.get("contact_groups") or {}
    if groups:
        label = "wheel" if "wheels" in summary else "contact"
        lines.append(
            f"{label:>8}  peak force (kN)  at t (s)  uplift (mm)  lift-offs  impacts  "
            "largest impulse (N s)"
        )
        for name, w in groups.items():
            imps = w.get("impacts", [])
            big = max((i["impulse_Ns"] for i in imps), default=0.0)
            lines.append(
                f"{name:>8}  {w['peak_force_N'] / 1e3:15.3f}  {w['peak_force_time_s']:8.5f}  "
                f"{w['max_uplift_m'] * 1e3:11.3f}  {w['lift_offs']['count']:9d}  "
                f"{len(imps):7d}  {big:21.4g}"
            )
    lines += _sliding_lines(summary)
    if "peak_bridge_von_mises_Pa" in summary:
        loc = summary.get("peak_bridge_von_mises_location_m")
        at = f" at ({', '.join(f'{x:.3f}' for x in loc)}) m" if loc else ""
        lines.append(
            f"bridge peak von Mises {summary['peak_bridge_von_mises_Pa'] / 1e6:.2f} MPa{at}, "
            f"t = {summary['peak_bridge_von_mises_t']:.5f} s"
        )
    for name, s in summary.get("supports", {}).items():
        lines.append(
            f"support {name}: peak force {s['peak_force_N'] / 1e3:.3f} kN at "
            f"t = {s['peak_force_time_s']:.5f} s (vertical {s['peak_vertical_N'] / 1e3:.3f} kN)"
        )
    return lines


def flange_impacts(summary: dict[str, Any], wheel: str) -> tuple[int, float] | None:
    """Wheel ``wheel``'s flanges, both sides (summary ``flanges``, keys ``in_<k>``,
    ``out_<k>``): their impact count and the larger peak force (N); None without flanges."""
    flanges = summary.get("flanges", {})
    sides = [flanges[f"{side}_{wheel}"] for side in ("in", "out") if f"{side}_{wheel}" in flanges]
    if not sides:
        return None
    count = sum(len(f.get("impacts", [])) for f in sides)
    return count, max(f["peak_force_N"] for f in sides)


def _sliding_lines(summary: dict[str, Any]) -> list[str]:
    """Per wheel: its largest slip across and along its rail (against the reach of its
    contact pairs) and its flanges' impacts (both sides), when the run has them."""
    wheels = summary.get("wheels", {})
    if not any("max_slip_across_m" in w for w in wheels.values()):
        return []
    lines = [
        "   wheel  slip across (mm)  slip along (mm)  reach (mm)  flange impacts  "
        "flange peak force (kN)"
    ]
    for name, w in wheels.items():
        both = flange_impacts(summary, name)
        flange = f"{both[0]:14d}  {both[1] / 1e3:22.3f}" if both else f"{'no flanges':>14}"
        lines.append(
            f"{name:>8}  {w['max_slip_across_m'] * 1e3:16.3f}  {w['max_slip_along_m'] * 1e3:15.3f}"
            f"  {w['slip_reach_m'] * 1e3:10.2f}  {flange}"
        )
    return lines
