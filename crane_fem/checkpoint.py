"""Checkpoints of a run with subdomains: its whole state at a macro step, from which
``crane-fem run … --restart OUTDIR`` continues to the result of the uninterrupted run.

Every ``output.checkpoint_every`` macro steps the run writes ``OUTDIR/checkpoint/``: one
``rank<r>.npz`` per rank (this rank's arrays: owned and ghost entries, the partition being
the same on restart) and ``meta.json`` (step, time, number of ranks, a hash of the
scenario), in a directory ``step_<n>`` that ``latest.json`` names. A checkpoint is written in
a temporary directory, renamed when every rank has written its file, and only then named by
``latest.json`` (replaced atomically), so an interrupted write leaves the previous checkpoint
the latest; the older ones are then removed.

The state is a nested dict of arrays and scalars that each stateful object gives
(``state_dict``) and takes back (``load_state_dict``): the coupling method (its system: both
sides' vectors, the energy books, the interface impulses, the step count; its own
accumulators), the record of the checkpoint's macro step (taken before the loop uses it), and
the loop's books (history rows, peaks, monitor, energy drift). Operators, factorisations and
interface operators are not saved: the normal set-up rebuilds them, the same. No random state
lives in a run: a synthetic ground motion is generated from its ``seed`` at set-up.

The scenario of a restart must be the one checkpointed except for :data:`FREE_KEYS`: the end
time may be moved (past the checkpoint: a run is extended by restarting it with a later
``time.end``), the checkpoint interval and the progress bar changed.
"""

from __future__ import annotations

import hashlib
import json
import shutil
import time
import zipfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
from mpi4py import MPI

from crane_fem.errors import ScenarioError
from crane_fem.io.xdmf import truncate_xdmf
from crane_fem.scenario import Scenario

__all__ = [
    "CHECKPOINT_DIR",
    "FREE_KEYS",
    "Checkpoint",
    "flatten",
    "raise_if_any",
    "read_checkpoint",
    "resume_series",
    "scenario_hash",
    "unflatten",
    "write_checkpoint",
]

CHECKPOINT_DIR = "checkpoint"
LATEST = "latest.json"
FORMAT = 1
#: Scenario keys a restart may change (section, key).
FREE_KEYS = (("time", "end"), ("output", "checkpoint_every"), ("output", "progress"))
_SEP = "/"


@dataclass(frozen=True)
class Checkpoint:
    """A checkpoint read back: its metadata (``step``, ``t``, ...) and this rank's state."""

    meta: dict[str, Any]
    state: dict[str, Any]

    @property
    def step(self) -> int:
        return int(self.meta["step"])


def scenario_hash(sc: Scenario) -> str:
    """SHA-256 of the scenario without :data:`FREE_KEYS` (not collective)."""
    data = sc.model_dump(mode="json")
    for section, key in FREE_KEYS:
        data.get(section, {}).pop(key, None)
    text = json.dumps(data, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


def flatten(state: dict[str, Any], prefix: str = "") -> dict[str, npt.NDArray[Any]]:
    """A nested dict of arrays and scalars (float, int, bool, str) as one level of arrays,
    keys joined by ``/`` (an empty dict vanishes)."""
    out: dict[str, npt.NDArray[Any]] = {}
    for key, value in state.items():
        if _SEP in key:
            raise ValueError(f"state key {key!r} contains {_SEP!r}")
        name = prefix + key
        if isinstance(value, dict):
            out.update(flatten(value, name + _SEP))
        else:
            out[name] = np.asarray(value)
    return out


def unflatten(arrays: dict[str, npt.NDArray[Any]]) -> dict[str, Any]:
    """The nested dict of :func:`flatten`, 0-d arrays as Python scalars."""
    out: dict[str, Any] = {}
    for name, value in arrays.items():
        *path, leaf = name.split(_SEP)
        node = out
        for key in path:
            node = node.setdefault(key, {})
        node[leaf] = value.item() if value.ndim == 0 else value
    return out


def raise_if_any(comm: MPI.Comm, error: str | None) -> None:
    """Raise :class:`ScenarioError` on every rank when some rank met ``error`` (collective)."""
    errors = [e for e in comm.allgather(error) if e]
    if errors:
        raise ScenarioError(errors[0])


def _on_root(comm: MPI.Comm, action: Callable[[], Any]) -> Any:
    """``action()`` on rank 0, its result broadcast; an error there raised on every rank as
    a one-line :class:`ScenarioError`."""
    result, error = None, None
    if comm.rank == 0:
        try:
            result = action()
        except (OSError, ValueError, KeyError) as exc:
            error = " ".join(str(exc).split()) or type(exc).__name__
    result, error = comm.bcast((result, error), root=0)
    if error:
        raise ScenarioError(error)
    return result


def write_checkpoint(
    outdir: Path, comm: MPI.Comm, meta: dict[str, Any], state: dict[str, Any]
) -> None:
    """Write the checkpoint of macro step ``meta["step"]`` (collective): this rank's
    ``state`` and, from rank 0, ``meta`` with the number of ranks and the format."""
    root = outdir / CHECKPOINT_DIR
    name = f"step_{int(meta['step']):08d}"
    tmp = root / (name + ".tmp")

    def start() -> None:
        if tmp.exists():
            shutil.rmtree(tmp)
        tmp.mkdir(parents=True)

    _on_root(comm, start)
    error = None
    try:
        with (tmp / f"rank{comm.rank}.npz").open("wb") as f:
            # (numpy's stub types the keyword arrays as its allow_pickle flag)
            np.savez(f, **flatten(state))  # type: ignore[arg-type]
    except OSError as exc:
        error = f"checkpoint: cannot write {tmp}: {exc}"
    raise_if_any(comm, error)
    meta = {**meta, "format": FORMAT, "nranks": comm.size, "written": time.time()}

    def finish() -> None:
        (tmp / "meta.json").write_text(json.dumps(meta, indent=2) + "\n", encoding="utf-8")
        final = root / name
        if final.exists():
            shutil.rmtree(final)
        tmp.rename(final)
        latest = root / (LATEST + ".tmp")
        latest.write_text(json.dumps({**meta, "dir": name}, indent=2) + "\n", encoding="utf-8")
        latest.replace(root / LATEST)
        for old in root.glob("step_*"):
            if old.name != name:
                shutil.rmtree(old, ignore_errors=True)

    _on_root(comm, finish)


def read_checkpoint(restart: Path, comm: MPI.Comm, sc: Scenario) -> Checkpoint:
    """The latest checkpoint in ``restart`` for this rank (collective). Refused, with a
    one-line :class:`ScenarioError` on every rank: no checkpoint, or one written by another
    number of ranks or for another scenario (:func:`scenario_hash`)."""
    root = restart / CHECKPOINT_DIR

    def latest() -> dict[str, Any]:
        path = root / LATEST
        if not path.is_file():
            raise ValueError(
                f"--restart: no checkpoint in {restart} (written by runs with "
                "output.checkpoint_every)"
            )
        try:
            meta: dict[str, Any] = json.loads(path.read_text(encoding="utf-8"))
            if not isinstance(meta, dict) or "dir" not in meta:
                raise ValueError("not a checkpoint record")
        except (ValueError, UnicodeDecodeError) as exc:
            raise ValueError(
                f"--restart: {path} is damaged ({' '.join(str(exc).split())}); its run was "
                "cut while writing it? restart from an earlier checkpoint directory, or run anew"
            ) from None
        if meta.get("format") != FORMAT:
            raise ValueError(f"--restart: {path}: checkpoint format {meta.get('format')}")
        if meta["nranks"] != comm.size:
            raise ValueError(
                f"--restart: the checkpoint in {restart} was written by {meta['nranks']} "
                f"rank(s); restart it with as many (this run has {comm.size})"
            )
        if meta["scenario_hash"] != scenario_hash(sc):
            keys = ", ".join(".".join(k) for k in FREE_KEYS)
            raise ValueError(
                f"--restart: the checkpoint in {restart} is of another scenario (only {keys} "
                "may change on restart)"
            )
        return meta

    meta = _on_root(comm, latest)
    error, state = None, {}
    path = root / str(meta["dir"]) / f"rank{comm.rank}.npz"
    try:
        with np.load(path, allow_pickle=False) as data:
            state = unflatten({k: data[k] for k in data.files})
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
        error = (
            f"--restart: cannot read {path} ({' '.join(str(exc).split()) or type(exc).__name__})"
            ": the checkpoint is damaged or incomplete"
        )
    raise_if_any(comm, error)
    return Checkpoint(meta, state)


def resume_series(
    restart: Path, outdir: Path, files: list[Path], frames: int, comm: MPI.Comm
) -> None:
    """Make the XDMF series ``files`` of ``outdir`` hold the first ``frames`` frames of
    ``restart``'s (copied first when the two directories differ), ready to be continued
    (collective; rank 0 works on the files)."""

    def prune() -> None:
        for path in files:
            src = restart / path.name
            if not src.is_file():
                raise ValueError(f"--restart: {src} is missing (the run wrote XDMF frames)")
            if restart.resolve() != outdir.resolve():
                outdir.mkdir(parents=True, exist_ok=True)
                shutil.copy2(src, path)
                shutil.copy2(src.with_suffix(".h5"), path.with_suffix(".h5"))
            truncate_xdmf(path, frames)

    _on_root(comm, prune)
