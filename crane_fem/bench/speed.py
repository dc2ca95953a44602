"""The speed study as a suite: ``benchmarks/speed.py``, run in processes of its own (it
times them), its printed tables kept in RESULTS.md."""

from __future__ import annotations

from pathlib import Path

from crane_fem.bench import Section
from crane_fem.bench.common import run_script

__all__ = ["NAME", "SUMMARY", "run"]

NAME = "speed"
SUMMARY = "the compiled kernel's cost per micro step against its roofline, and the coupled split"


def run(out: Path, quick: bool) -> list[Section]:
    """Run the script (``--quick`` when ``quick``) with its output under ``out``."""
    args = ["--quick"] if quick else []
    body = run_script(NAME, [*args, "-o", str(out / "runs" / NAME)])
    key = f"{NAME}-{'quick' if quick else 'full'}"
    return [Section(key, f"{SUMMARY[0].upper()}{SUMMARY[1:]}", f"```\n{body.strip()}\n```")]
