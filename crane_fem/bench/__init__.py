"""``crane-fem bench``: the benchmark suites, one module per suite behind :class:`Suite`.

Each suite runs its scenarios in this process, writes CSV and PNG to its output directory and
returns the Markdown that goes into ``benchmarks/RESULTS.md`` (:mod:`.report`).
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol

__all__ = ["ALL_SUITES", "SUITES", "Section", "Suite", "load_suite"]


@dataclass
class Section:
    """What a suite reports: a RESULTS.md block (``key`` names it), and the files written."""

    key: str
    title: str
    body: str
    files: list[Path] = field(default_factory=list)


class Suite(Protocol):
    """A module of this package: ``NAME``, ``SUMMARY`` (one line) and ``run``."""

    NAME: str
    SUMMARY: str

    def run(self, out: Path, quick: bool) -> list[Section]:
        """Run the suite (collective over COMM_WORLD), write its files under ``out``, and
        return its sections (the same on every rank)."""
        ...


#: The suites ``crane-fem bench`` runs by default, in this order (``--quick``: ≤ 10 min).
SUITES = ["stability", "pareto", "ensemble"]
#: Every suite: the default ones, and the studies run by name (each runs its script of
#: ``benchmarks/`` and keeps its own results there).
ALL_SUITES = [*SUITES, "three_component", "speed", "reduction", "convergence", "gc_stability"]


def load_suite(name: str) -> Suite:
    """The suite module ``crane_fem.bench.<name>``."""
    if name not in ALL_SUITES:
        raise KeyError(name)
    return importlib.import_module(f"crane_fem.bench.{name}")
