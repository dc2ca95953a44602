"""Shared fixtures: MPI-safe temporary directories and scenario builders."""

import copy
import json
import os
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, NamedTuple

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


#: A hang (a collective one rank left) fails the test instead of stalling the suite: the
#: scenes these tests run take seconds, 10 min is far beyond any of them.
SPAWN_TIMEOUT = 600


def run_two_ranks(args: list[str], out: Path) -> Path:
    """``mpiexec -n 2 crane-fem run ARGS -o OUT`` (one BLAS thread per rank,
    :func:`mpiexec_env`); ``out``."""
    import subprocess
    import sys

    bindir = Path(sys.executable).parent
    cmd = [str(bindir / "mpiexec"), "-n", "2", str(bindir / "crane-fem"), "run", *args]
    subprocess.run(
        [*cmd, "-o", str(out)],
        check=True,
        capture_output=True,
        env=mpiexec_env(),
        timeout=SPAWN_TIMEOUT,
    )
    return out


def run_serial_and_two_ranks(args: list[str], tmp: Path) -> tuple[Path, Path]:
    """``crane-fem run ARGS`` serially and under ``mpiexec -n 2`` (one BLAS thread per rank,
    :func:`mpiexec_env`), into ``tmp/serial`` and ``tmp/mpi``; their directories."""
    import subprocess
    import sys

    exe = Path(sys.executable).parent / "crane-fem"
    serial = tmp / "serial"
    subprocess.run(
        [str(exe), "run", *args, "-o", str(serial)],
        check=True,
        capture_output=True,
        env=mpiexec_env(),
        timeout=SPAWN_TIMEOUT,
    )
    return serial, run_two_ranks(args, tmp / "mpi")


@contextmanager
def own_petsc_options() -> Iterator[None]:
    """PETSc's options database as a new process has it (none of crane_fem's keys) inside,
    and as it was before on exit. For a run on MPI.COMM_SELF inside the two-rank pass: the
    library writes its solvers' defaults into that process-wide database, where they outlive
    the run (crane_fem/integrators/newmark.py, ``_cholesky``), and reads any key it finds
    there as the user's choice. A serial run's ``pc_type cholesky`` then makes the next
    two-rank run fail (PETSc error 92, MatSolverType petsc does not support mpiaij), and
    the two-rank runs' ``pc_type redundant`` would change the serial run's solver."""
    from petsc4py import PETSc

    opts = PETSc.Options()
    before = opts.getAll()
    ours = [k for k in before if k.startswith("crane_fem_")]
    for k in ours:
        opts.delValue(k)
    try:
        yield
    finally:
        for k in opts.getAll():
            if k.startswith("crane_fem_"):
                opts.delValue(k)
        for k in ours:
            opts.setValue(k, before[k])


def two_ranks_and_serial(
    scene: Path, sets: list[str], shared: Path, own: Path
) -> tuple[Path, Path]:
    """In the suite's ``mpiexec -n 2`` pass (else the calling test is skipped): ``crane-fem run
    SCENE --set SETS`` on the two ranks, in process (the entry point on MPI.COMM_WORLD), into
    ``shared/mpi``, and the same scenario serially on each rank alone (MPI.COMM_SELF) into
    ``own/serial`` (``own``: this rank's directory); the serial and the two-rank directories,
    both written when this returns. No process is started: for a small scene, starting two
    (a serial `crane-fem` and an `mpiexec -n 2` one) costs more than the runs."""
    from crane_fem.cli import main
    from crane_fem.scenario import load_scenario

    if COMM.size != 2:
        pytest.skip("a two-rank run against a serial one: in the suite's mpiexec -n 2 pass")
    par = shared / "mpi"
    args = ["run", str(scene), "-o", str(par), "--no-progress"]
    assert main([*args, *[a for s in sets for a in ("--set", s)]]) == 0
    serial = own / "serial"
    with own_petsc_options():
        run_scenario(load_scenario(scene, sets), serial, MPI.COMM_SELF, progress=False)
    COMM.barrier()
    sizes = [json.loads((d / "summary.json").read_text())["mpi_size"] for d in (serial, par)]
    assert sizes == [1, 2], sizes
    return serial, par


#: One `mpiexec -n 2` job that runs `crane-fem ARGS` for each case in turn: on each rank,
#: ``crane_fem.cli.main(ARGS)`` (the `crane-fem` entry point: its return value is the exit
#: code) with file descriptors 1 and 2 sent to files, so that whatever the case prints, from
#: Python or from C, is its own; an exception out of main is its traceback and exit code 1
#: (as a process's); warnings shown afresh for each case (as in a new process). Each rank
#: appends one JSON line per case to rank<r>.jsonl as soon as the case ends, so that a hang
#: names the case it is in.
_JOBS_ON_TWO_RANKS = r"""
import ctypes, json, os, sys, tempfile, traceback, warnings
from mpi4py import MPI
from crane_fem.cli import main

cases, out = json.loads(open(sys.argv[1]).read()), sys.argv[2]
libc = ctypes.CDLL(None)
with open(os.path.join(out, f"rank{MPI.COMM_WORLD.rank}.jsonl"), "w") as log:
    for name, args in cases.items():
        log.write(json.dumps({"start": name}) + "\n")
        log.flush()
        files = [tempfile.TemporaryFile() for _ in range(2)]
        saved = [os.dup(1), os.dup(2)]
        sys.stdout.flush(); sys.stderr.flush(); libc.fflush(None)
        os.dup2(files[0].fileno(), 1); os.dup2(files[1].fileno(), 2)
        try:
            with warnings.catch_warnings():
                try:
                    code = main(args)
                except SystemExit as exc:
                    code = exc.code if isinstance(exc.code, int) else 1
                except BaseException:
                    traceback.print_exc()
                    code = 1
        finally:
            sys.stdout.flush(); sys.stderr.flush(); libc.fflush(None)
            os.dup2(saved[0], 1); os.dup2(saved[1], 2)
            for fd in saved:
                os.close(fd)
        text = []
        for f in files:
            f.seek(0)
            text.append(f.read().decode(errors="replace"))
            f.close()
        log.write(json.dumps({"name": name, "code": code, "out": text[0], "err": text[1]}) + "\n")
        log.flush()
"""


class RankOutcome(NamedTuple):
    """One rank's exit code, stdout and stderr for one case of :func:`jobs_on_two_ranks`."""

    code: int
    out: str
    err: str


def jobs_on_two_ranks(
    cases: dict[str, list[str]], tmp: Path, timeout: float = 600.0
) -> dict[str, list[RankOutcome]]:
    """Each case's ``crane-fem ARGS`` on two ranks, all in one ``mpiexec -n 2`` job
    (:data:`_JOBS_ON_TWO_RANKS`, one BLAS thread per rank: :func:`mpiexec_env`): each case's
    outcome on rank 0 and rank 1. One job instead of one per case: each job's start (MPI,
    dolfinx, the kernels' cache) costs more than most bad inputs take to be refused. A hang
    (a collective one rank left) fails the calling test, naming the case it was in."""
    import subprocess
    import sys

    tmp.mkdir(parents=True, exist_ok=True)
    spec = tmp / "cases.json"
    spec.write_text(json.dumps(cases))
    bindir = Path(sys.executable).parent
    cmd = [str(bindir / "mpiexec"), "-n", "2", sys.executable, "-c", _JOBS_ON_TWO_RANKS]
    try:
        res = subprocess.run(
            [*cmd, str(spec), str(tmp)],
            capture_output=True,
            text=True,
            timeout=timeout,
            env=mpiexec_env(),
        )
    except subprocess.TimeoutExpired:
        logs = [tmp / f"rank{r}.jsonl" for r in (0, 1)]
        last = [p.read_text().splitlines()[-1:] if p.exists() else [] for p in logs]
        raise AssertionError(f"the job hung; each rank's last line: {last}") from None
    assert res.returncode == 0, (res.returncode, res.stdout, res.stderr)
    outcomes: dict[str, list[RankOutcome]] = {name: [] for name in cases}
    for r in (0, 1):
        for line in (tmp / f"rank{r}.jsonl").read_text().splitlines():
            entry = json.loads(line)
            if "name" in entry:
                outcomes[entry["name"]].append(
                    RankOutcome(entry["code"], entry["out"], entry["err"])
                )
    assert all(len(o) == 2 for o in outcomes.values()), outcomes
    return outcomes


def error_line(code: int, capsys: pytest.CaptureFixture[str]) -> str:
    """This rank's exit code and output, as the one error line a bad input must give (else a
    description of what came instead)."""
    out, err = capsys.readouterr()
    lines = err.strip().splitlines()
    if code != 2 or out or len(lines) != 1 or not lines[0].startswith("crane-fem: error: "):
        return f"exit code {code}, stdout {out!r}, stderr {err!r}"
    return lines[0]


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Serially: the modules that hold the most tests marked ``slow`` first (each module's
    tests in their order). The serial pass gives whole modules to its workers
    (``--dist loadfile``) in this order (``--no-loadscope-reorder``): the long modules start
    first and the many short ones fill in at the end, so that the workers finish together
    (xdist's own order, the modules with the most tests first, left the long modules, which
    have few tests, for the end). Under mpiexec: tests marked ``serial`` (those that launch
    their own MPI jobs, or whose two-rank run would check nothing more: each says why) are
    skipped."""
    if COMM.size == 1:
        weight: dict[str, int] = {}
        for item in items:
            module = item.nodeid.split("::")[0]
            weight[module] = weight.get(module, 0) + ("slow" in item.keywords)
        items.sort(key=lambda item: -weight[item.nodeid.split("::")[0]])
        return
    skip = pytest.mark.skip(reason="serial pass only (see the test or its module)")
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
        elif col.endswith(("_slip_x", "_slip_y", "_slip_z")):
            # A contact's slip vector, each component against its largest (a wheel rolling
            # along y slips across and normal to its rail by round-off of that).
            scale = _scale(h1, [col[:-1] + c for c in "xyz"]) or own
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


# ----------------------------------------------------------------------------------------
#: The rolling cranes' push along their rails: a steady ground acceleration (m/s²) behind a
#: half-cosine ramp (s), over a window (s).
ROLL_A, ROLL_TAU, ROLL_T = 2.0, 0.002, 0.02


def rolling_crane(tmp: Path, wheel_zones: str) -> Path:
    """The frame crane (``wheel_zones`` "lines": point-on-line wheels, fully explicit;
    "solid": node-to-surface wheels on solid zones, gc-mean m = 20), unbraked wheels μ = 0.3,
    pushed along its rails (y) by :data:`ROLL_A` over :data:`ROLL_T`; its scene file."""
    solid = wheel_zones == "solid"
    zones = 'wheel_zones = "solid"\nsolid_size = 0.04\nfine = 0.05\n' if solid else ""
    coupling = (
        'method = "gc-mean"\nratio = 20\n[newmark]\nmass = "lumped"\n'
        if solid
        else 'method = "monolithic"\n'
    )
    name = "frame_crane_rolling" if solid else "frame_crane_rolling_lines"
    toml = (
        f'name = "{name}"\n[model]\nkind = "frame_crane"\nhoisted_mass = 200.0\n{zones}'
        "[wheel]\nfriction = 0.3\nbraked = false\n"
        "[material]\nE = 2.1e11\nrho = 7800.0\nnu = 0.3\n"
        "[loading]\ngravity = [0.0, 0.0, -9.81]\n"
        '[[loading.ground_motion]]\nrecord = "along.csv"\ndirection = [0.0, 1.0, 0.0]\n'
        f"taper = {ROLL_TAU}\n"
        f"[coupling]\n{coupling}"
        f"[time]\nend = {ROLL_T}\ndt_factor = 0.9\n[output]\nxdmf = false\n"
    )
    path = tmp / f"{name}.toml"
    if COMM.rank == 0:  # (the ranks of an mpiexec pass share ``tmp``)
        (tmp / "along.csv").write_text(f"0.0,{ROLL_A}\n1.0,{ROLL_A}\n")
        path.write_text(toml)
    COMM.barrier()
    return path


def rigid_run_back(T: float) -> float:
    """How far a body that nothing holds along the rails runs back under the rolling
    cranes' push by ``T`` (m): x(τ) = Aτ²(1/4 − 1/π²), v(τ) = Aτ/2 over the ramp, then A."""
    a, tau = ROLL_A, ROLL_TAU
    return (
        a * tau**2 * (0.25 - 1.0 / np.pi**2) + 0.5 * a * tau * (T - tau) + 0.5 * a * (T - tau) ** 2
    )


def assert_wheel_slip_on_rails(s: dict, h: dict) -> None:
    """A frame crane's wheels' slip along (y) and across (x) their rails in the summary
    (``wheels.<k>``, as the 3D crane's, and ``contact_groups.wheel_<k>``) is their mean slip
    vector's of the history (``wheel_<k>_slip_y``/``_x``) at the sampling instants: the
    largest |·| with its instant, the last; the trolley's drift their wheels' mean."""
    finals = []
    for k, w in s["wheels"].items():
        row = s["contact_groups"][f"wheel_{k}"]
        for d, c in (("along", "y"), ("across", "x")):
            v = np.asarray(h[f"wheel_{k}_slip_{c}"])
            i = int(np.argmax(np.abs(v)))
            for table in (w, row):
                assert table[f"max_slip_{d}_m"] == pytest.approx(abs(v[i]), rel=1e-12, abs=1e-18)
                assert table[f"max_slip_{d}_time_s"] == pytest.approx(h["t"][i], rel=1e-12)
                assert table[f"final_slip_{d}_m"] == pytest.approx(v[-1], rel=1e-12, abs=1e-18)
        finals.append([w["final_slip_across_m"], w["final_slip_along_m"]])
    assert s["trolley_drift_m"] == pytest.approx(np.mean(finals, axis=0).tolist(), rel=1e-12)
