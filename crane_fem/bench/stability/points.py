"""A point of the stability map: its scheme, its run and its class (stable, energy growth,
unstable, refused)."""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from mpi4py import MPI

from crane_fem.bench.common import FloatArray, run_case, toml_value
from crane_fem.errors import CraneFemError
from crane_fem.scenario import load_scenario

__all__ = [
    "CLASSES",
    "ENERGY_GROWTH",
    "GROWTH",
    "HISTORY_ROWS",
    "REFUSED",
    "STABLE",
    "UNSTABLE",
    "Point",
    "Scheme",
    "classify",
    "run_point",
]

STABLE, GROWTH, UNSTABLE, REFUSED = "stable", "energy growth", "unstable", "refused"
#: The classes of a point. "refused": the package would not run it (Δt above the explicit
#: critical step on a coupled path, `ph` with a contact in the explicit side, `ec` whose
#: passes do not converge through a contact): the run stops with a CraneFemError, no verdict.
CLASSES = (STABLE, GROWTH, UNSTABLE, REFUSED)

#: A completed run whose max(kinetic + internal)/E0 exceeds this has created energy
#: ("energy growth"). No scene of the map has external work, so kinetic + internal can pass E0
#: only if the scheme or the interface creates energy. Measured on these scenes (full sweep),
#: the stable schemes stay at E0 or below to six digits (CD-Lagrange and Moreau–Jean on the
#: wall, where contact only dissipates; `ec`, `gc-mean` and `hybrid` on the undamped split
#: bar), while GC and PH show bounded excursions of up to +6.4 % (m = 1, while the pulse
#: crosses the interface, the same after 50 and 200 time units) and GC up to +4.9 % on the
#: split bar on the wall. 10 % sits above those and below what the map is looking for: GC's
#: weak instability (×1.6 to ×7·10⁵ over 200 time units without dissipation; RESULTS.md
#: "Long-run stability of the coupling") and explicit penalty near its own limit (the bar
#: leaves the wall with ×1.1 to ×9.6 the energy it came with).
ENERGY_GROWTH = 1.1

#: History rows kept per run (``output.every`` is set from it): enough to see growth, which
#: is slow when the run completes; the energy-growth monitor checks every step regardless.
HISTORY_ROWS = 500


@dataclass(frozen=True)
class Scheme:
    """A row of the map: its family ("wall", "coupled", "undamped"), the run's label, the
    parameter it stands for and the scenario settings that make it; ``row`` names its row
    in the tables (the label by default)."""

    family: str
    label: str
    parameter: str = ""
    settings: dict[str, Any] = field(default_factory=dict, hash=False, compare=False)
    k: float | None = None  #: penalty stiffness in units of EA/h
    m: int | None = None  #: coupling ratio ΔT/Δt
    row: str = ""

    @property
    def row_label(self) -> str:
        return self.row or self.label


@dataclass
class Point:
    """One run of the map and its class. ``dt_ratio``: Δt/(h/c) on the wall (the mesh's
    critical step), Δt/Δt_crit of the explicit half on the split bars; ``limit_ratio``:
    penalty's own limit 2/ω_p (springs closed) in units of h/c; ``own_ratio``: Δt/(2/ω_p);
    ``t_growth``: the first time E/E0 passed :data:`ENERGY_GROWTH`; ``contact_intervals``:
    the contact episodes of the run (one per impact without chatter)."""

    scheme: Scheme
    dt_ratio: float
    cls: str
    energy_ratio: float
    wall_s: float
    limit_ratio: float = math.nan
    own_ratio: float = math.nan
    t_growth: float = math.nan
    diagnosis: str = ""
    contact_intervals: int | None = None

    def row(self) -> dict[str, Any]:
        s = self.scheme

        def num(x: float) -> Any:
            return "" if math.isnan(x) else x

        return {
            "family": s.family,
            "scheme": s.label,
            "parameter": s.parameter,
            "dt_ratio": self.dt_ratio,
            "m": "" if s.m is None else s.m,
            "k_EA_over_h": "" if s.k is None else float(s.k),
            "class": self.cls,
            "max_energy_ratio": num(self.energy_ratio),
            "wall_s": self.wall_s,
            "penalty_limit_ratio": num(self.limit_ratio),
            "dt_over_penalty_limit": num(self.own_ratio),
            "t_growth": num(self.t_growth),
            "contact_intervals": "" if self.contact_intervals is None else self.contact_intervals,
            "diagnosis": self.diagnosis,
        }


def classify(status: str, energy: FloatArray) -> tuple[str, float]:
    """(class, max E/E0) of a run from its status and its kinetic + internal energy history
    (E0 first): "unstable" if the energy-growth monitor stopped it or an energy is not
    finite (max E/E0 then reported as inf), "energy growth" if it completed with
    max E/E0 > :data:`ENERGY_GROWTH`, else "stable"."""
    finite = energy.size > 0 and bool(np.all(np.isfinite(energy)))
    if status != "completed" or not finite:
        return UNSTABLE, math.inf  # the rows written before the stop miss the divergence
    e0 = float(energy[0])
    ratio = float(np.max(energy)) / e0 if e0 > 0.0 else math.inf
    return (GROWTH if ratio > ENERGY_GROWTH else STABLE), ratio


def run_point(
    scheme: Scheme,
    dt_ratio: float,
    scenario: Path,
    settings: dict[str, Any],
    outdir: Path,
    comm: MPI.Comm | None = None,
) -> Point:
    """Run ``scenario`` with ``settings`` into ``outdir`` and classify it (collective). A run
    the package refuses (a :class:`CraneFemError` other than divergence, once the scenario
    itself has validated) is "refused"."""
    overrides = [f"{k}={toml_value(v)}" for k, v in sorted(settings.items())]
    load_scenario(scenario, overrides)  # a bad key is the map's bug: raise it, don't classify
    t0 = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # "Δt exceeds the critical step"
            out = run_case(outdir.name, scenario, settings, outdir, comm)
    except CraneFemError as exc:
        reason = str(exc).splitlines()[0]
        wall = time.perf_counter() - t0
        return Point(scheme, dt_ratio, REFUSED, math.nan, wall, diagnosis=reason)
    h = out.history
    energy = h["kinetic"] + h["internal"] if "kinetic" in h else np.zeros(0)
    cls, ratio = classify(out.status, energy)
    t_growth = math.nan
    if cls == GROWTH:
        t_growth = float(h["t"][np.argmax(energy > ENERGY_GROWTH * energy[0])])
    wall = float(out.summary.get("wall_time_s", time.perf_counter() - t0))
    limit, crit = out.summary.get("dt_critical_penalty"), out.summary.get("dt_critical")
    lim = float(limit) / float(crit) if limit and crit else math.nan
    diagnosis = out.diagnosis.splitlines()[0] if out.diagnosis else ""
    intervals = out.summary.get("contact_intervals")
    return Point(
        scheme,
        dt_ratio,
        cls,
        ratio,
        wall,
        lim,
        math.nan,
        t_growth,
        diagnosis,
        None if intervals is None else int(intervals),
    )
