"""Heterogeneous (GC) run against the fully explicit run of the same crane scene.

The figures of the comparison are those of :mod:`crane_fem.plotting`; this module computes the
numbers the acceptance of the crane scene asks for:

- per wheel, the relative L2 difference over the run of the vertical displacement of the
  contact node pair (wheel and rail side), on the dynamic part u(t) − u(0) (the static preload
  deflection, identical in both runs, is left out: it would hide the differences) and on the
  whole u(t);
- the lift-off episodes of each wheel (all its pairs open, the flight higher than
  ``LIFT_HEIGHT``): count, onset and end times, and the onset shift in macro steps; the count of
  all separations (chatter included) beside it;
- the energy dissipated at the interface, relative to the largest magnitude of the external
  work over the run (the energy supplied by gravity and the earthquake);
- the wall-time ratio (explicit / heterogeneous), of the whole runs and of their time loops;
- criterion (b) of THEORY.md §8: every engineering quantity against the explicit run's with
  its tolerance (crane_fem.tolerances), the worst ratio and the quantities out.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from crane_fem.peaks import LIFT_GAP, LIFT_HEIGHT
from crane_fem.plotting import Run, load_runs
from crane_fem.scenario import COUPLED_METHODS
from crane_fem.spectra import read_spectra_csv
from crane_fem.tolerances import Check, judge_runs, with_spread
from crane_fem.tolerances import worst as worst_check

__all__ = [
    "compare_runs",
    "first_landing",
    "lift_off_episodes",
    "pair_l2",
    "separations",
    "write_comparison",
]

FloatArray = npt.NDArray[np.float64]


def separations(t: FloatArray, gap: FloatArray, lift_gap: float = LIFT_GAP) -> list[list[float]]:
    """[onset, end, height] of every interval where ``gap`` > ``lift_gap`` (end = the last
    time if the wheel is still off at the end of the run)."""
    off = gap > lift_gap
    edges = np.flatnonzero(np.diff(np.r_[0, off.astype(np.int8), 0]))
    return [
        [float(t[a]), float(t[b - 1]), float(np.max(gap[a:b]))]
        for a, b in zip(edges[::2], edges[1::2], strict=True)
    ]


def lift_off_episodes(
    t: FloatArray, gap: FloatArray, lift_gap: float = LIFT_GAP, height: float = LIFT_HEIGHT
) -> list[list[float]]:
    """[onset, end] of the lift-offs: separations (gap > ``lift_gap``) whose flight is higher
    than ``height``. The short, low separations that follow an impact (chatter of the
    node-to-node contact, tens of micrometres) are not lift-offs of the wheel."""
    return [[a, b] for a, b, h in separations(t, gap, lift_gap) if h > height]


def _rel_l2(a: FloatArray, ref: FloatArray) -> float:
    den = float(np.linalg.norm(ref))
    return float(np.linalg.norm(a - ref)) / den if den > 0 else float(np.linalg.norm(a - ref))


def pair_l2(run: Run, ref: Run, t_end: float | None = None) -> dict[int, tuple[float, float]]:
    """Per wheel, the relative L2 differences (wheel side, rail side) of u_z(t) − u_z(0) of
    the probed contact node pair between ``run`` and ``ref`` over [0, ``t_end``] (the whole
    run by default), ``ref`` interpolated to the times of ``run``."""
    t = run.history["t"]
    keep = t <= (t_end if t_end is not None else np.inf)
    out = {}
    for k in range(1, 5):
        if f"wheel{k}_wheel_uz" not in run.history:
            continue
        pair = []
        for side in ("wheel", "rail"):
            col = f"wheel{k}_{side}_uz"
            u = run.history[col][keep]
            u_ref = np.interp(t[keep], ref.history["t"], ref.history[col])
            pair.append(_rel_l2(u - u[0], u_ref - u_ref[0]))
        out[k] = (pair[0], pair[1])
    return out


def first_landing(run: Run, lift_gap: float = LIFT_GAP) -> float | None:
    """The time the last wheel comes down from its first lift-off (None without one)."""
    ends = [
        ep[0][1]
        for k in range(1, 5)
        if f"gap_wheel_{k}" in run.history
        and (ep := lift_off_episodes(run.history["t"], run.history[f"gap_wheel_{k}"], lift_gap))
    ]
    return max(ends) if ends else None


def compare_runs(
    het: Run, exp: Run, lift_gap: float = LIFT_GAP, members: list[Run] | None = None
) -> dict[str, Any]:
    """The comparison numbers (see the module docstring) of a coupled and an explicit run;
    with the explicit ensemble's ``members`` (the scene's explicit runs with the record
    × (1 ± ε), Δt × ½), criterion (b) judges each quantity by max(tolerance, their spread)
    and says which are beyond the scene's conditioning."""
    t = het.history["t"]
    te = exp.history["t"]
    t_land = first_landing(exp, lift_gap)
    to_landing = pair_l2(het, exp, t_land) if t_land is not None else {}
    out_land: dict[str, Any] = {"first_landing_s": t_land}
    dT = float(het.summary.get("dT", t[1] - t[0] if t.size > 1 else 1.0))
    out: dict[str, Any] = {"wheels": {}}
    worst = 0.0
    for k, dynamic in pair_l2(het, exp).items():
        w: dict[str, Any] = {}
        for side, l2 in zip(("wheel", "rail"), dynamic, strict=True):
            col = f"wheel{k}_{side}_uz"
            w[f"{side}_uz_l2_dynamic"] = l2
            w[f"{side}_uz_l2_total"] = _rel_l2(het.history[col], np.interp(t, te, exp.history[col]))
            worst = max(worst, l2)
        eh = lift_off_episodes(t, het.history[f"gap_wheel_{k}"], lift_gap)
        ee = lift_off_episodes(te, exp.history[f"gap_wheel_{k}"], lift_gap)
        w["lift_offs_heterogeneous"] = eh
        w["lift_offs_explicit"] = ee
        w["separations_heterogeneous"] = len(separations(t, het.history[f"gap_wheel_{k}"]))
        w["separations_explicit"] = len(separations(te, exp.history[f"gap_wheel_{k}"]))
        w["same_lift_off_count"] = len(eh) == len(ee)
        if len(eh) == len(ee) and eh:
            w["onset_shift_macro_steps"] = (
                max(abs(a[0] - b[0]) for a, b in zip(eh, ee, strict=True)) / dT
            )
        if k in to_landing:
            w["wheel_uz_l2_to_first_landing"], w["rail_uz_l2_to_first_landing"] = to_landing[k]
        out["wheels"][k] = w
    out["worst_pair_uz_l2_dynamic"] = worst
    out.update(out_land)
    ext = float(np.max(np.abs(het.history["external_work"])))
    ifd = het.history.get("interface_dissipated", np.zeros(1))
    out["external_work_max_abs_J"] = ext
    out["interface_dissipated_final_J"] = float(ifd[-1])
    out["interface_dissipated_max_abs_J"] = float(np.max(np.abs(ifd)))
    out["interface_dissipated_over_external_work"] = (
        float(np.max(np.abs(ifd))) / ext if ext > 0 else 0.0
    )
    wh, we = het.summary.get("wall_time_s"), exp.summary.get("wall_time_s")
    if isinstance(wh, float) and isinstance(we, float) and wh > 0:
        out["wall_time_s"] = {"heterogeneous": wh, "explicit": we}
        out["wall_time_ratio_explicit_over_heterogeneous"] = we / wh
    # The time loops alone (without set-up and output): the cost of each method.
    lh = het.summary.get("wall_time_integration_s")
    le = exp.summary.get("wall_time_integration_s")
    if isinstance(lh, float) and isinstance(le, float) and lh > 0:
        out["time_loop_s"] = {"heterogeneous": lh, "explicit": le}
        out["time_loop_ratio_explicit_over_heterogeneous"] = le / lh
    out["lift_gap_m"] = lift_gap
    out["lift_height_m"] = LIFT_HEIGHT
    checks = _tolerance_checks(het, exp)
    if members:
        checks = with_spread(checks, [_tolerance_checks(m, exp) for m in members])
        out["ensemble"] = [str(m.path) for m in members]
    out["tolerances"] = [
        {
            "quantity": c.quantity,
            "where": c.where,
            "note": c.note,
            "value": c.value,
            "explicit": c.reference,
            "unit": c.unit,
            "tolerance": c.rule,
            "ensemble_spread": c.spread,
            "beyond_conditioning": c.beyond_conditioning,
            "error_over_tolerance": c.ratio,
            "within": c.ok,
        }
        for c in checks
    ]
    top = worst_check(checks)
    out["worst_error_over_tolerance"] = top.ratio if top is not None else 0.0
    out["quantities_out_of_tolerance"] = sum(not c.ok for c in checks)
    out["quantities_beyond_conditioning"] = sum(c.beyond_conditioning for c in checks)
    return out


def _tolerance_checks(het: Run, exp: Run) -> list[Check]:
    """Criterion (b) of the two runs (their spectra where both wrote them)."""
    paths = [r.path / "spectra.csv" for r in (het, exp)]
    if all(p.exists() for p in paths):
        sh, se = (read_spectra_csv(p) for p in paths)
        return judge_runs(het.summary, exp.summary, sh, se)
    return judge_runs(het.summary, exp.summary)


def write_comparison(
    outdir: Path, ensemble: list[Path] | None = None
) -> tuple[Path, dict[str, Any]] | None:
    """Compare the coupled and the monolithic run found under ``outdir``, with the explicit
    ensemble's runs found under each of ``ensemble`` (run directories or directories of
    runs); write ``comparison.json`` there. None unless there is one run of each."""
    runs = load_runs(outdir)
    het = [r for r in runs if r.summary.get("method") in COUPLED_METHODS]
    exp = [r for r in runs if r.summary.get("method") == "monolithic"]
    if len(het) != 1 or len(exp) != 1:
        return None
    members = [m for d in ensemble or [] for m in load_runs(d)]
    result = compare_runs(het[0], exp[0], members=members)
    path = outdir / "comparison.json"
    path.write_text(json.dumps(result, indent=2, sort_keys=True))
    return path, result


def describe(result: dict[str, Any]) -> list[str]:
    """Lines summarising a comparison for the terminal."""
    lines = []
    for k, w in result["wheels"].items():
        shift = w.get("onset_shift_macro_steps")
        lines.append(
            f"wheel {k}: L2(u_z − u_z0) wheel {100 * w['wheel_uz_l2_dynamic']:.2f} %, rail "
            f"{100 * w['rail_uz_l2_dynamic']:.2f} %; lift-offs {len(w['lift_offs_heterogeneous'])} "
            f"(heterogeneous) / {len(w['lift_offs_explicit'])} (explicit)"
            + (f", onsets within {shift:.1f} macro steps" if shift is not None else "")
        )
    if result.get("first_landing_s") is not None and result["wheels"]:
        worst = max(
            max(w["wheel_uz_l2_to_first_landing"], w["rail_uz_l2_to_first_landing"])
            for w in result["wheels"].values()
        )
        lines.append(
            f"up to the first landing (t = {result['first_landing_s']:.4g} s): worst L2(u_z − "
            f"u_z0) {100 * worst:.2f} %"
        )
    lines.append(
        f"interface dissipated: max |E_Γ| = {result['interface_dissipated_max_abs_J']:.3e} J = "
        f"{100 * result['interface_dissipated_over_external_work']:.3f} % of max |external work|"
    )
    if "tolerances" in result:
        out_q = [t for t in result["tolerances"] if not t["within"]]
        lines.append(
            f"engineering tolerances (THEORY.md §8 (b)): {len(result['tolerances']) - len(out_q)} "
            f"of {len(result['tolerances'])} quantities within, worst error / tolerance "
            f"{result['worst_error_over_tolerance']:.2f}"
            + "".join(
                f"; out: {t['quantity']}, {t['where']} ({t['error_over_tolerance']:.2f})"
                for t in out_q[:5]
            )
        )
    if "ensemble" in result:
        beyond = [t for t in result["tolerances"] if t["beyond_conditioning"]]
        lines.append(
            f"judged by max(tolerance, the spread of {len(result['ensemble'])} explicit "
            f"ensemble runs): {len(beyond)} quantities beyond the scene's conditioning"
            + (
                ": " + "; ".join(f"{t['quantity']}, {t['where']}" for t in beyond[:6])
                if beyond
                else ""
            )
            + (", …" if len(beyond) > 6 else "")
        )
    if "time_loop_ratio_explicit_over_heterogeneous" in result:
        lt = result["time_loop_s"]
        ratio = result["time_loop_ratio_explicit_over_heterogeneous"]
        lines.append(
            f"time loop (the cost of each method): explicit {lt['explicit']:.1f} s, "
            f"heterogeneous {lt['heterogeneous']:.1f} s (explicit / heterogeneous {ratio:.2f})"
        )
    if "wall_time_ratio_explicit_over_heterogeneous" in result:
        wt = result["wall_time_s"]
        ratio = result["wall_time_ratio_explicit_over_heterogeneous"]
        lines.append(
            f"whole runs, set-up and output included: explicit {wt['explicit']:.1f} s, "
            f"heterogeneous {wt['heterogeneous']:.1f} s (ratio {ratio:.2f}; a fresh install's "
            "first run also compiles the kernels)"
        )
    return lines
