# # Bar impact on a rigid wall with CD-Lagrange
#
# An elastic steel bar moving at 5 m/s hits a rigid wall. The exact solution (d'Alembert): the
# contact lasts 2L/c, the contact force is ρ c |v0| A, and the bar leaves at +5 m/s. This demo
# runs the scenario file `demos/bar_impact.toml` through the library, compares the contact
# duration and impulse with the exact values and plots the energy balance.
#
# Run it serially or with `mpiexec -n 2 python demos/demo_bar_impact.py`.

# +
from pathlib import Path

import matplotlib

import crane_fem  # noqa: F401  (MPI before dolfinx)

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from mpi4py import MPI

from crane_fem.driver import run_scenario
from crane_fem.exact import WallImpact
from crane_fem.scenario import load_scenario

scenario_file = Path(__file__).parent / "bar_impact.toml"
outdir = Path("out/demo_bar_impact")
# -

# ## Run

sc = load_scenario(scenario_file, ["output.xdmf=false"])
result = run_scenario(sc, outdir, MPI.COMM_WORLD, progress=False)
h, s = result.history, result.summary

# ## Compare with the exact solution

c = (sc.material.E / sc.material.rho) ** 0.5
exact = WallImpact(sc.model.length, c, sc.initial.velocity, sc.contact[0].gap)
((t_first, t_last),) = s["contact_interval_times"]
impulse = float(h["contact_force"].sum() * s["dt"])
impulse_exact = 2 * sc.material.rho * sc.model.area * sc.model.length * abs(sc.initial.velocity)

# ## Plot the energy balance

if MPI.COMM_WORLD.rank == 0:
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 3.5))
    for name in ("kinetic", "internal", "contact_dissipated", "total"):
        ax1.plot(h["t"] * 1e3, h[name], label=name)
    ax1.set_xlabel("t (ms)")
    ax1.set_ylabel("energy (J)")
    ax1.legend()
    ax2.plot(h["t"] * 1e3, h["contact_force"] / 1e3)
    ax2.axhline(
        sc.material.rho * c * abs(sc.initial.velocity) * sc.model.area / 1e3,
        ls="--",
        color="k",
        label="ρ c |v0| A",
    )
    ax2.set_xlabel("t (ms)")
    ax2.set_ylabel("contact force (kN)")
    ax2.legend()
    fig.tight_layout()
    fig.savefig(outdir / "bar_impact.png", dpi=100)
    print(f"contact duration {t_last - t_first:.4e} s (exact 2L/c = {exact.duration:.4e} s)")
    print(f"impulse {impulse:.5f} N·s (exact {impulse_exact:.5f} N·s)")
    # Global check value, the same on any number of ranks:
    print(f"check: impulse/exact = {impulse / impulse_exact:.6f}")
