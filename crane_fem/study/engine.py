"""Run a study's cases on dask.distributed: a ``LocalCluster`` of N workers by default, or a
running scheduler (``--scheduler ADDRESS``, e.g. started by dask-jobqueue on SLURM or PBS).

Each case is ``crane-fem run`` in a process of its own (dolfinx on its own communicator, one
BLAS thread), into ``DIR/cases/<name>/``, with the case's keys as ``--set``/``--unset``; its
``case.json`` records them. The local workers are threads of the study's process that wait
on their case's process, which is bound to its worker (Linux ``PR_SET_PDEATHSIG``): a study
killed, even by SIGKILL, leaves no case running; each case's process stops as an
interrupted run (its outputs flushed, its checkpoints kept).

Resumable: a case whose ``summary.json`` says "completed" under the same keys is skipped; one
interrupted with a checkpoint continues from it (``--restart``); any other starts again.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from crane_fem.errors import ScenarioError
from crane_fem.study.cases import Case, cli_arguments

__all__ = ["CaseResult", "case_state", "cluster", "run_cases", "stop_local_cases"]

#: Environment variables of an MPI launcher that a case's own process must not inherit
#: (the study may itself run under a launcher's environment).
_LAUNCHER_PREFIXES = ("PMI_", "PMIX_", "HYDRA_", "MPIR_", "OMPI_", "I_MPI_")
#: Seconds to wait for ``--scheduler ADDRESS`` to answer.
CONNECT_TIMEOUT_S = 10.0
#: The cases' processes this process started and waits on (local workers).
_LIVE: set[subprocess.Popen[str]] = set()
_LIVE_LOCK = threading.Lock()
#: Set when the study is interrupted: a local worker then starts no other case.
_STOP = threading.Event()


@dataclass
class CaseResult:
    """A case's outcome: ``status`` is the run's ("completed", "unstable", "interrupted"),
    "failed" (refused or crashed, ``error`` its one line) or "skipped" (its nominal case did
    not complete); ``reused`` when an earlier study's run was kept."""

    name: str
    status: str
    error: str = ""
    wall_s: float = 0.0
    sampling_s: float | None = None
    reused: bool = False


def case_state(outdir: Path, settings: dict[str, Any]) -> str:
    """ "done" (completed under these keys), "restart" (a checkpoint under these keys) or
    "new"."""
    try:
        recorded = json.loads((outdir / "case.json").read_text())["settings"]
    except (OSError, ValueError, KeyError):
        return "new"
    if recorded != json.loads(json.dumps(settings)):
        return "new"
    try:
        status = json.loads((outdir / "summary.json").read_text()).get("status")
    except (OSError, ValueError):
        status = None
    if status == "completed":
        return "done"
    return "restart" if (outdir / "checkpoint" / "latest.json").is_file() else "new"


def _sampling(outdir: Path) -> float | None:
    try:
        return float(json.loads((outdir / "summary.json").read_text())["sampling_interval_s"])
    except (OSError, ValueError, KeyError, TypeError):
        return None


def _bind_to_parent() -> None:  # pragma: no cover - runs in the child before exec
    """The case's process receives SIGTERM when the thread that started it ends."""
    with contextlib.suppress(OSError, AttributeError):
        import ctypes

        libc = ctypes.CDLL("libc.so.6", use_errno=True)
        libc.prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG


def _environment() -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith(_LAUNCHER_PREFIXES)}
    env.update(OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    return env


def _error_line(stderr: str, code: int) -> str:
    lines = [ln for ln in stderr.splitlines() if ln.startswith("crane-fem: error:")]
    if lines:
        return lines[-1].removeprefix("crane-fem: error:").strip()
    tail = [ln for ln in stderr.splitlines() if ln.strip()]
    return f"exit code {code}" + (f": {tail[-1].strip()}" if tail else "")


def run_case(
    scene: str, outdir: str, settings: dict[str, Any], name: str, base: CaseResult | None
) -> CaseResult:
    """Run one case in a process of its own (executed on a dask worker). ``base`` is the
    nominal case's result for a Δt × ½ member (sampled at its instants)."""
    out = Path(outdir)
    st = dict(settings)
    if base is not None:
        if base.status != "completed" or base.sampling_s is None:
            return CaseResult(name, "skipped", f"its nominal case {base.name} is {base.status}")
        st["output.sample_interval"] = base.sampling_s
    state = case_state(out, st)
    if state == "done":
        return CaseResult(name, "completed", sampling_s=_sampling(out), reused=True)
    if _STOP.is_set():
        return CaseResult(name, "interrupted", "the study was interrupted before it started")
    out.mkdir(parents=True, exist_ok=True)
    cmd = [sys.executable, "-m", "crane_fem.cli", "run", scene, "-o", str(out), "--no-progress"]
    cmd += cli_arguments(st)
    if state == "restart":
        cmd += ["--restart", str(out)]
    else:
        (out / "case.json").write_text(json.dumps({"name": name, "settings": st}, indent=1))
    t0 = time.perf_counter()
    with open(out / "run.log", "a", encoding="utf-8") as log:
        proc = subprocess.Popen(
            cmd,
            stdout=log,
            stderr=subprocess.PIPE,
            text=True,
            env=_environment(),
            preexec_fn=_bind_to_parent,
        )
        with _LIVE_LOCK:
            _LIVE.add(proc)
            if _STOP.is_set():
                proc.terminate()
        try:
            _, stderr = proc.communicate()
        except BaseException:
            proc.terminate()
            proc.wait()
            raise
        finally:
            with _LIVE_LOCK:
                _LIVE.discard(proc)
        log.write(stderr)
    wall = time.perf_counter() - t0
    if proc.returncode == 0:
        return CaseResult(name, "completed", wall_s=wall, sampling_s=_sampling(out))
    status = {3: "unstable", 130: "interrupted", 143: "interrupted"}.get(proc.returncode, "failed")
    return CaseResult(name, status, _error_line(stderr, proc.returncode), wall)


def stop_local_cases() -> None:
    """SIGTERM every case's process this process started: each stops at its next macro step
    as an interrupted run (outputs flushed, checkpoints kept); waits for them. The local
    workers start no other case."""
    with _LIVE_LOCK:
        _STOP.set()
        procs = list(_LIVE)
    for p in procs:
        with contextlib.suppress(OSError):
            p.terminate()
    for p in procs:
        with contextlib.suppress(OSError, subprocess.TimeoutExpired):
            p.wait(timeout=60)


@contextlib.contextmanager
def cluster(workers: int, scheduler: str | None) -> Iterator[Any]:
    """A dask ``Client``: on ``scheduler`` (an address that must answer within
    :data:`CONNECT_TIMEOUT_S`), else on a ``LocalCluster`` of ``workers`` single-threaded
    workers in this process (each waits on its case's process).

    Raises:
        ScenarioError: the scheduler does not answer, naming it.
    """
    import logging

    from distributed import Client, LocalCluster

    logging.getLogger("distributed").setLevel(logging.ERROR)
    _STOP.clear()
    if scheduler is not None:
        try:
            client = Client(scheduler, timeout=CONNECT_TIMEOUT_S)
        except (OSError, TimeoutError, ValueError) as exc:
            raise ScenarioError(
                f"--scheduler {scheduler}: no dask scheduler answered within "
                f"{CONNECT_TIMEOUT_S:g} s ({type(exc).__name__})"
            ) from None
        try:
            yield client
        finally:
            client.close()
        return
    with (
        LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=False,
            dashboard_address=None,
        ) as lc,
        Client(lc) as client,
    ):
        yield client


def run_cases(
    client: Any,
    scene: Path,
    cases: list[Case],
    root: Path,
    on_done: Callable[[CaseResult], None] | None = None,
) -> dict[str, CaseResult]:
    """Submit every case (each Δt × ½ member after its nominal case) and gather their
    results as they complete; ``on_done`` is called with each."""
    from distributed import as_completed

    results: dict[str, CaseResult] = {}
    futures: dict[str, Any] = {}
    for c in cases:
        if c.error:
            results[c.name] = CaseResult(c.name, "failed", c.error)
            if on_done is not None:
                on_done(results[c.name])
            continue
        base = futures.get(c.base) if c.sample_like_base else None
        if c.sample_like_base and base is None:
            results[c.name] = CaseResult(c.name, "skipped", f"its nominal case {c.base} failed")
            if on_done is not None:
                on_done(results[c.name])
            continue
        futures[c.name] = client.submit(
            run_case,
            str(scene),
            str(root / c.name),
            c.settings,
            c.name,
            base,
            key=f"case-{c.name}-{time.time_ns()}",
            pure=False,
        )
    names = {f.key: n for n, f in futures.items()}
    for fut in as_completed(list(futures.values())):
        try:
            res = fut.result()
        except Exception as exc:  # a worker lost or a crash outside the case's process
            res = CaseResult(names[fut.key], "failed", f"{type(exc).__name__}: {exc}")
        results[res.name] = res
        if on_done is not None:
            on_done(res)
    return {c.name: results[c.name] for c in cases}


def result_dict(r: CaseResult) -> dict[str, Any]:
    return asdict(r)
