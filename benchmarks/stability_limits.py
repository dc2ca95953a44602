"""Where each contact integrator becomes unstable, and what penalty stiffness does to contact.

Bar on a rigid wall (L = E = ρ = 1, v0 = −1, 100 elements). For each scheme, Δt is given as a
multiple of the mesh's critical step h/c, and each run is classified stable / unstable by the
energy-growth monitor (crane_fem.stability). A penalty sweep at Δt = 0.9 × each stiffness's own
limit records the contact intervals (chatter) and the kinetic-energy error after separation.

    python benchmarks/stability_limits.py
"""

from __future__ import annotations

import warnings

from mpi4py import MPI

import crane_fem  # noqa: F401  (MPI first)
from crane_fem.driver import run_scenario
from crane_fem.errors import UnstableRunError
from crane_fem.scenario import parse_scenario

BASE = {
    "name": "stability",
    "model": {"kind": "bar", "length": 1.0, "elements": 100},
    "material": {"E": 1.0, "rho": 1.0},
    "initial": {"velocity": -1.0},
    "contact": [{"type": "wall", "gap": 0.1}],
    "time": {"end": 2.5},
    "output": {"xdmf": False},
}
H_OVER_C = 0.01


def run(integrator: dict, time: dict) -> tuple[str, dict]:
    data = {**BASE, "integrator": integrator, "time": {**BASE["time"], **time}}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            res = run_scenario(parse_scenario(data), "out/bench_stability", progress=False)
        except UnstableRunError as exc:
            return "unstable", {"diagnosis": str(exc)}
    return "stable", {**res.summary, "history": res.history}


def main() -> None:
    rank0 = MPI.COMM_WORLD.rank == 0
    factors = [0.5, 0.9, 0.99, 1.0, 1.01, 1.05, 2.0, 5.0, 20.0]
    schemes = {
        "cd-lagrange": {"scheme": "cd-lagrange"},
        "penalty k=EA/h": {"scheme": "penalty", "penalty": 100.0},
        "penalty k=10EA/h": {"scheme": "penalty", "penalty": 1000.0},
        "penalty k=100EA/h": {"scheme": "penalty", "penalty": 10000.0},
        "moreau-jean θ=1/2": {"scheme": "moreau-jean", "theta": 0.5},
        "moreau-jean θ=1": {"scheme": "moreau-jean", "theta": 1.0},
    }
    if rank0:
        print("| scheme | " + " | ".join(f"Δt = {f}·h/c" for f in factors) + " |")
        print("|---|" + "---|" * len(factors))
    for name, integ in schemes.items():
        cells = []
        for f in factors:
            verdict, _ = run(integ, {"dt": f * H_OVER_C})
            cells.append("stable" if verdict == "stable" else "**unstable**")
        if rank0:
            print(f"| {name} | " + " | ".join(cells) + " |")

    if rank0:
        print()
        print(
            "| penalty k (× EA/h) | Δt limit (× h/c) | contact intervals | KE after / KE before |"
        )
        print("|---|---|---|---|")
    for k in (0.1, 1.0, 10.0, 100.0, 1000.0):
        verdict, s = run({"scheme": "penalty", "penalty": 100.0 * k}, {"dt_factor": 0.9})
        if rank0 and verdict == "stable":
            hist = s["history"]
            ratio = hist["kinetic"][-1] / hist["kinetic"][0]
            print(
                f"| {k:g} | {s['dt_critical_penalty'] / H_OVER_C:.3f} | "
                f"{s['contact_intervals']} | {ratio:.4f} |"
            )
    verdict, s = run({"scheme": "cd-lagrange"}, {"dt_factor": 0.9})
    if rank0:
        hist = s["history"]
        print(
            f"| CD-Lagrange (no k) | {s['dt_critical'] / H_OVER_C:.3f} | "
            f"{s['contact_intervals']} | {hist['kinetic'][-1] / hist['kinetic'][0]:.4f} |"
        )


if __name__ == "__main__":
    main()
