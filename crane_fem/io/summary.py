"""summary.json: the run's step sizes, cost, energy closure and contact statistics."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from mpi4py import MPI

__all__ = ["write_summary"]


def write_summary(path: Path, summary: dict[str, Any], comm: MPI.Comm) -> None:
    """Write ``summary`` as JSON on rank 0 (atomically: temp file then rename)."""
    if comm.rank != 0:
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(summary, indent=2, sort_keys=True) + "\n", encoding="utf-8")
    tmp.replace(path)
