"""Crane scene: heterogeneous (GC, m = 100) vs fully explicit, side by side in one process tree.

    .venv/bin/python benchmarks/crane.py [SCENARIO] [-o OUTDIR]

Runs the scenario (default ``demos/crane.toml``) heterogeneous, then fully explicit
(``coupling.method = "monolithic"``), one after the other on an otherwise idle machine, then
``crane-fem plot``; prints the comparison (pair-displacement L2 differences, lift-off episodes,
interface-dissipated energy, wall-time ratio) as the Markdown block kept in RESULTS.md.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("scenario", nargs="?", default=str(ROOT / "demos" / "crane.toml"))
    parser.add_argument("-o", "--output", default=str(ROOT / "out" / "bench_crane"))
    args = parser.parse_args()
    exe = str(Path(sys.executable).parent / "crane-fem")
    out = Path(args.output)
    for name, extra in (
        ("heterogeneous", []),
        ("explicit", ["--set", "coupling.method='monolithic'"]),
    ):
        cmd = [exe, "run", args.scenario, "-o", str(out / name), "--no-progress", *extra]
        subprocess.run(cmd, check=True)
    subprocess.run([exe, "plot", str(out)], check=True)
    cmp = json.loads((out / "comparison.json").read_text())
    het = json.loads((out / "heterogeneous" / "summary.json").read_text())
    print(f"\n### Crane scene `{Path(args.scenario).name}` (python benchmarks/crane.py)\n")
    print(
        f"Δt = {het['dt']:.4e} s (critical {het['dt_critical']:.4e} s), m = {het['ratio']}, "
        f"{het['micro_steps']} micro steps, {het['interface_dofs']} interface DOFs.\n"
    )
    cols = ["wheel", "L2(u_z − u_z0) wheel side", "rail side", "L2(u_z)"]
    cols += ["lift-offs het. / expl.", "onset shift (macro steps)"]
    print("| " + " | ".join(cols) + " |")
    print("|---|---|---|---|---|---|")
    for k, w in cmp["wheels"].items():
        shift = w.get("onset_shift_macro_steps")
        wd, rd = 100 * w["wheel_uz_l2_dynamic"], 100 * w["rail_uz_l2_dynamic"]
        print(
            f"| {k} | {wd:.2f} % | {rd:.2f} % "
            f"| {100 * w['wheel_uz_l2_total']:.3f} % | {len(w['lift_offs_heterogeneous'])} / "
            f"{len(w['lift_offs_explicit'])} | {'—' if shift is None else f'{shift:.1f}'} |"
        )
    e_max = cmp["interface_dissipated_max_abs_J"]
    print(
        f"\nInterface-dissipated energy: max |E_Γ| = {e_max:.3e} J "
        f"= {100 * cmp['interface_dissipated_over_external_work']:.3f} % of max |external work| "
        f"({cmp['external_work_max_abs_J']:.3e} J); "
        f"final {cmp['interface_dissipated_final_J']:.3e} J."
    )
    wt = cmp.get("wall_time_s")
    if wt:
        print(
            f"\nWall time: heterogeneous {wt['heterogeneous']:.1f} s, fully explicit "
            f"{wt['explicit']:.1f} s: ratio explicit/heterogeneous "
            f"{cmp['wall_time_ratio_explicit_over_heterogeneous']:.2f}."
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
