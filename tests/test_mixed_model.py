"""A user's mixed gmsh model (issue 33): beams (line groups) and a solid (a volume group) in one
``.msh``, tied by ``[[joint]] face, node`` (crane_fem.coupling.rigid_section), the solid
explicit, the beams Newmark, through the scenario pipeline (``crane-fem run``).

The model: a bar of square section 0.1 × 0.1 m along x, a beam 0–3 m, a P1 solid 3–4 m and a
beam 4–7 m, the beams' end nodes on the solid's end faces' centroids (a test writes it with
gmsh; variants of it are the bad inputs)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import (
    COMM,
    assert_same_histories,
    assert_wheel_slip_on_rails,
    error_line,
    rigid_run_back,
    rolling_crane,
    two_ranks_and_serial,
)

from crane_fem.cli import main
from crane_fem.io import read_history

pytestmark = [pytest.mark.gmsh]

E, NU, RHO = 2.1e11, 0.3, 7800.0
SIDE = 0.1


def write_bar(path: Path, variant: str = "") -> Path:
    """The mixed bar (rank 0 writes, every rank waits). ``variant``: "touching" (a strut
    from a corner of the solid), "split" (the solid in two volumes; face_mid between them),
    "off" (the first beam's end 1 cm off its face's centroid), "bent" (face_in takes the
    solid's top face too), "two_nodes" (the first
    joint's point group holds the beam's far end too), "block" (a block resting on the
    solid's whole top face, whose edges are the joints' faces')."""
    if COMM.rank == 0:
        import gmsh

        gmsh.initialize(interruptible=False)
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("General.NumThreads", 1)
        gmsh.model.add("mixed_bar")
        occ = gmsh.model.occ
        c = SIDE / 2
        if variant == "split":
            a, b = occ.addBox(3, 0, 0, 0.5, SIDE, SIDE), occ.addBox(3.5, 0, 0, 0.5, SIDE, SIDE)
            occ.fragment([(3, a)], [(3, b)])
            vols = [a, b]
        else:
            vols = [occ.addBox(3, 0, 0, 1, SIDE, SIDE)]
        z_in = c + (0.01 if variant == "off" else 0.0)
        p0, p1 = occ.addPoint(0, c, c), occ.addPoint(3, c, z_in)
        p2, p3 = occ.addPoint(4, c, c), occ.addPoint(7, c, c)
        l1, l2 = occ.addLine(p0, p1), occ.addLine(p2, p3)
        extra = []
        if variant == "touching":
            extra = [occ.addLine(occ.addPoint(4, SIDE, SIDE), occ.addPoint(4, 1.0, SIDE))]
        p_extra = p0 if variant == "two_nodes" else None
        cube = occ.addBox(3.45, 0.025, SIDE, 0.1, 0.05, 0.05) if variant == "block" else None
        occ.synchronize()

        def faces_at(x: float) -> list[int]:
            out = []
            for v in vols:
                for d, t in gmsh.model.getBoundary([(3, v)], oriented=False):
                    lo = gmsh.model.getBoundingBox(d, t)
                    if abs(lo[0] - x) < 1e-6 and abs(lo[3] - x) < 1e-6:
                        out.append(abs(t))
            return sorted(set(out))

        gmsh.model.addPhysicalGroup(3, vols, name="solid")
        bent = []
        if variant == "bent":  # face_in with the solid's top face: not planar
            for d, t in gmsh.model.getBoundary([(3, vols[0])], oriented=False):
                bb = gmsh.model.getBoundingBox(d, t)
                if abs(bb[2] - SIDE) < 1e-6 and abs(bb[5] - SIDE) < 1e-6:
                    bent.append(abs(t))
        gmsh.model.addPhysicalGroup(2, faces_at(3.0) + bent, name="face_in")
        gmsh.model.addPhysicalGroup(2, faces_at(4.0), name="face_out")
        if cube is not None:  # a block on the solid's whole top face (its edges: the joints')

            def z_face(vol: int, z: float) -> list[int]:
                return [
                    abs(t)
                    for d, t in gmsh.model.getBoundary([(3, vol)], oriented=False)
                    if abs(gmsh.model.getBoundingBox(d, t)[2] - z) < 1e-6
                    and abs(gmsh.model.getBoundingBox(d, t)[5] - z) < 1e-6
                ]

            gmsh.model.addPhysicalGroup(3, [cube], name="block")
            gmsh.model.addPhysicalGroup(2, z_face(vols[0], SIDE), name="top")
            gmsh.model.addPhysicalGroup(2, z_face(cube, SIDE), name="block_bottom")
        if variant == "split":
            gmsh.model.addPhysicalGroup(2, faces_at(3.5), name="face_mid")
        gmsh.model.addPhysicalGroup(1, [l1], name="beam_in")
        gmsh.model.addPhysicalGroup(1, [l2, *extra], name="beam_out")
        gmsh.model.addPhysicalGroup(
            0, [p1] + ([p_extra] if p_extra is not None else []), name="joint_in"
        )
        gmsh.model.addPhysicalGroup(0, [p2], name="joint_out")
        gmsh.model.addPhysicalGroup(0, [p0], name="left_end")
        gmsh.option.setNumber("Mesh.MeshSizeMax", 0.05)
        gmsh.model.mesh.generate(3)
        gmsh.write(str(path))
        gmsh.finalize()
    COMM.barrier()
    return path


def scenario(mesh: Path, **over: str) -> str:
    """The scene's TOML: the beams' left end clamped, gravity from rest, gc-mean at m = 4, 10 ms;
    ``over`` replaces a block by name (``support``, ``loading``, ``initial``, ``joints``,
    ``subdomains``, ``coupling``)."""
    blocks = {
        "support": '[[support]]\ngroup = "left_end"\n',
        "loading": "[loading]\ngravity = [0.0, 0.0, -9.81]\n",
        "initial": "[initial]\npreload = false\n",
        "joints": (
            '[[joint]]\nface = "face_in"\nnode = "joint_in"\n'
            '[[joint]]\nface = "face_out"\nnode = "joint_out"\n'
        ),
        "subdomains": (
            '[[subdomain]]\nname = "solid"\ngroups = ["solid"]\nscheme = "cd-lagrange"\n'
            '[[subdomain]]\nname = "beams"\ngroups = ["beam_in", "beam_out"]\n'
            'scheme = "newmark"\n'
        ),
        "coupling": '[coupling]\nmethod = "gc-mean"\nratio = 4\n',
    }
    blocks.update(over)
    return (
        f'name = "mixed_bar"\n[model]\nkind = "gmsh"\nmesh = "{mesh}"\n'
        '[[section]]\ngroups = ["beam_in", "beam_out"]\norientation = [0, 0, 1]\n'
        f'shape = "rectangle"\nb = {SIDE}\nh = {SIDE}\n'
        f"[material]\nE = {E}\nnu = {NU}\nrho = {RHO}\n"
        + "".join(blocks.values())
        + "[time]\nend = 0.01\ndt_factor = 0.9\n[output]\nxdmf = false\n"
    )


def write(path: Path, text: str) -> Path:
    if COMM.rank == 0:
        path.write_text(text, encoding="utf-8")
    COMM.barrier()
    return path


#: The coupled run (the solid explicit, the beams Newmark) and the fully explicit one (the
#: beams under the central difference at the solid's step, through the joints every step;
#: the coupled run's refinement at impacts, ``fine_ratio``, ignored as every monolithic run
#: ignores the split).
COUPLINGS = {
    "gc-mean": '[coupling]\nmethod = "gc-mean"\nratio = 4\n',
    "monolithic": '[coupling]\nmethod = "monolithic"\nratio = 4\nfine_ratio = 2\n',
}


@pytest.mark.serial  # the same scene's two-rank run is test_two_ranks_equal_serial's
@pytest.mark.parametrize("coupling", list(COUPLINGS))
def test_uniform_velocity_stays_a_rigid_translation(shared_tmp: Path, coupling: str) -> None:
    """The free bar thrown at [1, 0.5, −0.2] m/s, no gravity: the joints carry a rigid motion
    exactly, so the kinetic energy stays ½ m |v|² (m = ρ × 0.07 m³; the beams' consistent
    mass and the solid's lumped one integrate a translation exactly) and the strain energy
    stays at round-off: both within 1e-10 of the kinetic energy (measured 1.2e-11 and
    2.7e-11 after 2 772 micro steps: K u on a rigid displacement growing to 1 cm is ε ‖K‖ |u|
    per step, K's rows summing to zero only to round-off, and it accumulates with the steps);
    the interface's velocity jump at round-off of the bar's speed, 1.14 m/s (≤ 1e-12 of it;
    measured 2.8e-14 m/s)."""
    mesh = write_bar(shared_tmp / "bar.msh")
    toml = scenario(
        mesh,
        support="",
        loading="",
        initial="[initial]\nvelocity = [1.0, 0.5, -0.2]\n",
        coupling=COUPLINGS[coupling],
    )
    path = write(shared_tmp / "thrown.toml", toml)
    out = shared_tmp / f"thrown_{coupling}"
    assert main(["run", str(path), "-o", str(out), "--no-progress"]) == 0
    assert json.loads((out / "summary.json").read_text())["method"] == coupling
    h = read_history(out / "history.csv")
    kinetic = 0.5 * RHO * SIDE * SIDE * 7.0 * (1.0 + 0.25 + 0.04)
    assert np.max(np.abs(h["kinetic"] - kinetic)) <= 1e-10 * kinetic
    assert np.max(np.abs(h["internal"])) <= 1e-10 * kinetic
    speed = np.sqrt(1.0 + 0.25 + 0.04)
    assert np.nanmax(np.abs(h["interface_velocity_jump"])) <= 1e-12 * speed
    summary = json.loads((out / "summary.json").read_text())
    assert summary["interface_dofs"] == 12  # six unknowns per joint
    assert summary["energy_balance_error"] <= 1e-8


@pytest.mark.parametrize("coupling", list(COUPLINGS))
def test_two_ranks_equal_serial(shared_tmp: Path, tmp_path: Path, coupling: str) -> None:
    """The cantilever (the first beam's end clamped) under gravity from rest, coupled and
    fully explicit: its energy balance closes (≤ 1e-8 of the energies' scale), the support
    carries a growing load; on two ranks, the history equals the serial one within 1e-8 of
    each column's scale."""
    mesh = write_bar(shared_tmp / "bar.msh")
    path = write(
        shared_tmp / f"cantilever_{coupling}.toml", scenario(mesh, coupling=COUPLINGS[coupling])
    )
    if COMM.size == 1:
        out = shared_tmp / f"cantilever_{coupling}"
        assert main(["run", str(path), "-o", str(out), "--no-progress"]) == 0
        summary = json.loads((out / "summary.json").read_text())
        assert summary["energy_balance_error"] <= 1e-8
        assert summary["supports"]["1"]["peak_vertical_N"] > 0.0
        groups = summary["peak_von_mises_by_group"]
        assert set(groups) == {"solid", "beam_in", "beam_out"}
        return
    serial, par = two_ranks_and_serial(path, [], shared_tmp, tmp_path)
    h1, h2 = read_history(serial / "history.csv"), read_history(par / "history.csv")
    # The interface's velocity jump (gc-mean ties the macro step's mean velocities, not the
    # end ones: 6e-6 of the speed here) against the bar's mean speed √(2 K / m): the scene
    # has no probe to scale it by.
    v_mean = np.sqrt(2.0 * np.max(h1["kinetic"]) / (RHO * SIDE * SIDE * 7.0))
    jumps = [h.pop("interface_velocity_jump") for h in (h1, h2)]
    assert np.nanmax(np.abs(jumps[0] - jumps[1])) <= 1e-8 * v_mean
    assert_same_histories(h1, h2, 1e-8)


def test_preload_holds_the_cantilever_still(shared_tmp: Path) -> None:
    """The cantilever from its static preload through the joints (crane_fem.preload.mixed):
    at rest to round-off (kinetic energy ≤ 1e-12 of the strain energy; measured 3e-18 J
    against 138 J), the support's force the bar's weight and its moment the weight × 3.5 m
    (the joints pass the solid's share of both) within 1e-8 of them, on one rank or two
    (measured 1.1e-9: the reaction is read from K u − f on a sag of 1 mm, at the round-off of
    K's 1e11 N/m entries times it, ε ‖K‖ |u| ≈ 1e-5 N)."""
    mesh = write_bar(shared_tmp / "bar.msh")
    path = write(shared_tmp / "preloaded.toml", scenario(mesh, initial=""))
    out = shared_tmp / "preloaded"
    assert main(["run", str(path), "-o", str(out), "--no-progress"]) == 0
    h = read_history(out / "history.csv")
    assert np.max(h["kinetic"]) <= 1e-12 * h["internal"][0]
    weight = RHO * SIDE * SIDE * 7.0 * 9.81
    assert np.max(np.abs(h["support1_fz"] - weight)) <= 1e-8 * weight
    assert np.max(np.abs(h["support1_my"] + 3.5 * weight)) <= 1e-8 * 3.5 * weight


@pytest.mark.parametrize(
    ("variant", "over", "message"),
    [
        ("touching", {}, "model.mesh: line group 'beam_out' of bar_touching.msh touches a solid"),
        ("off", {}, "joint 'face_in': the beam node lies 0.01 m from the face's centroid"),
        ("two_nodes", {}, "joint[0].node: point group 'joint_in' has 2 vertices"),
        ("bent", {}, "joint face 'face_in' is not planar"),
        (
            "split",
            {
                "joints": '[[joint]]\nface = "face_mid"\nnode = "joint_in"\n'
                '[[joint]]\nface = "face_out"\nnode = "joint_out"\n'
            },
            "joint[0].face: face 'face_mid' lies between two cells",
        ),
        ("", {"joints": ""}, "joint: bar_.msh holds beams (line groups beam_in, beam_out)"),
        (
            "",
            {
                "joints": '[[joint]]\nface = "face_in"\nnode = "joint_in"\n'
                '[[joint]]\nface = "face_in"\nnode = "joint_out"\n'
            },
            "joint[1].face: 'face_in' is already joint[0]'s",
        ),
        (
            "",
            {
                "subdomains": '[[subdomain]]\nname = "all"\ngroups = ["solid", "beam_in", '
                '"beam_out"]\nscheme = "cd-lagrange"\n'
            },
            "subdomain[0].groups: mixes volume groups ['solid'] with line groups",
        ),
        (
            "block",
            {
                "subdomains": '[[subdomain]]\nname = "solids"\ngroups = ["solid", "block"]\n'
                'scheme = "cd-lagrange"\n[[subdomain]]\nname = "beams"\n'
                'groups = ["beam_in", "beam_out"]\nscheme = "newmark"\n'
                '[[contact]]\ntype = "surface"\npoints = "block_bottom"\nsurface = "top"\n'
                "friction = 0.3\n"
            },
            "contact 'block_bottom': a frictional contact may not touch the interface",
        ),
        (
            "",
            {
                "coupling": '[coupling]\nmethod = "gc-mean"\nratio = 4\n'
                "interface_truncation = 0.01\n"
            },
            "coupling.interface_truncation: not with joints",
        ),
    ],
    ids=[
        "touching",
        "off",
        "two_nodes",
        "bent",
        "split",
        "no_joint",
        "face_twice",
        "one_kind",
        "friction_on_joint",
        "truncation",
    ],
)
def test_bad_input_refused(
    shared_tmp: Path, capsys: pytest.CaptureFixture[str], variant: str, over: dict, message: str
) -> None:
    """Each bad mixed model: one line naming the key or the group, exit 2, on every rank
    (``check``, which refuses what ``run`` refuses)."""
    mesh = write_bar(shared_tmp / f"bar_{variant}.msh", variant)
    path = write(shared_tmp / "bad.toml", scenario(mesh, **over))
    code = main(["check", str(path)])
    line = error_line(code, capsys)
    assert line.startswith(f"crane-fem: error: {message}") or message in line, line


@pytest.mark.serial  # the reduced side's set-up; its two-rank behaviour: test_reduction.py
def test_reduced_beams_through_joints(shared_tmp: Path) -> None:
    """The beams reduced by Craig–Bampton (40 modes and the static vectors): the boundary is
    the DOFs the joints' rows touch (the two nodes' six DOFs, the rotation rows' I_G block
    several terms a row); the cantilever's energies follow the full beams' within 1e-3 of
    their scale over its first 10 ms (measured 4.5e-5 on the kinetic, 3.9e-4 on the strain
    energy: the modes' truncation)."""
    mesh = write_bar(shared_tmp / "bar.msh")
    path = write(shared_tmp / "cantilever.toml", scenario(mesh))
    runs = {}
    for name, sets in (
        ("full", []),
        ("reduced", ['subdomain.1.scheme="newmark-reduced"', "subdomain.1.modes=40"]),
    ):
        out = shared_tmp / name
        args = ["run", str(path), "-o", str(out), "--no-progress"]
        assert main([*args, *[a for s in sets for a in ("--set", s)]]) == 0
        runs[name] = (
            read_history(out / "history.csv"),
            json.loads((out / "summary.json").read_text()),
        )
    (full, _), (red, summary) = runs["full"], runs["reduced"]
    assert summary["reduction"]["interface_coordinates"] == 12
    assert summary["energy_balance_error"] <= 1e-8
    for col in ("kinetic", "internal"):
        scale = np.max(np.abs(full[col]))
        assert np.max(np.abs(full[col] - red[col])) <= 1e-3 * scale, col


def test_demo_is_checked(capsys: pytest.CaptureFixture[str]) -> None:
    """demos/own_mixed/runway_girder.toml (its mesh committed) passes ``check``: the mixed
    model the user guide shows reads and sets up (its run: about a minute)."""
    demo = Path(__file__).parent.parent / "demos" / "own_mixed" / "runway_girder.toml"
    assert main(["check", str(demo)]) == 0
    out = capsys.readouterr().out
    assert "newmark on girder" in out or COMM.rank > 0  # (rank 0 prints)


#: The defaults' trolley: plate 1.2 x 0.8 x 0.05 m, four wheel blocks 0.05 x 0.08 x 0.06 m, 200 kg.
TROLLEY_WEIGHT = 9.81 * (7800.0 * (1.2 * 0.8 * 0.05 + 4 * 0.05 * 0.08 * 0.06) + 200.0)


@pytest.mark.serial  # set-up and 2 ms; the mixed models' two-rank runs are tested above
@pytest.mark.parametrize(("trolley", "interface"), [("grillage", 48), ("solid", 24)])
def test_frame_crane_with_solid_wheel_zones(shared_tmp: Path, trolley: str, interface: int) -> None:
    """The frame crane with solid wheel zones (``model.wheel_zones = "solid"``): a mixed gmsh
    scene made from its geometry keys, four node-to-surface wheels. With the grillage trolley
    eight joints (each girder's segment at both ends, each wheel block at its stub: 48
    interface unknowns); with ``model.trolley_body = "solid"`` the trolley's plate a solid
    glued to the four blocks (one explicit body with the zones, the hoisted mass spread over
    it as the 3D mock-up's) and four joints (24 unknowns). Its preload through the joints:
    the supports carry the whole weight (Σ F_z = weight within 1e-8), the four wheels the
    trolley's by symmetry (equal within 1e-9: the zones' meshes are mirror images of one
    quarter's) — the solid trolley's exactly g (ρ V + 200 kg) within 1e-8 (the grillage's
    stubs weigh beside it); 2 ms after it, the balance ≤ 1e-8."""
    toml = (
        f'name = "frame_crane_solid_{trolley}"\n[model]\nkind = "frame_crane"\n'
        f'hoisted_mass = 200.0\nwheel_zones = "solid"\ntrolley_body = "{trolley}"\n'
        "solid_size = 0.04\nfine = 0.05\n"
        "[material]\nE = 2.1e11\nrho = 7800.0\nnu = 0.3\n"
        "[loading]\ngravity = [0.0, 0.0, -9.81]\n"
        '[coupling]\nmethod = "gc-mean"\nratio = 20\n[newmark]\nmass = "lumped"\n'
        "[time]\nend = 0.002\ndt_factor = 0.9\n[output]\nxdmf = false\n"
    )
    path = write(shared_tmp / f"frame_crane_solid_{trolley}.toml", toml)
    out = shared_tmp / f"frame_crane_solid_{trolley}"
    assert main(["run", str(path), "-o", str(out), "--no-progress"]) == 0
    s = json.loads((out / "summary.json").read_text())
    assert s["interface_dofs"] == interface
    assert s["explicit_subdomains"] == ["wheel_zones"] and s["implicit_subdomains"] == ["beams"]
    weight = s["preload"]["weight_N"]
    fz = sum(sup["initial_force_N"][2] for sup in s["supports"].values())
    assert abs(fz - weight) <= 1e-8 * weight
    w = s["preload"]["contact_forces_N"]
    if trolley == "solid":
        assert sum(w.values()) == pytest.approx(TROLLEY_WEIGHT, rel=1e-8)
    for k in (2, 3, 4):
        assert abs(w[f"wheel_{k}"] - w["wheel_1"]) <= 1e-9 * w["wheel_1"], w
    assert s["energy_balance_error"] <= 1e-8


@pytest.mark.serial  # set-up and 26 ms; the contacts' two-rank behaviour: test_sliding.py
def test_flanges_of_the_solid_wheel_zones(shared_tmp: Path) -> None:
    """Solid wheel zones with flanges (``model.flanges``): each wheel block carries the
    mock-up's two flanges, 5 mm off its rail's sides, frictionless node-to-surface contacts
    ``flange_in_k``/``flange_out_k`` on the rail's side faces. A steady ground acceleration
    a = 20 m/s² across the rails (half-cosine ramp τ = 2 ms) drives the bridge under the
    trolley, which the frictionless wheels leave behind: each wheel's flange on the +x side
    of its rail strikes (girder 2's outer ones, girder 1's inner ones: the names hold
    through the mirror images), the other four stay clear. Rigid rails would close the
    clearance c at t* = τ/2 + √(2c/a); the bridge yields to the same acceleration (its
    rails move along with the trolley), so the strike comes no earlier and within 10 %."""
    (shared_tmp / "push.csv").write_text("0.0,20.0\n1.0,20.0\n")
    toml = (
        'name = "frame_crane_flanges"\n[model]\nkind = "frame_crane"\nhoisted_mass = 200.0\n'
        'wheel_zones = "solid"\nflanges = true\nsolid_size = 0.04\nfine = 0.05\n'
        "[material]\nE = 2.1e11\nrho = 7800.0\nnu = 0.3\n"
        "[loading]\ngravity = [0.0, 0.0, -9.81]\n"
        '[[loading.ground_motion]]\nrecord = "push.csv"\ndirection = [1.0, 0.0, 0.0]\n'
        "taper = 0.002\n"
        '[coupling]\nmethod = "gc-mean"\nratio = 20\n[newmark]\nmass = "lumped"\n'
        "[time]\nend = 0.026\ndt_factor = 0.9\n[output]\nxdmf = false\n"
    )
    path = write(shared_tmp / "frame_crane_flanges.toml", toml)
    out = shared_tmp / "frame_crane_flanges"
    assert main(["run", str(path), "-o", str(out), "--no-progress"]) == 0
    s = json.loads((out / "summary.json").read_text())
    assert s["preload"]["contact_forces_N"]["flange_in_1"] == 0.0  # 5 mm off at rest
    t_star = 0.001 + (2.0 * 0.005 / 20.0) ** 0.5
    flanges = s["flanges"]
    struck = {"in_1", "in_2", "out_3", "out_4"}
    for name, f in flanges.items():
        if name in struck:
            assert f["impacts"], (name, f)
            assert t_star <= f["impacts"][0]["t_s"] <= 1.1 * t_star, (name, f["impacts"][0])
        else:
            assert not f["impacts"] and f["peak_force_N"] == 0.0, (name, f)
    # The mirror images strike alike (the zones' meshes are one quarter's reflections).
    for a, b in (("in_1", "in_2"), ("out_3", "out_4")):
        pa, pb = flanges[a]["peak_force_N"], flanges[b]["peak_force_N"]
        assert abs(pa - pb) <= 1e-9 * pa
    assert s["energy_balance_error"] <= 1e-8


@pytest.mark.serial  # two ranks: test_rolling_mixed_crane_two_ranks_equal_serial
def test_unbraked_wheels_of_the_solid_zones_roll(shared_tmp: Path) -> None:
    """``wheel.braked = false`` with solid wheel zones: the wheels' node-to-surface contacts
    roll along the rails (``[[contact]] rolling = [0, 1, 0]``: friction μ = 0.3 across them
    only) and the static preload holds no force along them (the wheels' loads as braked).
    A steady ground acceleration a = 2 m/s² along the rails (below μg, half-cosine ramp
    τ = 2 ms) leaves the trolley behind: no force acts on it along y, so its wheels run back
    along their rails by the rigid body's a(t)'s double integral. The four wheels' mean slip
    follows it within 1 % (measured −0.6 %: the pairs +2.1 and −3.2 %, the trolley's own
    along-rail vibration, set off by the ramp, in phase opposition at its two ends); across
    the rails they stay put (below 1 % of it, measured 0.3 %); the mirror images (1 ↔ 3,
    2 ↔ 4) alike. The summary gives each wheel's slip along and across its rail (the
    contacts' ``along = [0, 1, 0]``), its mean slip's components of the history."""
    path = rolling_crane(shared_tmp, "solid")
    out = shared_tmp / "frame_crane_rolling"
    assert main(["run", str(path), "-o", str(out), "--no-progress"]) == 0
    s = json.loads((out / "summary.json").read_text())
    braked = 1434.7321  # the wheels' preload braked (as the frame's 1 434.7 N)
    for k in range(1, 5):
        assert s["preload"]["contact_forces_N"][f"wheel_{k}"] == pytest.approx(braked, rel=1e-7)
    h = read_history(out / "history.csv")
    rigid = rigid_run_back(float(h["t"][-1]))
    assert_wheel_slip_on_rails(s, h)
    along = [-float(h[f"wheel_{k}_slip_y"][-1]) for k in range(1, 5)]
    across = [float(h[f"wheel_{k}_slip_x"][-1]) for k in range(1, 5)]
    print(f"slips along {along} m, across {across} m; rigid body {rigid:.6e} m")
    assert np.mean(along) == pytest.approx(rigid, rel=0.01)
    assert max(abs(x) for x in across) < 0.01 * rigid
    assert abs(along[0] - along[2]) <= 1e-9 * rigid and abs(along[1] - along[3]) <= 1e-9 * rigid
    assert s["energy_balance_error"] <= 1e-8


@pytest.mark.mpi
def test_rolling_mixed_crane_two_ranks_equal_serial(shared_tmp: Path, tmp_path: Path) -> None:
    """The rolling crane above, its wheels' rolling rows (one tangent each) and the loose
    preload split over two ranks: the history equals the serial one within 1e-8 of each
    column's scale (measured 7e-9 of the wheels' gaps)."""
    serial, par = two_ranks_and_serial(rolling_crane(shared_tmp, "solid"), [], shared_tmp, tmp_path)
    h1, h2 = read_history(serial / "history.csv"), read_history(par / "history.csv")
    assert_same_histories(h1, h2, 1e-8)


@pytest.mark.mpi
def test_mixed_crane_with_flanges_two_ranks_equal_serial(shared_tmp: Path, tmp_path: Path) -> None:
    """The mixed crane of demos/frame_crane_solid_3c.toml (three components, braked wheels
    μ = 0.3 sliding on the rail tops, flanges, eight joints) over its first 10 ms, its solid
    zones and its beams split over two ranks: the history equals the serial one within 1e-8
    of each column's scale (measured 8e-10 of the wheels' gaps, 2e-11 elsewhere)."""
    demo = Path(__file__).parent.parent / "demos" / "frame_crane_solid_3c.toml"
    sets = ["time.end=0.01", "output.sample_interval=0.0002", "output.xdmf=false"]
    serial, par = two_ranks_and_serial(demo, sets, shared_tmp, tmp_path)
    h1, h2 = read_history(serial / "history.csv"), read_history(par / "history.csv")
    assert_same_histories(h1, h2, 1e-8)


@pytest.mark.mpi
def test_mixed_crane_with_a_solid_trolley_two_ranks_equal_serial(
    shared_tmp: Path, tmp_path: Path
) -> None:
    """The mixed crane of demos/frame_crane_solid.toml (its trolley's plate a solid glued to
    the wheel blocks, across the mesh's mirror planes; four joints) over its first 10 ms,
    split over two ranks: the history equals the serial one within 1e-8 of each column's
    scale, and so do the supports' low-passed peaks (the scene's ``output.support_lowpass_hz``;
    the beams' point supports, on the implicit side)."""
    demo = Path(__file__).parent.parent / "demos" / "frame_crane_solid.toml"
    sets = ["time.end=0.01", "output.xdmf=false"]
    serial, par = two_ranks_and_serial(demo, sets, shared_tmp, tmp_path)
    h1, h2 = read_history(serial / "history.csv"), read_history(par / "history.csv")
    assert_same_histories(h1, h2, 1e-8)
    low = [
        {
            k: s["lowpass"]
            for k, s in json.loads((d / "summary.json").read_text())["supports"].items()
        }
        for d in (serial, par)
    ]
    assert low[0].keys() == low[1].keys() and len(low[0]) == 4
    for k, a in low[0].items():
        for q in ("peak_force_N", "peak_vertical_N"):
            assert a[q] == pytest.approx(low[1][k][q], rel=1e-8), (k, q)


@pytest.mark.serial  # two checks (mesh, subdomains, ω_max); no integration
def test_fully_explicit_step_within_the_beams_critical_step(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """The mixed crane fully explicit (``coupling.method = "monolithic"``) steps both element
    kinds at one Δt: within the beams' central-difference limit 2/ω_max too. With the wheel
    stubs' rotary inertia × 0.01 their thickness-shear mode sets it (6.16e-7 s, the solids'
    2.06e-6 s): Δt = 1e-6 s is refused naming time.dt, which the coupled run (the beams
    Newmark, unconditionally stable) accepts."""
    demo = Path(__file__).parent.parent / "demos" / "frame_crane_solid.toml"
    common = ["--set", "model.trolley_body='grillage'"]  # (the stubs: the grillage's)
    common += ["--set", "model.rotary_scale=0.01", "--set", "time.dt=1e-6"]
    common += ["--unset", "time.dt_factor"]
    assert main(["check", str(demo), *common]) == 0
    capsys.readouterr()
    code = main(["check", str(demo), *common, "--set", "coupling.method='monolithic'"])
    line = error_line(code, capsys)
    assert "time.dt = 1.0000e-06 s exceeds the critical step 6.16" in line, line


@pytest.mark.serial  # five short runs; the methods' two-rank behaviour: test_coupling.py
def test_every_coupling_method_through_the_joints(shared_tmp: Path) -> None:
    """gc, gc-mean, ec, ph and hybrid on the cantilever from rest (m = 4, 4 ms): each closes
    its energy balance (≤ 1e-8; measured ~1.5e-12 over 10 ms) and its support force follows
    gc-mean's within 1 % of its peak (measured 0.2–0.4 % over 10 ms: the methods' own
    differences at m = 4): the joints' rows (W_E,ΓΓ not diagonal) serve every method's
    interface solve."""
    mesh = write_bar(shared_tmp / "bar.msh")
    path = write(shared_tmp / "cantilever.toml", scenario(mesh))
    fz = {}
    for method in ("gc-mean", "gc", "ec", "ph", "hybrid"):
        out = shared_tmp / method
        args = ["run", str(path), "-o", str(out), "--no-progress"]
        sets = ["--set", f'coupling.method="{method}"', "--set", "time.end=0.004"]
        assert main([*args, *sets]) == 0
        s = json.loads((out / "summary.json").read_text())
        assert s["energy_balance_error"] <= 1e-8, method
        fz[method] = read_history(out / "history.csv")["support1_fz"]
    peak = np.max(np.abs(fz["gc-mean"]))
    for method, f in fz.items():
        assert np.max(np.abs(f - fz["gc-mean"])) <= 0.01 * peak, method


def test_modes_of_the_mixed_bar(shared_tmp: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``crane-fem modes`` on the mixed cantilever (crane_fem.modes.mixed: the joints' beam
    nodes eliminated by the rigid sections' rows): its axial mode — the only one with mass
    along x — at c / 4L of the uniform bar within 1e-4 (measured 5e-6: the 120 beam elements'
    consistent mass, (π h / 4 L)² / 12 ≈ 1e-5, and the lateral inertia of bar theory's
    Rayleigh–Love term, (ν π r_g / 2 L)² ≈ 8e-6, are below it: the joint adds nothing
    axially); its first bending pair at Euler–Bernoulli's within 2.5 % (measured +1.5 and
    +1.6 %: the P1 solid metre, two tetrahedra across, locks; the beams alone are exact to
    0.1 % at L/h = 70); its shape in both files (solid, beams); the same modes.json on every
    rank (each computes them alone). Asked
    with --degree 2 or --compare: one line, exit 2."""
    import math

    mesh = write_bar(shared_tmp / "bar_modes.msh")
    path = write(shared_tmp / "cantilever_modes.toml", scenario(mesh))
    out = shared_tmp / "modes"
    assert main(["modes", str(path), "--n", "14", "--out", str(out)]) == 0
    capsys.readouterr()
    doc = json.loads((out / "modes.json").read_text())
    modes = doc["modes"]
    f = np.array([m["frequency_hz"] for m in modes])
    along_x = [m for m in modes if m["effective_mass_fraction"]["x"] > 0.5]
    assert len(along_x) == 1
    length = 7.0
    axial = math.sqrt(E / RHO) / (4.0 * length)
    assert abs(along_x[0]["frequency_hz"] / axial - 1.0) < 1e-4, along_x[0]["frequency_hz"]
    inertia, area = SIDE**4 / 12.0, SIDE * SIDE
    bending = 1.8751**2 / (2.0 * math.pi) * math.sqrt(E * inertia / (RHO * area * length**4))
    assert np.all(np.abs(f[:2] / bending - 1.0) < 0.025), f[:2] / bending - 1.0
    assert "modes_beams.xdmf" in doc["shapes"]
    # The shapes, both files: the axial mode's u_x is the clamped-free bar's sin(π x / 2L)
    # in the beams and in the solid (its joints' nodes recovered from their faces), within
    # 2e-4 of its largest value (measured 5.2e-5: the discretisation's, as the frequency's
    # 5e-6; the solid's Poisson contraction is in y and z): both files' points together
    # carry the whole bar, continuous through its joints.
    import meshio

    k = modes.index(along_x[0])
    files = [meshio.read(out / name) for name in ("modes.xdmf", "modes_beams.xdmf")]
    x = np.concatenate([m.points[:, 0] for m in files])
    ux = np.concatenate([m.point_data[f"mode_{k + 1}"][:, 0] for m in files])
    exact = np.sin(np.pi * x / (2.0 * length))
    amplitude = float(ux @ exact / (exact @ exact))
    assert np.max(np.abs(ux - amplitude * exact)) < 2e-4 * abs(amplitude)
    assert files[0].cells[0].type == "tetra" and files[1].cells[0].type == "line"
    assert x.min() == 0.0 and x.max() == length
    mine = (out / "modes.json").read_text()
    assert all(t == mine for t in COMM.allgather(mine))
    for extra, named in ((["--degree", "2"], "--degree 2"), (["--compare", str(out)], "--compare")):
        code = main(["modes", str(path), "--out", str(shared_tmp / "no"), *extra])
        line = error_line(code, capsys)
        assert line.startswith("crane-fem: error: modes") and named in line, line


def test_response_spectrum_of_the_mixed_bar(
    shared_tmp: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The mixed cantilever shaken along z (El Centro vertical, 1 s): the response-spectrum
    estimate through the joints (crane_fem.modes.mixed._estimate) against equilibrium, which
    holds exactly whatever the mesh — the clamp's static force is the bar's weight and its
    moment the weight × 3.5 m (the centre of mass), within 1e-8; the SRSS of the modes' clamp
    forces along z is sqrt(Σ (m_eff,i Sa_i)²), each mode's base shear Γ_i L_i Sa_i, within
    1e-8 (the modes' forces recovered on the beams from shapes expanded through the
    joints); measured 6.5e-11, 5.1e-11 and 1.3e-11; the same modes.json on every rank."""
    import math

    mesh = write_bar(shared_tmp / "bar_spectrum.msh")
    loading = (
        "[loading]\ngravity = [0.0, 0.0, -9.81]\n[loading.ground_motion]\n"
        'record = "el_centro_1940_up"\ndirection = [0.0, 0.0, 1.0]\n'
    )
    text = scenario(mesh, loading=loading).replace("end = 0.01", "end = 1.0")
    path = write(shared_tmp / "cantilever_spectrum.toml", text)
    out = shared_tmp / "modes_spectrum"
    assert main(["modes", str(path), "--n", "14", "--out", str(out)]) == 0
    printed = capsys.readouterr().out  # (rank 0 prints)
    assert COMM.rank or "response spectrum of the input over [0, 1] s" in printed, printed
    doc = json.loads((out / "modes.json").read_text())
    rs = doc["response_spectrum"]
    (support,) = rs["supports"].values()
    weight = RHO * 7.0 * SIDE * SIDE * 9.81
    assert abs(support["static_N"][2] - weight) <= 1e-8 * weight, support["static_N"]
    moment = math.hypot(*support["static_moment_Nm"])
    assert abs(moment - 3.5 * weight) <= 1e-8 * 3.5 * weight, support["static_moment_Nm"]
    base = [m["effective_mass_kg"]["z"] * m["sa_m_s2"]["z"] for m in doc["modes"]]
    expected = math.sqrt(sum(b * b for b in base))
    assert abs(support["srss_N"][2] - expected) <= 1e-8 * expected, (support, expected)
    mine = (out / "modes.json").read_text()
    assert all(t == mine for t in COMM.allgather(mine))
