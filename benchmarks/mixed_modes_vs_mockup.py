"""Issue 33's "the first six frequencies within 3 %": the mixed crane's first six natural
frequencies (demos/frame_crane_solid.toml, the trolley's plate a P1 solid) at several plate
element sizes, against the all-solid mock-up's (demos/crane.toml) with P2 tetrahedra refined
until its frequencies stop moving.

    .venv/bin/python benchmarks/mixed_modes_vs_mockup.py [--out DIR] [--report FILE]
        [--p2-sizes 0.06,0.05,0.04,0.03,0.025] [--trolley-sizes 0.04,0.025,0.0167,0.0125]
        [--reuse]

Runs (subprocesses, OMP_NUM_THREADS=1, one after the other, in DIR, default
benchmarks/out/mixed_modes_vs_mockup/):

* ``crane-fem mesh demos/crane.toml --set model.size=S`` (and ``model.fine=S`` below the
  wheels' zones' 0.04 m) and ``crane-fem modes demos/crane.toml --n 6 --degree 2`` on it, for
  each of ``--p2-sizes`` (benchmarks/mockup_convergence.py's own functions);
* ``crane-fem modes demos/frame_crane_solid.toml --n 6 --set model.trolley_size=S`` for each
  of ``--trolley-sizes`` (the plate's elements; the wheel zones keep the scene's 0.04 m).

Both with the contacts closed (the preload's ties). The report (markdown, printed and
written to FILE, default benchmarks/out/mixed_modes_vs_mockup.md) takes the finest P2 mesh as
the reference, gives every mixed frequency's ratio to it and counts those within 3 %.
Only numbers read from the outputs; ``--reuse`` reads what DIR already holds.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

from frame_vs_mockup import ROOT
from mockup_convergence import MIXED, _modes, modes_in

TOLERANCE = 0.03  # issue 33: "the first six frequencies within 3 %"


def _mixed_modes(out: Path, trolley_size: str, reuse: bool) -> dict[str, Any]:
    args = ["--set", f"model.trolley_size={trolley_size}"]
    return modes_in(out / f"mixed_plate_{trolley_size}", MIXED, args, reuse)


def _freqs(m: dict[str, Any]) -> list[float]:
    return [float(x["frequency_hz"]) for x in m["modes"]]


def report(p2: dict[str, dict[str, Any]], mixed: dict[str, dict[str, Any]], started: str) -> str:
    ref_size, ref = list(p2.items())[-1]
    f_ref = _freqs(ref)
    lines = [
        "# The mixed crane's first six frequencies against the converged mock-up",
        "",
        "Command: `.venv/bin/python benchmarks/mixed_modes_vs_mockup.py`",
        "",
        f"Started {started}. `crane-fem modes demos/crane.toml --n 6 --degree 2` at uniform "
        "sizes (the mock-up, P2 tetrahedra) and `crane-fem modes demos/frame_crane_solid.toml "
        "--n 6 --set model.trolley_size=S` (the mixed crane, its trolley's plate P1 at S), the "
        "contacts closed.",
        "",
        "## The mock-up, P2 (Hz)",
        "",
    ]
    head = ["mode", *[f"P2 {s} ({m['free_dofs']} DOFs)" for s, m in p2.items()]]
    lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for i in range(6):
        row = [str(i + 1)]
        prev = None
        for m in p2.values():
            f = _freqs(m)[i]
            row.append(f"{f:.3f}" + ("" if prev is None else f" ({f / prev - 1:+.2%})"))
            prev = f
        lines.append("| " + " | ".join(row) + " |")
    lines += [
        "",
        "In brackets: the change from the next coarser mesh.",
        "",
        f"## The mixed crane against P2 {ref_size} (the reference)",
        "",
    ]
    head = ["trolley_size (m)", "free DOFs", *[f"mode {i + 1}" for i in range(6)], "within 3 %"]
    lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for s, m in mixed.items():
        fs = _freqs(m)
        errs = [f / r - 1 for f, r in zip(fs, f_ref, strict=True)]
        n_ok = sum(abs(e) <= TOLERANCE for e in errs)
        cells = [f"{f:.2f} ({e:+.1%})" for f, e in zip(fs, errs, strict=True)]
        lines.append("| " + " | ".join([s, str(m["free_dofs"]), *cells, f"{n_ok} of 6"]) + " |")
    lines += ["", f"Reference: P2 {ref_size}: " + ", ".join(f"{f:.3f}" for f in f_ref) + " Hz."]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    out_default = ROOT / "benchmarks" / "out" / "mixed_modes_vs_mockup"
    ap.add_argument("--out", type=Path, default=out_default)
    ap.add_argument(
        "--report", type=Path, default=ROOT / "benchmarks" / "out" / "mixed_modes_vs_mockup.md"
    )
    ap.add_argument("--p2-sizes", default="0.06,0.05,0.04,0.03,0.025")
    ap.add_argument("--trolley-sizes", default="0.04,0.025,0.0167,0.0125")
    ap.add_argument("--reuse", action="store_true")
    args = ap.parse_args(argv)
    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    started = time.strftime("%Y-%m-%d %H:%M:%S")
    p2 = {s: _modes(out, s, 2, args.reuse) for s in args.p2_sizes.split(",") if s}
    mixed = {s: _mixed_modes(out, s, args.reuse) for s in args.trolley_sizes.split(",") if s}
    text = report(p2, mixed, started)
    args.report.write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
