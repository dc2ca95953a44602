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

__all__ = ["RunResult", "StopRequest", "finish_summary", "progress_bar"]

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


class StopRequest:
    """SIGINT and SIGTERM, turned into a request that every rank sees at the same macro step
    (a context manager: the handlers are installed inside it only).

    A signal only sets a flag; :meth:`requested` (collective: one small allreduce under MPI)
    tells every rank whether any rank received one, so that all stop at the same step
    boundary, with no rank left waiting in a collective the others never reach.
    """

    def __init__(self, comm: MPI.Comm) -> None:
        self.comm = comm
        self.signal_name = ""
        self._flag = 0
        self._old: dict[int, Any] = {}

    def _handler(self, signum: int, frame: Any) -> None:
        import signal

        self._flag = int(signum)
        self.signal_name = signal.Signals(signum).name

    def __enter__(self) -> StopRequest:
        import signal
        import threading

        if threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGINT, signal.SIGTERM):
                self._old[sig] = signal.signal(sig, self._handler)
        return self

    def __exit__(self, *exc: object) -> None:
        import signal

        for sig, old in self._old.items():
            signal.signal(sig, old)
        self._old.clear()

    def requested(self) -> bool:
        """Whether a signal reached any rank (collective)."""
        flag = self._flag
        if self.comm.size > 1:
            flag = int(self.comm.allreduce(flag, op=MPI.MAX))
        if flag and not self.signal_name:
            import signal

            self.signal_name = signal.Signals(flag).name
        return bool(flag)
