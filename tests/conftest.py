"""Shared fixtures: MPI-safe temporary directories and scenario builders."""

import copy
import os
import tempfile
from pathlib import Path
from typing import Any

import pytest
from mpi4py import MPI

import crane_fem  # noqa: F401  (loads MPI before dolfinx: keep first)
from crane_fem.driver import RunResult, run_scenario
from crane_fem.scenario import Scenario, parse_scenario

COMM = MPI.COMM_WORLD


def pytest_configure(config: pytest.Config) -> None:
    """Under mpiexec, give each rank its own pytest base temp dir (no cleanup races)."""
    if COMM.size > 1 and not config.option.basetemp:
        job = COMM.bcast(os.getpid(), root=0)
        base = Path(tempfile.gettempdir()) / f"crane_fem_pytest_{job}" / f"rank{COMM.rank}"
        base.parent.mkdir(parents=True, exist_ok=True)
        config.option.basetemp = str(base)


@pytest.fixture
def shared_tmp(tmp_path: Path) -> Path:
    """A temporary directory that is the same on every rank (rank 0's)."""
    return Path(COMM.bcast(str(tmp_path), root=0))


BASE: dict[str, Any] = {
    "name": "test",
    "model": {"kind": "bar", "length": 1.0, "elements": 100},
    "material": {"E": 1.0, "rho": 1.0},
    "initial": {"velocity": -1.0},
    "contact": [{"type": "wall", "gap": 0.1}],
    "time": {"end": 2.5, "dt_factor": 0.9},
    "integrator": {"scheme": "cd-lagrange"},
    "output": {"xdmf": False},
}


def make_scenario(**sections: Any) -> Scenario:
    """BASE with whole sections or ``section={key: value}`` merged in."""
    data = copy.deepcopy(BASE)
    for name, value in sections.items():
        if isinstance(value, dict) and isinstance(data.get(name), dict):
            data[name].update(value)
        else:
            data[name] = value
    return parse_scenario(data)


def run(sc: Scenario, outdir: Path) -> RunResult:
    return run_scenario(sc, outdir, COMM, progress=False)


def mpiexec_env() -> dict[str, str]:
    """The environment of a spawned `mpiexec -n 2`: one BLAS/OpenMP thread per rank. Two
    ranks of two-threaded BLAS on two cores oversubscribe them, and the threaded reductions
    then differ from run to run at round-off (two identical runs: up to 1e-11 relative).
    With one thread per rank a serial run is reproducible to the bit; a parallel one still
    varies at round-off (distributed MUMPS: 5e-12 m/s on the crane's transverse probe
    velocity between two runs)."""
    return {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Tests marked ``serial`` launch their own MPI jobs: run them only in the serial pass."""
    if COMM.size == 1:
        return
    skip = pytest.mark.skip(reason="serial-only (launches its own mpiexec)")
    for item in items:
        if "serial" in item.keywords:
            item.add_marker(skip)
