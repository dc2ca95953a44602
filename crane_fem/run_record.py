"""What every run gives back and leaves behind: the result record, the progress bar, and the
closing fields of summary.json (cost, energy closure, contact intervals)."""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
from mpi4py import MPI
from tqdm import tqdm

from crane_fem.io import write_summary
from crane_fem.scenario import Scenario

__all__ = ["RunResult", "finish_summary", "progress_bar"]

FloatArray = npt.NDArray[np.float64]


@dataclass
class RunResult:
    """Summary and the in-memory history (global values, identical on every rank)."""

    summary: dict[str, Any]
    history: dict[str, FloatArray] = field(default_factory=dict)


def progress_bar(sc: Scenario, comm: MPI.Comm, progress: bool | None, total: int, unit: str) -> Any:
    """tqdm bar on rank 0, shown after 2 s, off when stderr is not a terminal (unless forced)."""
    show = progress if progress is not None else sc.output.progress
    on = comm.rank == 0 and (sys.stderr.isatty() if show == "auto" else bool(show))
    return tqdm(total=total, disable=not on, delay=2.0, mininterval=0.5, unit=unit, desc=sc.name)


def finish_summary(
    summary: dict[str, Any],
    out: Path,
    comm: MPI.Comm,
    t_wall: float,
    times: FloatArray | list[float],
    active: npt.NDArray[np.bool_] | list[bool],
    max_drift: float,
    scale: float,
) -> None:
    """Add cost, energy closure and contact intervals, then write summary.json (collective)."""
    intervals = _contact_intervals(times, active)
    summary.update(
        {
            "wall_time_s": comm.allreduce(time.perf_counter() - t_wall, op=MPI.MAX),
            "energy_balance_error": max_drift / scale if scale > 0 else 0.0,
            "energy_balance_error_abs": max_drift,
            "contact_intervals": len(intervals),
            "contact_interval_times": intervals[:100],
        }
    )
    write_summary(out / "summary.json", summary, comm)


def _contact_intervals(
    times: FloatArray | list[float], active: npt.NDArray[np.bool_] | list[bool]
) -> list[tuple[float, float]]:
    """Maximal runs of consecutive steps with a non-zero contact impulse: (first, last) times."""
    t = np.asarray(times, dtype=np.float64)
    on = np.asarray(active, dtype=bool)
    edges = np.flatnonzero(np.diff(np.r_[np.int8(0), on.astype(np.int8), np.int8(0)]))
    return [(float(t[a]), float(t[b - 1])) for a, b in zip(edges[::2], edges[1::2], strict=True)]
