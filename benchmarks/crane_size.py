"""Crane quick scene: where the heterogeneous run pays, against the size of the implicit part.

    .venv/bin/python benchmarks/crane_size.py [-o OUTDIR] [--sizes 0.12 0.08 0.06 0.045 0.04]

For each coarse element size ``model.size`` (the contact zones keep ``fine`` = 0.04 m, so the
explicit step, the explicit zones and the interface stay the same while the implicit part
grows), meshes `demos/crane_quick.toml`, runs it fully explicit and heterogeneous (GC, m = 100)
one after the other with one BLAS thread each, compares the pair displacements
(crane_fem.compare) and prints the Markdown table kept in RESULTS.md; the chart goes to
`benchmarks/results/crane_size.png` (wall time of both runs against the DOF count; ``--chart``).
The static deflection of a rail node under the trolley (the preload) is reported beside: how
stiff the mesh makes the bridge.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SCENARIO = ROOT / "demos" / "crane_quick.toml"


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("-o", "--output", default=str(ROOT / "out" / "bench_crane_size"))
    parser.add_argument("--sizes", type=float, nargs="+", default=[0.12, 0.08, 0.06, 0.045, 0.04])
    parser.add_argument("--chart", default=str(ROOT / "benchmarks" / "results" / "crane_size.png"))
    args = parser.parse_args()
    out = Path(args.output)
    exe = str(Path(sys.executable).parent / "crane-fem")
    # One thread per run: the two runs are compared side by side, neither borrows the other core.
    env = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}

    from crane_fem.compare import compare_runs
    from crane_fem.plotting import load_runs

    rows = []
    for size in args.sizes:
        d = out / f"size_{size:g}"
        mesh = d / "crane.msh"
        subprocess.run(
            [exe, "mesh", str(SCENARIO), "-o", str(mesh), "--set", f"model.size={size!r}"],
            check=True,
            env=env,
        )
        base = [exe, "run", str(SCENARIO), "--no-progress", "--set", "output.xdmf=false"]
        base += ["--set", f"model.mesh='{mesh.as_posix()}'", "--set", f"model.size={size!r}"]
        for name, extra in (("heterogeneous", []), ("explicit", ["coupling.method='monolithic'"])):
            sets = [a for e in extra for a in ("--set", e)]
            subprocess.run([*base, "-o", str(d / name), *sets], check=True, env=env)
        het, exp = (load_runs(d / n)[0] for n in ("heterogeneous", "explicit"))
        c = compare_runs(het, exp)
        wt = c["wall_time_s"]
        worst_rail = max(w["rail_uz_l2_dynamic"] for w in c["wheels"].values())
        worst_wheel = max(w["wheel_uz_l2_dynamic"] for w in c["wheels"].values())
        s = het.summary
        rows.append(
            {
                "size": size,
                "dofs": exp.summary["dofs_explicit"],
                "dofs_explicit": s["dofs_explicit"],
                "dt_explicit": exp.summary["dt"],
                "dt_heterogeneous": s["dt"],
                # Static deflection of wheel 1's rail node under the trolley (preload).
                "deflection": -float(exp.history["wheel1_rail_uz"][0]),
                "dofs_implicit": s["dofs_implicit"],
                "interface_dofs": s["interface_dofs"],
                "wall_explicit": wt["explicit"],
                "wall_heterogeneous": wt["heterogeneous"],
                "ratio": c["wall_time_ratio_explicit_over_heterogeneous"],
                "l2_wheel": worst_wheel,
                "l2_rail": worst_rail,
                "interface": c["interface_dissipated_over_external_work"],
            }
        )
    (out / "crane_size.json").write_text(json.dumps(rows, indent=1))
    print("\n| coarse size (m) | DOFs | explicit zone / implicit / interface DOFs |", end="")
    print(" static deflection (mm) | Δt explicit run / coupled (µs) | wall explicit (s) |", end="")
    print(" wall GC m = 100 (s) | explicit / GC | worst L2 wheel / rail | E_Γ / max W_ext |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(
            f"| {r['size']:g} | {r['dofs']} | {r['dofs_explicit']} / {r['dofs_implicit']} / "
            f"{r['interface_dofs']} | {1e3 * r['deflection']:.4f} | "
            f"{1e6 * r['dt_explicit']:.3f} / {1e6 * r['dt_heterogeneous']:.3f} | "
            f"{r['wall_explicit']:.1f} | {r['wall_heterogeneous']:.1f} | "
            f"{r['ratio']:.2f} | {100 * r['l2_wheel']:.2f} / {100 * r['l2_rail']:.2f} % | "
            f"{100 * r['interface']:.1f} % |"
        )
    _chart(rows, Path(args.chart))
    return 0


def _chart(rows: list[dict[str, float]], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    n = [r["dofs"] for r in rows]
    ax.plot(n, [r["wall_explicit"] for r in rows], "s-", label="fully explicit")
    ax.plot(n, [r["wall_heterogeneous"] for r in rows], "o-", label="heterogeneous (GC, m = 100)")
    ax.set_xlabel("DOFs of the crane mesh (explicit zones fixed)")
    ax.set_ylabel("wall time (s), quick scene, one thread")
    ax.grid(True, alpha=0.3)
    ax.legend()
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)


if __name__ == "__main__":
    sys.exit(main())
