"""Outputs of `crane-fem run`: history.csv, summary.json and the XDMF time series."""

import json
from pathlib import Path

import meshio
import numpy as np
import pytest
from conftest import COMM, two_ranks_and_serial

from crane_fem.cli import main
from crane_fem.io import read_history, read_xdmf

ENERGIES = {
    "kinetic",
    "internal",
    "external_work",
    "damping_dissipated",
    "contact_dissipated",
    "numerical_dissipated",
    "total",
}
SCENARIO = Path(__file__).parent.parent / "demos" / "bar_impact.toml"
COLUMNS = [
    "t",
    "kinetic",
    "internal",
    "external_work",
    "contact_dissipated",
    "total",
    "contact_force",
    "damping_dissipated",
    "numerical_dissipated",
]


def test_cli_run_writes_history_summary_xdmf(shared_tmp) -> None:
    out = shared_tmp / "run"
    code = main(
        [
            "run",
            str(SCENARIO),
            "-o",
            str(out),
            "--set",
            "output.every=2",
            "--set",
            "model.elements=50",
            "--no-progress",
        ]
    )
    assert code == 0
    COMM.barrier()
    hist = read_history(out / "history.csv")
    for col in COLUMNS:
        assert col in hist
    summary = json.loads((out / "summary.json").read_text())
    for key in (
        "dt",
        "dt_critical",
        "steps",
        "wall_time_s",
        "energy_balance_error",
        "contact_intervals",
    ):
        assert key in summary
    assert summary["status"] == "completed" and summary["mpi_size"] == COMM.size
    assert hist["t"].size == summary["steps"] // 2 + 1 + (summary["steps"] % 2)
    assert np.all(np.diff(hist["t"]) > 0)

    geometry, _, fields = read_xdmf(out / "solution.xdmf")
    assert set(fields) == {"displacement", "velocity", "contact_force"}
    # One grid per time with every field: meshio's reader finds them all at every time.
    with meshio.xdmf.TimeSeriesReader(out / "solution.xdmf") as reader:
        points, cells = reader.read_points_cells()
        assert [c.type for c in cells] == ["line"] and cells[0].data.shape == (50, 2)
        assert reader.num_steps == len(fields["displacement"])
        for k in range(reader.num_steps):
            t, point_data, _ = reader.read_data(k)
            assert {n: v.shape for n, v in point_data.items()} == {
                n: (points.shape[0], 1) for n in fields
            }
            assert t == fields["velocity"][k][0]
            np.testing.assert_array_equal(point_data["velocity"], fields["velocity"][k][1])
    times = [t for t, _ in fields["displacement"]]
    assert times[0] == 0.0 and times[-1] == pytest.approx(hist["t"][-1])
    assert np.all(np.diff(times) > 0)
    # Global check, independent of the node order: the leftmost material point is the contact
    # end, whose position is the wall gap in the history.
    _, u_end = fields["displacement"][-1]
    position = geometry[:, 0] + u_end.ravel()
    assert position.min() == pytest.approx(hist["gap_wall"][-1], rel=1e-12, abs=1e-15)
    # Contact force field sums to the total contact force at its time.
    for t, f in fields["contact_force"]:
        k = int(np.argmin(np.abs(hist["t"] - t)))
        if hist["t"][k] == pytest.approx(t):
            assert f.sum() == pytest.approx(hist["contact_force"][k], rel=1e-12, abs=1e-12)


#: The bar against the wall (split across ranks), two bars striking each other, Moreau–Jean.
TWO_RANK_CASES = {
    "wall": ["model.elements=101"],
    "bars": [
        "model.elements=60",
        "contact=[{type='bars', gap=0.001}]",
        "model.second_bar={length=1.0, elements=40, area=1e-4, velocity=-5.0}",
        "initial.velocity=5.0",
    ],
    "mj": ["integrator.scheme='moreau-jean'", "integrator.theta=1.0", "time.dt_factor=3.0"],
}


@pytest.mark.mpi
@pytest.mark.parametrize("name", list(TWO_RANK_CASES))
def test_two_ranks_same_histories_as_serial(name, shared_tmp, tmp_path) -> None:
    """`crane-fem run` on two ranks gives the serial histories (bar split across ranks); in
    the suite's mpiexec pass (conftest.two_ranks_and_serial)."""
    sets = ["output.xdmf=false", *TWO_RANK_CASES[name]]
    serial, par = two_ranks_and_serial(SCENARIO, sets, shared_tmp, tmp_path)
    h1, h2 = read_history(serial / "history.csv"), read_history(par / "history.csv")
    assert h1.keys() == h2.keys()
    energy_scale = np.max(np.abs(h1["total"]))
    for col in h1:
        # Same algorithm, different summation order in SpMV and reductions: round-off.
        # Energies are parts of one balance: their round-off is relative to the total
        # (a stiff body in rigid motion has ε K u² of round-off in its strain energy).
        scale = energy_scale if col in ENERGIES else max(np.max(np.abs(h1[col])), 1e-300)
        assert np.max(np.abs(h1[col] - h2[col])) <= 1e-10 * scale, (name, col)


QUICK = Path(__file__).parent.parent / "demos" / "crane_quick.toml"


def test_support_and_bridge_stress_histories(shared_tmp) -> None:
    """history.csv holds the support forces and the bridge's largest von Mises stress at the
    rows where they are evaluated (every 2nd sampling interval here, and the last) and NaN at
    the others; the stress's peak in summary.json is the largest of those rows, at its time,
    the supports' the largest of their forces at every macro step (the sampled rows among
    them: never below the rows')."""
    out = shared_tmp / "crane"
    sets = ["time.end=0.004", "output.xdmf=false", "output.every=1", "output.stress_every=2"]
    args = ["run", str(QUICK), "-o", str(out), "--no-progress"]
    assert main([*args, *[a for s in sets for a in ("--set", s)]]) == 0
    COMM.barrier()
    hist = read_history(out / "history.csv")
    summary = json.loads((out / "summary.json").read_text())
    sample = np.rint(hist["t"] / summary["sampling_interval_s"]).astype(int)
    assert np.array_equal(sample, np.arange(sample.size)) and sample.size > 10
    evaluated = sample % 2 == 0
    evaluated[-1] = True
    vm = hist["bridge_von_mises_max"]
    assert np.array_equal(np.isfinite(vm), evaluated)
    assert np.all(vm[evaluated] > 0.0)
    k = int(np.nanargmax(vm))
    assert summary["peak_bridge_von_mises_Pa"] == vm[k]
    assert summary["peak_bridge_von_mises_t"] == hist["t"][k]
    faces = summary["supports"]
    assert len(faces) == 4
    for face, s in faces.items():
        f = np.column_stack([hist[f"support{face}_f{c}"] for c in "xyz"])
        assert np.array_equal(np.isfinite(f).all(axis=1), evaluated), face
        norm = np.linalg.norm(f, axis=1)
        assert s["peak_force_N"] >= np.nanmax(norm) * (1 - 1e-14)
        step = s["peak_force_time_s"] / (10 * summary["dt"])
        assert abs(step - round(step)) < 1e-6  # a (fine, m = 10) macro step's end
        assert s["initial_force_N"] == pytest.approx(f[0].tolist(), rel=1e-14)
        assert s["peak_vertical_N"] >= np.nanmax(np.abs(f[:, 2])) * (1 - 1e-14)
