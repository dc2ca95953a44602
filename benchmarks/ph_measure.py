"""Prakash–Hjelmstad: its interface energy in the measure of its argument (S_E + the implicit
side's energy, docs/theory-notes.md §10) against the physical one, on the linear split bar.

    python benchmarks/ph_measure.py

Prints the Markdown table that goes into benchmarks/RESULTS.md.
"""

from __future__ import annotations

import warnings

import numpy as np

import crane_fem  # noqa: F401  (MPI first)
from crane_fem.driver import run_scenario
from crane_fem.scenario import parse_scenario

SUBS = [
    {"name": "near", "groups": ["left"], "scheme": "cd-lagrange"},
    {"name": "far", "groups": ["right"], "scheme": "newmark"},
]


def split_bar(m: int, end: float, dt_factor: float = 0.5):  # type: ignore[no-untyped-def]
    return parse_scenario(
        {
            "name": "ph_measure",
            "model": {"kind": "bar", "length": 1.0, "elements": 400, "split": 0.4},
            "material": {"E": 1.0, "rho": 1.0},
            "initial": {"pulse": {"center": 0.2, "width": 0.2, "amplitude": 1e-3}},
            "subdomain": SUBS,
            "coupling": {"method": "ph", "ratio": m},
            "time": {"end": end, "dt_factor": dt_factor},
            "output": {"xdmf": False},
            "monitor": {"energy_growth": 1e12},
        }
    )


def measure(m: int, end: float) -> dict[str, float]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = run_scenario(split_bar(m, end), "out/bench_ph", progress=False)
    h, s = res.history, res.summary
    e0 = h["total"][0]
    e_ph0 = h["energy_ph_explicit"][0] + h["kinetic_implicit"][0] + h["internal_implicit"][0]
    return {
        "macro": s["steps"],
        "kmin": s["ph_kappa_min"],
        "kmax": s["ph_kappa_max"],
        "eph0": e_ph0 / e0,
        "ph": float(np.max(np.abs(h["interface_energy_ph"]))) / e_ph0,
        "phys": float(h["interface_dissipated"][-1]) / e0,
        "emax": float(np.max(h["kinetic"] + h["internal"])) / e0,
    }


def main() -> None:
    print(
        "| m | macro steps | κ min | κ max | E_PH(0)/E0 "
        "| max abs. interface energy, PH measure / E_PH(0) "
        "| physical interface energy / E0 (end) | max physical energy / E0 |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for m in (1, 2, 10, 100, 1000):
        for end in (max(1.0, 8 * m * 0.5 / 400), 40.0):
            r = measure(m, end)
            print(
                f"| {m} | {r['macro']} | {r['kmin']:.2e} | {r['kmax']:.2e} | {r['eph0']:.3g} | "
                f"{r['ph']:.1e} | {r['phys']:.2e} | {r['emax']:.3g} |"
            )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = run_scenario(split_bar(30, 1.0), "out/bench_ph", progress=False)
    print(f"\nm = 30 (Δt = h/2): {res.summary['ph_measure']}")


if __name__ == "__main__":
    main()
