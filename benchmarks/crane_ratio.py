"""Crane quick scene: accuracy, interface energy and speed of the couplings against the ratio m.

    .venv/bin/python benchmarks/crane_ratio.py [-o OUTDIR]

Runs `demos/crane_quick.toml` fully explicit once, then heterogeneous with `gc`, `hybrid` and
`gc-mean` for m = 10, 20, 50, 100, 200 (one after the other on the idle machine; 16 runs,
about 10 minutes), compares each with the explicit run
(crane_fem.compare), and writes the Markdown table kept in RESULTS.md and
`benchmarks/results/crane_ratio.png` (error and interface energy against wall time). A run the
energy-growth monitor stops is reported as unstable with the time it stopped.
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SCENARIO = ROOT / "demos" / "crane_quick.toml"
METHODS = ("gc", "hybrid", "gc-mean")
#: One marker per method in the chart.
MARKERS = {"gc": "o", "hybrid": "D", "gc-mean": "^"}


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("-o", "--output", default=str(ROOT / "out" / "bench_crane_ratio"))
    args = parser.parse_args()
    out = Path(args.output)
    exe = str(Path(sys.executable).parent / "crane-fem")
    base = [exe, "run", str(SCENARIO), "--no-progress", "--set", "output.xdmf=false"]
    subprocess.run([*base, "-o", str(out / "explicit"), "--set", "coupling.method='monolithic'"])

    from crane_fem.compare import compare_runs
    from crane_fem.plotting import load_runs

    exp = load_runs(out / "explicit")[0]
    rows = []
    for method in METHODS:
        for m in (10, 20, 50, 100, 200):
            d = out / f"{method}_m{m}"
            cmd = [*base, "-o", str(d), "--set", f"coupling.ratio={m}"]
            res = subprocess.run([*cmd, "--set", f"coupling.method='{method}'"])
            s = json.loads((d / "summary.json").read_text())
            cmp = compare_runs(load_runs(d)[0], exp) if res.returncode == 0 else None
            rows.append((method, m, cmp, s))
    print("\n### Crane quick scene against m (python benchmarks/crane_ratio.py)\n")
    print(f"Fully explicit: {exp.summary['wall_time_s']:.1f} s.\n")
    print(
        "| method | m | status | worst L2(u_z − u_z0) | lift-offs as explicit "
        "| E_Γ / max external work | wall s | explicit / heterogeneous |"
    )
    print("|---|---|---|---|---|---|---|---|")
    pts = []
    for method, m, cmp, s in rows:
        wall = float(s["wall_time_s"])
        if cmp is None:
            found = re.search(r"\(t = ([^)]*)\)", str(s.get("diagnosis", "")))
            when = f"stopped at t = {found.group(1)}" if found else "stopped"
            print(f"| {method} | {m} | unstable, {when} | — | — | — | {wall:.1f} | — |")
            continue
        same = all(w["same_lift_off_count"] for w in cmp["wheels"].values())
        frac = cmp["interface_dissipated_over_external_work"]
        ratio = float(exp.summary["wall_time_s"]) / wall
        print(
            f"| {method} | {m} | completed | {100 * cmp['worst_pair_uz_l2_dynamic']:.2f} % | "
            f"{'yes' if same else 'no'} | {100 * frac:.2f} % | {wall:.1f} | {ratio:.2f} |"
        )
        pts.append((method, m, wall, cmp["worst_pair_uz_l2_dynamic"], frac))
    if pts:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(7, 4.5))
        for method, m, wall, err, frac in pts:
            mk = MARKERS[method]
            ax.scatter(wall, 100 * err, color="C0", marker=mk)
            ax.scatter(wall, 100 * frac, color="C1", marker=mk)
            ax.annotate(f"m={m}", (wall, 100 * err), textcoords="offset points", xytext=(4, 4))
        ax.axvline(float(exp.summary["wall_time_s"]), color="k", ls=":", label="fully explicit")
        ax.scatter([], [], color="C0", marker="s", label="worst pair L2 error (%)")
        ax.scatter([], [], color="C1", marker="s", label="interface energy / external work (%)")
        for method, mk in MARKERS.items():
            ax.scatter([], [], color="k", marker=mk, label=method)
        ax.set_yscale("log")
        ax.set_xlabel("wall time (s)")
        ax.set_ylabel("%")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        fig.tight_layout()
        path = ROOT / "benchmarks" / "results" / "crane_ratio.png"
        path.parent.mkdir(exist_ok=True)
        fig.savefig(path, dpi=120)
        print(f"\nChart: `{path.relative_to(ROOT)}`.")
    return 0


if __name__ == "__main__":
    sys.exit(main())
