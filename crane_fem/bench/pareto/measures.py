"""The Pareto chart's error measures: the bar's against the exact d'Alembert solution, the
crane's against its Δt × ½ explicit reference within the accuracy window."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from crane_fem.bench.common import FloatArray, Outcome
from crane_fem.compare import lift_off_episodes, pair_l2
from crane_fem.exact import WallImpact
from crane_fem.plotting import Run

__all__ = [
    "MEASURES",
    "accuracy_window",
    "bar_errors",
    "contact_end_exact",
    "crane_errors",
    "wheel_peaks",
]

#: Error measures per case: (key, axis label); the first is the accuracy criterion's.
MEASURES = {
    "bar": [
        ("u_end_l2", "contact-end u, rel. L2 vs exact"),
        ("peak_force", "|peak force / ρc|v0|A − 1|"),
        ("energy_balance", "energy balance error"),
    ],
    "crane": [
        ("tolerance_ratio", "worst error / tolerance of (b) vs the explicit run"),
        ("pair_l2", "worst pair u_z L2 to 2nd take-off"),
        ("peak_force", "max over wheels |F_peak / F_ref − 1|"),
        ("energy_balance", "energy balance error"),
    ],
}


def contact_end_exact(exact: WallImpact, t: FloatArray) -> FloatArray:
    """u(0, t) of :class:`WallImpact` (the contact end), vectorised over ``t``: free flight,
    held at the wall for 2L/c, then the rebound at −v0."""
    t = np.asarray(t, dtype=np.float64)
    tc, v0 = exact.t_contact, exact.v0
    rebound = 2.0 * v0 * (tc + exact.length / exact.c) - v0 * t
    return np.where(t <= tc, v0 * t, np.where(t <= tc + exact.duration, v0 * tc, rebound))


def bar_errors(
    history: dict[str, FloatArray], summary: dict[str, Any], exact: WallImpact, force: float
) -> dict[str, float]:
    """The bar's errors against :class:`WallImpact`: relative L2 over the run (through the
    release) of the contact-end displacement (``gap_wall`` − gap); ``|peak force / force −
    1|`` with ``force`` the exact contact force ρ c |v0| A (the peak of every micro step,
    summary ``contact_groups.wall.peak_force_N``, else of the history rows); the run's energy
    balance error; and
    the contact duration error relative to 2L/c (from the micro-step contact intervals)."""
    t = history["t"]
    u = history["gap_wall"] - exact.gap
    u_ex = contact_end_exact(exact, t)
    den = float(np.linalg.norm(u_ex))
    wall = (summary.get("contact_groups") or {}).get("wall") or {}
    peak = float(wall.get("peak_force_N", np.max(history["force_wall"])))
    out = {
        "u_end_l2": float(np.linalg.norm(u - u_ex)) / den if den > 0 else math.nan,
        "peak_force": abs(peak / force - 1.0),
        "energy_balance": float(summary.get("energy_balance_error", math.nan)),
    }
    iv = summary.get("contact_interval_times") or []
    if iv:
        duration = float(iv[-1][1]) - float(iv[0][0])
        out["contact_duration"] = abs(duration / exact.duration - 1.0)
    return out


def wheel_peaks(summary: dict[str, Any], history: dict[str, FloatArray]) -> FloatArray:
    """Per wheel (1–4), the peak contact force: ``summary["wheels"][k]["peak_force_N"]`` (every
    micro step) when present, else the largest ``force_wheel_k`` of the history (its rows only:
    the macro steps, or every ``ratio`` steps of a monolithic run)."""
    wheels = summary.get("wheels") or {}
    out = np.full(4, np.nan)
    for k in range(1, 5):
        w = wheels.get(str(k), wheels.get(k)) if isinstance(wheels, dict) else None
        if isinstance(w, dict) and "peak_force_N" in w:
            out[k - 1] = float(w["peak_force_N"])
        elif f"force_wheel_{k}" in history:
            out[k - 1] = float(np.max(history[f"force_wheel_{k}"]))
    return out


def accuracy_window(history: dict[str, FloatArray]) -> tuple[float, str]:
    """The end of the crane's accuracy window from the reference's history: the onset of its
    second take-off (the bounce of the first landing), latest over the wheels; the end of the
    run without one. Returns the time and how it was found."""
    t = history["t"]
    onsets = [
        eps[1][0]
        for k in range(1, 5)
        if f"gap_wheel_{k}" in history
        and len(eps := lift_off_episodes(t, history[f"gap_wheel_{k}"])) >= 2
    ]
    if onsets:
        return float(max(onsets)), "the reference's second take-off (latest over the wheels)"
    return float(t[-1]), "the end of the run (the reference has no second take-off)"


def crane_errors(run: Outcome, ref: Outcome, t_acc: float, nominal: Outcome) -> dict[str, float]:
    """The crane's errors: the worst error / tolerance over every quantity of criterion (b)
    against the ``nominal`` fully explicit run (Δt = 0.9 Δt_crit, THEORY.md §8; the
    accuracy axis); against the Δt × ½ explicit reference ``ref``, the worst relative L2 of
    the pair displacement u_z − u_z(0) (wheel and rail sides, four wheels) up to ``t_acc``
    and the largest relative error of a wheel's peak contact force; the run's energy
    balance error; besides, the worst L2 of the wheel side alone (``pair_l2_wheel_side``)."""
    from crane_fem.bench.ensemble import judge
    from crane_fem.tolerances import worst

    w = worst(judge(run, nominal))
    l2 = pair_l2(
        Run(run.outdir, run.history, run.summary), Run(ref.outdir, ref.history, ref.summary), t_acc
    )
    peaks, peaks_ref = wheel_peaks(run.summary, run.history), wheel_peaks(ref.summary, ref.history)
    return {
        "tolerance_ratio": w.ratio if w is not None else math.nan,
        "pair_l2": max((max(v) for v in l2.values()), default=math.nan),
        "peak_force": float(np.max(np.abs(peaks / peaks_ref - 1.0))),
        "energy_balance": float(run.summary.get("energy_balance_error", math.nan)),
        "pair_l2_wheel_side": max((v[0] for v in l2.values()), default=math.nan),
    }
