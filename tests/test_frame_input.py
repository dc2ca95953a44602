"""Bad input of a frame (``[model] kind = "frame"``): each ends with one line naming the key,
the same on every rank, exit code 2, no traceback; `check` refuses what `run` refuses, with
the same line.

One small valid frame (a girder on a short rail, a post standing 1 cm off the girder's axis
within its flanges' clearance, a rope from the post's top to the girder's end), and one
change to it per case: a section property missing or not positive, an orientation along a
member, a mesh of 3-node lines, a contact point beyond its line's end or across it without
clearance, a group not in the mesh, a rope of zero length. In process on every rank of the
suite's run (serially, and on two ranks under its mpiexec pass), and as `mpiexec -n 2
crane-fem` (one job; a hang would time out)."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import COMM, error_line, jobs_on_two_ranks

from crane_fem.cli import main
from crane_fem.geometry.frame_sketch import FrameSketch

pytestmark = [pytest.mark.gmsh, pytest.mark.no_kernels]


SCENE = """\
name = "frame_input"
[model]
kind = "frame"
mesh = "{mesh}"
[[section]]
groups = ["rail", "girder"]
orientation = [0, 0, 1]
shape = "rectangle"
b = 0.05
h = 0.1
[[section]]
groups = ["post"]
orientation = [1, 0, 0]
shape = "circle"
d = 0.03
[material]
E = 2.1e11
nu = 0.3
rho = 7800
[[support]]
group = "ends"
[[contact]]
type = "point-on-line"
points = "foot"
line = "girder"
offset = 0.05
clearance = 0.02
[[rope]]
line = "rope"
length = 1.2
stiffness = 1e5
[initial]
preload = false
[time]
end = 1e-4
dt_factor = 0.9
[output]
xdmf = false
"""

#: Each case: the crane-fem arguments that change the valid frame, and fragments of the one
#: line (the key first).
CASES: dict[str, tuple[list[str], list[str]]] = {
    "section_property_missing": (
        ["--unset", "section.0.h"],
        ["section[0].h", "missing"],
    ),
    "section_property_zero": (
        ["--set", "section.1.d=0.0"],
        ["section[1].d", "must be positive"],
    ),
    "section_property_negative": (
        ["--set", "section.0.b=-0.05"],
        ["section[0].b", "must be positive"],
    ),
    "orientation_along_a_member": (
        ["--set", "section.0.orientation=[1.0, 0.0, 0.0]"],
        ["section[0].orientation", "parallel to a member"],
    ),
    "quadratic_lines": (
        ["--set", "model.mesh='{quad}'"],
        ["model.mesh", "quad.msh", "2-node lines"],
    ),
    "point_beyond_its_line": (
        ["--set", "contact.0.line='rail'"],
        ["contact[0].points", "'foot'", "not over line group 'rail'"],
    ),
    "point_across_its_line": (
        ["--unset", "contact.0.clearance"],
        ["contact[0].points", "'foot'", "0.01 m across"],
    ),
    "support_group_not_in_the_mesh": (
        ["--set", "support.0.group='nowhere'"],
        ["support[0].group", "'nowhere'"],
    ),
    "section_group_not_in_the_mesh": (
        ["--set", "section.0.groups=['rail', 'girder', 'nowhere']"],
        ["section[0].groups", "'nowhere'"],
    ),
    "rope_of_zero_length": (
        ["--set", "rope.0.length=0.0"],
        ["rope[0].length"],
    ),
}


@pytest.fixture(scope="module")
def frame(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The valid frame's scenario file, its mesh and the same mesh of 3-node lines
    (``quad.msh``: gmsh's order 2) beside it; written on rank 0, the same path on every
    rank."""
    tmp = Path(COMM.bcast(str(tmp_path_factory.mktemp("frame_input")), root=0))
    mesh, quad = tmp / "frame.msh", tmp / "quad.msh"
    if COMM.rank == 0:
        sketch = FrameSketch()
        sketch.member("rail", (0.0, 0.0, 0.0), (0.5, 0.0, 0.0), elements=1)
        sketch.member("girder", (0.5, 0.0, 0.0), (2.0, 0.0, 0.0), elements=3)
        # The post's foot: over the girder, 5 cm above its axis (the offset) and 1 cm off it
        # sideways (within the clearance).
        sketch.member("post", (1.0, 0.01, 0.05), (1.0, 0.01, 0.5), elements=2)
        sketch.member("rope", (1.0, 0.01, 0.5), (2.0, 0.0, 0.0), elements=1)
        sketch.points("ends", [(0.0, 0.0, 0.0), (2.0, 0.0, 0.0)])
        sketch.points("foot", [(1.0, 0.01, 0.05)])
        sketch.write(mesh)
        import gmsh

        gmsh.initialize(interruptible=False)
        try:
            gmsh.option.setNumber("General.Terminal", 0)
            gmsh.open(str(mesh))
            gmsh.model.mesh.setOrder(2)
            gmsh.write(str(quad))
        finally:
            gmsh.finalize()
        (tmp / "frame.toml").write_text(SCENE.format(mesh=mesh.as_posix()), encoding="utf-8")
    COMM.barrier()
    return tmp / "frame.toml"


def case_args(frame: Path, name: str) -> tuple[list[str], list[str]]:
    args, fragments = CASES[name]
    quad = (frame.parent / "quad.msh").as_posix()
    return [a.replace("{quad}", quad) for a in args], fragments


def test_the_frame_is_valid(frame: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The frame of every case but for its one change passes `check` (so each case's error
    is its change's)."""
    assert main(["check", str(frame)]) == 0
    assert "ok (frame;" in capsys.readouterr().out or COMM.rank != 0


@pytest.mark.parametrize("name", list(CASES))
def test_bad_frame_input(
    frame: Path, name: str, shared_tmp: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`check` and `run` end with exit code 2 and the same one line, naming the key, on
    every rank (the lines gathered before the verdict: the same on every rank)."""
    args, fragments = case_args(frame, name)
    checked = error_line(main(["check", str(frame), *args]), capsys)
    out = str(shared_tmp / "out")
    ran = error_line(main(["run", str(frame), "-o", out, "--no-progress", *args]), capsys)
    lines = COMM.allgather((checked, ran))
    assert len(set(lines)) == 1, lines
    assert ran == checked, (ran, checked)
    assert checked.startswith("crane-fem: error: "), checked
    for f in fragments:
        assert f in checked, (f, checked)


@pytest.mark.serial  # launches its own `mpiexec -n 2` job
def test_bad_frame_input_under_mpiexec(frame: Path, tmp_path: Path) -> None:
    """Each case's `run` as `crane-fem` on two ranks (one `mpiexec -n 2` job that runs the
    cases in turn: conftest.jobs_on_two_ranks): exit code 2, the same one line on each of the
    two ranks, naming the key, no traceback, nothing on stdout, no hang (a timeout would
    raise). (`check` on two ranks, and its line against `run`'s: test_bad_frame_input in the
    suite's mpiexec pass.)"""
    jobs = {}
    for name in CASES:
        args, _ = case_args(frame, name)
        jobs[name] = ["run", str(frame), "-o", str(tmp_path / name), "--no-progress", *args]
    done = jobs_on_two_ranks(jobs, tmp_path / "job")
    problems = []  # every case's, not the first one's only
    for name, ranks in done.items():
        err = [r.err.strip().splitlines() for r in ranks]
        if [r.code for r in ranks] != [2, 2] or [len(e) for e in err] != [1, 1]:
            problems.append((name, ranks))
        elif err[0] != err[1] or not err[0][0].startswith("crane-fem: error: "):
            problems.append((name, ranks))
        elif any("Traceback" in r.err or r.out != "" for r in ranks):
            problems.append((name, ranks))
        else:
            problems += [(name, f, err[0][0]) for f in CASES[name][1] if f not in err[0][0]]
    assert not problems, problems
