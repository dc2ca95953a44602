"""What every benchmark suite needs: run one scenario variant in this process and keep its
summary, history and cost; the demo scenarios; the rows written to CSV."""

from __future__ import annotations

import csv
import json
import shutil
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
from mpi4py import MPI

from crane_fem.errors import UnstableRunError
from crane_fem.scenario import Scenario, load_scenario

__all__ = [
    "Outcome",
    "demo",
    "explicit_settings",
    "run_case",
    "run_script",
    "toml_value",
    "write_csv",
]

FloatArray = npt.NDArray[np.float64]

#: The repository's scenarios (the suites run the demos as a user would) and scripts.
DEMOS = Path(__file__).resolve().parents[2] / "demos"
SCRIPTS = Path(__file__).resolve().parents[2] / "benchmarks"


def demo(name: str) -> Path:
    """The path of ``demos/<name>.toml``."""
    path = DEMOS / f"{name}.toml"
    if not path.is_file():
        raise FileNotFoundError(f"{path}: demo scenario not found (run from a crane_fem checkout)")
    return path


def explicit_settings(
    scene: Path,
    scale: float = 1.0,
    dt: float = 1.0,
    sampling: float | None = None,
    base: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """The settings of a crane scene's fully explicit run with the record scaled by
    ``scale`` and Δt by ``dt``, sampled every ``sampling`` seconds (the nominal run's
    ``sampling_interval_s``, so that a run of another Δt samples the same instants; None:
    the scene's own interval), on top of ``base`` (a variant's settings). The suites that
    need the same run (the Pareto chart's reference, the ensemble's member) get the same
    settings from here, and so share the run (:func:`run_case`)."""
    sc = load_scenario(
        scene,
        [f"{k}={toml_value(v)}" for k, v in (base or {}).items() if v is not None],
        [k for k, v in (base or {}).items() if v is None],
    )
    from crane_fem.study.cases import halved_step, scaled_record

    out: dict[str, Any] = {**(base or {}), "coupling.method": "monolithic", "output.xdmf": False}
    if scale != 1.0:
        out.update(scaled_record(sc, scale))
    if dt != 1.0:
        assert dt == 0.5, "the ensemble halves Δt"
        out.update(halved_step(sc))
    if sampling is not None:
        out["output.sample_interval"] = sampling
    return out


def toml_value(value: Any) -> str:
    """``value`` as a TOML literal for ``--set KEY=VALUE`` (the study's writer)."""
    from crane_fem.study.cases import toml_literal

    return toml_literal(value)


@dataclass
class Outcome:
    """One run of a suite: ``status`` is "completed" or "unstable" (stopped by the
    energy-growth monitor or a non-finite energy, with ``diagnosis``)."""

    label: str
    scenario: Scenario
    outdir: Path
    status: str
    summary: dict[str, Any] = field(default_factory=dict)
    history: dict[str, FloatArray] = field(default_factory=dict)
    diagnosis: str = ""

    @property
    def stable(self) -> bool:
        return self.status == "completed"

    @property
    def wall_per_second(self) -> float:
        """Wall time of the time loop per simulated second (s/s)."""
        t_end = float(self.history["t"][-1]) if self.history.get("t") is not None else 0.0
        return float(self.summary.get("wall_time_integration_s", np.nan)) / max(t_end, 1e-300)


#: Runs done in this process, by (scenario, settings): suites that need the same run (the
#: crane's explicit reference serves the Pareto chart and the ensemble) share it.
_DONE: dict[tuple[str, str], Outcome] = {}


def run_case(
    label: str,
    scenario: str | Path,
    settings: dict[str, Any],
    outdir: Path,
    comm: MPI.Comm | None = None,
) -> Outcome:
    """Run ``scenario`` with ``settings`` ({"key.path": value}; None removes the key) into
    ``outdir`` (emptied first), in this process and without a progress bar (collective over
    ``comm``). A run with the same scenario and settings done earlier in this process is
    returned again."""
    comm = MPI.COMM_WORLD if comm is None else comm
    overrides = [f"{k}={toml_value(v)}" for k, v in sorted(settings.items()) if v is not None]
    unset = sorted(k for k, v in settings.items() if v is None)
    key = (str(Path(scenario).resolve()), "\n".join([*overrides, *unset]))
    if key in _DONE:
        return _DONE[key]
    outcome = _run(label, scenario, overrides, outdir, comm, unset)
    _DONE[key] = outcome
    return outcome


def _run(
    label: str,
    scenario: str | Path,
    overrides: list[str],
    outdir: Path,
    comm: MPI.Comm,
    unset: list[str] | None = None,
) -> Outcome:
    from crane_fem.driver import run_scenario

    sc = load_scenario(scenario, overrides, unset)
    if comm.rank == 0 and outdir.exists():
        shutil.rmtree(outdir)
    comm.barrier()
    try:
        res = run_scenario(sc, outdir, comm, progress=False)
    except UnstableRunError as exc:
        from crane_fem.io import read_history

        summary = json.loads((outdir / "summary.json").read_text(encoding="utf-8"))
        history = read_history(outdir / "history.csv")
        return Outcome(label, sc, outdir, "unstable", summary, history, str(exc))
    return Outcome(label, sc, outdir, "completed", res.summary, res.history)


def write_csv(path: Path, rows: list[dict[str, Any]]) -> Path:
    """Rows (dicts with the same keys) as CSV (not collective: call on rank 0)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    keys: list[str] = []
    for r in rows:
        keys += [k for k in r if k not in keys]
    with path.open("w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, fieldnames=keys)
        w.writeheader()
        for r in rows:
            w.writerow({k: _fmt(r.get(k, "")) for k in keys})
    return path


def _fmt(v: Any) -> Any:
    return f"{v:.6g}" if isinstance(v, float) else v


def run_script(name: str, args: list[str]) -> str:
    """Run ``benchmarks/<name>.py ARGS`` (a study that times its runs in processes of its
    own) on rank 0 and return what it printed: its Markdown tables (collective: the other
    ranks wait and receive the text)."""
    comm = MPI.COMM_WORLD
    text = ""
    if comm.rank == 0:
        script = SCRIPTS / f"{name}.py"
        if not script.is_file():
            raise FileNotFoundError(f"{script}: benchmark script not found")
        done = subprocess.run(
            [sys.executable, str(script), *args], capture_output=True, text=True, check=False
        )
        if done.returncode != 0:
            raise RuntimeError(f"{script} failed ({done.returncode}): {done.stderr[-2000:]}")
        text = done.stdout
    result: str = comm.bcast(text, root=0)
    return result
