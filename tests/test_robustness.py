"""What a new user runs into (issue 17, robustness): bad input ends with one line naming the key
or the file, on every rank, exit code 2, before any work; `check` refuses what `run` refuses
and says what will run; mesh files, record files, output directories and launchers are
checked."""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import COMM, jobs_on_two_ranks, mpiexec_env

from crane_fem import _compat
from crane_fem.cli import main
from crane_fem.errors import ScenarioError
from crane_fem.io import prepare_output_dir
from crane_fem.loading import read_at2, read_csv
from crane_fem.scenario import apply_overrides, apply_unsets, load_scenario

ROOT = Path(__file__).parent.parent
DEMOS = ROOT / "demos"
QUICK = DEMOS / "crane_quick.toml"
BAR = DEMOS / "bar_impact.toml"
MESH = ROOT / "meshes" / "crane.msh"
OWN_MESH = DEMOS / "own_model" / "cabinet_on_slab.msh"
FRAME_MESH = DEMOS / "own_frame" / "gantry.msh"
BIN = Path(sys.executable).parent
AT2_HEAD = (
    "# a comment line: counted in the line numbers\nPEER\nRSN0\n"
    "ACCELERATION TIME SERIES IN UNITS OF G\nNPTS=   6, DT=   .0100 SEC\n"
)


def _unwritable(tmp: Path) -> Path | None:
    """A directory path that cannot be created: under a read-only directory, or (root passes
    permission bits) under /sys."""
    if os.geteuid() != 0:
        ro = tmp / "read_only"
        ro.mkdir()
        ro.chmod(0o500)
        return ro / "out"
    path = Path("/sys/crane_fem_test_out")
    try:
        path.mkdir()
    except OSError:
        return path
    path.rmdir()
    return None


def _cases(tmp: Path) -> dict[str, tuple[list[str], list[str]]]:
    """Bad inputs of the crane scene: (crane-fem arguments, fragments of the one line)."""
    nan_csv = tmp / "nan_record.csv"
    nan_csv.write_text("t, a\n0.0, 0.0\n0.01, nan\n0.02, 0.0\n")
    as_file = tmp / "a_file"
    as_file.write_text("not a directory\n")
    bare = tmp / "bare.msh"  # the committed mesh without its sidecar
    shutil.copy(MESH, bare)
    q = str(QUICK)
    same_name = tmp / "same_name.toml"
    text = QUICK.read_text().replace('name = "structure"', 'name = "contact_zones"')
    same_name.write_text(text.replace("../meshes/", f"{MESH.parent.as_posix()}/"))
    cases = {
        "mesh_keys": (["check", q, "--set", "model.size=0.1"], ["model.size = 0.1", "crane.msh"]),
        "no_mesh": (["check", q, "--set", "model.mesh='nope.msh'"], ["model.mesh", "nope.msh"]),
        "no_sidecar": (
            ["check", q, "--set", f"model.mesh='{bare}'"],
            ["model.mesh", "bare.msh", "bare.json", "crane-fem mesh"],
        ),
        "no_record": (
            ["check", q, "--set", "loading.ground_motion={record='missing.AT2'}"],
            [str(DEMOS / "missing.AT2"), "not found"],
        ),
        "unknown_record": (
            ["check", q, "--set", "loading.ground_motion={record='el_centro_1941'}"],
            ["loading.ground_motion.record", "el_centro_1941", "bundled"],
        ),
        "nan_record": (
            ["check", q, "--set", f"loading.ground_motion={{record='{nan_csv}'}}"],
            [f"{nan_csv}: line 3", "not a finite number"],
        ),
        "window": (
            ["check", q, "--set", "loading.ground_motion={record='el_centro_1940_up', start=99.0}"],
            ["loading.ground_motion.start"],
        ),
        "dt_factor": (
            ["check", q, "--set", "time.dt_factor=1.5"],
            ["time.dt_factor = 1.5", "critical step"],
        ),
        "union_value": (
            ["check", q, "--set", "loading.ground_motion.seed='x'"],
            ["loading.ground_motion.seed: Input should be a valid integer (got 'x')"],
        ),
        "unset_unknown": (["check", q, "--unset", "model.nope"], ["--unset model.nope"]),
        "method": (
            ["check", q, "--set", "coupling.method='zz'"],
            ["coupling.method", "'gc-mean' or 'monolithic' (got 'zz')"],
        ),
        "no_scenario": (["check", str(tmp / "nope.toml")], ["nope.toml", "not found"]),
        "fine_ratio_not_finer": (
            ["check", q, "--set", "coupling.fine_ratio=100"],
            ["coupling.fine_ratio = 100", "smaller than coupling.ratio = 100"],
        ),
        "fine_ratio_not_dividing": (
            ["run", q, "--set", "coupling.fine_ratio=30"],
            ["coupling.fine_ratio = 30", "divide it"],
        ),
        "gravity_up": (
            ["check", q, "--set", "loading.gravity=[0.0, 0.0, 9.81]"],
            ["loading.gravity = [0.0, 0.0, 9.81]", "must point down"],
        ),
        "gravity_along_y": (
            ["check", q, "--set", "loading.gravity=[0.0, -9.81, 0.0]"],
            ["loading.gravity", "must point down"],
        ),
        "E_in_MPa": (
            ["check", q, "--set", "material.E=2.1e5"],
            ["material: the wave speed", "5.19 m/s", "E in Pa"],
        ),
        "rho_in_t_per_mm3": (
            ["check", q, "--set", "material.rho=7.85e-9"],
            ["material: the wave speed", "kg/m³"],
        ),
        "point_off_the_structure": (
            ["check", q, "--set", "spectra.points.far=[0.0, 2.0, 15.0]"],
            ["spectra.points.far", "14.5 m from the nearest point"],
        ),
        "same_subdomain_name": (
            ["check", str(same_name)],
            ["[[subdomain]] name 'contact_zones' is given to 2 subdomains"],
        ),
        "record_ends_before_the_run": (
            ["run", q, "--set", "time.end=0.1"],
            ["loading.ground_motion", "lasts 0.06 s, less than time.end = 0.1 s"],
        ),
        "one_macro_step_beyond_the_end": (
            ["check", q, "--set", "time.end=1e-4"],
            ["time.end = 0.0001 s", "shorter than one macro step", "coupling.ratio"],
        ),
        "sample_interval": (
            ["run", q, "--set", "output.sample_interval=1e-9"],
            ["output.sample_interval = 1e-09 s", "below the time step"],
        ),
        "zone_margin_overlap": (
            ["check", q, "--unset", "model.mesh", "--set", "model.zone_margin=0.3"],
            ["model.zone_margin = 0.3", "overlap"],
        ),
        "zone_margin_zero": (
            ["check", q, "--set", "model.zone_margin=0"],
            ["model.zone_margin", "greater than 0"],
        ),
        "mass_scaling_too_much": (
            ["check", q, "--set", "time.mass_scaling=3e-6"],
            ["time.mass_scaling = 3e-06 s", "% of the model's", "at most 2 %"],
        ),
        "drift_correction_not_gc": (
            ["check", q, "--set", "coupling.drift_correction=true"],
            ["coupling.drift_correction", "'gc' only"],
        ),
        "mass_scaling_of_a_bar": (
            ["check", str(BAR), "--set", "time.mass_scaling=1e-6"],
            ["time.mass_scaling", "'crane' and 'gmsh' only"],
        ),
        "wheel_contact": (
            ["check", q, "--set", "wheel.contact='faces'"],
            ["wheel.contact", "'nodes' or 'surface'"],
        ),
        "outdir_file": (["run", q, "-o", str(as_file)], [f"output directory {as_file} is a file"]),
    }
    # A gmsh model (demos/own_model): groups that are not in its mesh, contact points off
    # their surface or buried in it.
    own = DEMOS / "own_model" / "cabinet_on_slab.toml"
    own_text = own.read_text().replace('mesh = "cabinet_on_slab.msh"', f'mesh = "{OWN_MESH}"')
    variants = {
        "gmsh_no_mesh": (own_text.replace(str(OWN_MESH), "nope.msh"), ["model.mesh", "nope.msh"]),
        "gmsh_surface_group": (
            own_text.replace('surface = "floor"', 'surface = "flor"'),
            ["contact[0].surface", "'flor'", "floor"],
        ),
        "gmsh_points_off": (
            own_text.replace('points = "cabinet_feet"', 'points = "X"')
            .replace('surface = "floor"', 'surface = "cabinet_feet"')
            .replace('points = "X"', 'points = "floor"'),
            ["contact[0].points", "'floor'", "projects onto no triangle", "'cabinet_feet'"],
        ),
        "gmsh_points_buried": (
            own_text.replace('points = "cabinet_feet"', 'points = "slab_underside"'),
            ["contact[0].points", "'slab_underside'", "inside", "'floor'"],
        ),
        "gmsh_rolling_frictionless": (
            own_text.replace("friction = 0.3", "friction = 0.0\nrolling = [1.0, 0.0, 0.0]"),
            ["contact[0].rolling", "applies to a contact with friction"],
        ),
        "gmsh_rolling_along_the_normal": (
            own_text.replace("friction = 0.3", "friction = 0.3\nrolling = [0.0, 0.2, 1.0]"),
            ["contact[0].rolling = [0.0, 0.2, 1.0]", "nearer the normal", "'floor'"],
        ),
        "gmsh_along_the_normal": (
            own_text.replace("friction = 0.3", "friction = 0.3\nalong = [0.0, 0.0, -1.0]"),
            ["contact[0].along = [0.0, 0.0, -1.0]", "nearer the normal", "'floor'"],
        ),
        "gmsh_along_zero": (
            own_text.replace("friction = 0.3", "friction = 0.3\nalong = [0.0, 0.0, 0.0]"),
            ["contact[0].along", "must not be the zero vector"],
        ),
        "gmsh_material_group": (
            own_text.replace('groups = ["cabinet"]', 'groups = ["cabinet", "roof"]'),
            ["material[1].groups", "'roof'"],
        ),
        "gmsh_support_group": (
            own_text.replace('group = "slab_underside"', 'group = "ground"'),
            ["support[0].group", "'ground'"],
        ),
    }
    # A mesh drawn in mm (the demo's, scaled by 1000): refused by `check` and `run` before
    # any other error (Δt, sampling interval, contacts), naming the mesh; a solid's and a
    # frame's. A mesh of hexahedra: its element type named as gmsh names it.
    own_mm, frame_mm, hexa = tmp / "cabinet_mm.msh", tmp / "gantry_mm.msh", tmp / "hexa.msh"
    _rewrite_mesh(OWN_MESH, own_mm, 1000.0)
    _rewrite_mesh(FRAME_MESH, frame_mm, 1000.0)
    _write_hexahedra(hexa)
    drawn_in_mm = ["model.mesh", "the mesh looks drawn in mm", "2000 × 1200 × 1200 m"]
    variants |= {
        "gmsh_mesh_in_mm": (own_text.replace(str(OWN_MESH), str(own_mm)), drawn_in_mm),
        "gmsh_hexahedra": (
            own_text.replace(str(OWN_MESH), str(hexa)),
            ["model.mesh", "hexa.msh", "gmsh types 5 (Hexahedron 8)", "type 4"],
        ),
    }
    frame_text = (DEMOS / "own_frame" / "gantry.toml").read_text()
    frame_text = frame_text.replace('mesh = "gantry.msh"', f'mesh = "{frame_mm}"')
    variants["frame_mesh_in_mm"] = (
        frame_text,
        ["model.mesh", str(frame_mm), "the mesh looks drawn in mm", "6000 × 100 × 4150 m"],
    )
    for name, (text, fragments) in variants.items():
        path = tmp / f"{name}.toml"
        path.write_text(text)
        cases[name] = (["check", str(path)], fragments)
    run_mm = ["run", str(tmp / "gmsh_mesh_in_mm.toml"), "-o", str(tmp / "mm_out")]
    cases["gmsh_mesh_in_mm_run"] = (run_mm, [str(own_mm), *drawn_in_mm])
    # A record written with decimal commas: four columns, and the hint.
    comma = tmp / "decimal_comma.csv"
    comma.write_text("t;a\n0;0\n0,01;0,25\n0,02;-0,5\n")
    cases["record_decimal_commas"] = (
        ["check", q, "--set", f"loading.ground_motion={{record='{comma}'}}"],
        [f"{comma}: line 3: 4 columns", "decimal commas", "0.01, not 0,01"],
    )
    unwritable = _unwritable(tmp)
    if unwritable is not None:
        cases["outdir_unwritable"] = (["run", q, "-o", str(unwritable)], [str(unwritable)])
    return cases


def _rewrite_mesh(src: Path, dst: Path, scale: float) -> None:
    """``src`` written again to ``dst`` with its coordinates times ``scale`` (gmsh's
    Mesh.ScalingFactor; this process only)."""
    import gmsh

    gmsh.initialize(interruptible=False)
    gmsh.option.setNumber("General.Terminal", 0)
    try:
        gmsh.open(str(src))
        gmsh.option.setNumber("Mesh.ScalingFactor", scale)
        gmsh.write(str(dst))
    finally:
        gmsh.finalize()


def _write_hexahedra(path: Path) -> None:
    """A unit cube of 2 × 2 × 2 hexahedra (gmsh type 5) whose groups are named as the cabinet
    demo's (this process only)."""
    import gmsh

    gmsh.initialize(interruptible=False)
    gmsh.option.setNumber("General.Terminal", 0)
    try:
        box = gmsh.model.occ.addBox(0.0, 0.0, 0.0, 1.0, 1.0, 1.0)
        gmsh.model.occ.synchronize()
        for name in ("slab_base", "slab_top_layer", "cabinet"):
            gmsh.model.addPhysicalGroup(3, [box], name=name)
        faces = [t for _, t in gmsh.model.getBoundary([(3, box)], oriented=False)]
        for name in ("slab_underside", "cabinet_feet", "floor"):
            gmsh.model.addPhysicalGroup(2, faces[:1], name=name)
        for _, c in gmsh.model.getEntities(1):
            gmsh.model.mesh.setTransfiniteCurve(c, 3)
        for _, f in gmsh.model.getEntities(2):
            gmsh.model.mesh.setTransfiniteSurface(f)
        gmsh.model.mesh.setTransfiniteVolume(box)
        gmsh.option.setNumber("Mesh.RecombineAll", 1)
        gmsh.option.setNumber("Mesh.Recombine3DAll", 1)
        gmsh.model.mesh.generate(3)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()


@pytest.fixture(scope="module")
def mpiexec_errors(tmp_path_factory):
    """Every bad input on two ranks: each case's `crane-fem` command, in one `mpiexec -n 2`
    job that runs them in turn (conftest.jobs_on_two_ranks)."""
    tmp = tmp_path_factory.mktemp("bad_inputs")
    cases = _cases(tmp)
    done = jobs_on_two_ranks({name: args for name, (args, _) in cases.items()}, tmp / "job")
    yield {name: (done[name], fragments) for name, (_, fragments) in cases.items()}
    for ro in tmp.glob("read_only"):
        ro.chmod(0o700)


@pytest.mark.serial
def test_bad_inputs_one_line_on_every_rank_under_mpiexec(mpiexec_errors) -> None:
    """At least ten bad inputs of the crane scene: each ends with exit code 2 and the same one
    line on each of the two ranks, naming the key or the file, no traceback, nothing on
    stdout, no hang (a timeout would raise)."""
    assert len(mpiexec_errors) >= 10
    for name, (ranks, fragments) in mpiexec_errors.items():
        lines = [r.err.strip().splitlines() for r in ranks]
        assert [r.code for r in ranks] == [2, 2], (name, ranks)
        assert [len(x) for x in lines] == [1, 1] and lines[0] == lines[1], (name, ranks)
        line = lines[0][0]
        assert line.startswith("crane-fem: error: "), (name, line)
        assert all("Traceback" not in r.err and r.out == "" for r in ranks), (name, ranks)
        for f in fragments:
            assert f in line, (name, f, line)
        assert "more problem" not in line and "[also" not in line, (name, line)
        assert "np." not in line, (name, line)  # plain numbers, not numpy reprs


def test_check_names_what_will_run(capsys) -> None:
    """`check` builds the subdomains to find Δt and names the schemes that run where."""
    assert main(["check", str(QUICK)]) == 0
    out = capsys.readouterr().out
    if COMM.rank == 0:
        assert (
            "ok (crane; gc-mean, m = 100 (10 at impacts): cd-lagrange on contact_zones, newmark "
            "on structure; "
            "Δt = 1.3026e-06 s (0.9× critical 1.4473e-06 s))"
        ) in out, out
    assert main(["check", str(QUICK), "--set", "coupling.method='monolithic'"]) == 0
    out = capsys.readouterr().out
    if COMM.rank == 0:
        assert "ok (crane; monolithic cd-lagrange; Δt = " in out, out
    assert main(["check", str(BAR)]) == 0
    out = capsys.readouterr().out
    if COMM.rank == 0:
        assert "ok (bar; cd-lagrange; Δt = 8.6726e-07 s (0.9× critical 9.6362e-07 s))" in out
    # Mass scaling: the critical step reaches at least the target and grows from 1.4473e-06 s
    # unscaled; the added mass is stated where it goes.
    assert main(["check", str(QUICK), "--set", "time.mass_scaling=1.2e-6"]) == 0
    out = capsys.readouterr().out
    if COMM.rank == 0:
        crit = float(out.split("critical ")[1].split(" s")[0])
        assert crit >= 1.2e-6 and crit > 1.2 * 1.4473e-6, out
        assert "mass scaling to a 1.2e-06 s vertex step" in out and "wheel_1 " in out, out


def test_committed_mesh_is_what_crane_fem_mesh_writes(tmp_path) -> None:
    """`crane-fem mesh` of the quick scene's keys writes the committed mesh byte for byte, and
    the committed sidecar beside it (--unset works on `mesh` too: model.mesh is not needed)."""
    if COMM.rank != 0:
        return
    path = tmp_path / "crane.msh"
    assert main(["mesh", str(QUICK), "-o", str(path), "--unset", "model.mesh"]) == 0
    assert path.read_bytes() == MESH.read_bytes()
    assert json.loads(path.with_suffix(".json").read_text()) == json.loads(
        MESH.with_suffix(".json").read_text()
    )


def test_geometry_keys_checked_against_the_mesh(tmp_path) -> None:
    """Keys given must be the mesh's; keys left out take the mesh's values; a mesh without a
    sidecar is taken as it is only without geometry keys."""
    mesh = tmp_path / "m.msh"
    shutil.copy(MESH, mesh)
    side = json.loads(MESH.with_suffix(".json").read_text())
    side["geometry"]["zone_margin"] = 0.07
    mesh.with_suffix(".json").write_text(json.dumps(side))
    sc = load_scenario(QUICK, [f"model.mesh='{mesh}'"])
    assert sc.model.zone_margin == 0.07 and sc.model.size == 0.12
    with pytest.raises(ScenarioError, match=r"model.zone_margin = 0.06 disagrees .* 0.07"):
        load_scenario(QUICK, [f"model.mesh='{mesh}'", "model.zone_margin=0.06"])
    mesh.with_suffix(".json").unlink()
    with pytest.raises(ScenarioError, match=r"model\.size, model\.fine cannot be checked"):
        load_scenario(QUICK, [f"model.mesh='{mesh}'"])
    sc = load_scenario(QUICK, [f"model.mesh='{mesh}'"], ["model.size", "model.fine"])
    assert sc.model.mesh == str(mesh)
    # `crane-fem mesh` writes the mesh from the keys: the old mesh does not constrain them.
    sc = load_scenario(QUICK, ["model.size=0.1"], read_mesh=False)
    assert sc.model.size == 0.1


def test_prepare_output_dir(shared_tmp) -> None:
    """Created if missing; a file is refused on every rank; with restart, kept as it is."""
    out = shared_tmp / "a" / "b"
    assert prepare_output_dir(out, COMM, restart=False) == []
    assert out.is_dir()
    blocker = shared_tmp / "file"
    if COMM.rank == 0:
        blocker.write_text("x")
    COMM.barrier()
    with pytest.raises(ScenarioError, match="is a file, not a directory"):
        prepare_output_dir(blocker, COMM, restart=False)
    with pytest.raises(ScenarioError, match=r"--restart .*: no such directory"):
        prepare_output_dir(shared_tmp / "none", COMM, restart=True)


STALE = [
    "solution_structure.xdmf",
    "solution_structure.h5",
    "spectra.csv",
    "results.csv",
    "history.csv",
    "summary.json",
]


def _make_stale(out: Path) -> None:
    if COMM.rank == 0:
        for d in ("checkpoint", "figures"):
            (out / d).mkdir(parents=True, exist_ok=True)
            (out / d / "x").write_text("old")
        for name in [*STALE, "notes.txt"]:
            (out / name).write_text("old")
    COMM.barrier()


def test_stale_outputs_removed_unless_restart(shared_tmp, capsys) -> None:
    """An earlier run's outputs are removed before a run (said in one line), other files are
    kept; with --restart the directory is the run's own and nothing is removed."""
    out = shared_tmp / "run"
    _make_stale(out)
    args = ["run", str(BAR), "-o", str(out), "--set", "time.end=1e-5", "--no-progress"]
    assert main(args) == 0
    said = capsys.readouterr().out
    if COMM.rank == 0:
        line = next(ln for ln in said.splitlines() if "removed" in ln)
        assert f"removed the outputs of an earlier run in {out}/" in line
        for name in ["solution_structure.xdmf", "checkpoint/", "figures/", "spectra.csv"]:
            assert name in line, (name, line)
    assert (out / "notes.txt").exists() and not (out / "checkpoint").exists()
    assert not (out / "solution_structure.h5").exists() and (out / "solution.xdmf").exists()
    COMM.barrier()
    _make_stale(out)
    # The bar path has no checkpoints: the driver refuses, after the directory was kept.
    assert main(["run", str(BAR), "--restart", str(out)]) == 2
    assert "checkpoints are written by scenes with subdomains" in capsys.readouterr().err
    assert all((out / n).exists() for n in [*STALE, "checkpoint/x", "figures/x"])


def test_restart_reaches_the_driver(shared_tmp, monkeypatch, capsys) -> None:
    """--restart OUTDIR: the run continues into OUTDIR, or into -o's directory."""
    seen: list[tuple[Path, object]] = []

    def fake_run(sc, outdir, comm, progress=None, restart=None):
        seen.append((Path(outdir), restart))
        raise ScenarioError("stopped by the test")

    monkeypatch.setattr("crane_fem.driver.run_scenario", fake_run)
    prev = shared_tmp / "prev"
    _make_stale(prev)
    assert main(["run", str(QUICK), "--restart", str(prev)]) == 2
    assert seen[-1] == (prev, prev)
    assert (prev / "history.csv").exists()
    assert main(["run", str(QUICK), "--restart", str(prev), "-o", str(shared_tmp / "new")]) == 2
    assert seen[-1] == (shared_tmp / "new", prev)
    assert "stopped by the test" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("body", "fragment"),
    [
        (AT2_HEAD + "0.1 0.2 0.3\n0.4 NaN 0.6\n", "line 7: 'NaN' is not a finite number"),
        (AT2_HEAD + "0.1 0.2 inf\n0.4 0.5 0.6\n", "line 6: 'inf' is not a finite number"),
        (AT2_HEAD + "0.1 0.2 0.3\n0.4 0.5 x\n", "line 7: 'x' is not a number"),
        (AT2_HEAD.replace(".0100", "1e999") + "0.1\n", "line 5: DT must be a positive finite"),
    ],
)
def test_nan_or_inf_in_an_at2_record(tmp_path, body, fragment) -> None:
    """A value that is not a finite number: an input error naming the file and the line."""
    path = tmp_path / "rec.AT2"
    path.write_text(body)
    with pytest.raises(ScenarioError) as exc:
        read_at2(path)
    assert str(exc.value).startswith(f"{path}: {fragment}"), str(exc.value)


def test_nan_or_inf_in_a_csv_record(tmp_path) -> None:
    path = tmp_path / "rec.csv"
    for bad, line in (("nan", 3), ("-inf", 3), ("1e400", 3)):
        path.write_text(f"t, a\n0.0, 0.0\n0.01, {bad}\n0.02, 0.0\n")
        with pytest.raises(ScenarioError, match=f"{path}: line {line}: .* not a finite number"):
            read_csv(path)
    path.write_text("t, a\n0.0, 0.0\n0.01, 1.0\n")
    assert read_csv(path).pga == 1.0


def test_unset_keys() -> None:
    """--unset removes a key (a number indexes an array of tables); a key not there is an
    error naming it."""
    data = {"a": {"b": 1, "c": 2}, "s": [{"m": 1}, {"m": 2}]}
    apply_unsets(data, ["a.b", "s.1.m"])
    assert data == {"a": {"c": 2}, "s": [{"m": 1}, {}]}
    for key in ("a.b", "a.c.d", "s.2.m", "x"):
        with pytest.raises(ScenarioError, match=f"--unset {key}: no key"):
            apply_unsets(data, [key])


def test_an_index_in_brackets_is_named_with_its_dotted_form() -> None:
    """`--set key[0].x=…` and `--unset key[1]` (the index in brackets, as in Python or TOML
    paths elsewhere): one line giving the key as crane_fem writes it, before the scenario is
    touched (it had made a key "ground_motion[0]" and a garbled validation message)."""
    data = {"loading": {"ground_motion": [{"scale": 1.0}, {"scale": 2.0}]}}
    with pytest.raises(ScenarioError) as e:
        apply_overrides(data, ["loading.ground_motion[0].scale=3.0"])
    assert str(e.value) == (
        "--set loading.ground_motion[0].scale: an array of tables is indexed by a number as a "
        "key of its own, not in brackets: loading.ground_motion.0.scale"
    )
    with pytest.raises(
        ScenarioError,
        match=r"--unset loading.ground_motion\[1\]: .*: "
        r"loading.ground_motion.1$",
    ):
        apply_unsets(data, ["loading.ground_motion[1]"])
    assert data == {"loading": {"ground_motion": [{"scale": 1.0}, {"scale": 2.0}]}}


def test_unset_switches_a_synthetic_record_to_a_file(shared_tmp, capsys) -> None:
    """The quick scene's synthetic record replaced by a file: its synthetic-only keys unset."""
    rec = shared_tmp / "rec.csv"
    if COMM.rank == 0:
        rec.write_text("t, a\n" + "".join(f"{0.001 * k}, {0.1 * (k % 7)}\n" for k in range(80)))
    COMM.barrier()
    switch = [f"loading.ground_motion.record='{rec}'"]
    with pytest.raises(ScenarioError, match="pga and duration apply to record = 'synthetic'"):
        load_scenario(QUICK, switch)
    unset = ["--unset", "loading.ground_motion.pga", "--unset", "loading.ground_motion.duration"]
    assert main(["check", str(QUICK), *unset, "--set", switch[0]]) == 0
    assert "Traceback" not in capsys.readouterr().err


@pytest.mark.parametrize(
    ("overrides", "expected"),
    [
        (
            ["loading.ground_motion.pga=-1.0"],
            "loading.ground_motion.pga: Input should be greater than 0 (got -1.0)",
        ),
        (
            ["loading.ground_motion=5"],
            "loading.ground_motion: Input should be a table or an array of tables (got 5)",
        ),
        (
            ["loading.ground_motion=[{record='synthetic', pga=1.0, duration='x'}]"],
            "loading.ground_motion[0].duration: Input should be a valid number (got 'x')",
        ),
        (
            ["output.progress='x'"],
            "output.progress: Input should be a valid boolean or 'auto' (got 'x')",
        ),
        (
            ["material.E=-1.0", "time.end=0.0"],
            "material.E: Input should be greater than 0 (got -1.0) [also: time.end]",
        ),
    ],
)
def test_validation_names_the_real_problem(overrides, expected) -> None:
    """A union (a table or an array of tables, a boolean or 'auto') reports the problem in the
    branch the input was meant for, not the other branch's "should be a valid list"; other
    distinct problems are named after [also: …]."""
    with pytest.raises(ScenarioError) as exc:
        load_scenario(QUICK, overrides)
    msg = str(exc.value)
    assert msg.endswith(expected), msg
    assert "more problem" not in msg


def test_record_paths_are_relative_to_the_scenario_file(tmp_path, monkeypatch) -> None:
    """A record file is found beside the scenario, from whatever directory; a bundled name
    stays a name."""
    scene = tmp_path / "scenes" / "quick.toml"
    scene.parent.mkdir()
    scene.write_text(QUICK.read_text().replace('"../meshes/crane.msh"', f'"{MESH}"'))
    (scene.parent / "rec.csv").write_text("t, a\n0.0, 0.0\n0.01, 1.0\n")
    monkeypatch.chdir(tmp_path)
    unset = ["loading.ground_motion.pga", "loading.ground_motion.duration"]
    sc = load_scenario(scene, ["loading.ground_motion.record='rec.csv'"], unset)
    assert sc.loading.ground_motions[0].record == str(scene.parent / "rec.csv")
    sc = load_scenario(scene, ["loading.ground_motion.record='el_centro_1940_up'"], unset)
    assert sc.loading.ground_motions[0].record == "el_centro_1940_up"
    assert load_scenario(scene).model.mesh == str(MESH)


def test_foreign_launcher_detected() -> None:
    """Open MPI's or a PMIx launcher's variables, and a launcher size this MPI does not see."""
    if _compat.mpi_family() != "MPICH":
        pytest.skip("the refusal is MPICH's (the pip wheel this environment installs)")
    env = {"OMPI_COMM_WORLD_SIZE": "2", "PMIX_RANK": "0"}
    assert _compat.foreign_launcher(env) == "Open MPI: OMPI_COMM_WORLD_SIZE=2"
    assert _compat.foreign_launcher({"PMIX_RANK": "1"}) == "PMIx: PMIX_RANK=1"
    assert _compat.foreign_launcher({"PMI_SIZE": "2", "PMI_RANK": "0"}) is None
    assert _compat.launcher_size_mismatch(1, {"PMI_SIZE": "2"}) == "PMI_SIZE=2"
    assert _compat.launcher_size_mismatch(2, {"PMI_SIZE": "2"}) is None


def _one_error_line_per_rank(res: subprocess.CompletedProcess[str], ranks: int) -> str:
    lines = [ln for ln in res.stderr.splitlines() if ln.startswith("crane-fem: error: ")]
    assert len(lines) == ranks and len(set(lines)) == 1, res.stderr
    assert "Traceback" not in res.stderr
    return lines[0]


@pytest.mark.serial
def test_foreign_launcher_refused_before_mpi_starts(tmp_path) -> None:
    """Under Open MPI's launcher this MPICH would abort in MPI_Init with a page of internals:
    crane-fem stops first with one line naming the launcher and the launcher to use. With the
    system's Open MPI `mpirun` when there is one, else with its variables."""
    env = {**mpiexec_env(), "OMPI_COMM_WORLD_SIZE": "2"}
    cmd = [str(BIN / "crane-fem"), "check", str(QUICK)]
    res = subprocess.run(cmd, capture_output=True, text=True, timeout=60, env=env, cwd=tmp_path)
    assert res.returncode == 2, res.stderr
    line = _one_error_line_per_rank(res, 1)
    assert "foreign MPI launcher (Open MPI: OMPI_COMM_WORLD_SIZE=2)" in line
    assert f"use {BIN / 'mpiexec'}" in line
    mpirun = shutil.which("mpirun", path="/usr/bin:/usr/local/bin")
    if mpirun is None:
        return
    version = subprocess.run([mpirun, "--version"], capture_output=True, text=True, timeout=30)
    if "Open MPI" not in version.stdout + version.stderr:
        return
    env = {**mpiexec_env(), "OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1"}
    cmd = [mpirun, "--oversubscribe", "-n", "2", *cmd]
    res = subprocess.run(cmd, capture_output=True, text=True, timeout=120, env=env, cwd=tmp_path)
    assert res.returncode == 2, res.stderr
    assert "foreign MPI launcher (Open MPI" in _one_error_line_per_rank(res, 2)


def test_version(capsys) -> None:
    """`crane-fem --version` prints the package's version and exits 0."""
    from crane_fem import __version__

    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.strip() == f"crane-fem {__version__}"


def test_check_prints_what_damping_costs(capsys) -> None:
    """ζ = 5 % between 2 and 20 Hz (Rayleigh) puts a β K term in C that cuts the explicit
    step about 1000× below the undamped one: `check` says so, with the micro steps and a
    cost estimate; without it, nothing is said."""
    sets = ["--unset", "material.rayleigh", "--set", "material.damping={ratio=0.05, f1=2, f2=20}"]
    assert main(["check", str(QUICK), *sets]) == 0
    out = capsys.readouterr().out
    if COMM.rank == 0:
        assert "stiffness-proportional damping (β K) makes the critical step 1e+03× smaller" in out
        assert "46049400 micro steps" in out
    assert main(["check", str(QUICK)]) == 0
    assert "damping" not in capsys.readouterr().out


@pytest.mark.parametrize(
    ("scene", "contact"),
    [("own_model/cabinet_on_slab.toml", "feet"), ("own_frame/gantry.toml", "wheels")],
    ids=["gmsh", "frame"],
)
def test_zero_gravity_on_resting_contacts_warns(capsys, scene, contact) -> None:
    """A gmsh model or a frame whose contacts touch at t = 0, without gravity: nothing presses
    them, and `check` says so in one warning line (on rank 0 only: one line whatever the
    ranks), exit 0. With gravity nothing is said."""
    path = str(DEMOS / scene)
    assert main(["check", path, "--set", "loading.gravity=[0.0, 0.0, 0.0]"]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    if COMM.rank == 0:
        assert len(err) == 1, err
        assert err[0].startswith(
            f"crane-fem: warning: loading.gravity is zero, yet contact '{contact}' touches at "
            "t = 0: nothing presses it"
        ), err
    else:
        assert err == [], err
    assert main(["check", path]) == 0
    assert "warning" not in capsys.readouterr().err
