"""The output directory of a run: checked, created, and cleared of an earlier run's outputs."""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

from mpi4py import MPI

from crane_fem.errors import ScenarioError

__all__ = ["RUN_OUTPUTS", "prepare_output_dir"]

#: What a run writes in its directory (file names, globs and subdirectories): an earlier
#: run's copies are removed before a new run, so that no stale file sits beside fresh ones
#: (a ``solution_<subdomain>.xdmf`` of a subdomain the new run no longer has, say).
RUN_OUTPUTS = (
    "history.csv",
    "summary.json",
    "summary.json.tmp",
    "results.csv",
    "spectra.csv",
    "solution*.xdmf",
    "solution*.h5",
    "checkpoint",
    "figures",
)


def _stale(out: Path) -> list[Path]:
    found: list[Path] = []
    for pattern in RUN_OUTPUTS:
        found += sorted(out.glob(pattern))
    return found


def _prepare(out: Path, restart: bool) -> tuple[str | None, list[str]]:
    """(error, names removed) on this process: the checks and the clean-up of rank 0."""
    where = f"output directory {out}"
    if out.exists() and not out.is_dir():
        return f"{where} is a file, not a directory", []
    if restart:
        if not out.is_dir():
            return f"--restart {out}: no such directory", []
    else:
        try:
            out.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            return f"{where}: cannot create it ({exc.strerror or exc})", []
    try:  # os.access is not enough: root passes it, a read-only file system does not
        with tempfile.TemporaryFile(dir=out, prefix=".crane-fem-write-test-"):
            pass
    except OSError as exc:
        return f"{where} is not writable ({exc.strerror or exc})", []
    if restart:
        return None, []
    removed: list[str] = []
    try:
        for path in _stale(out):
            if path.is_dir() and not path.is_symlink():
                shutil.rmtree(path)
                removed.append(f"{path.name}/")
            else:
                path.unlink()
                removed.append(path.name)
    except OSError as exc:
        return f"{where}: cannot remove the earlier run's {path.name} ({exc.strerror or exc})", []
    return None, removed


def prepare_output_dir(outdir: str | Path, comm: MPI.Comm, *, restart: bool) -> list[str]:
    """Make ``outdir`` ready for a run: create it, check that it is a writable directory, and
    remove the outputs of an earlier run there (:data:`RUN_OUTPUTS`) unless ``restart`` (the
    run continues in that directory, which must then exist).

    Collective over ``comm``: rank 0 checks and cleans, then broadcasts its verdict, so every
    rank raises the same error or none, before any other work.

    Returns:
        The names removed (directories with a trailing ``/``), on every rank.

    Raises:
        ScenarioError: ``outdir`` is a file, cannot be created, is not writable, or a stale
            output cannot be removed (one line, on every rank).
    """
    out = Path(outdir)
    verdict: tuple[str | None, list[str]] = (None, [])
    if comm.rank == 0:
        verdict = _prepare(out, restart)
    error, removed = comm.bcast(verdict, root=0)
    if error is not None:
        raise ScenarioError(error)
    return removed
