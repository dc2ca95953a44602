"""The frame crane judged by THEORY.md §8 (b): candidate runs of a scene against its fully
explicit run, each quantity against max(its tolerance, the explicit ensemble's spread), with
their wall times side by side.

    .venv/bin/python benchmarks/frame_crane.py SCENE [--out DIR] [--set KEY=VALUE ...]
        [--candidate "LABEL:KEY=VALUE;KEY=VALUE" ...] [--reuse]

Runs (each a `crane-fem run` in DIR/<label>/): the reference (`coupling.method =
"monolithic"`), the ensemble (record × 0.995, × 1.005, Δt × ½, fully explicit) and the
candidates (the scene as written unless given). Prints a markdown report and writes it to
DIR/report.md.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from crane_fem.bench.ensemble import conditioning
from crane_fem.tolerances import Check, judge_dirs

ROOT = Path(__file__).resolve().parents[1]
EXE = ROOT / ".venv" / "bin" / "crane-fem"

EXPLICIT = ['coupling.method="monolithic"']
_PLAIN = str.maketrans({"×": "x", "½": "half"})


def _scales(scene: Path, factor: float) -> list[str]:
    """--set values scaling every ground-motion component of the scene by ``factor``."""
    import tomllib

    data = tomllib.loads(scene.read_text())
    gm = data.get("loading", {}).get("ground_motion")
    if isinstance(gm, list):
        return [
            f"loading.ground_motion.{i}.scale={g.get('scale', 1.0) * factor!r}"
            for i, g in enumerate(gm)
        ]
    return [f"loading.ground_motion.scale={gm.get('scale', 1.0) * factor!r}"]


def run(scene: Path, out: Path, sets: list[str], reuse: bool) -> dict[str, Any]:
    """One run of the scene (a subprocess), its summary and wall time."""
    summary = out / "summary.json"
    if reuse and summary.exists():
        return json.loads(summary.read_text())
    cmd = [str(EXE), "run", str(scene), "-o", str(out)]
    for s in sets:
        cmd += ["--set", s]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed:\n{proc.stderr[-2000:]}")
    data = json.loads(summary.read_text())
    data["_process_s"] = time.perf_counter() - t0
    summary.write_text(json.dumps(data, indent=1))
    return data


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene", type=Path)
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--set", action="append", default=[], dest="sets")
    ap.add_argument("--candidate", action="append", default=[])
    ap.add_argument("--no-ensemble", action="store_true")
    ap.add_argument("--reuse", action="store_true")
    args = ap.parse_args(argv)
    out = args.out or ROOT / "benchmarks" / "out" / f"frame_{args.scene.stem}"
    out.mkdir(parents=True, exist_ok=True)
    base = list(args.sets)
    ref = run(args.scene, out / "explicit", base + EXPLICIT, args.reuse)
    members: list[list[Check]] = []
    rows = [("explicit (reference)", ref, None)]
    if not args.no_ensemble:
        for label, sets in (
            ("explicit, record × 0.995", _scales(args.scene, 0.995)),
            ("explicit, record × 1.005", _scales(args.scene, 1.005)),
            ("explicit, Δt × ½", [f"time.dt_factor={0.45!r}"]),
        ):
            d = out / label.replace(" ", "_").replace("×", "x").replace(",", "").replace(
                "½", "half"
            )
            summary = run(args.scene, d, base + EXPLICIT + sets, args.reuse)
            checks = judge_dirs(d, out / "explicit")
            members.append(checks)
            rows.append((label, summary, checks))
    spread = conditioning(members)
    cands = args.candidate or ["as written:"]
    for cand in cands:
        label, _, sets = cand.partition(":")
        d = out / label.replace(" ", "_")
        summary = run(args.scene, d, base + [s for s in sets.split(";") if s], args.reuse)
        rows.append((label, summary, judge_dirs(d, out / "explicit")))
    given = " ".join(sys.argv[1:] if argv is None else argv)
    lines = [
        f"Command: `.venv/bin/python benchmarks/frame_crane.py {given}`",
        "",
        "| run | wall s | loop s | checks within | beyond conditioning | resolved and missed |",
        "|---|---|---|---|---|---|",
    ]
    detail = []
    for label, summary, checks in rows:
        wall = summary.get("wall_time_s", float("nan"))
        loop = summary.get("wall_time_integration_s", float("nan"))
        if checks is None:
            lines.append(f"| {label} | {wall:.1f} | {loop:.1f} | — | — | — |")
            continue
        within = [c for c in checks if c.ok]
        beyond = [c for c in checks if spread.get((c.quantity, c.where), 0.0) > 1.0]
        missed = [
            c
            for c in checks
            if not c.ok
            and spread.get((c.quantity, c.where), 0.0) < c.ratio
            and spread.get((c.quantity, c.where), 0.0) <= 1.0
        ]
        lines.append(
            f"| {label} | {wall:.1f} | {loop:.1f} | {len(within)} of {len(checks)} | "
            f"{len(beyond)} | {len(missed)} |"
        )
        for c in missed:
            detail.append(
                f"- {label}: {c.quantity}, {c.where}: {c.value:.4g} against {c.reference:.4g} "
                f"{c.unit} ({c.ratio:.2f}× its tolerance, {c.rule})"
            )
    text = "\n".join(lines + (["", *detail] if detail else [])) + "\n"
    (out / "report.md").write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
