"""The reduction study as a suite: ``benchmarks/reduction.py``, run in processes of its own (it
times them), its printed tables kept in RESULTS.md."""

from __future__ import annotations

from pathlib import Path

from crane_fem.bench import Section
from crane_fem.bench.common import run_script

__all__ = ["NAME", "SUMMARY", "run"]

NAME = "reduction"
SUMMARY = "the Craig–Bampton mode-count study on the stress-grade crane"


def run(out: Path, quick: bool) -> list[Section]:
    """Run the script (``--modes 50 200 --pairs 1`` when ``quick``), runs under ``out``."""
    args = ["--modes", "50", "200", "--pairs", "1"] if quick else []
    body = run_script(NAME, [*args, "-o", str(out / "runs" / NAME)])
    key = f"{NAME}-{'quick' if quick else 'full'}"
    return [Section(key, f"{SUMMARY[0].upper()}{SUMMARY[1:]}", f"```\n{body.strip()}\n```")]
