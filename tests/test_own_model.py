"""A user's own gmsh structure (``model.kind = "gmsh"``): a test writes a two-body model in
its own gmsh code — a slab clamped at its bottom, a block resting on it through a frictional
node-to-surface contact — and runs it through the CLI (serially, and on two ranks under the
suite's mpiexec run), against the exact rigid-block solutions of Coulomb friction.

In the relative formulation the clamped slab stands still and the block feels the body force
−ρ a_g: with a constant ground acceleration A > μg it slides back with relative acceleration
A − μg, slip (A − μg) T²/2 after T; below μg it sticks. After a pulse of A over τ (v0 = Aτ)
it slides until v0/(μg) exactly, over v0²(1 − μg/A)/(2μg) (the pulse's own slide included:
(A − μg)τ²/2 while it lasts, then the deceleration μg from (A − μg)τ).
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

from crane_fem.cli import main

COMM = MPI.COMM_WORLD
MU, G = 0.3, 9.81


def write_block_on_slab(
    path: Path,
    slab: tuple[float, float, float] = (0.32, 0.12, 0.03),
    block: tuple[float, float, float] = (0.06, 0.06, 0.06),
    corner: tuple[float, float] = (0.02, 0.03),
    h_slab: float = 0.03,
    h_block: float = 0.03,
) -> None:
    """The slab [0, Lx]×[0, Ly]×[−t, 0] and the block on it, meshed apart (their own nodes
    on z = 0: not fragmented), on rank 0; groups ``slab``, ``block`` (volumes), ``slab_bottom``,
    ``slab_top``, ``block_bottom`` (surfaces)."""
    if COMM.rank == 0:
        import gmsh

        gmsh.initialize(interruptible=False)
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("General.NumThreads", 1)
        gmsh.model.add("block_on_slab")
        occ = gmsh.model.occ
        s = occ.addBox(0.0, 0.0, -slab[2], *slab)
        b = occ.addBox(corner[0], corner[1], 0.0, *block)
        occ.synchronize()

        def face(vol: int, z: float) -> int:
            for dim, tag in gmsh.model.getBoundary([(3, vol)], oriented=False):
                box = gmsh.model.getBoundingBox(dim, tag)
                if abs(box[2] - z) < 1e-6 and abs(box[5] - z) < 1e-6:
                    return tag
            raise AssertionError(f"no face at z = {z}")

        gmsh.model.addPhysicalGroup(3, [s], name="slab")
        gmsh.model.addPhysicalGroup(3, [b], name="block")
        gmsh.model.addPhysicalGroup(2, [face(s, -slab[2])], name="slab_bottom")
        gmsh.model.addPhysicalGroup(2, [face(s, 0.0)], name="slab_top")
        gmsh.model.addPhysicalGroup(2, [face(b, 0.0)], name="block_bottom")
        for vol, h in ((s, h_slab), (b, h_block)):
            pts = gmsh.model.getBoundary([(3, vol)], recursive=True)
            gmsh.model.mesh.setSize(pts, h)
        gmsh.model.mesh.generate(3)
        gmsh.write(str(path))
        gmsh.finalize()
    COMM.barrier()


def write_record(path: Path, rows: list[tuple[float, float]]) -> None:
    if COMM.rank == 0:
        path.write_text("".join(f"{t!r},{a!r}\n" for t, a in rows), encoding="utf-8")
    COMM.barrier()


def scenario(mesh: Path, record: Path, end: float, sample: float) -> str:
    return f"""
name = "block_on_slab"
[model]
kind = "gmsh"
mesh = "{mesh}"
[material]
E = 1e8
rho = 1000.0
nu = 0.3
[[support]]
group = "slab_bottom"
[[contact]]
type = "surface"
points = "block_bottom"
surface = "slab_top"
friction = {MU}
name = "feet"
[loading]
gravity = [0.0, 0.0, -{G}]
[[loading.ground_motion]]
record = "{record}"
direction = [1.0, 0.0, 0.0]
[time]
end = {end}
dt_factor = 0.9
[output]
xdmf = false
sample_interval = {sample}
"""


def run_cli(tmp: Path, toml: str, name: str) -> tuple[dict, dict[str, np.ndarray]]:
    path = tmp / f"{name}.toml"
    if COMM.rank == 0:
        path.write_text(toml, encoding="utf-8")
    COMM.barrier()
    out = tmp / name
    assert main(["run", str(path), "--output", str(out), "--no-progress"]) == 0
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    data = np.genfromtxt(out / "history.csv", delimiter=",", names=True)
    return summary, {k: data[k] for k in data.dtype.names}


@pytest.mark.parametrize("ratio", [2.0, 0.5], ids=["slides", "sticks"])
def test_block_on_a_shaken_slab_slides_at_A_minus_mu_g(shared_tmp: Path, ratio: float) -> None:
    """A = 2μg: slip (A − μg)T²/2 within 3 %; A = μg/2: slip below 1 % of (A/2)T²."""
    mesh = shared_tmp / "block_on_slab.msh"
    write_block_on_slab(mesh)
    A, T = ratio * MU * G, 0.08
    write_record(shared_tmp / "step.csv", [(0.0, A), (1.0, A)])
    summary, hist = run_cli(shared_tmp, scenario(mesh, shared_tmp / "step.csv", T, 1e-3), "run")
    assert summary["status"] == "completed"
    slip = -hist["feet_slip_x"][-1]  # the block lags behind the ground: −x relative to it
    T = hist["t"][-1]  # the end of the last step (time.end rounded up to a whole step)
    print(f"slip {slip:.6e} m at T = {T:.6g} s; (A - mu g) T^2/2 = {(A - MU * G) * T**2 / 2:.6e}")
    pre = summary["preload"]
    # The preload's contact force is the block's weight (its penalty's round-off only).
    block_weight = 1000.0 * 0.06**3 * G
    assert pre["contact_forces_N"]["feet"] == pytest.approx(block_weight, rel=1e-6)
    if ratio > 1.0:
        exact = (A - MU * G) * T**2 / 2.0
        # 3 %: the block is elastic (E = 1e8 Pa): its sudden load sets off its shear and
        # rocking modes (≈ 1 kHz), whose oscillating share of the friction force averages out
        # over T; the rigid-block solution is the reference.
        assert slip == pytest.approx(exact, rel=0.03)
        assert summary["contact_groups"]["feet"]["max_slip_m"] >= 0.97 * exact
    else:
        assert abs(slip) < 0.01 * A / 2.0 * T**2


@pytest.mark.serial  # the same path as the shaken slab's, one more tangent choice
def test_rolling_block_rolls_freely_along_and_sticks_across(shared_tmp: Path) -> None:
    """``rolling = [1, 0, 0]`` (free-rolling wheels' contact): shaken by A = μg/2 along x and
    along y at once, the block runs back freely along x — slip A T²/2, the rigid body's, within
    0.1 %, where braked it would stick — and sticks
    across (y, A below μg): slip below 1 % of A T²/2. The preload holds it on the slab with
    its weight and no force along x."""
    mesh = shared_tmp / "block_on_slab.msh"
    write_block_on_slab(mesh)
    A, T = 0.5 * MU * G, 0.08
    write_record(shared_tmp / "step.csv", [(0.0, A), (1.0, A)])
    toml = scenario(mesh, shared_tmp / "step.csv", T, 1e-3)
    toml = toml.replace(f"friction = {MU}\n", f"friction = {MU}\nrolling = [1.0, 0.0, 0.0]\n")
    toml += f"""
[[loading.ground_motion]]
record = "{shared_tmp / "step.csv"}"
direction = [0.0, 1.0, 0.0]
"""
    summary, hist = run_cli(shared_tmp, toml, "rolling")
    assert summary["status"] == "completed"
    T = hist["t"][-1]
    free = A * T**2 / 2.0
    along, across = -hist["feet_slip_x"][-1], -hist["feet_slip_y"][-1]
    print(f"slip along {along:.6e}, across {across:.6e} m; A T^2/2 = {free:.6e}")
    # No force acts along x: the feet follow the rigid block up to its elastic vibration, set
    # off by the friction across (measured 1.2e-5 of the slip).
    assert along == pytest.approx(free, rel=1e-3)
    assert abs(across) < 0.01 * free
    # Its slip along the rolling direction (the contact's ``along`` by default) and across it
    # (along × n = x × z = −y) in the summary: the history's mean slip's components.
    feet = summary["contact_groups"]["feet"]
    assert feet["final_slip_along_m"] == pytest.approx(hist["feet_slip_x"][-1], rel=1e-12)
    assert feet["final_slip_across_m"] == pytest.approx(-hist["feet_slip_y"][-1], rel=1e-12)
    assert feet["max_slip_along_m"] == pytest.approx(np.abs(hist["feet_slip_x"]).max(), rel=1e-12)
    block_weight = 1000.0 * 0.06**3 * G
    assert summary["preload"]["contact_forces_N"]["feet"] == pytest.approx(block_weight, rel=1e-6)


@pytest.mark.serial  # its two-rank behaviour is the shaken slab's (the same model and path)
def test_block_slides_over_ten_slab_elements_and_stops_where_coulomb_says(
    shared_tmp: Path,
) -> None:
    """Issue 24's verification over a meshed elastic base: a pulse A over τ gives the block
    v0 = Aτ relative to the slab; it slides over more than 10 of the slab's elements, is
    re-paired triangle after triangle, and stops at v0/(μg) within 2 % and after
    v0²(1 − μg/A)/(2μg) within 1 %."""
    h = 0.015
    mesh = shared_tmp / "long_slab.msh"
    write_block_on_slab(mesh, slab=(0.36, 0.12, 0.03), corner=(0.26, 0.03), h_slab=h)
    A, tau = 50.0, 0.02
    v0 = A * tau
    write_record(shared_tmp / "pulse.csv", [(0.0, A), (tau, A), (tau + 1e-9, 0.0), (1.0, 0.0)])
    toml = scenario(mesh, shared_tmp / "pulse.csv", 0.4, 5e-4)
    summary, hist = run_cli(shared_tmp, toml, "pulse")
    t, slip = hist["t"], -hist["feet_slip_x"]
    distance = v0**2 * (1.0 - MU * G / A) / (2.0 * MU * G)
    assert distance > 10 * h
    speed = np.diff(slip) / np.diff(t)
    after = t[1:] > 2 * tau
    # Stopped: the first sample after the pulse slower than 0.5 % of v0 (reached 0.5 % of
    # v0/(μg) = 1.7 ms before the stop: within the 2 %).
    t_stop = float(t[1:][after & (np.abs(speed) < 0.005 * v0)][0])
    print(
        f"stop {t_stop:.5f} s (exact {v0 / (MU * G):.5f}); slid {slip[-1]:.6f} m (exact "
        f"{distance:.6f}); re-paired {summary['node_to_surface']['repairings']} times"
    )
    assert t_stop == pytest.approx(v0 / (MU * G), rel=0.02)
    assert slip[-1] == pytest.approx(distance, rel=0.01)
    assert summary["node_to_surface"]["repairings"] >= 10


def _clamped_mass(mesh: Path, rho: float) -> float:
    """The lumped mass of the ``slab_bottom`` vertices, ρ V/4 per tetrahedron and vertex (P1),
    read with gmsh on rank 0 (the same on every rank)."""
    mass = 0.0
    if COMM.rank == 0:
        import gmsh

        gmsh.initialize(interruptible=False)
        gmsh.option.setNumber("General.Terminal", 0)
        try:
            gmsh.open(str(mesh))
            group = next(
                g
                for g in gmsh.model.getPhysicalGroups(2)
                if gmsh.model.getPhysicalName(*g) == "slab_bottom"
            )
            clamped, _ = gmsh.model.mesh.getNodesForPhysicalGroup(*group)
            tags, xyz, _ = gmsh.model.mesh.getNodes()
            where = np.empty(int(tags.max()) + 1, dtype=np.int64)
            where[tags] = np.arange(tags.size)
            xyz = xyz.reshape(-1, 3)
            types, _, nodes = gmsh.model.mesh.getElements(3)
            tets = np.asarray(nodes[list(types).index(4)], dtype=np.int64).reshape(-1, 4)
            x = xyz[where[tets]]
            volume = np.abs(np.linalg.det(x[:, 1:] - x[:, :1])) / 6.0
            on_face = np.isin(tets, clamped).sum(axis=1)
            mass = float(np.sum(rho * volume / 4.0 * on_face))
        finally:
            gmsh.finalize()
    return float(COMM.bcast(mass, root=0))


def test_sliding_block_outputs(shared_tmp: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """What a run of a gmsh model with a sliding contact shows (issue 32): the contact's
    largest slip (with its time) and final slip in the end table and in results.csv as in
    the summary; the input motion in history.csv (``ground_a*``) and in `crane-fem plot`'s
    input_motion.png, the slip in its contact_slip.png. The support's force at t = 0 is its
    static part (the weight of slab and block, no horizontal force) plus the ground's
    acceleration A on the clamped vertices' own mass, m_f A along x, m_f = Σ ρV/4."""
    mesh = shared_tmp / "block_on_slab.msh"
    write_block_on_slab(mesh)
    A = 2.0 * MU * G
    write_record(shared_tmp / "step.csv", [(0.0, A), (1.0, A)])
    toml = scenario(mesh, shared_tmp / "step.csv", 0.03, 1e-3)
    summary, hist = run_cli(shared_tmp, toml, "outputs")
    printed = capsys.readouterr().out
    out = shared_tmp / "outputs"
    feet = summary["contact_groups"]["feet"]
    assert feet["max_slip_m"] > 1e-4 and 0.0 < feet["max_slip_time_s"] <= hist["t"][-1]
    final = float(np.linalg.norm(feet["final_slip_m"]))
    if COMM.rank == 0:
        header = " contact  max slip (mm)  at t (s)  final slip (mm)  final slip x, y, z (mm)"
        assert f"crane-fem: {header}\n" in printed, printed
        row = printed.split(header)[1].splitlines()[1].split()
        assert row[:4] == [
            "crane-fem:",
            "feet",
            f"{feet['max_slip_m'] * 1e3:.3f}",
            f"{feet['max_slip_time_s']:.5f}",
        ], row
        assert row[4] == f"{final * 1e3:.3f}", row
    with open(out / "results.csv", newline="", encoding="utf-8") as f:
        rows = {r["quantity"]: r for r in csv.DictReader(f) if r["where"] == "contact feet"}
    assert float(rows["max_slip"]["value"]) == feet["max_slip_m"]
    assert float(rows["max_slip"]["time_s"]) == feet["max_slip_time_s"]
    assert float(rows["final_slip"]["value"]) == pytest.approx(final, rel=1e-12)
    # The input motion: the record's constant A along x at every row.
    assert np.all(hist["ground_ax"] == A) and not np.any(hist["ground_ay"])
    if COMM.rank == 0:
        assert main(["plot", str(out)]) == 0
        for name in ("input_motion.png", "contact_slip.png"):
            assert (out / "figures" / name).is_file(), name
    # The support's first force and its static part.
    s1 = summary["supports"]["1"]
    weight = 1000.0 * (0.32 * 0.12 * 0.03 + 0.06**3) * G
    static, initial = np.array(s1["static_force_N"]), np.array(s1["initial_force_N"])
    assert static[2] == pytest.approx(weight, rel=1e-6)
    assert np.abs(static[:2]).max() < 1e-9 * weight
    m_f = _clamped_mass(mesh, 1000.0)
    print(f"clamped mass {m_f:.6g} kg: initial - static = {initial - static} N, m_f A = {m_f * A}")
    assert initial[0] - static[0] == pytest.approx(m_f * A, rel=1e-9)
    assert np.abs(initial[1:] - static[1:]).max() < 1e-9 * weight


def test_small_model_drawn_in_mm_refused_by_its_mass(shared_tmp: Path, capsys) -> None:
    """The block on its slab drawn in mm is 320 m across, within the extent rule (1 km), but
    weighs 1.4e9 kg: refused by the mass rule (1e9 kg) in one line naming the mesh, exit 2,
    on every rank, before any other error (the same model in metres runs in the tests
    above)."""
    mesh = shared_tmp / "block_on_slab_mm.msh"
    write_block_on_slab(mesh, (320.0, 120.0, 30.0), (60.0, 60.0, 60.0), (20.0, 30.0), 30.0, 30.0)
    write_record(shared_tmp / "zero.csv", [(0.0, 0.0), (1.0, 0.0)])
    path = shared_tmp / "mm.toml"
    if COMM.rank == 0:
        path.write_text(scenario(mesh, shared_tmp / "zero.csv", 0.01, 1e-3), encoding="utf-8")
    COMM.barrier()
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert err[0].startswith(
        f"crane-fem: error: model.mesh: {mesh}: the mesh looks drawn in mm: its bounding box "
        "is 320 × 120 × 90 m and its mass 1.37e+09 kg"
    ), err


@pytest.mark.serial  # set-up only: its two-rank behaviour is the runs' above
def test_materials_and_masses_per_group(shared_tmp: Path) -> None:
    """``[[material]]`` per volume group and ``[[mass]]`` on a group reach the model: the
    preload's contact force is the block's own weight (its ρ) plus its carried mass; a
    stiffer block shortens the critical step (its E)."""
    mesh = shared_tmp / "block_on_slab.msh"
    write_block_on_slab(mesh)
    write_record(shared_tmp / "zero.csv", [(0.0, 0.0), (1.0, 0.0)])
    base = scenario(mesh, shared_tmp / "zero.csv", 2e-4, 1e-4)
    one = base.split("[material]")[0]
    rest = base.split("nu = 0.3\n", 1)[1]

    def with_materials(e_block: float, rho_block: float, mass: float) -> str:
        entries = (
            '[[material]]\ngroups = ["slab"]\nE = 1e8\nrho = 1000.0\n'
            f'[[material]]\ngroups = ["block"]\nE = {e_block}\nrho = {rho_block}\n'
        )
        extra = f'[[mass]]\ngroup = "block"\nmass = {mass}\n' if mass else ""
        return one + entries + extra + rest

    s1, _ = run_cli(shared_tmp, with_materials(1e8, 3000.0, 0.5), "per_group")
    weight = (3000.0 * 0.06**3 + 0.5) * G
    assert s1["preload"]["contact_forces_N"]["feet"] == pytest.approx(weight, rel=1e-6)
    # The support (the slab's underside) carries the whole weight at t = 0 (statics).
    total = weight + 1000.0 * 0.32 * 0.12 * 0.03 * G
    assert list(s1["supports"]) == ["1"]
    assert s1["supports"]["1"]["initial_force_N"][2] == pytest.approx(total, rel=1e-6)
    # Each volume group's peak von Mises stress: the block's, near its base, is of the order
    # of its weight over its base, ρ_eff g H (the bonded base and the corners concentrate
    # it, Poisson's ratio relieves the uniaxial value: within a factor 2 either way).
    mean = weight / 0.06**2
    block = s1["peak_von_mises_by_group"]["block"]["peak_Pa"]
    assert 0.5 * mean < block < 2.0 * mean, (block, mean)
    # `crane-fem modes` on the model, its touching contact points tied: no rigid mode (the
    # block held by its feet), and the support's static reaction is the whole weight.
    toml = shared_tmp / "per_group.toml"
    assert main(["modes", str(toml), "--n", "3", "--out", str(shared_tmp / "modes")]) == 0
    report = json.loads((shared_tmp / "modes" / "modes.json").read_text(encoding="utf-8"))
    assert report["modes"][0]["frequency_hz"] > 10.0
    static = report["response_spectrum"]["supports"]["1"]["static_N"]
    assert static[2] == pytest.approx(total, rel=1e-6)
    s2, _ = run_cli(shared_tmp, with_materials(1e9, 1000.0, 0.0), "stiff_block")
    s0, _ = run_cli(shared_tmp, base, "uniform")
    assert s2["dt_critical"] < 0.9 * s0["dt_critical"]
