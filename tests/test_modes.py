"""`crane-fem modes` (issue 25, item 2): the lowest modes of the structure with its contacts
closed, their effective masses, and the response-spectrum estimate beside a time history.

Unit: the CQC correlation and the combinations. Verification: the box beam's bending
frequencies against a converged reference; the static forces of the closed crane against
the preload. Regression of measured figures: the crane's cumulative vertical mass. CLI:
the RS/TH table, --version, bad input."""

import importlib.metadata
import json
import math
from pathlib import Path

import numpy as np
import pytest
from conftest import COMM, run

from crane_fem.cli import main
from crane_fem.modes import (
    assemble_closed_structure,
    combine_cqc,
    combine_srss,
    cqc_correlation,
    solve_modes,
)
from crane_fem.pipeline import build_mesh
from crane_fem.scenario import load_scenario

DEMOS = Path(__file__).parent.parent / "demos"
QUICK = DEMOS / "crane_quick.toml"
BOX = DEMOS / "box_beam.toml"


# --- unit: modal combination -----------------------------------------------------------


def test_cqc_correlation_and_combinations() -> None:
    """ρ_ij is Der Kiureghian's closed form for equal damping, symmetric with a unit
    diagonal; CQC equals the absolute sum for coincident modes and tends to SRSS for modes
    far apart; the SRSS of independent peaks is their root sum of squares."""
    zeta = 0.05
    omega = np.array([10.0, 10.0, 13.0, 1000.0])
    rho = cqc_correlation(omega, np.full(4, zeta))
    r = 1.3
    closed = 8 * zeta**2 * (1 + r) * r**1.5 / ((1 - r**2) ** 2 + 4 * zeta**2 * r * (1 + r) ** 2)
    assert rho[0, 2] == pytest.approx(closed, rel=1e-12)
    assert np.allclose(rho, rho.T) and np.allclose(np.diag(rho), 1.0)
    assert rho[0, 1] == pytest.approx(1.0)
    assert rho[0, 3] < 1e-3
    peaks = np.array([3.0, -4.0, 0.0, 12.0])
    assert combine_srss(peaks) == pytest.approx(13.0)
    # Modes 1 and 2 coincide: their peaks add algebraically (|3 − 4| = 1), mode 4 is apart.
    assert combine_cqc(peaks, rho) == pytest.approx(math.hypot(1.0, 12.0), rel=2e-3)
    # Undamped modes do not correlate unless they coincide.
    rho0 = cqc_correlation(omega[2:], np.zeros(2))
    assert np.allclose(rho0, np.eye(2))


# --- verification: the box beam's bending ---------------------------------------------


def _frequencies(path: Path, n: int, degree: int, sets: list[str]) -> np.ndarray:
    """The ``n`` lowest frequencies (Hz) of a scenario's closed structure (collective)."""
    sc = load_scenario(path, sets)
    st = assemble_closed_structure(
        build_mesh(sc, COMM), sc.material.E, sc.material.nu, sc.material.rho, np.zeros(3), degree
    )
    try:
        return solve_modes(st, n).frequency
    finally:
        st.destroy()


@pytest.mark.serial
def test_box_beam_bending_frequencies(shared_tmp: Path) -> None:
    """demos/box_beam.toml (1 m × 0.1 m × 0.1 m steel, clamped at x = 0) by `crane-fem modes
    --degree 2` on the demo's mesh (h = 0.05 m): its first two modes, the bending pair in y
    and z (83.68, 83.69 Hz), agree within 1 % (measured 0.1 %) with the converged reference,
    P2 on the mesh of half the size (h = 0.025 m: 83.598, 83.600 Hz; P2 at h = 0.1, 0.05,
    0.025 m gives 83.89, 83.68, 83.60 Hz). Euler–Bernoulli, (1.875²/2π) √(EI/ρA)/L² =
    83.81 Hz, is within 0.3 % of it (shear flexibility and the fully clamped face nearly
    cancel at L/h = 10). P1 on the demo's mesh is 30 % stiff (108.6 Hz: linear tetrahedra
    lock in bending), which is why the reference is P2."""
    out = shared_tmp / "box"
    assert main(["modes", str(BOX), "--degree", "2", "--n", "2", "--out", str(out)]) == 0
    data = json.loads((out / "modes.json").read_text())
    f = np.array([m["frequency_hz"] for m in data["modes"]])
    ref = _frequencies(BOX, 2, 2, ["model.h=0.025"])
    assert np.all(np.abs(f / ref - 1.0) < 0.01), (f, ref)
    E, rho, h, L = 2.1e11, 7800.0, 0.1, 1.0
    euler_bernoulli = 1.875**2 / (2 * math.pi) * math.sqrt(E * h**4 / 12 / (rho * h**2)) / L**2
    assert np.all(np.abs(ref / euler_bernoulli - 1.0) < 0.01)
    # The bending pair moves no mass along the beam, and each of the two is bending: together
    # they carry 61 % of y and of z (a cantilever's first mode: 61.3 % of its mass).
    cum = data["modes"][1]["cumulative_fraction"]
    assert cum["x"] < 1e-6 and cum["y"] == pytest.approx(0.61, abs=0.01) == cum["z"]


# --- regression: the crane's effective masses (serial and two ranks alike) --------------


def test_crane_cumulative_vertical_mass() -> None:
    """The crane of demos/crane_quick.toml (P1, committed mesh, 200 kg hoisted): the
    effective vertical mass reaches 90 % of the free mass with 16 modes (90.5 %: the
    girders' first vertical bending, mode 2 at 53.2 Hz, carries 65.6 %), not with 15
    (79.7 %); the free mass is 2733.5 kg of the 2765.9 kg on the mesh (the rest sits on the
    clamped DOFs)."""
    sc = load_scenario(QUICK, [])
    st = assemble_closed_structure(
        build_mesh(sc, COMM), sc.material.E, sc.material.nu, sc.material.rho, np.zeros(3)
    )
    try:
        basis = solve_modes(st, 16)
        mass_total = st.mass_total
    finally:
        st.destroy()
    cum = basis.cumulative_fraction[:, 2]
    assert cum[15] >= 0.90 > cum[14], cum
    assert basis.frequency[1] == pytest.approx(53.19, abs=0.01)
    assert basis.effective_fraction[1, 2] == pytest.approx(0.656, abs=1e-3)
    assert mass_total == pytest.approx(2765.888, rel=1e-6)
    assert basis.total_mass[2] == pytest.approx(2733.5, abs=0.1)


# --- CLI: the response spectrum beside the time history --------------------------------


@pytest.mark.serial
def test_rs_beside_th(shared_tmp: Path, capsys) -> None:
    """A 0.01 s run of the quick crane (the wheels just lift off), then `modes --compare`:
    the table prints RS (SRSS, CQC), TH and RS/TH for each support and wheel, modes.json
    holds the same; the closed structure's static forces are the run's preloaded ones (its
    wheels carry the trolley's weight, its supports the run's initial vertical forces), and
    the estimate is for the run's window."""
    sets = ["time.end=0.01", "output.xdmf=false"]
    run_dir = shared_tmp / "run"
    run(load_scenario(QUICK, sets), run_dir)
    capsys.readouterr()
    out = shared_tmp / "modes"
    args = ["modes", str(QUICK), "--n", "16", "--out", str(out), "--compare", str(run_dir)]
    assert main([*args, *(a for s in sets for a in ("--set", s))]) == 0
    printed = capsys.readouterr().out
    summary = json.loads((run_dir / "summary.json").read_text())
    data = json.loads((out / "modes.json").read_text())
    rs = data["response_spectrum"]
    assert rs["window_s"][1] == pytest.approx(0.01)
    static_wheels = sum(w["static_N"] for w in rs["wheels"].values())
    assert static_wheels == pytest.approx(summary["preload"]["trolley_weight_N"], rel=1e-6)
    for k, s in summary["supports"].items():
        assert rs["supports"][k]["static_N"][2] == pytest.approx(s["initial_force_N"][2], rel=1e-6)
    rows = data["comparison"]["rows"]
    assert len(rows) == 3 * 4  # vertical and magnitude per support, contact per wheel
    for row in rows:
        assert row["ratio_rs_th"] == pytest.approx(row["rs_cqc_N"] / row["th_N"])
        assert f"{row['where']} {row['quantity']}" in printed
    th = {r["where"]: r["th_N"] for r in rows if r["quantity"] != "magnitude"}
    assert th["wheel 1"] == summary["wheels"]["1"]["peak_force_N"]
    assert th["support 1"] == summary["supports"]["1"]["peak_vertical_N"]
    assert "RS/TH" in printed and "response spectrum (RS) against the time history" in printed
    import meshio

    shapes = meshio.read(out / "modes.xdmf")  # P1 vector fields, one per mode
    assert shapes.points.shape == (3182, 3) and shapes.cells[0].data.shape == (11340, 4)
    assert sorted(shapes.point_data) == sorted(f"mode_{k}" for k in range(1, 17))
    assert shapes.point_data["mode_2"].shape == (3182, 3)


def test_version(capsys) -> None:
    """`crane-fem --version` prints the installed distribution's version and exits 0."""
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.strip() == f"crane-fem {importlib.metadata.version('crane_fem')}"


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["modes", "no_such_scenario.toml"], "no_such_scenario.toml: scenario file not found"),
        (["modes", str(QUICK), "--n", "0"], "modes: --n must be at least 1 (got 0)"),
        (["modes", str(QUICK), "--n", "-3"], "modes: --n must be at least 1 (got -3)"),
        (
            ["modes", str(QUICK), "--compare", "no_such_run"],
            "--compare no_such_run: no summary.json (a crane-fem run directory)",
        ),
    ],
)
def test_modes_bad_input(args: list[str], message: str, capsys) -> None:
    """An unknown scenario file, N ≤ 0, a run directory without summary.json: one line on
    stderr, exit 2, before any work."""
    assert main(args) == 2
    err = capsys.readouterr().err.splitlines()
    assert err == [f"crane-fem: error: {message}"]


def test_docs_command_lines_parse() -> None:
    """Every `crane-fem modes` line of docs/modes.md's fenced blocks parses with the CLI's
    parser and names an existing scenario (the docs cannot drift from the options)."""
    import re
    import shlex

    from crane_fem.cli import _parser

    root = Path(__file__).parent.parent
    text = (root / "docs" / "modes.md").read_text(encoding="utf-8")
    blocks = re.findall(r"^```[^\n]*\n(.*?)^```", text, re.M | re.S)
    lines = [ln.removeprefix("$ ") for b in blocks for ln in b.splitlines()]
    commands = [ln for ln in lines if ln.startswith("crane-fem modes demos/")]
    assert commands
    for line in commands:
        args = _parser().parse_args(shlex.split(line)[1:])
        assert (root / args.scenario).is_file(), line
