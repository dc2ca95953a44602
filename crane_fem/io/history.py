"""history.csv: one row per output step, written by rank 0 and flushed row by row."""

from __future__ import annotations

import csv
import operator
from pathlib import Path
from types import TracebackType

import numpy as np
import numpy.typing as npt
from mpi4py import MPI

__all__ = ["HistoryWriter", "read_history"]


class HistoryWriter:
    """CSV writer on rank 0 of ``comm``; other ranks hold no file. Values must be global.

    Each row is flushed, so an interrupted run leaves a valid file of complete rows.
    ``rows``: columns of rows to write first, as :meth:`write` would have (a restarted run's
    rows up to its checkpoint: the file is written anew, so rows written after the
    checkpoint by the interrupted run are dropped).
    """

    def __init__(
        self,
        path: Path,
        columns: list[str],
        comm: MPI.Comm,
        rows: dict[str, list[float]] | None = None,
    ) -> None:
        self.columns = columns
        # A row's values in column order (a 1-tuple for one column: itemgetter gives a bare
        # value).
        get = operator.itemgetter(*columns)
        self._values = get if len(columns) > 1 else lambda row: (get(row),)
        self._file = None
        self._writer = None
        if comm.rank == 0:
            path.parent.mkdir(parents=True, exist_ok=True)
            self._file = path.open("w", newline="", encoding="utf-8")
            self._writer = csv.writer(self._file)
            self._writer.writerow(columns)
            if rows:
                n = len(rows[columns[0]])
                for i in range(n):
                    self._writer.writerow([repr(float(rows[c][i])) for c in columns])
            self._file.flush()

    def write(self, row: dict[str, float]) -> None:
        if self._writer is None or self._file is None:
            return
        # The csv writer's line (no float's repr needs quoting; its line end is \r\n),
        # joined here at a third of its cost.
        self._file.write(",".join(map(repr, map(float, self._values(row)))) + "\r\n")
        self._file.flush()

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None
            self._writer = None

    def __enter__(self) -> HistoryWriter:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()


def read_history(path: str | Path) -> dict[str, npt.NDArray[np.float64]]:
    """Read a history.csv into ``{column: array}`` (not collective)."""
    with Path(path).open(encoding="utf-8") as f:
        reader = csv.reader(f)
        header = next(reader)
        rows = [[float(x) for x in r] for r in reader if r]
    data = np.array(rows, dtype=np.float64).reshape(-1, len(header))
    return {name: data[:, i] for i, name in enumerate(header)}
