"""The results table of a run: the peaks an engineer reads (wheels and contacts, impacts,
slip, bridge stress, supports) as ``results.csv`` and as lines to print after the run's own
line (steps, wall time, energy balance), from the summary."""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["flange_impacts", "results_lines", "results_rows", "run_line", "write_results_csv"]

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
        if w.get("max_uplift_at_end"):  # a flight still rising at the end: a lower bound
            add("max_uplift_at_end", where, 1, "flag", summary.get("t_reached_s"))
        add("lift_offs", where, w["lift_offs"]["count"], "count")
        lifts = w["lift_offs"]
        for k, (span, apex) in enumerate(
            zip(lifts["intervals"], lifts.get("apex_m", []), strict=False), 1
        ):
            add(f"lift_off_{k}_apex", where, apex, "m", span[0])
        for k, imp in enumerate(w.get("impacts", []), start=1):
            add(f"impact_{k}_impulse", where, imp["impulse_Ns"], "N s", imp["t_s"])
            add(f"impact_{k}_peak_force", where, imp["peak_force_N"], "N", imp["t_s"])
        if "max_slip_across_m" in w:
            add("max_slip_across", where, w["max_slip_across_m"], "m", w["max_slip_across_time_s"])
            add("max_slip_along", where, w["max_slip_along_m"], "m", w["max_slip_along_time_s"])
        if "max_slip_m" in w:  # a gmsh model's or a frame's sliding contact
            add("max_slip", where, w["max_slip_m"], "m", w.get("max_slip_time_s"))
            add("final_slip", where, float(np.linalg.norm(w["final_slip_m"])), "m")
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
        if "lowpass" in s:  # output.support_lowpass_hz
            lp = s["lowpass"]
            add(
                "peak_support_force_lowpass",
                where,
                lp["peak_force_N"],
                "N",
                lp["peak_force_time_s"],
                c,
            )
            add(
                "peak_support_vertical_lowpass",
                where,
                lp["peak_vertical_N"],
                "N",
                lp["peak_vertical_time_s"],
                c,
            )
    return rows


def write_results_csv(path: str | Path, summary: dict[str, Any]) -> None:
    """Write :func:`results_rows` as CSV (rank 0 only: not collective)."""
    with open(path, "w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=COLUMNS)
        writer.writeheader()
        for row in results_rows(summary):
            writer.writerow({k: ("" if v is None else v) for k, v in row.items()})


def run_line(name: str, s: dict[str, Any]) -> str:
    """The first line a run prints, from its summary ``s``: its steps (a refining run's coarse
    and fine macro steps, a coupled run's macro and micro steps, or a single integrator's
    steps), its wall time, energy-balance error and contact intervals (not collective)."""
    ad = s.get("adaptive")
    if ad:  # the macro step refined at impacts: how many of each
        steps = (
            f"{s['steps_done']} macro steps ({ad['coarse_steps']} of ΔT = {s['dT']:.4e} s, "
            f"m = {ad['coarse_ratio']}; {ad['fine_steps']} of m = {ad['fine_ratio']} around "
            f"impacts), {s['micro_steps_done']} micro steps of Δt = {s['dt']:.4e} s ("
        )
    elif s.get("ratio", 1) > 1:  # coupled: macro steps of m micro steps
        steps = (
            f"{s['steps']} macro steps of ΔT = {s['dT']:.4e} s (m = {s['ratio']}, "
            f"{s['micro_steps']} micro steps of Δt = {s['dt']:.4e} s, "
        )
    else:
        steps = f"{s.get('micro_steps', s['steps'])} steps of Δt = {s['dt']:.4e} s ("
    return (
        f"{name}: {steps}critical {s['dt_critical']:.4e} s) in {s['wall_time_s']:.2f} s; "
        f"energy balance error {s['energy_balance_error']:.2e}; "
        f"{s['contact_intervals']} contact interval(s)"
    )


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
        rising = [name for name, w in groups.items() if w.get("max_uplift_at_end")]
        if rising:
            which = ", ".join(rising)
            lines.append(
                f"{label} {which}: the largest uplift is the last instant's, a flight still "
                "rising when the run ends: a lower bound of its apex (lengthen time.end to read "
                "it)"
            )
    lines += _sliding_lines(summary)
    lines += _contact_slip_lines(summary)
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
            + (
                f"; low-passed at {s['lowpass']['cutoff_hz']:g} Hz "
                f"{s['lowpass']['peak_force_N'] / 1e3:.3f} kN "
                f"(vertical {s['lowpass']['peak_vertical_N'] / 1e3:.3f} kN)"
                if "lowpass" in s
                else ""
            )
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
        # (a node-to-surface or point-on-line wheel: no pairs, so no reach of theirs)
        reach = f"{w['slip_reach_m'] * 1e3:10.2f}" if "slip_reach_m" in w else f"{'—':>10}"
        lines.append(
            f"{name:>8}  {w['max_slip_across_m'] * 1e3:16.3f}  {w['max_slip_along_m'] * 1e3:15.3f}"
            f"  {reach}  {flange}"
        )
    return lines


def _contact_slip_lines(summary: dict[str, Any]) -> list[str]:
    """Per sliding contact of a gmsh model or a frame: its largest point slip with its time,
    and its points' mean slip at the end (its size and its x, y, z components)."""
    groups = summary.get("contact_groups", {})
    slipping = {k: g for k, g in groups.items() if "max_slip_m" in g}
    if not slipping:
        return []
    lines = [" contact  max slip (mm)  at t (s)  final slip (mm)  final slip x, y, z (mm)"]
    for name, g in slipping.items():
        final = np.asarray(g["final_slip_m"], dtype=np.float64) * 1e3
        t = g.get("max_slip_time_s")
        at = f"{t:8.5f}" if t is not None else f"{'':8}"
        xyz = ", ".join(f"{c if abs(c) >= 5e-4 else 0.0:.3f}" for c in final)  # no "-0.000"
        lines.append(
            f"{name:>8}  {g['max_slip_m'] * 1e3:13.3f}  {at}  {np.linalg.norm(final):15.3f}  {xyz}"
        )
    return lines
