"""Shared fixtures: MPI-safe temporary directories and scenario builders."""

import copy
import os
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mpi4py import MPI

import crane_fem  # noqa: F401  (loads MPI before dolfinx: keep first)
from crane_fem.coupling import ENERGY_KEYS, PH_KEYS
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


def run_serial_and_two_ranks(args: list[str], tmp: Path) -> tuple[Path, Path]:
    """``crane-fem run ARGS`` serially and under ``mpiexec -n 2`` (one BLAS thread per rank,
    :func:`mpiexec_env`), into ``tmp/serial`` and ``tmp/mpi``; their directories."""
    import subprocess
    import sys

    bindir = Path(sys.executable).parent
    base = [str(bindir / "crane-fem"), "run", *args]
    serial, par = tmp / "serial", tmp / "mpi"
    env = mpiexec_env()
    # A hang (a collective one rank left) fails the test instead of stalling the suite: the
    # scenes these tests run take seconds, 10 min is far beyond any of them.
    limit = 600
    subprocess.run(
        [*base, "-o", str(serial)], check=True, capture_output=True, env=env, timeout=limit
    )
    cmd = [str(bindir / "mpiexec"), "-n", "2", *base, "-o", str(par)]
    subprocess.run(cmd, check=True, capture_output=True, env=env, timeout=limit)
    return serial, par


def error_line(code: int, capsys: pytest.CaptureFixture[str]) -> str:
    """This rank's exit code and output, as the one error line a bad input must give (else a
    description of what came instead)."""
    out, err = capsys.readouterr()
    lines = err.strip().splitlines()
    if code != 2 or out or len(lines) != 1 or not lines[0].startswith("crane-fem: error: "):
        return f"exit code {code}, stdout {out!r}, stderr {err!r}"
    return lines[0]


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Tests marked ``serial`` launch their own MPI jobs: run them only in the serial pass."""
    if COMM.size == 1:
        return
    skip = pytest.mark.skip(reason="serial-only (launches its own mpiexec)")
    for item in items:
        if "serial" in item.keywords:
            item.add_marker(skip)


ENERGIES = {*ENERGY_KEYS, *PH_KEYS, "total"}


def _scale(h: dict, names: list[str]) -> float:
    return max((float(np.max(np.abs(h[c]))) for c in names if c in h), default=0.0)


def _support(col: str) -> bool:
    """A support force component's column (``support<k>_f<x|y|z>``)."""
    return col.startswith("support") and col[-3:-1] == "_f"


def assert_same_histories(h1: dict, h2: dict, rtol: float) -> None:
    """Two histories equal to ``rtol``, each column against the scale it belongs to.

    Energies are parts of one balance, compared to its scale; gaps to the displacements,
    the interface velocity jump (round-off itself) to the velocities (the crane's wheel pairs,
    else the probe); the interface impulse defect (round-off itself for ec and ph) to the
    impulse; each component of the probe's displacement or velocity to that vector's largest
    component (the crane's probe moves vertically: its transverse velocity peaks at 0.5 % of
    the vertical one, and the parallel run, whose distributed solves sum in an order that
    changes from run to run, differs from one run to the next by 5e-12 m/s there — 1e-8 of
    that component's own peak); the rest to its own largest value."""
    # The measured points' accelerations (ground_a*, <point>_a*), the friction term of the
    # balance (zero without friction), the support forces (support<k>_f*) and the bridge's
    # largest stress and the wheels' slips (wheel<k>_slip_*) came after the stored references
    # were made: a history may have them where the other does not.
    extra = set(h1) ^ set(h2)
    later = ("_ax", "_ay", "_az", "_slip_across", "_slip_along")
    assert all(
        c.endswith(later) or c in ("friction_dissipated", "bridge_von_mises_max") or _support(c)
        for c in extra
    ), extra
    h1 = {c: h1[c] for c in h1 if c in h2}
    energy = {c for c in h1 if c in ENERGIES or c.startswith(("kinetic", "internal"))}
    e_scale = _scale(h1, ["total", "external_work", "kinetic", "internal"])
    wheels = [c for c in h1 if c.startswith("wheel") and c[-3:] in ("_uz", "_vz")]
    probe = {q: _scale(h1, [c for c in h1 if c.startswith(f"probe_{q}")]) for q in "uv"}
    v_scale = _scale(h1, [c for c in wheels if c.endswith("_vz")]) or probe["v"]
    u_scale = _scale(h1, [c for c in wheels if c.endswith("_uz")]) or probe["u"]
    acc_scale = _scale(h1, [c for c in h1 if c.endswith(("_ax", "_ay", "_az"))])
    support_scale = _scale(h1, [c for c in h1 if _support(c)])
    force_scale = _scale(h1, [c for c in h1 if c.startswith("force_")])
    t_rows = h1.get("t", h2.get("t", np.zeros(0)))
    d_t = float(np.min(np.diff(t_rows), initial=np.inf)) if t_rows.size > 1 else np.inf
    for col in h1:
        own = max(float(np.max(np.abs(h1[col]))), 1e-300)
        if col in energy:
            scale = e_scale
        elif col.startswith("gap") or col.endswith(("_slip_across", "_slip_along")):
            # A gap or a wheel's slip is a difference of displacements: its round-off is
            # theirs (a symmetric crane's slip along the rail is round-off of zero).
            scale = u_scale or own
        elif col == "interface_velocity_jump":
            scale = v_scale or own
        elif col == "interface_impulse_defect":
            scale = _scale(h1, ["interface_impulse"]) or own
        elif col.startswith("probe_"):
            scale = probe[col[6]]
        elif col.startswith("force_") and force_scale:
            # A contact's force against the largest contact force: the multipliers are
            # solved together, so a flange's few newtons carry the round-off of the wheels'
            # kilonewtons (frame_crane_3c restarted on two ranks: 1.6e-7 N on a flange's
            # 147 N, 1.1e-9 of it).
            scale = force_scale
        elif _support(col):
            # Each component of a support's force against the largest of them all (a
            # symmetric crane's transverse components are round-off of the vertical ones).
            scale = support_scale
        elif col.endswith(("_ax", "_ay", "_az")):
            # Absolute accelerations, second differences of displacements over δ² (δ the
            # rows' interval): their round-off is the displacements' over δ²; measured
            # against that scale, or the largest acceleration's.
            scale = max(acc_scale, u_scale / d_t**2)
        else:
            scale = own
        assert h1[col].shape == h2[col].shape, col
        err = float(np.max(np.abs(h1[col] - h2[col]), initial=0.0))
        assert err <= rtol * scale, (col, err / scale)


REFERENCE = Path(__file__).parent / "data" / "reference"
#: demos/crane_quick.toml as the stored references were made (tests/data/reference): GC at a
#: fixed ratio, the implicit side's consistent mass. The scene as written refines at impacts
#: (gc-mean, lumped implicit mass: tests/test_adaptive.py judges it against the explicit run).
QUICK_FIXED_UNSET = ["coupling.fine_ratio", "coupling.refine_quiet", "newmark"]


def quick_fixed(method: str = "gc") -> list[str]:
    """The crane-fem arguments that run demos/crane_quick.toml as its references were made,
    with ``method`` at the scene's ratio (later ``--set`` arguments override)."""
    args = [a for key in QUICK_FIXED_UNSET for a in ("--unset", key)]
    return [*args, "--set", f"coupling.method='{method}'"]


#: The compiled kernel against the Python path it replaced (issue 13: 1e-10 relative). The
#: floor is that path's own spread: its serial and two-rank runs differed by 3.3e-11 (gc) to
#: 9.1e-11 (monolithic), two of its two-rank runs by 7.1e-11 (tests/data/reference/README.md):
#: round-off that the crane's impacts amplify by 1e5 over the quick scene.
REFERENCE_RTOL = 1e-10
#: "hybrid" is followed to less than that, whatever the kernel: its "ec" macro steps solve the
#: interface system of a macro step, of condition ~1e5, to the round-off of an explicit pass
#: (residual 7.6e-12 of the increments after the one exact Newton correction), so two
#: implementations agree on its link force G to ~1e-11 only, which the impacts amplify. The
#: quick scene's first 0.03 s (one BLAS thread) differ from the Python path by 1.4e-10, and
#: still by 1.7e-10 with the Python path's one-block interface operator and MUMPS LU; and
#: three two-rank runs of the Python path itself, identical to one another, differ from its
#: own two-rank hybrid reference by 1.2e-10. Twice the worst measured.
REFERENCE_RTOL_HYBRID = 3.5e-10
#: Two-rank runs against the Python path's two-rank references: their floor is the two-rank
#: run's own spread. The static preload's distributed MUMPS solve sums in an order that
#: depends on timing, so two `mpiexec -n 2` runs of the same code start 1.6e-12 apart in
#: internal energy, which the impacts amplify (measured session 12, six runs per method of
#: the quick scene: monolithic 8.9e-11 between runs, gc 7.5e-11, gc-mean 4.1e-11; a CI run's
#: monolithic came out 1.03e-10 from its reference). Twice the worst measured.
REFERENCE_RTOL_NP2 = 2.1e-10


def reference(name: str, rows: int | None = None) -> dict[str, np.ndarray]:
    """A reference history of tests/data/reference, its first ``rows`` rows if given."""
    with np.load(REFERENCE / f"{name}.npz") as data:
        return {k: data[k][:rows] for k in data.files}
