"""GC's long-run stability study as a suite: ``benchmarks/gc_stability.py`` (the undamped
split bar and the amplification matrix of one macro step), its printed tables kept in
RESULTS.md."""

from __future__ import annotations

from pathlib import Path

from crane_fem.bench import Section
from crane_fem.bench.common import run_script

__all__ = ["NAME", "SUMMARY", "run"]

NAME = "gc_stability"
SUMMARY = "GC's long-run stability: the undamped split bar, the macro step's spectral radius"


def run(out: Path, quick: bool) -> list[Section]:
    """Run the script (it has one variant: ``quick`` changes nothing)."""
    body = run_script(NAME, [])
    key = f"{NAME}-{'quick' if quick else 'full'}"
    return [Section(key, f"{SUMMARY[0].upper()}{SUMMARY[1:]}", f"```\n{body.strip()}\n```")]
