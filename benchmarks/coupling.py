"""Heterogeneous coupling: time convergence of GC and PH, interface dissipation vs m, the
impact in the explicit part, and the 3D box beam (accuracy and wall time vs monolithic).

    python benchmarks/coupling.py

Prints the Markdown tables that go into benchmarks/RESULTS.md and writes
benchmarks/results/coupling_convergence.png.
"""

from __future__ import annotations

import time
import warnings
from pathlib import Path

import matplotlib

import crane_fem  # noqa: F401  (MPI first)

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from mpi4py import MPI

from crane_fem.driver import run_scenario
from crane_fem.scenario import load_scenario, parse_scenario

OUT = Path("benchmarks/results")
SUBS = [
    {"name": "near", "groups": ["left"], "scheme": "cd-lagrange"},
    {"name": "far", "groups": ["right"], "scheme": "newmark"},
]


def bar(**kw):  # type: ignore[no-untyped-def]
    d = {
        "name": "coupling_bench",
        "model": {"kind": "bar", "length": 1.0, "elements": 400, "split": 0.4},
        "material": {"E": 1.0, "rho": 1.0},
        "initial": {"pulse": {"center": 0.2, "width": 0.2, "amplitude": 1e-3}},
        "time": {"end": 1.0, "dt_factor": 0.5},
        "output": {"xdmf": False},
    }
    d.update(kw)
    return parse_scenario(d)


def run(sc):  # type: ignore[no-untyped-def]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return run_scenario(sc, "out/bench_coupling", progress=False)


def main() -> None:
    rank0 = MPI.COMM_WORLD.rank == 0
    OUT.mkdir(parents=True, exist_ok=True)
    # Reference: monolithic CD on the same mesh with a 20× smaller step.
    ref = run(
        bar(
            coupling={"method": "monolithic", "scheme": "cd-lagrange"},
            time={"end": 1.0, "dt_factor": 0.005},
        )
    )
    rt, ru = ref.history["t"], ref.history["probe_u0"]
    factors = [0.8, 0.4, 0.2, 0.1, 0.05]
    m = 4
    rows = {}
    for method in ("gc", "ph", "ec", "gc-mean"):
        errs, dts = [], []
        for f in factors:
            res = run(
                bar(
                    subdomain=SUBS,
                    coupling={"method": method, "ratio": m},
                    newmark={"mass": "lumped"},
                    time={"end": 1.0, "dt_factor": f},
                )
            )
            h = res.history
            errs.append(
                float(
                    np.max(np.abs(h["probe_u0"] - np.interp(h["t"], rt, ru))) / np.max(np.abs(ru))
                )
            )
            dts.append(res.summary["dt"])
        rows[method] = (dts, errs)
    if rank0:
        print(f"Time convergence, split bar (400 el.), m = {m}, probe = free right end:")
        print(
            "| method | "
            + " | ".join(f"Δt = {f}·Δt_crit" for f in factors)
            + " | order (4 finest) |"
        )
        print("|---|" + "---|" * (len(factors) + 1))
        for method, (dts, errs) in rows.items():
            order = np.polyfit(np.log(dts[1:]), np.log(errs[1:]), 1)[0]
            print(f"| {method} | " + " | ".join(f"{e:.2e}" for e in errs) + f" | {order:.2f} |")
        fig, ax = plt.subplots(figsize=(5, 4))
        for method, (dts, errs) in rows.items():
            ax.loglog(dts, errs, "o-", label=method)
        ax.set_xlabel("Δt")
        ax.set_ylabel("max |u_probe − u_ref| / max |u_ref|")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
        fig.tight_layout()
        fig.savefig(OUT / "coupling_convergence.png", dpi=110)

    # Interface dissipation vs m (pulse resolved by ≥ 40 macro steps at m = 10, 1000 el.).
    if rank0:
        print("\nInterface energy vs m (split bar, 1000 el., pulse 0.2 wide, Δt = 0.5 Δt_crit):")
        print(
            "| method | m | macro steps per pulse width | GC-measure dissipation / E0 "
            "| physical interface work / E0 | min per macro step / E0 | peak error vs mono |"
        )
        print("|---|---|---|---|---|---|---|")
    mono = run(
        bar(
            model={"kind": "bar", "length": 1.0, "elements": 1000, "split": 0.4},
            coupling={"method": "monolithic", "scheme": "cd-lagrange"},
        )
    )
    peak_ref = np.max(mono.history["probe_u0"])
    for method, mm in [
        (x, y) for x in ("gc", "ph", "ec", "gc-mean") for y in (1, 2, 10, 100, 1000)
    ]:
        res = run(
            bar(
                model={"kind": "bar", "length": 1.0, "elements": 1000, "split": 0.4},
                subdomain=SUBS,
                coupling={"method": method, "ratio": mm},
            )
        )
        h, s = res.history, res.summary
        e0 = h["total"][0]
        if rank0:
            print(
                f"| {method} | {mm} | {0.2 / s['dT']:.1f} | "
                f"{h['interface_energy_gc'][-1] / e0:.2e} | "
                f"{h['interface_work_physical'][-1] / e0:.2e} | "
                f"{s['interface_energy_gc_min_step'] / e0:.2e} | "
                f"{abs(np.max(h['probe_u0']) / peak_ref - 1):.2e} |"
            )

    # Impact in the explicit part: contact duration error vs m.
    if rank0:
        print("\nImpact in the explicit half of the split bar (200 el., wall at the left end):")
        print(
            "| method | m | contact duration − 2L/c (in h/c) | contact intervals "
            "| bound 2h/c + Δt (in h/c) |"
        )
        print("|---|---|---|---|---|")
    for method, mm in [(x, y) for x in ("gc", "ec", "gc-mean") for y in (1, 2, 5, 10)]:
        res = run(
            parse_scenario(
                {
                    "name": "impact",
                    "model": {"kind": "bar", "length": 1.0, "elements": 200, "split": 0.5},
                    "material": {"E": 1.0, "rho": 1.0},
                    "initial": {"velocity": -1.0},
                    "contact": [{"type": "wall", "gap": 0.1}],
                    "subdomain": SUBS,
                    "coupling": {"method": method, "ratio": mm},
                    "time": {"end": 2.4, "dt_factor": 0.9},
                    "output": {"xdmf": False},
                }
            )
        )
        s = res.summary
        (a, b) = s["contact_interval_times"][0]
        if rank0:
            n_c = len(s["contact_interval_times"])
            print(
                f"| {method} | {mm} | {(b - a - 2.0) * 200:.2f} | {n_c} "
                f"| {(2 / 200 + s['dt']) * 200:.2f} |"
            )

    # 3D box beam: tip displacement error and wall time vs monolithic, side by side.
    beam = Path("demos/box_beam.toml")  # lumped mass on both sides
    # ratio = 1: a monolithic run of a coupled scenario writes every `ratio` steps otherwise.
    monolithic = [
        "coupling.method='monolithic'",
        "coupling.scheme='cd-lagrange'",
        "coupling.ratio=1",
    ]
    t0 = time.perf_counter()
    mono = run(load_scenario(beam, ["output.xdmf=false", *monolithic]))
    t_mono = time.perf_counter() - t0
    if rank0:
        print("\n3D box beam (h = 0.05, lumped mass on both sides), tip z-displacement:")
        print("| method | m | max error / peak | wall s | wall / monolithic CD |")
        print("|---|---|---|---|---|")
        print(f"| monolithic CD | — | — | {t_mono:.2f} | 1.00 |")
    ref_t, ref = mono.history["t"], mono.history["probe_u2"]
    for method, mm in [(x, y) for x in ("gc", "ec", "gc-mean") for y in (1, 3, 10, 30)]:
        t0 = time.perf_counter()
        over = ["output.xdmf=false", f"coupling.ratio={mm}", f"coupling.method='{method}'"]
        res = run(load_scenario(beam, over))
        wall = time.perf_counter() - t0
        h = res.history
        err = np.max(np.abs(h["probe_u2"] - np.interp(h["t"], ref_t, ref))) / np.max(np.abs(ref))
        if rank0:
            print(f"| {method} | {mm} | {err:.2e} | {wall:.2f} | {wall / t_mono:.2f} |")


if __name__ == "__main__":
    main()
