"""The Craig–Bampton mode-count study on the stress-grade crane (issue 14).

    .venv/bin/python benchmarks/reduction.py [--modes 25 50 100 200 400] [-o out/bench_reduction]

One after the other, serially, each a ``crane-fem run`` of the whole 0.2 s window (no XDMF; the
bridge's peak von Mises stress is taken at the frame times ``output.xdmf_every`` sets, the same
in every run):

- the fully explicit run (``coupling.method = "monolithic"``, CD-Lagrange everywhere);
- the full implicit side (``demos/crane_stress.toml`` as written: GC, m = 200, Newmark);
- the reduced implicit side (``demos/crane_stress_reduced.toml``) for each mode count N;
- N = 50 and 200 without the static load vectors (``static_vectors = false``): the error the
  quasi-static response to self-weight and the ground acceleration avoids.

Per run: the contact pair's vertical displacement (wheel and rail side, every wheel) L2 through
the first landing against the full side and against the explicit run (crane_fem.compare), the
interface energy, the peak bridge von Mises stress against the full side's, the time loop
(``wall_time_integration_s``) and its ratio to the explicit run's measured in this same run, the
set-up and its eigensolve. The ideal bound of the speed-up is the DOF split: a micro step that
cost only the explicit zone's share of the fully explicit step, (n_E + n_I) / n_E.

Results: ``benchmarks/results/reduction.json`` and ``reduction.png``; the table is printed in
Markdown (copied into benchmarks/RESULTS.md with this command line).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
DEMOS = ROOT / "demos"
FULL = DEMOS / "crane_stress.toml"
REDUCED = DEMOS / "crane_stress_reduced.toml"
RESULTS = ROOT / "benchmarks" / "results"
ENV = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
BIN = Path(sys.executable).parent
MODES = [25, 50, 100, 200, 400]


def _run(out: Path, scene: Path, name: str, sets: list[str]) -> dict[str, Any]:
    """A serial CLI run without XDMF; its summary."""
    d = out / name
    cmd = [str(BIN / "crane-fem"), "run", str(scene), "-o", str(d), "--no-progress"]
    for s in ["output.xdmf=false", *sets]:
        cmd += ["--set", s]
    res = subprocess.run(cmd, env=ENV, capture_output=True, text=True, check=False)
    if res.returncode:
        raise RuntimeError(f"{' '.join(cmd)} failed:\n{res.stderr[-2000:]}")
    summary: dict[str, Any] = json.loads((d / "summary.json").read_text())
    print(
        f"  {name}: time loop {summary['wall_time_integration_s']:.2f} s, "
        f"set-up {summary['wall_time_setup_s']:.1f} s",
        flush=True,
    )
    return summary


def _row(out: Path, name: str, summary: dict[str, Any], n_modes: int | None) -> dict[str, Any]:
    from crane_fem.compare import compare_runs, first_landing, pair_l2
    from crane_fem.plotting import load_runs

    run = load_runs(out / name)[0]
    full, exp = load_runs(out / "full")[0], load_runs(out / "explicit")[0]
    landing = first_landing(exp)
    vs_full = pair_l2(run, full, landing)
    vs_exp = pair_l2(run, exp, landing)
    cmp = compare_runs(run, exp)
    full_summary = full.summary
    sigma = float(summary["peak_bridge_von_mises_Pa"])
    sigma_full = float(full_summary["peak_bridge_von_mises_Pa"])  # type: ignore[arg-type]
    red = summary.get("reduction") or {}
    return {
        "case": name,
        "modes": n_modes,
        "static_vectors": bool(red.get("static_vectors", 0)) if red else None,
        "reduced_size": red.get("reduced_size"),
        "frequency_range_hz": red.get("frequency_range_hz"),
        "eigensolve_s": red.get("eigensolve_s"),
        "constraint_modes_s": red.get("constraint_modes_s"),
        "reduce_s": red.get("reduce_s"),
        "initial_state_projection_error": red.get("initial_state_projection_error"),
        "static_response_missed_by_modes": red.get("static_response_missed_by_modes"),
        "integration_s": summary["wall_time_integration_s"],
        "setup_s": summary["wall_time_setup_s"],
        "first_landing_s": landing,
        "pair_l2_to_landing_vs_full": max(max(v) for v in vs_full.values()),
        "pair_l2_to_landing_vs_explicit": max(max(v) for v in vs_exp.values()),
        "pair_l2_to_landing_vs_explicit_by_wheel": {k: list(v) for k, v in vs_exp.items()},
        "interface_energy_over_work": cmp["interface_dissipated_over_external_work"],
        "peak_bridge_von_mises_Pa": sigma,
        "peak_bridge_von_mises_t": summary["peak_bridge_von_mises_t"],
        "peak_stress_vs_full": (sigma - sigma_full) / sigma_full,
        "preload_sum_error": (summary.get("preload") or {}).get("sum_relative_error"),
        "lift_offs": [len(w["lift_offs_heterogeneous"]) for w in cmp["wheels"].values()],
        "lift_offs_explicit": [len(w["lift_offs_explicit"]) for w in cmp["wheels"].values()],
        "dofs_explicit": summary["dofs_explicit"],
        "dofs_implicit": summary["dofs_implicit"],
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--modes", type=int, nargs="+", default=MODES)
    parser.add_argument(
        "--without-static",
        type=int,
        nargs="*",
        default=[50, 200],
        metavar="N",
        help="mode counts run again without the static load vectors",
    )
    parser.add_argument(
        "--pairs",
        type=int,
        default=3,
        help="timing pairs (fully explicit, then the scene as written) run one after the other",
    )
    parser.add_argument("-o", "--out", type=Path, default=ROOT / "out" / "bench_reduction")
    parser.add_argument("--report", action="store_true", help="tables and figure from the JSON")
    args = parser.parse_args()
    import crane_fem  # noqa: F401  (MPI before dolfinx)

    RESULTS.mkdir(parents=True, exist_ok=True)
    path = RESULTS / "reduction.json"
    if not args.report:
        out: Path = args.out
        print("explicit, full, then the reduced side for N =", args.modes, flush=True)
        exp = _run(out, FULL, "explicit", ["coupling.method='monolithic'"])
        full = _run(out, FULL, "full", [])
        runs: list[tuple[str, dict[str, Any], int | None]] = [
            ("explicit", exp, None),
            ("full", full, None),
        ]
        for n in args.modes:
            name = f"reduced_{n}"
            runs.append((name, _run(out, REDUCED, name, [f"subdomain.1.modes={n}"]), n))
        for n in args.without_static:
            name = f"reduced_{n}_no_static"
            sets = [f"subdomain.1.modes={n}", "subdomain.1.static_vectors=false"]
            runs.append((name, _run(out, REDUCED, name, sets), n))
        # Speed side by side: pairs run back to back (the machine's speed drifts by tens of %
        # over minutes), the ratio taken pair by pair and its median quoted.
        pairs = []
        for k in range(args.pairs):
            e = _run(out, FULL, f"timing_explicit_{k}", ["coupling.method='monolithic'"])
            r = _run(out, REDUCED, f"timing_reduced_{k}", [])
            pairs.append(
                {
                    "explicit_s": e["wall_time_integration_s"],
                    "reduced_s": r["wall_time_integration_s"],
                    "ratio": e["wall_time_integration_s"] / r["wall_time_integration_s"],
                    "reduced_total_s": r["wall_time_s"],
                    "explicit_total_s": e["wall_time_s"],
                    "modes": r["reduction"]["modes"],
                }
            )
            print(f"  pair {k}: {pairs[-1]['ratio']:.2f}x", flush=True)
        rows = [_row(out, name, s, n) for name, s, n in runs]
        t_exp = exp["wall_time_integration_s"]
        for r in rows:
            r["speedup"] = t_exp / r["integration_s"]
        het = full
        n_e, n_i = het["dofs_explicit"], het["dofs_implicit"]
        res = {
            "command": "python benchmarks/reduction.py " + " ".join(sys.argv[1:]),
            "ratio": het["ratio"],
            "dt": het["dt"],
            "end_s": het["steps_done"] * het["dT"],
            "dofs_explicit": n_e,
            "dofs_implicit": n_i,
            "ideal_speedup": (n_e + n_i) / n_e,
            "rows": rows,
            "pairs": pairs,
        }
        path.write_text(json.dumps(res, indent=1))
    res = json.loads(path.read_text())
    _table(res)
    _figure(res)
    return 0


def _pct(x: float | None) -> str:
    return "—" if x is None else f"{100 * x:.3g} %"


def _table(res: dict[str, Any]) -> None:
    print(f"\n`{res['command']}` — stress-grade crane, {res['end_s']:.3g} s, GC m = {res['ratio']}")
    print(
        "\n| case | N | reduced size | modes up to (Hz) | pair L2 to landing vs full | "
        "vs explicit | peak bridge σ_vm vs full | interface energy / work | lift-offs | "
        "time loop (s) | × explicit | set-up (s) | eigensolve (s) |"
    )
    print("|" + "---|" * 13)
    for r in res["rows"]:
        case = r["case"].replace("_", " ")
        f = r["frequency_range_hz"]
        print(
            f"| {case} | {r['modes'] or '—'} | {r['reduced_size'] or '—'} | "
            f"{f'{f[1]:.0f}' if f else '—'} | "
            f"{_pct(r['pair_l2_to_landing_vs_full']) if r['case'] != 'explicit' else '—'} | "
            f"{_pct(r['pair_l2_to_landing_vs_explicit']) if r['case'] != 'explicit' else '—'} | "
            f"{_pct(r['peak_stress_vs_full'])} ({r['peak_bridge_von_mises_Pa'] / 1e6:.1f} MPa) | "
            f"{_pct(r['interface_energy_over_work'])} | {r['lift_offs']} | "
            f"{r['integration_s']:.2f} | {r['speedup']:.2f} | {r['setup_s']:.1f} | "
            f"{r['eigensolve_s'] if r['eigensolve_s'] is None else round(r['eigensolve_s'], 1)} |"
        )
    pairs = res.get("pairs") or []
    if pairs:
        ratios = sorted(p["ratio"] for p in pairs)
        print(
            f"\nSide by side (time loop, `wall_time_integration_s`), {len(pairs)} pairs run back "
            f"to back, demos/crane_stress_reduced.toml (N = {pairs[0]['modes']}) against the "
            f"fully explicit run: median **{ratios[len(ratios) // 2]:.2f}×** (pairs: "
            + ", ".join(
                f"{p['explicit_s']:.1f} s / {p['reduced_s']:.2f} s = {p['ratio']:.2f}×"
                for p in pairs
            )
            + "); whole runs, set-up included: "
            + ", ".join(
                f"{p['explicit_total_s']:.0f} s / {p['reduced_total_s']:.0f} s" for p in pairs
            )
        )
    print(
        f"\nIdeal bound from the DOF split: ({res['dofs_explicit']} + {res['dofs_implicit']}) / "
        f"{res['dofs_explicit']} = {res['ideal_speedup']:.1f}×"
    )


def _figure(res: dict[str, Any]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    red = [r for r in res["rows"] if r["case"].startswith("reduced") and r["static_vectors"]]
    red.sort(key=lambda r: r["modes"])
    n = [r["modes"] for r in red]
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2))
    a.loglog(
        n,
        [100 * r["pair_l2_to_landing_vs_full"] for r in red],
        "o-",
        label="pair L2 to the first landing, vs full side",
    )
    a.loglog(
        n,
        [100 * abs(r["peak_stress_vs_full"]) or 1e-6 for r in red],
        "s-",
        label="|peak bridge σ_vm − full| / full",
    )
    a.loglog(
        n,
        [100 * r["pair_l2_to_landing_vs_explicit"] for r in red],
        "^--",
        label="pair L2 to the first landing, vs explicit run",
    )
    for r in res["rows"]:
        if r["case"].endswith("no_static"):
            a.plot(
                [r["modes"]],
                [100 * r["pair_l2_to_landing_vs_full"]],
                "x",
                ms=10,
                color="k",
                label=f"N = {r['modes']} without static vectors (pair vs full)",
            )
    a.axhline(1.0, color="grey", lw=0.8, ls=":")
    a.set_xlabel("fixed-interface modes N")
    a.set_ylabel("%")
    a.set_title(f"Truncation error (GC m = {res['ratio']})")
    a.legend(fontsize=7)
    exp = next(r for r in res["rows"] if r["case"] == "explicit")
    full = next(r for r in res["rows"] if r["case"] == "full")
    b.semilogx(n, [r["integration_s"] for r in red], "o-", label="reduced: time loop")
    b.semilogx(n, [r["setup_s"] for r in red], "s-", label="reduced: set-up")
    b.semilogx(n, [r["eigensolve_s"] for r in red], "d:", label="reduced: eigensolve")
    b.axhline(exp["integration_s"], color="C3", ls="--", label="fully explicit: time loop")
    b.axhline(full["integration_s"], color="C4", ls="--", label="full Newmark side: time loop")
    b.set_yscale("log")
    b.set_xlabel("fixed-interface modes N")
    b.set_ylabel("wall time (s)")
    b.set_title(f"Wall time, {res['end_s']:.2g} s of the record")
    b.legend(fontsize=7)
    for ax in (a, b):
        ax.set_xscale("log")
        ax.set_xticks(n, [str(k) for k in n])
        ax.xaxis.set_minor_locator(matplotlib.ticker.NullLocator())
    fig.tight_layout()
    fig.savefig(RESULTS / "reduction.png", dpi=120)


if __name__ == "__main__":
    sys.exit(main())
