"""The convergence study as a suite: ``benchmarks/convergence.py``, run in processes of its own (it
times them), its printed tables kept in RESULTS.md."""

from __future__ import annotations

from pathlib import Path

from crane_fem.bench import Section
from crane_fem.bench.common import run_script

__all__ = ["NAME", "SUMMARY", "run"]

NAME = "convergence"
SUMMARY = "convergence of the contact integrators on the bar against d'Alembert"


def run(out: Path, quick: bool) -> list[Section]:
    """Run the script (it has no quick variant) with its results under ``out``."""
    body = run_script(NAME, ["--out", str(out)])
    key = f"{NAME}-{'quick' if quick else 'full'}"
    return [Section(key, f"{SUMMARY[0].upper()}{SUMMARY[1:]}", f"```\n{body.strip()}\n```")]
