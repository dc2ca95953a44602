"""The 3D mock-up's own mesh convergence, against which the frame and the mixed crane are
judged (issue 33: "the mixed crane against the all-solid mock-up"): its first six natural
frequencies with P1 and P2 tetrahedra and its fully explicit run on the vertical record at
several mesh sizes, beside the frame crane's and the mixed crane's.

    .venv/bin/python benchmarks/mockup_convergence.py [--out DIR] [--report FILE]
        [--sizes 0.08,0.06,0.04] [--p2-sizes 0.12,0.08,0.06] [--no-runs] [--reuse]

Runs (each a subprocess, OMP_NUM_THREADS=1, one after the other, in DIR, default
benchmarks/out/mockup_convergence/):

* ``crane-fem mesh demos/crane.toml --set model.size=S`` for each size other than the
  committed mesh's (0.12 m, refined to 0.04 m in the wheels' zones: ``committed``);
* ``crane-fem modes demos/crane.toml --n 6 --degree D`` on each mesh (P1: the committed mesh
  and every ``--sizes``; P2: every ``--p2-sizes``), the contacts closed;
* unless ``--no-runs``: ``crane-fem run demos/crane.toml --set coupling.method="monolithic"``
  on each P1 mesh (the committed one's is benchmarks/out/frame_vs_mockup/solid when there),
  ``demos/frame_crane.toml`` fully explicit (benchmarks/out/frame_vs_mockup/frame) and
  ``demos/frame_crane_solid.toml`` as written (gc-mean, the mixed crane);
* the mixed crane's frequencies: benchmarks/out/mixed_modes.json (benchmarks/mixed_modes.py).

``--reuse`` reads what DIR already holds instead of running it again. The report (markdown,
printed and written to FILE, default benchmarks/out/mockup_convergence.md) gives the
frequencies side by side with the finest P2 mesh as the reference, and each run's wheel
quantities (frame_vs_mockup.wheel_quantities; the uplift of the first flight read from
history.csv's ``gap_wheel_k`` before the first landing). Only numbers read from the outputs.
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
import time
import tomllib
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

from frame_vs_mockup import EXE, ROOT, _call, wheel_quantities

SOLID = ROOT / "demos" / "crane.toml"
FRAME = ROOT / "demos" / "frame_crane.toml"
MIXED = ROOT / "demos" / "frame_crane_solid.toml"
PREVIOUS = ROOT / "benchmarks" / "out" / "frame_vs_mockup"
COMMITTED = "committed"
FINE = tomllib.loads(SOLID.read_text())["model"]["fine"]  # the wheels' zones' size (0.04 m)
EXPLICIT = ['coupling.method="monolithic"', "output.xdmf=false"]
QUANTITIES = (
    "first lift-off (ms)",
    "uplift in the first flight (mm)",
    "first landing (ms)",
    "first landing impulse (N s)",
    "first landing peak (kN)",
    "peak wheel force (kN)",
)


def _mesh_sets(out: Path, size: str, reuse: bool) -> list[str]:
    """The --set arguments that give the mock-up the mesh of ``size`` (none: committed); below
    the wheels' zones' size (``model.fine``, 0.04 m) those zones take ``size`` too."""
    if size == COMMITTED:
        return []
    mesh = out / f"crane_{size}.msh"
    sizes = [f"model.size={size}"]
    if float(size) < FINE:
        sizes.append(f"model.fine={size}")
    if not (reuse and mesh.exists()):
        _call([str(EXE), "mesh", str(SOLID), *_flags(sizes), "-o", str(mesh)])
    return [f"model.mesh='{mesh}'", *sizes]


def _flags(sets: list[str]) -> list[str]:
    return [a for s in sets for a in ("--set", s)]


def modes_in(d: Path, scene: Path, args: list[str], reuse: bool) -> dict[str, Any]:
    """``crane-fem modes SCENE --n 6 ARGS --out d`` (its wall time in d/process.json) and its
    modes.json; ``reuse``: the one already in ``d``."""
    if not (reuse and (d / "modes.json").exists()):
        elapsed, _ = _call([str(EXE), "modes", str(scene), "--n", "6", *args, "--out", str(d)])
        (d / "process.json").write_text(json.dumps({"elapsed_s": elapsed}))
    return json.loads((d / "modes.json").read_text())


def _modes(out: Path, size: str, degree: int, reuse: bool) -> dict[str, Any]:
    args = ["--degree", str(degree), *_flags(_mesh_sets(out, size, True))]
    return modes_in(out / f"modes_p{degree}_{size}", SOLID, args, reuse)


def _run(scene: Path, d: Path, sets: list[str], reuse: bool) -> dict[str, Any]:
    """A run's summary with the first flight's uplift per wheel (mm) and its wall time."""
    if not (reuse and (d / "summary.json").exists()):
        cmd = [str(EXE), "run", str(scene), "-o", str(d), "--no-progress"]
        for s in sets:
            cmd += ["--set", s]
        _call(cmd)
    s = json.loads((d / "summary.json").read_text())
    with (d / "history.csv").open() as f:
        rows = list(csv.DictReader(f))
    flights = []
    for k in ("1", "2", "3", "4"):
        impacts = s["wheels"][k]["impacts"]
        t_land = impacts[0]["t_s"] if impacts else float("inf")
        gaps = [float(r[f"gap_wheel_{k}"]) for r in rows if float(r["t"]) < t_land]
        flights.append(1e3 * max(gaps))
    s["_first_flight_mm"] = flights
    return s


def _span(values: list[float]) -> str:
    lo, hi = min(values), max(values)
    return f"{lo:.4g}" if abs(hi - lo) <= 1e-6 * max(abs(hi), 1e-300) else f"{lo:.4g}–{hi:.4g}"


def _wheels(s: dict[str, Any]) -> dict[str, str]:
    q = wheel_quantities(s)
    q["uplift in the first flight (mm)"] = s["_first_flight_mm"]
    return {k: _span(q[k]) if k in q else "—" for k in QUANTITIES}


def report(
    p1: dict[str, dict[str, Any]],
    p2: dict[str, dict[str, Any]],
    runs: dict[str, dict[str, Any]],
    mixed_modes: dict[str, Any] | None,
    frame_modes: dict[str, Any] | None,
    started: str,
) -> str:
    lines = [
        "# The 3D mock-up's mesh convergence, beside the frame and the mixed crane",
        "",
        "Command: `.venv/bin/python benchmarks/mockup_convergence.py`",
        "",
        f"Started {started}. `crane-fem modes demos/crane.toml --n 6 [--degree 2]` (contacts "
        "closed) and `crane-fem run` fully explicit on the vertical record (0.2 s), at the "
        "committed mesh (0.12 m, 0.04 m in the wheels' zones) and uniform sizes; the frame "
        "(`demos/frame_crane.toml`, fully explicit) and the mixed crane "
        "(`demos/frame_crane_solid.toml`; frequencies: benchmarks/mixed_modes.py).",
        "",
        "## First six frequencies (Hz)",
        "",
    ]
    cols = [(f"P1 {s}", m) for s, m in p1.items()] + [(f"P2 {s}", m) for s, m in p2.items()]
    ref_label, ref = cols[-1]
    extra = []
    if frame_modes is not None:
        extra.append(("frame", [m["frequency_hz"] for m in frame_modes["modes"]]))
    if mixed_modes is not None:
        extra.append(("mixed", list(mixed_modes["frequencies_Hz"])))
    head = ["mode", *[c for c, _ in cols], *[c for c, _ in extra]]
    lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    ref_f = [m["frequency_hz"] for m in ref["modes"]]
    for i in range(6):
        row = [str(i + 1)]
        for _, m in cols:
            f = m["modes"][i]["frequency_hz"]
            row.append(f"{f:.2f} ({f / ref_f[i]:.3f})")
        for _, fs in extra:
            row.append(f"{fs[i]:.2f} ({fs[i] / ref_f[i]:.3f})")
        lines.append("| " + " | ".join(row) + " |")
    lines += [
        "",
        f"In brackets: the ratio to {ref_label} (the finest P2 mesh). Free DOFs: "
        + ", ".join(f"{c} {m['free_dofs']}" for c, m in cols)
        + ". Dominant direction of each mode (effective mass ≥ 1 %), "
        f"{ref_label}: "
        + ", ".join(
            f"{i + 1} "
            + (
                max("xyz", key=lambda a, m=m: m["effective_mass_fraction"][a])
                if max(m["effective_mass_fraction"].values()) >= 0.01
                else "local"
            )
            for i, m in enumerate(ref["modes"])
        )
        + ".",
        "",
        "## The vertical record, wheels 1–4 (min–max)",
        "",
    ]
    head = ["quantity", *runs]
    lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    table = {k: _wheels(s) for k, s in runs.items()}
    for q in QUANTITIES:
        lines.append("| " + " | ".join([q, *[table[k][q] for k in runs]]) + " |")
    lines.append(
        "| explicit DOFs; Δt (s); whole run (s) | "
        + " | ".join(
            f"{s['dofs_explicit']}; {s['dt']:.3g}; {s['wall_time_s']:.1f}" for s in runs.values()
        )
        + " |"
    )
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "out" / "mockup_convergence")
    ap.add_argument(
        "--report", type=Path, default=ROOT / "benchmarks" / "out" / "mockup_convergence.md"
    )
    ap.add_argument("--sizes", default="0.08,0.06,0.04")
    ap.add_argument("--p2-sizes", default="0.12,0.08,0.06")
    ap.add_argument("--no-runs", action="store_true")
    ap.add_argument("--reuse", action="store_true")
    args = ap.parse_args(argv)
    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    started = time.strftime("%Y-%m-%d %H:%M:%S")
    sizes = [s for s in args.sizes.split(",") if s]
    p2_sizes = [COMMITTED if s == "0.12" else s for s in args.p2_sizes.split(",") if s]
    p1 = {s: _modes(out, s, 1, args.reuse) for s in [COMMITTED, *sizes]}
    p2 = {s: _modes(out, s, 2, args.reuse) for s in p2_sizes}
    runs: dict[str, dict[str, Any]] = {}
    if not args.no_runs:
        for s in [COMMITTED, *sizes]:
            d = PREVIOUS / "solid" if s == COMMITTED else out / f"run_{s}"
            sets = [*EXPLICIT, *_mesh_sets(out, s, True)]
            runs[f"3D P1 {s}"] = _run(SOLID, d, sets, args.reuse or s == COMMITTED)
        runs["frame"] = _run(FRAME, PREVIOUS / "frame", EXPLICIT, True)
        runs["mixed"] = _run(MIXED, out / "mixed", ["output.xdmf=false"], args.reuse)
    mixed_path = ROOT / "benchmarks" / "out" / "mixed_modes.json"
    frame_path = PREVIOUS / "frame_modes" / "modes.json"
    mixed = json.loads(mixed_path.read_text()) if mixed_path.exists() else None
    frame = json.loads(frame_path.read_text()) if frame_path.exists() else None
    text = report(p1, p2, runs, mixed, frame, started)
    args.report.write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
