"""The runs of the Pareto chart: the bar's schemes and couplings, the crane's explicit runs
and couplings at their ratios."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from crane_fem.bench.common import demo
from crane_fem.bench.pareto.points import Spec
from crane_fem.exact import WallImpact
from crane_fem.scenario import BarModel, Contact, load_scenario

__all__ = ["COUPLINGS", "CRANE_RATIOS", "NOMINAL", "REFINING_FULL", "bar_specs", "crane_specs"]

#: The stress-grade full-side scene refining at impacts as demos/crane_stress_reduced.toml
#: does (crane_stress.toml itself keeps GC at m = 200).
REFINING_FULL = {
    "coupling.method": "gc-mean",
    "coupling.fine_ratio": 20,
    "coupling.refine_quiet": 1e-3,
    "newmark.mass": "lumped",
}

#: The crane's nominal fully explicit run (``explicit_settings(scene)``, the keys it sets);
#: :func:`~crane_fem.bench.common.explicit_settings` gives its Δt × ½ reference. The ensemble
#: suite makes the same runs with the same settings (bench.common memoises them in-process:
#: the second suite reuses them).
NOMINAL = {"coupling.method": "monolithic", "output.xdmf": False}
#: The coupling methods of the chart (ph refuses an active explicit contact; ec refuses a
#: contact that changes state near the interface: both cases have one).
COUPLINGS = ("gc", "gc-mean", "hybrid")

#: The crane's coupling ratios per mode ("reduced": gc with the reduced implicit side). Left
#: out: m = 1 (an implicit solve per micro step: ~46 000 on crane_quick, ~150 000 of ~19 ms on
#: crane_stress); hybrid at m = 1000 (each macro step in which a contact changes state is redone
#: with 1000 implicit solves: 1.1e3 s per simulated second on crane_quick) and, in quick mode,
#: the costlier or redundant points (the quick budget is 3.5 min).
CRANE_RATIOS: dict[str, dict[str, tuple[int, ...]]] = {
    "quick": {
        "gc": (10, 100, 1000),
        "gc-mean": (10, 100),
        "hybrid": (100,),
        "reduced": (100, 1000),
    },
    "full": {
        "gc": (10, 100, 200, 1000),
        "gc-mean": (10, 100, 1000),
        "hybrid": (10, 100),
        "reduced": (10, 100, 200, 1000),
    },
}


def bar_specs() -> tuple[list[Spec], WallImpact, float]:
    """The bar of demos/split_bar.toml: single-subdomain (bar_impact.toml made the same bar)
    for CD-Lagrange, penalty and Moreau–Jean; the split bar for the couplings."""
    split = load_scenario(demo("split_bar"))
    mdl = split.model
    assert isinstance(mdl, BarModel)
    c = math.sqrt(split.uniform_material.E / split.uniform_material.rho)
    wall = split.contact[0]
    assert isinstance(wall, Contact)
    gap = wall.gap
    exact = WallImpact(mdl.length, c, split.initial.bar_velocity, gap)
    single = {
        "model.length": mdl.length,
        "model.elements": mdl.elements,
        "model.area": mdl.area,
        "material.E": split.uniform_material.E,
        "material.rho": split.uniform_material.rho,
        "initial.velocity": split.initial.velocity,
        "contact.0.gap": gap,
        "time.end": split.time.end,
        "output.xdmf": False,
    }
    bar = demo("bar_impact")
    specs: list[Spec] = []
    for f in (0.9, 0.5, 0.25, 0.1):
        s = {**single, "integrator.scheme": "cd-lagrange", "time.dt_factor": f}
        specs.append(Spec("bar", "CD-Lagrange", f"bar_cd_dt{f:g}", bar, s, {"dt_factor": f}))
    # Penalty: k against the element stiffness EA/h; Δt = 0.9 × the limit with the springs.
    k_el = split.uniform_material.E * mdl.area * mdl.elements / mdl.length
    for r in (0.1, 1.0, 10.0, 100.0):
        s = {**single, "integrator.scheme": "penalty", "integrator.penalty": r * k_el}
        s["time.dt_factor"] = 0.9
        params = {"k": r * k_el, "dt_factor": 0.9}
        specs.append(Spec("bar", "penalty", f"bar_penalty_k{r * k_el:g}", bar, s, params))
    for theta, fam in ((0.5, "Moreau–Jean θ=½"), (1.0, "Moreau–Jean θ=1")):
        for f in (0.25, 0.9, 3.0):
            s = {**single, "integrator.scheme": "moreau-jean", "integrator.theta": theta}
            s["time.dt_factor"] = f
            label = f"bar_mj{theta:g}_dt{f:g}"
            specs.append(Spec("bar", fam, label, bar, s, {"theta": theta, "dt_factor": f}))
    # m = 1000 is left out: ΔT = 1000 Δt = 4.5 s exceeds the whole run (2.4 s).
    for method in COUPLINGS:
        for m in (1, 10, 100):
            s = {"coupling.method": method, "coupling.ratio": m, "output.xdmf": False}
            lab = f"split_bar_{method}_m{m}"
            specs.append(Spec("bar", method, lab, demo("split_bar"), s, {"m": m}))
    force = split.uniform_material.rho * c * abs(split.initial.bar_velocity) * mdl.area
    return specs, exact, force


def _coupled_settings(scene: Path, method: str, m: int) -> dict[str, Any]:
    """``method`` at ratio ``m`` on ``scene``, without the keys the scene already has (the
    ensemble suite runs the scene's own method and ratio with ``output.xdmf`` only: shared)."""
    sc = load_scenario(scene)
    assert sc.coupling is not None
    s: dict[str, Any] = {"output.xdmf": False}
    if method != sc.coupling.method:
        s["coupling.method"] = method
    if m != sc.coupling.ratio:
        s["coupling.ratio"] = m
    if sc.coupling.fine_ratio is not None:  # a fixed ratio: the refining keys go
        s.update({"coupling.fine_ratio": None, "coupling.refine_quiet": None})
    return s


def crane_specs(quick: bool, window: float) -> tuple[list[Spec], str]:
    """The crane's runs after its reference: the explicit family, the couplings at the ratios
    of :data:`CRANE_RATIOS`, the reduced side. Quick: crane_quick (the reduced side by --set
    on its implicit subdomain); full: crane_stress and crane_stress_reduced, the m = 10 runs
    to ``window`` only."""
    scene = demo("crane_quick" if quick else "crane_stress")
    name = scene.stem
    specs = [
        Spec("crane", "CD-Lagrange", f"{name}_explicit_dt0.9", scene, NOMINAL, {"dt_factor": 0.9}),
    ]
    # Rows every 0.75 × ratio steps of 0.6 Δt_crit: on every other row of the reference's
    # time grid (ratio steps of 0.45 Δt_crit), as the nominal run's, so that pair_l2 does not
    # interpolate the reference between its rows (that error would hide the run's own).
    sc0 = load_scenario(scene)
    assert sc0.coupling is not None
    s = {**NOMINAL, "time.dt_factor": 0.6, "coupling.ratio": round(0.75 * sc0.coupling.ratio)}
    specs.append(
        Spec("crane", "CD-Lagrange", f"{name}_explicit_dt0.6", scene, s, {"dt_factor": 0.6})
    )
    ratios = CRANE_RATIOS["quick" if quick else "full"]
    modes = 100 if quick else 200
    reduced = scene if quick else demo("crane_stress_reduced")
    for method, ms in ratios.items():
        for m in ms:
            params: dict[str, float] = {"m": m}
            if method == "reduced":
                s = _coupled_settings(reduced, "gc", m)
                if quick:
                    s.update({"subdomain.1.scheme": "newmark-reduced", "subdomain.1.modes": modes})
                params["modes"] = modes
                fam, sc, label = "gc, reduced implicit", reduced, f"{name}_reduced_m{m}"
            else:
                s = _coupled_settings(scene, method, m)
                fam, sc, label = method, scene, f"{name}_{method}_m{m}"
            if m == 10 and not quick:
                s["time.end"] = params["time_end"] = window
            specs.append(Spec("crane", fam, label, sc, s, params))
    # The macro step that refines at impacts: the scenes that use it as written (quick: the
    # scene itself; full: the stress-grade reduced scene), and the full side with its keys.
    fam = "gc-mean refining"
    if quick:
        specs.append(Spec("crane", fam, f"{name}_refining", scene, {"output.xdmf": False}, {}))
    else:
        full = {"output.xdmf": False, **REFINING_FULL}
        specs.append(Spec("crane", fam, f"{name}_refining", scene, full, {"m": 200}))
        red = demo("crane_stress_reduced")
        specs.append(
            Spec(
                "crane",
                f"{fam}, reduced",
                f"{name}_reduced_refining",
                red,
                {"output.xdmf": False},
                {"modes": modes},
            )
        )
    return specs, name
