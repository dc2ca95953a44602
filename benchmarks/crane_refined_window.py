"""Diagnostic: the crane's heterogeneous run with the macro step refined in a time window.

    .venv/bin/python benchmarks/crane_refined_window.py --window 0.11 0.14 --ratio 1 \
        [-o OUTDIR] [--reference out/bench_crane/explicit] [SCENARIO]

Runs the scenario (default ``demos/crane.toml``, GC with its m) but, for the macro steps that
start inside [T0, T1), replaces each macro step by m / RATIO GC steps of RATIO micro steps (a
second Newmark operator factored for the shorter step; the state (U, V, A) of average
acceleration carries over unchanged; the refinement of the "hybrid" coupling). This is an
experiment on the scene: it patches ``GravouilCombescure.step`` in this process only. It
answers where the interface energy of the default scene is lost: during the landing (then
refining the landing removes it) or in what the landing leaves behind (then it comes back when
m does).

Prints the interface energy before, inside and after the window, the wall time and, when the
reference explicit run exists, the pair-displacement L2 differences against it.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import crane_fem._compat  # noqa: F401  (mpi4py before dolfinx)
from crane_fem.coupling.gravouil_combescure import GravouilCombescure
from crane_fem.coupling.hybrid import Hybrid
from crane_fem.coupling.operator import create_interface_operator
from crane_fem.coupling.system import MacroRecord

ROOT = Path(__file__).resolve().parent.parent


def refine_in_window(t0: float, t1: float, ratio: int) -> None:
    """Patch GravouilCombescure.step: GC macro steps starting in [t0, t1) are run as m / ratio
    GC steps of ``ratio`` micro steps each (the refinement of the "hybrid" coupling,
    docs/theory-notes.md §8, borrowed from crane_fem.coupling.hybrid)."""
    base_step = GravouilCombescure.step
    refiners: dict[int, Hybrid] = {}

    def step(self: GravouilCombescure) -> MacroRecord:
        s = self.system
        if not t0 <= s.n * s.dT < t1:
            return base_step(self)
        if s.m % ratio:
            raise SystemExit(f"--ratio {ratio} does not divide m = {s.m}")
        if id(self) not in refiners:
            E = s.E
            assert E is not None

            def operator(side):  # type: ignore[no-untyped-def]
                return create_interface_operator(E.zone.w_gamma, side.W, side.gamma, ratio)[0]

            refiners[id(self)] = Hybrid(s, self.op, operator, impact_ratio=ratio)
        res = refiners[id(self)]._refined(s.n * s.dT)
        s.n += 1
        return s.record(res.lam, res.gaps, res.micro)

    GravouilCombescure.step = step  # type: ignore[method-assign]


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("scenario", nargs="?", default=str(ROOT / "demos" / "crane.toml"))
    parser.add_argument("--window", nargs=2, type=float, required=True, metavar=("T0", "T1"))
    parser.add_argument("--ratio", type=int, required=True, help="micro steps per refined step")
    parser.add_argument("-o", "--output", default=str(ROOT / "out" / "bench_crane_refined"))
    parser.add_argument("--reference", default=str(ROOT / "out" / "bench_crane" / "explicit"))
    args = parser.parse_args()
    refine_in_window(args.window[0], args.window[1], args.ratio)
    from crane_fem.cli import main as cli_main

    code = cli_main(["run", args.scenario, "-o", args.output, "--no-progress"])
    out = Path(args.output)
    summary = json.loads((out / "summary.json").read_text())
    print(f"status {summary.get('status')}, wall time {summary.get('wall_time_s', 0.0):.1f} s")
    if code or not (out / "history.csv").exists():
        return code
    import numpy as np

    from crane_fem.compare import pair_l2
    from crane_fem.plotting import load_runs

    run = load_runs(out)[0]
    h = run.history
    e_g = h["interface_dissipated"]
    w = float(np.max(np.abs(h["external_work"])))
    t0, t1 = args.window
    for label, t in (("window start", t0), ("window end", t1), ("end of run", h["t"][-1])):
        i = min(int(np.searchsorted(h["t"], t)), h["t"].size - 1)
        print(f"E_Γ at {label} (t = {h['t'][i]:.4f} s): {e_g[i]:.4f} J")
    e_max = float(np.max(np.abs(e_g)))
    print(f"E_Γ max = {e_max:.4f} J = {100 * e_max / w:.2f} % of max |W_ext|")
    ref = Path(args.reference)
    if (ref / "history.csv").exists():
        for k, (a, b) in pair_l2(run, load_runs(ref)[0]).items():
            print(f"wheel {k}: L2(u_z − u_z0) wheel / rail side {100 * a:.2f} / {100 * b:.2f} %")
    return 0


if __name__ == "__main__":
    sys.exit(main())
