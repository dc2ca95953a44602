"""The first natural frequencies of a mixed model (solids and beams tied by joints), serially:
issue 33's "the first six frequencies within 3 %" of the mixed crane against the 3D mock-up.
The modes are `crane-fem modes`' own for mixed models (crane_fem.modes.mixed: both parts'
closed structures, the joints' beam nodes eliminated by the rigid sections' rows, SciPy's
shift-and-invert Lanczos); this script writes them as benchmarks/out/mixed_modes.{md,json}.

    .venv/bin/python benchmarks/mixed_modes.py [SCENE] [--n 6] [--set KEY=VALUE ...]

SCENE defaults to demos/frame_crane_solid.toml.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from mpi4py import MPI

from crane_fem.modes.mixed import solve_mixed_modes
from crane_fem.pipeline import build_mesh
from crane_fem.pipeline.kinds import concrete_scenario
from crane_fem.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "out"
SELF = MPI.COMM_SELF


def mixed_frequencies(scene: Path, sets: list[str], n: int) -> dict:
    """The mixed model's lowest ``n`` modes (crane_fem.modes.mixed, as `crane-fem modes`)."""
    sc = concrete_scenario(load_scenario(scene, sets), SELF)
    t0 = time.perf_counter()
    res = solve_mixed_modes(sc, build_mesh(sc, SELF), n)
    b = res.basis
    return {
        "scene": str(scene),
        "sets": sets,
        "free_dofs": res.free_dofs,
        "frequencies_Hz": b.frequency.tolist(),
        "effective_mass_fraction": b.effective_fraction.tolist(),
        "eigensolve_s": time.perf_counter() - t0,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", nargs="?", default=str(ROOT / "demos" / "frame_crane_solid.toml"))
    ap.add_argument("--n", type=int, default=6)
    ap.add_argument("--set", action="append", default=[], dest="sets")
    args = ap.parse_args()
    res = mixed_frequencies(Path(args.scene), args.sets, args.n)
    lines = [
        "# First natural frequencies of a mixed model",
        "",
        f"Command: `.venv/bin/python benchmarks/mixed_modes.py {args.scene} --n {args.n}`",
        "",
        f"{res['free_dofs']} free DOFs after the joints' elimination.",
        "",
        "| mode | f (Hz) | m_eff x | m_eff y | m_eff z |",
        "|---|---|---|---|---|",
    ]
    for k, (fk, e) in enumerate(
        zip(res["frequencies_Hz"], res["effective_mass_fraction"], strict=True), start=1
    ):
        lines.append(f"| {k} | {fk:.3f} | {e[0]:.1%} | {e[1]:.1%} | {e[2]:.1%} |")
    text = "\n".join(lines) + "\n"
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / "mixed_modes.md").write_text(text, encoding="utf-8")
    (OUT / "mixed_modes.json").write_text(json.dumps(res, indent=2) + "\n", encoding="utf-8")
    print(text)


if __name__ == "__main__":
    main()
