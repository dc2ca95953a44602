"""Convergence of the contact integrators on the bar-on-wall impact (exact d'Alembert solution).

Δt → 0 with h refined at a fixed Courant number Δt c / h = 0.5, for CD-Lagrange, Moreau–Jean
(θ = ½ and 1) and explicit penalty (k_p = E A / h, the usual mesh-scaled choice). Errors at the
final time t_c + 2.5 L/c (after separation), in the nodal (lumped) L2 norm relative to the exact
field, plus the relative energy error and the wall time per run, side by side.

    python benchmarks/convergence.py [--out benchmarks/results]

Writes ``convergence.json``, ``convergence.png`` (log–log, error vs Δt and error vs cost) and
prints the Markdown table with the fitted orders that goes into ``benchmarks/RESULTS.md``.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import matplotlib

import crane_fem  # noqa: F401  (MPI first)

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from mpi4py import MPI

from crane_fem.driver import Simulation
from crane_fem.exact import WallImpact
from crane_fem.scenario import parse_scenario

L, E, RHO, V0, GAP = 1.0, 1.0, 1.0, -1.0, 0.1
COURANT = 0.5
MESHES = [25, 50, 100, 200, 400, 800]
SCHEMES = {
    "cd-lagrange": {"scheme": "cd-lagrange"},
    "moreau-jean θ=1/2": {"scheme": "moreau-jean", "theta": 0.5},
    "moreau-jean θ=1": {"scheme": "moreau-jean", "theta": 1.0},
    "penalty k=EA/h": {"scheme": "penalty"},
}


def run_case(ne: int, integrator: dict) -> dict[str, float]:
    h = L / ne
    c = (E / RHO) ** 0.5
    exact = WallImpact(L, c, V0, GAP)
    dt = COURANT * h / c
    t_end = exact.t_contact + 2.5 * L / c
    integ = dict(integrator)
    if integ["scheme"] == "penalty":
        integ["penalty"] = E * 1.0 / h
    sc = parse_scenario(
        {
            "name": "convergence",
            "model": {"kind": "bar", "length": L, "elements": ne},
            "material": {"E": E, "rho": RHO},
            "initial": {"velocity": V0},
            "contact": [{"type": "wall", "gap": GAP}],
            "time": {"end": t_end, "dt": dt},
            "integrator": integ,
            "output": {"xdmf": False},
        }
    )
    comm = MPI.COMM_WORLD
    t0 = time.perf_counter()
    sim = Simulation(sc, comm)
    x = sim.problem.model.V.tabulate_dof_coordinates()[: sim.problem.model.n_owned, 0]
    mass = sim.problem.model.mass
    end_err = 0.0
    at_end = np.isclose(x, GAP)  # the contact-end node (exact coordinate GAP)
    try:
        for rec in sim.records():
            u_end = float(comm.allreduce(float(np.sum(rec.u[at_end])), op=MPI.SUM))
            end_err = max(end_err, abs(u_end - exact.displacement(np.array([0.0]), rec.t)[0]))
            last = rec
        X = x - GAP
        ue, ve = exact.displacement(X, last.t), exact.velocity(X, last.t)

        def l2(f: np.ndarray) -> float:
            return float(np.sqrt(comm.allreduce(float(np.sum(mass * f * f)), op=MPI.SUM)))

        eu = l2(last.u - ue) / l2(ue)
        ev = l2(last.v - ve) / l2(ve)
        e0 = 0.5 * RHO * L * V0**2
        energy = last.energy.kinetic + last.energy.internal
        ee = abs(energy - e0) / e0
    finally:
        sim.destroy()
    return {
        "ne": ne,
        "dt": dt,
        "err_u": eu,
        "err_v": ev,
        "err_energy": ee,
        "err_contact_end_max": end_err,
        "wall_s": time.perf_counter() - t0,
        "steps": sim.n_steps,
    }


def order(dts: list[float], errs: list[float]) -> float:
    """Least-squares slope of log(err) vs log(Δt) over the three finest runs."""
    return float(np.polyfit(np.log(dts[-3:]), np.log(errs[-3:]), 1)[0])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("benchmarks/results"))
    args = parser.parse_args()
    results: dict[str, list[dict[str, float]]] = {}
    for name, integ in SCHEMES.items():
        results[name] = [run_case(ne, integ) for ne in MESHES]
    if MPI.COMM_WORLD.rank != 0:
        return
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "convergence.json").write_text(json.dumps(results, indent=2))

    fig, axes = plt.subplots(1, 4, figsize=(18, 4.2))
    keys = [
        ("err_u", "displacement L2"),
        ("err_v", "velocity L2"),
        ("err_energy", "energy after separation"),
    ]
    for ax, (key, title) in zip(axes[:3], keys, strict=True):
        for name, rows in results.items():
            ax.loglog([r["dt"] for r in rows], [max(r[key], 1e-16) for r in rows], "o-", label=name)
        ax.set_xlabel("Δt (h refined, Courant 0.5)")
        ax.set_title(f"relative error: {title}")
        ax.grid(True, which="both", alpha=0.3)
    for name, rows in results.items():
        axes[3].loglog([r["wall_s"] for r in rows], [r["err_u"] for r in rows], "o-", label=name)
    axes[3].set_xlabel("wall time per run (s)")
    axes[3].set_title("displacement error vs cost")
    axes[3].grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(args.out / "convergence.png", dpi=120)

    print(
        "| scheme | order u | order v | order energy | err u (finest) | err v (finest) "
        "| energy err (finest) | wall s (finest) |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for name, rows in results.items():
        dts = [r["dt"] for r in rows]
        f = rows[-1]
        print(
            f"| {name} | {order(dts, [r['err_u'] for r in rows]):.2f} "
            f"| {order(dts, [r['err_v'] for r in rows]):.2f} "
            f"| {order(dts, [max(r['err_energy'], 1e-16) for r in rows]):.2f} "
            f"| {f['err_u']:.2e} | {f['err_v']:.2e} | {f['err_energy']:.2e} | {f['wall_s']:.2f} |"
        )


if __name__ == "__main__":
    main()
