"""The joint over 10 s (issue 33: "over 10 s the joint adds no energy: energy balance ≤ 1e-8").

The mixed bar of tests/test_mixed_model.py (a beam 0–3 m clamped at x = 0, a P1 solid 3–4 m,
a beam 4–7 m; square section 0.1 m; the beams' end nodes tied to the solid's end faces by two
rigid-section joints) released from rest under gravity: it swings about its sag for 10 s
(its first bending mode 1.4 Hz, 14 periods). The solid runs CD-Lagrange, the beams Newmark,
coupled by gc-mean at m = 40 (2.77 million micro steps). Reports the energy balance's largest
error over the run relative to the energies' scale, the smallest interface energy of a macro
step (≥ 0: the joint takes energy out, never puts it in), gc-mean's interface identity and
the wall time. Writes benchmarks/out/joint_energy.json.

    .venv/bin/python benchmarks/joint_energy.py [--end 10] [--ratio 40]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI

from crane_fem.driver import run_scenario
from crane_fem.scenario import load_scenario

ROOT = Path(__file__).resolve().parent
OUT = ROOT / "out"
WORK = OUT / "joint_energy"
sys.path.insert(0, str(ROOT.parent / "tests"))  # the mixed bar's gmsh script and scene

from test_mixed_model import scenario, write_bar  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--end", type=float, default=10.0)
    ap.add_argument("--ratio", type=int, default=40)
    args = ap.parse_args()
    WORK.mkdir(parents=True, exist_ok=True)
    mesh = write_bar(WORK / "bar.msh")
    path = WORK / "bar.toml"
    path.write_text(scenario(mesh), encoding="utf-8")
    sets = [
        f"time.end={args.end}",
        f"coupling.ratio={args.ratio}",
        "output.sample_interval=0.001",
    ]
    t0 = time.perf_counter()
    res = run_scenario(load_scenario(path, sets), WORK / "run", MPI.COMM_WORLD, progress=False)
    wall = time.perf_counter() - t0
    h, s = res.history, res.summary
    total = np.asarray(h["total"])
    scale = max(float(np.max(np.abs(h[c]))) for c in ("kinetic", "internal", "external_work"))
    out = {
        "command": "python benchmarks/joint_energy.py "
        + " ".join(f"--{k} {v}" for k, v in vars(args).items()),
        "end_s": args.end,
        "ratio": args.ratio,
        "micro_steps": s["micro_steps"],
        "energy_balance_error": float(np.max(np.abs(total - total[0]))) / scale,
        "interface_dissipated_J": float(h["interface_dissipated"][-1]),
        "interface_energy_min_step_J": s["interface_energy_gc_min_step"],
        "interface_identity_error": s.get("interface_identity_error"),
        "energy_scale_J": scale,
        "wall_time_s": wall,
    }
    (OUT / "joint_energy.json").write_text(json.dumps(out, indent=2) + "\n", encoding="utf-8")
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
