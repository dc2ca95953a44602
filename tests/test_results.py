"""What an engineer reads from a run: the results table (wheels and their impacts, the
bridge's peak stress with its place and time, the support reactions), the measured points'
motion for response spectra, and a run stopped by a signal that leaves valid files."""

import csv
import json
import math
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import COMM, mpiexec_env
from mpi4py import MPI

from crane_fem.driver import run_scenario
from crane_fem.io import read_history
from crane_fem.io.results import results_rows
from crane_fem.pipeline import create_simulation
from crane_fem.scenario import load_scenario

QUICK = Path(__file__).parent.parent / "demos" / "crane_quick.toml"
BIN = Path(sys.executable).parent


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory) -> tuple[dict, Path]:
    """The quick crane over 0.003 s (24 macro steps), every macro step sampled."""
    out = Path(COMM.bcast(str(tmp_path_factory.mktemp("results")), root=0))
    sc = load_scenario(QUICK, ["time.end=0.003", "output.xdmf=false"])
    return run_scenario(sc, out, COMM, progress=False).summary, out


def test_supports_carry_the_weight(quick_run) -> None:
    """At t = 0 the crane rests in its static preload: the four clamped faces carry its whole
    weight (Σ lumped masses of both sides × g), and no net horizontal force. The preload is
    solved to round-off (its wheel sum to 2.6e-12), so 1e-9 of the weight is a tight bound."""
    summary, _ = quick_run
    sc = load_scenario(QUICK)
    sim = create_simulation(sc, COMM)
    try:
        md = sim.models
        local = sum(
            float(s.model.mass.reshape(-1, 3)[:, 2].sum()) for s in (md.explicit, md.implicit)
        )
    finally:
        sim.destroy()
    weight = COMM.allreduce(local, op=MPI.SUM) * 9.81
    forces = np.array([s["initial_force_N"] for s in summary["supports"].values()])
    assert forces.shape == (4, 3)
    assert forces[:, 2].sum() == pytest.approx(weight, rel=1e-9)
    assert np.abs(forces[:, :2].sum(axis=0)).max() < 1e-9 * weight
    # The faces are the end carriages' ends, numbered along y then x.
    centres = np.array([s["centre_m"] for s in summary["supports"].values()])
    assert np.allclose(centres[:, 0], [-0.8, 0.8, -0.8, 0.8])
    assert centres[0, 1] < 0.2 and centres[3, 1] > 3.8


def test_results_table_matches_the_summary(quick_run) -> None:
    """results.csv holds the summary's peaks row by row; the bridge's peak stress lies in the
    bridge, at the centre of one of its cells."""
    summary, out = quick_run
    with open(out / "results.csv", newline="") as f:
        table = list(csv.DictReader(f))
    rows = results_rows(summary)
    assert len(table) == len(rows) > 0
    for got, want in zip(table, rows, strict=True):
        assert got["quantity"] == want["quantity"] and got["where"] == want["where"]
        assert float(got["value"]) == want["value"]
    wheels = [r for r in table if r["quantity"] == "peak_contact_force"]
    assert [r["where"] for r in wheels] == [f"wheel {k}" for k in range(1, 5)]
    x, y, z = summary["peak_bridge_von_mises_location_m"]
    assert abs(x) <= 0.8 and 0.0 <= y <= 4.0 and 0.0 <= z <= 0.39
    assert 0.0 <= summary["peak_bridge_von_mises_t"] <= 0.003 + 1e-12
    vm = [r for r in table if r["quantity"] == "peak_von_mises"]
    assert len(vm) == 1 and float(vm[0]["x_m"]) == x


def test_measured_points_and_spectra(quick_run) -> None:
    """The crane's default points: the trolley's centre is a vertex (implicit side), wheel 1
    is read on the explicit side; their absolute accelerations and the ground's are history
    columns, and spectra.csv holds the input's and each point's vertical spectrum."""
    summary, out = quick_run
    pts = summary["spectra_points"]
    assert pts["trolley"] == {"side": "implicit", "distance_m": pytest.approx(0.0, abs=1e-12)}
    assert pts["wheel_1"]["side"] == "explicit"
    assert pts["support_1"]["side"] == "implicit"
    h = read_history(out / "history.csv")
    for col in ("ground_az", "trolley_az", "wheel_1_az", "support_1_az"):
        assert col in h and np.all(np.isfinite(h[col]))
    with open(out / "spectra.csv") as f:
        header = f.readline().strip().split(",")
    assert header == [
        "period_s",
        "psa_input_z",
        "psa_trolley_z",
        "psa_wheel_1_z",
        "psa_support_1_z",
    ]
    assert summary["spectra_damping"] == 0.05


def _interrupt(cmd: list[str], out: Path, rows: int) -> subprocess.CompletedProcess:
    """Start ``cmd``, send SIGTERM once history.csv has ``rows`` data rows, wait for it."""
    proc = subprocess.Popen(
        cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=mpiexec_env()
    )
    hist = out / "history.csv"
    deadline = time.monotonic() + 240
    while time.monotonic() < deadline and proc.poll() is None:
        if hist.exists() and hist.read_text().count("\n") > rows:
            break
        time.sleep(0.2)
    proc.send_signal(signal.SIGTERM)
    stdout, stderr = proc.communicate(timeout=120)
    return subprocess.CompletedProcess(cmd, proc.returncode, stdout, stderr)


@pytest.mark.serial
@pytest.mark.parametrize("ranks", [1, 2])
def test_sigterm_leaves_an_interrupted_run_with_valid_files(tmp_path, ranks) -> None:
    """SIGTERM during the time loop (serial, and to mpiexec, which forwards it to both ranks):
    every rank stops at the same macro step; summary.json says "interrupted" with the time
    reached, history.csv ends at that time, the XDMF files hold the frames written, and the
    message is one line per rank with no traceback."""
    out = tmp_path / "run"
    cli = [str(BIN / "crane-fem"), "run", str(QUICK), "-o", str(out), "--set", "time.end=0.05"]
    cmd = cli if ranks == 1 else [str(BIN / "mpiexec"), "-n", "2", *cli]
    res = _interrupt(cmd, out, rows=5)
    assert res.returncode == 128 + signal.SIGTERM
    assert "Traceback" not in res.stderr, res.stderr
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert len(lines) == ranks and all("interrupted by SIGTERM" in ln for ln in lines), lines
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "interrupted"
    assert 0.0 < summary["t_reached_s"] < 0.05
    h = read_history(out / "history.csv")
    assert h["t"][-1] == summary["t_reached_s"]
    import h5py

    for xdmf in out.glob("solution_*.xdmf"):
        with h5py.File(xdmf.with_suffix(".h5"), "r") as f:
            assert len(f["Function"]["displacement"]) >= 1
    assert math.isfinite(summary["energy_balance_error"])


def test_run_prints_the_results_table(shared_tmp, capsys) -> None:
    """`crane-fem run` ends with the wheels table, the bridge's peak stress and the supports,
    and names results.csv and spectra.csv among its outputs (rank 0 prints)."""
    from crane_fem.cli import main

    out = shared_tmp / "cli"
    code = main(["run", str(QUICK), "-o", str(out), "--set", "time.end=0.002"])
    assert code == 0
    text = capsys.readouterr().out
    if COMM.rank == 0:
        assert "peak force (kN)" in text and "bridge peak von Mises" in text
        assert text.count("crane-fem: support ") == 4
        assert "results.csv, spectra.csv" in text
