"""What ``crane-fem modes`` reports: the modal table, the response-spectrum forces, their
comparison with a time-history run's peaks, as printed lines and as ``modes.json``."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from crane_fem.errors import ScenarioError
from crane_fem.modes.eigen import ModalBasis
from crane_fem.modes.estimate import SpectralEstimate

__all__ = [
    "ComparisonRow",
    "ModesReport",
    "compare_with_run",
    "read_run_summary",
    "report_dict",
    "report_lines",
]

FloatArray = npt.NDArray[np.float64]
AXES = "xyz"


@dataclass(frozen=True)
class ComparisonRow:
    """One force of the response-spectrum estimate beside a time history's peak (N)."""

    quantity: str
    where: str
    rs_srss: float
    rs_cqc: float
    th: float

    @property
    def ratio(self) -> float:
        """RS (CQC) / TH; inf when the time history's peak is 0."""
        return self.rs_cqc / self.th if self.th > 0.0 else math.inf


@dataclass(frozen=True, eq=False)
class ModesReport:
    """The results of ``crane-fem modes`` (global values, identical on every rank).

    Attributes:
        scenario: the scenario's name.
        degree: the Lagrange degree of the displacement.
        free_dofs: the free DOFs of the eigenproblem.
        mass_total: ∫ ρ dx of the whole structure, kg (the hoisted mass included).
        basis: the modes (its ``shapes`` are this rank's).
        damping: ζ_i of each mode.
        estimate: the response-spectrum estimate, or None without a ground motion.
        comparison: its forces beside a run's peaks (empty without ``--compare``).
        run: the compared run's directory, or None.
    """

    scenario: str
    degree: int
    free_dofs: int
    mass_total: float
    basis: ModalBasis
    damping: FloatArray
    estimate: SpectralEstimate | None
    comparison: list[ComparisonRow]
    run: Path | None = None
    #: A mixed model's (crane_fem.modes.mixed): two shapes files.
    mixed: bool = False


def read_run_summary(run: Path) -> dict[str, Any]:
    """The ``summary.json`` of a ``crane-fem run`` directory (not collective).

    Raises:
        ScenarioError: no such file, not JSON, or no time-history peaks in it.
    """
    path = Path(run) / "summary.json"
    try:
        summary = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ScenarioError(
            f"--compare {run}: no summary.json (a crane-fem run directory)"
        ) from None
    except (OSError, ValueError) as exc:
        raise ScenarioError(f"--compare {run}: cannot read summary.json: {exc}") from None
    if not isinstance(summary, dict) or not ("supports" in summary or "wheels" in summary):
        raise ScenarioError(
            f"--compare {run}: summary.json has no supports' or wheels' peaks to compare with"
        )
    return summary


def compare_with_run(est: SpectralEstimate, summary: dict[str, Any]) -> list[ComparisonRow]:
    """The estimate's peaks (static + seismic) beside the run's: each support's vertical
    force and force magnitude, each wheel's contact force (not collective)."""
    rows: list[ComparisonRow] = []
    srss, cqc = est.peak("srss"), est.peak("cqc")
    for k in range(srss.support.shape[0]):
        th = summary.get("supports", {}).get(str(k + 1))
        if th is None:
            continue
        rows.append(
            ComparisonRow(
                "vertical",
                f"support {k + 1}",
                srss.support[k, 2],
                cqc.support[k, 2],
                float(th["peak_vertical_N"]),
            )
        )
        rows.append(
            ComparisonRow(
                "magnitude", f"support {k + 1}", float(np.linalg.norm(srss.support[k])),
                float(np.linalg.norm(cqc.support[k])), float(th["peak_force_N"]),
            )
        )  # fmt: skip
    for w in range(srss.wheel.size):
        th = summary.get("wheels", {}).get(str(w + 1))
        if th is not None:
            rows.append(
                ComparisonRow(
                    "contact", f"wheel {w + 1}", float(srss.wheel[w]), float(cqc.wheel[w]),
                    float(th["peak_force_N"]),
                )
            )  # fmt: skip
    return rows


def _xyz(values: FloatArray) -> dict[str, float]:
    return {c: float(v) for c, v in zip(AXES, values, strict=True)}


def _moments(est: SpectralEstimate, k: int) -> dict[str, Any]:
    """Support ``k``'s moments about its centre (N·m), for a structure with rotational DOFs
    (beams); empty otherwise."""
    if est.static.moment.shape[1] == 0:
        return {}
    peak = est.peak("cqc").moment[k]
    return {
        "static_moment_Nm": [float(x) for x in est.static.moment[k]],
        "srss_moment_Nm": [float(x) for x in est.srss.moment[k]],
        "cqc_moment_Nm": [float(x) for x in est.cqc.moment[k]],
        "residual_moment_Nm": [float(x) for x in est.residual.moment[k]],
        "peak_moment_Nm": float(np.linalg.norm(peak)),
    }


def report_dict(rep: ModesReport) -> dict[str, Any]:
    """``modes.json``: the modes, the estimate and the comparison (not collective)."""
    b = rep.basis
    modes = []
    for i in range(b.omega.size):
        mode: dict[str, Any] = {
            "mode": i + 1,
            "frequency_hz": float(b.frequency[i]),
            "period_s": float(1.0 / b.frequency[i]),
            "damping": float(rep.damping[i]),
            "participation_factor": _xyz(b.gamma[i]),
            "effective_mass_kg": _xyz(b.effective_mass[i]),
            "effective_mass_fraction": _xyz(b.effective_fraction[i]),
            "cumulative_fraction": _xyz(b.cumulative_fraction[i]),
        }
        if rep.estimate is not None:
            mode["sa_m_s2"] = _xyz(rep.estimate.sa[i])
        modes.append(mode)
    out: dict[str, Any] = {
        "scenario": rep.scenario,
        "contacts": "closed: wheel/rail pairs (a gmsh model's touching contact points, on "
        "their triangles) tied in x, y, z by k_p; flanges and open points left open",
        "degree": rep.degree,
        "mass_matrix": "consistent",
        "shapes": (
            "mass-normalised (phi^T M phi = 1), modes.xdmf (the solids) and modes_beams.xdmf "
            "(the beams; the joints' beam nodes recovered from their faces)"
            if rep.mixed
            else "mass-normalised (phi^T M phi = 1), modes.xdmf"
        ),
        "free_dofs": rep.free_dofs,
        "mass_total_kg": rep.mass_total,
        "mass_free_kg": _xyz(b.total_mass),
        "cumulative_fraction": _xyz(b.cumulative_fraction[-1]),
        "modes": modes,
    }
    est = rep.estimate
    if est is not None:
        dyn, peak = est.dynamic("cqc"), est.peak("cqc")
        supports = {
            str(k + 1): {
                "centre_m": [float(x) for x in est.support_centres[k]],
                "static_N": [float(x) for x in est.static.support[k]],
                "srss_N": [float(x) for x in est.srss.support[k]],
                "cqc_N": [float(x) for x in est.cqc.support[k]],
                "residual_N": [float(x) for x in est.residual.support[k]],
                "peak_vertical_N": float(peak.support[k, 2]),
                "peak_force_N": float(np.linalg.norm(peak.support[k])),
                **_moments(est, k),
            }
            for k in range(est.static.support.shape[0])
        }
        wheels = {
            str(w + 1): {
                "static_N": float(est.static.wheel[w]),
                "srss_N": float(est.srss.wheel[w]),
                "cqc_N": float(est.cqc.wheel[w]),
                "residual_N": float(est.residual.wheel[w]),
                "peak_N": float(peak.wheel[w]),
                "min_N": float(est.static.wheel[w] - dyn.wheel[w]),
                "lift_off": bool(est.static.wheel[w] - dyn.wheel[w] < 0.0),
            }
            for w in range(est.static.wheel.size)
        }
        out["response_spectrum"] = {
            "window_s": [0.0, est.window],
            "zpa_m_s2": _xyz(est.zpa),
            "combination": "modes by SRSS or CQC (Der Kiureghian), directions by SRSS, "
            "missing mass by SRSS; peak = |static| + dynamic (CQC)",
            "supports": supports,
            "wheels": wheels,
        }
    if rep.comparison:
        out["comparison"] = {
            "run": str(rep.run),
            "rows": [
                {
                    "quantity": r.quantity,
                    "where": r.where,
                    "rs_srss_N": r.rs_srss,
                    "rs_cqc_N": r.rs_cqc,
                    "th_N": r.th,
                    "ratio_rs_th": r.ratio,
                }
                for r in rep.comparison
            ],
        }
    return out


def report_lines(rep: ModesReport) -> list[str]:
    """The table to print (not collective)."""
    b = rep.basis
    lines = [
        f"{rep.scenario}: {b.omega.size} modes with the contacts closed (P{rep.degree}, "
        f"consistent mass, {rep.free_dofs} free DOFs; free mass {b.total_mass[0]:.1f} kg of "
        f"{rep.mass_total:.1f} kg)",
        " mode     f (Hz)  ζ (%)   m_eff x (%)    y (%)    z (%)   cumul. x (%)    y (%)    z (%)",
    ]
    for i in range(b.omega.size):
        fr, cu = 100.0 * b.effective_fraction[i], 100.0 * b.cumulative_fraction[i]
        lines.append(
            f"{i + 1:5d} {b.frequency[i]:10.3f} {100.0 * rep.damping[i]:6.2f} {fr[0]:13.2f} "
            f"{fr[1]:8.2f} {fr[2]:8.2f} {cu[0]:14.2f} {cu[1]:8.2f} {cu[2]:8.2f}"
        )
    est = rep.estimate
    if rep.mixed:
        lines.append(
            "a mixed model: solids and beams through their joints, the joints' beam nodes "
            "following their faces"
        )
    if est is None:
        lines.append("no ground motion in the scenario: no response-spectrum estimate")
        return lines
    shaken = ", ".join(f"{c} {est.zpa[d]:.4g}" for d, c in enumerate(AXES) if est.zpa[d] > 0)
    lines.append(
        f"response spectrum of the input over [0, {est.window:g}] s (ZPA {shaken} m/s²): "
        f"{b.omega.size} modes by SRSS and CQC, + missing mass; peak = |static| + dynamic (CQC)"
    )
    lines.append(
        f"{'force':>19}  {'static (kN)':>11}  {'SRSS (kN)':>9}  {'CQC (kN)':>8}  "
        f"{'residual (kN)':>13}  {'peak (kN)':>9}"
    )
    peak = est.peak("cqc")
    for k in range(est.static.support.shape[0]):
        lines.append(
            f"{f'support {k + 1} vertical':>19}  {est.static.support[k, 2] / 1e3:11.3f}  "
            f"{est.srss.support[k, 2] / 1e3:9.3f}  {est.cqc.support[k, 2] / 1e3:8.3f}  "
            f"{est.residual.support[k, 2] / 1e3:13.3f}  {peak.support[k, 2] / 1e3:9.3f}"
        )
    if est.static.moment.shape[1]:
        lines.append(
            f"{'moment':>19}  {'static (kN·m)':>13}  {'SRSS (kN·m)':>11}  {'CQC (kN·m)':>10}  "
            f"{'residual (kN·m)':>15}  {'peak (kN·m)':>11}   (magnitudes about each centre)"
        )
        norm = {
            "static": np.linalg.norm(est.static.moment, axis=1),
            "srss": np.linalg.norm(est.srss.moment, axis=1),
            "cqc": np.linalg.norm(est.cqc.moment, axis=1),
            "residual": np.linalg.norm(est.residual.moment, axis=1),
            "peak": np.linalg.norm(peak.moment, axis=1),
        }
        for k in range(est.static.moment.shape[0]):
            lines.append(
                f"{f'support {k + 1}':>19}  {norm['static'][k] / 1e3:13.3f}  "
                f"{norm['srss'][k] / 1e3:11.3f}  {norm['cqc'][k] / 1e3:10.3f}  "
                f"{norm['residual'][k] / 1e3:15.3f}  {norm['peak'][k] / 1e3:11.3f}"
            )
    dyn = est.dynamic("cqc")
    for w in range(est.static.wheel.size):
        lift = "  (lift-off: static − dynamic < 0)" if est.static.wheel[w] < dyn.wheel[w] else ""
        lines.append(
            f"{f'wheel {w + 1}':>19}  {est.static.wheel[w] / 1e3:11.3f}  "
            f"{est.srss.wheel[w] / 1e3:9.3f}  {est.cqc.wheel[w] / 1e3:8.3f}  "
            f"{est.residual.wheel[w] / 1e3:13.3f}  {peak.wheel[w] / 1e3:9.3f}{lift}"
        )
    if rep.comparison:
        lines.append(f"response spectrum (RS) against the time history (TH) of {rep.run}:")
        lines.append(
            f"{'force':>19}  {'RS SRSS (kN)':>12}  {'RS CQC (kN)':>11}  {'TH (kN)':>9}  "
            f"{'RS/TH':>6}"
        )
        for r in rep.comparison:
            lines.append(
                f"{f'{r.where} {r.quantity}':>19}  {r.rs_srss / 1e3:12.3f}  "
                f"{r.rs_cqc / 1e3:11.3f}  {r.th / 1e3:9.3f}  {r.ratio:6.2f}"
            )
    return lines
