"""Studies over records, positions and directions: ``crane-fem study STUDY.toml``.

One scene, the axes along which it varies (:mod:`.spec`), its cases and their conditioning
ensembles (:mod:`.cases`), run on dask.distributed (:mod:`.engine`), and the tables an
engineer signs off (:mod:`.aggregate`): every sign-off quantity in every case, its envelope,
the codes' combination over records, the governing case and whether the scene resolves it.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from crane_fem.errors import RunInterrupted, ScenarioError
from crane_fem.study.aggregate import StudyTables, tabulate, write_tables
from crane_fem.study.cases import Case, ensemble_members, expand_cases, load_case
from crane_fem.study.engine import CaseResult, cluster, run_cases, stop_local_cases
from crane_fem.study.spec import StudySpec, load_study

__all__ = [
    "Case",
    "CaseResult",
    "StudySpec",
    "StudyTables",
    "load_study",
    "run_ensemble_members",
    "run_study",
]


def _say(line: str) -> None:
    print(f"crane-fem: {line}", flush=True)


@contextlib.contextmanager
def _sigterm_as_interrupt() -> Iterator[None]:
    """SIGTERM (a batch system's time limit) stops the study as Ctrl-C does."""

    def handler(signum: int, frame: Any) -> None:
        raise KeyboardInterrupt("SIGTERM")

    old = signal.signal(signal.SIGTERM, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, old)


def run_study(
    path: Path, out: Path | None, workers: int | None, scheduler: str | None
) -> tuple[int, Path]:
    """Run (or resume) the study ``path`` into ``out`` (default ``out/<study file stem>``)
    and write its tables; returns the exit code (0 every case completed, 1 some did not)
    and the study directory.

    Raises:
        ScenarioError: the study file, its scene, an axis refused for every value, a
            scheduler that does not answer.
    """
    from tqdm import tqdm

    spec, scene, records = load_study(path)
    cases = expand_cases(spec, scene, records)
    out = out if out is not None else Path("out") / path.stem
    root = out / "cases"
    if out.exists() and not out.is_dir():
        raise ScenarioError(f"-o {out}: is a file, expected a directory")
    root.mkdir(parents=True, exist_ok=True)
    n_workers = workers or os.cpu_count() or 1
    if n_workers < 1:
        raise ScenarioError(f"--workers {workers}: expected a positive number")
    t0 = time.perf_counter()
    bar = tqdm(total=len(cases), unit="case", desc="study", disable=None)
    failed: list[CaseResult] = []

    finished: list[str] = []

    def done(r: CaseResult) -> None:
        finished.append(r.name)
        bar.update()
        if r.status != "completed":
            failed.append(r)
            bar.write(f"crane-fem: case {r.name}: {r.status}: {r.error}", file=sys.stderr)

    try:
        with _sigterm_as_interrupt(), cluster(n_workers, scheduler) as client:
            where = scheduler or f"a local cluster of {n_workers} workers"
            _say(f"study {path.name}: {len(cases)} cases of {scene.name} on {where}")
            try:
                results = run_cases(client, scene, cases, root, done)
            except KeyboardInterrupt:
                # No SIGTERM handler while the cases are stopped and the cluster closes.
                signal.signal(signal.SIGTERM, signal.SIG_IGN)
                stop_local_cases()
                raise
    except KeyboardInterrupt as exc:
        # The cases' processes end with the workers' threads (interrupted runs, flushed;
        # their checkpoints kept): the same command resumes.
        how = "SIGTERM" if str(exc) == "SIGTERM" else "SIGINT"
        raise RunInterrupted(
            f"study interrupted by {how}: {len(finished)} of {len(cases)} cases finished "
            f"in {root}/; run the same command again to finish the others"
        ) from None
    finally:
        bar.close()
    tables = tabulate(root, cases, results)
    head = {
        "study": str(path.resolve()),
        "scene": str(scene),
        "wall_time_s": time.perf_counter() - t0,
        "workers": n_workers if scheduler is None else None,
        "scheduler": scheduler,
    }
    paths = write_tables(out, tables, cases, results, head)
    reused = sum(r.reused for r in results.values())
    ok = sum(r.status == "completed" for r in results.values())
    _say(
        f"study done in {time.perf_counter() - t0:.1f} s: {ok} of {len(cases)} cases "
        f"completed ({reused} from an earlier run), {len(failed)} not"
    )
    beyond = [k for k, q in tables.quantities.items() if q.get("conditioning", {}).get("beyond")]
    if any("conditioning" in q for q in tables.quantities.values()):
        _say(
            f"{len(beyond)} of {len(tables.quantities)} quantities beyond the scene's "
            "conditioning (the ensemble moves them by more than their tolerance)"
            + (f": {', '.join(beyond[:6])}{', …' if len(beyond) > 6 else ''}" if beyond else "")
        )
    for w in tables.warnings:
        _say(f"warning: {w}")
    _say(f"outputs in {out}/ ({', '.join(p.name for p in paths)}; cases/<case>/)")
    return (0 if not failed else 1), out


def run_ensemble_members(
    scene: Path,
    settings: dict[str, Any],
    sampling: float,
    root: Path,
    epsilon: float = 0.005,
    dt: bool = True,
    workers: int | None = None,
) -> list[tuple[str, Path, CaseResult]]:
    """The conditioning ensemble of the run of ``scene`` with ``settings`` (sampled every
    ``sampling`` seconds), run as a study's members are, on a local cluster, into
    ``root/<member>/``: (label, directory, result) of each. ``crane-fem bench ensemble``'s
    members (its reference, timed, runs alone in its own process)."""
    sc = load_case(scene, settings)
    cases = [
        Case(
            suffix,
            {
                **settings,
                **extra,
                **({"output.sample_interval": sampling} if "Δt" in label else {}),
            },
            "reference",
            member=label,
        )
        for suffix, label, extra in ensemble_members(sc, epsilon, dt)
    ]
    with cluster(workers or os.cpu_count() or 1, None) as client:
        results = run_cases(client, scene, cases, root)
    return [(c.member, root / c.name, results[c.name]) for c in cases]
