"""Wheel flanges (issue 16): geometry keys checked before meshing, flange/rail-side patches and
their node pairs (one to one after a translation by the clearance, normals from the rail to the
flange), the crane without flanges unchanged."""

import dataclasses
from pathlib import Path

import dolfinx.mesh
import gmsh
import numpy as np
import pytest
from conftest import COMM

from crane_fem.errors import ScenarioError
from crane_fem.geometry.crane import (
    FLANGE_SURFACE_NAMES,
    CraneGeometry,
    CraneMesh,
    build_crane_model,
    create_crane_mesh,
    read_mesh_sidecar,
    write_crane_mesh,
)
from crane_fem.scenario import load_scenario

ROOT = Path(__file__).parent.parent
CRANE_MSH = ROOT / "meshes" / "crane.msh"
FLANGES_MSH = ROOT / "meshes" / "crane_flanges.msh"
SCENE = ROOT / "demos" / "crane_3c.toml"
#: The committed meshes' geometry (demos/crane.toml, demos/crane_3c.toml).
PLAIN = CraneGeometry(size=0.12, fine=0.04)
FLANGED = dataclasses.replace(PLAIN, flanges=True)
# Pair coordinates are copies (periodic meshing) or mirror images 2c − x of copies: exact to
# the last bit of a coordinate of size ~4 m, far below 1e-12 m.
TOL = 1e-12


@pytest.mark.parametrize(
    ("change", "fragment"),
    [
        ({"flange_clearance": -0.001}, "geometry.flange_clearance = -0.001 must be >= 0"),
        ({"flange_depth": 0.04}, "geometry.flange_depth = 0.04 must be < geometry.rail_height"),
        ({"flange_depth": 0.0}, "geometry.flange_depth must be > 0"),
        ({"flange_thickness": -0.01}, "geometry.flange_thickness must be > 0"),
        ({"flange_thickness": 0.5}, "geometry.flange_thickness = 0.5: the inner flanges reach"),
    ],
)
def test_bad_flange_keys_are_refused_before_meshing(change, fragment) -> None:
    geo = dataclasses.replace(FLANGED, **change)
    with pytest.raises(ScenarioError, match=fragment) as err:
        geo.validate()
    assert "\n" not in str(err.value)


def test_flange_shape_is_not_checked_without_flanges() -> None:
    """Without flanges their depth and thickness are unused (a shallower rail stays valid);
    the clearance's sign is checked all the same."""
    dataclasses.replace(PLAIN, rail_height=0.01, flange_thickness=0.6).validate()
    with pytest.raises(ScenarioError, match="flange_clearance"):
        dataclasses.replace(PLAIN, flange_clearance=-1e-3).validate()


@pytest.mark.parametrize(
    ("overrides", "fragment"),
    [
        (["model.flange_clearance=-0.01"], "model.flange_clearance: Input should be greater"),
        (["model.flange_depth=0.05"], "model.flange_depth = 0.05 must be < model.rail_height"),
        (["model.flanges=1"], "model.flanges: Input should be a valid boolean"),
        (["model.flange_clearance=0.01"], "model.flange_clearance = 0.01 disagrees with"),
        (['model.mesh="../meshes/crane.msh"'], "model.flanges = 1 disagrees with"),
    ],
)
def test_bad_flange_keys_in_a_scenario(overrides, fragment) -> None:
    with pytest.raises(ScenarioError, match=fragment) as err:
        load_scenario(SCENE, overrides)
    assert "\n" not in str(err.value)


def test_sidecars_record_the_flanges() -> None:
    """A sidecar written before the flanges existed reads as flanges off; the flange scene's
    keys are those its mesh was written with."""
    old = read_mesh_sidecar(CRANE_MSH)
    assert old is not None and old["flanges"] is False
    new = read_mesh_sidecar(FLANGES_MSH)
    assert new is not None and new["flanges"] is True
    assert load_scenario(SCENE).model.geometry() == FLANGED  # type: ignore[union-attr]


@pytest.mark.gmsh
@pytest.mark.parametrize(("geo", "msh"), [(PLAIN, CRANE_MSH), (FLANGED, FLANGES_MSH)])
def test_committed_meshes_are_written_again_bit_for_bit(geo, msh, tmp_path) -> None:
    """Flanges off, the crane is meshed exactly as before them (meshes/crane.msh); the
    flange mesh is reproducible from demos/crane_3c.toml's keys."""
    if COMM.rank != 0:
        pytest.skip("gmsh runs on rank 0 only")
    write_crane_mesh(geo, tmp_path / "again.msh")
    assert (tmp_path / "again.msh").read_bytes() == msh.read_bytes()


def _vertex_coordinates(crane: CraneMesh, ids: np.ndarray) -> dict[int, np.ndarray]:
    """Coordinates of global parent vertices, gathered from their owners (collective)."""
    mesh = crane.tagged.mesh
    mesh.topology.create_connectivity(0, mesh.topology.dim)
    n_own = mesh.topology.index_map(0).size_local
    own = np.arange(n_own, dtype=np.int32)
    glob = np.asarray(mesh.topology.index_map(0).local_to_global(own))
    xyz = mesh.geometry.x[dolfinx.mesh.entities_to_geometry(mesh, 0, own).ravel()]
    want = set(ids.ravel().tolist())
    mine = {int(g): xyz[i] for i, g in enumerate(glob) if int(g) in want}
    return {k: v for part in COMM.allgather(mine) for k, v in part.items()}


def _group_vertices(crane: CraneMesh, name: str) -> set[int]:
    """Global parent vertices of a cell group's cells (collective)."""
    mesh = crane.tagged.mesh
    mesh.topology.create_connectivity(mesh.topology.dim, 0)
    cells = crane.tagged.cells([name])
    local = dolfinx.mesh.compute_incident_entities(mesh.topology, cells, mesh.topology.dim, 0)
    return set(crane.tagged.global_vertices(local).tolist())


@pytest.mark.gmsh
def test_without_flanges_the_crane_is_unchanged() -> None:
    """Meshed in memory or read from the committed meshes/crane.msh: the same vertices, the
    same wheel/rail pairs, and no flange pairs."""
    built = create_crane_mesh(COMM, PLAIN)
    read = create_crane_mesh(COMM, PLAIN, CRANE_MSH)
    for crane in (built, read):
        assert crane.flange_pairs.shape == (0, 2) and crane.flange_normal.shape == (0, 3)
        assert crane.flange_wheel.size == crane.flange_gap.size == crane.flange_inner.size == 0
        assert not set(FLANGE_SURFACE_NAMES) & set(crane.tagged.facet_groups)
    assert built.tagged.mesh.topology.index_map(0).size_global == 3182
    assert read.tagged.mesh.topology.index_map(0).size_global == 3182
    assert built.pairs.shape == (32, 2)
    np.testing.assert_array_equal(built.pairs, read.pairs)
    np.testing.assert_array_equal(built.wheel, read.wheel)


@pytest.mark.gmsh
def test_flange_pairs_of_the_committed_mesh() -> None:
    """Every flange pair: a wheel_k vertex and a zone_k vertex, the flange vertex the rail
    vertex moved by the clearance along the normal, the normal ±e_x pointing from the rail to
    the flange (towards x = 0 for an inner flange), on the rail side below the rail top."""
    geo = FLANGED
    crane = create_crane_mesh(COMM, geo, FLANGES_MSH)
    fp = crane.flange_pairs
    assert fp.shape == (64, 2) and crane.pairs.shape == (32, 2)
    assert set(FLANGE_SURFACE_NAMES) <= set(crane.tagged.facet_groups)
    # Two flanges per wheel, as many pairs on each (the mesh is mirror symmetric).
    for k in range(1, 5):
        for inner in (True, False):
            assert np.sum((crane.flange_wheel == k) & (crane.flange_inner == inner)) == 8
    assert len({(int(a), int(b)) for a, b in fp}) == 64  # no pair twice
    assert not set(fp[:, 0].tolist()) & set(fp[:, 1].tolist())  # flange ≠ rail vertices
    np.testing.assert_allclose(np.abs(crane.flange_normal[:, 0]), 1.0, rtol=0, atol=0)
    assert np.all(crane.flange_normal[:, 1:] == 0.0)
    np.testing.assert_allclose(crane.flange_gap, geo.flange_clearance, rtol=0, atol=TOL)
    pos = _vertex_coordinates(crane, np.concatenate([fp.ravel(), crane.pairs.ravel()]))
    zt = geo.rail_top
    centres = geo.wheel_centres()
    for k in range(1, 5):
        wheel, zone = _group_vertices(crane, f"wheel_{k}"), _group_vertices(crane, f"zone_{k}")
        x_axis = centres[k - 1][0]
        for j in np.flatnonzero(crane.flange_wheel == k):
            f, r = pos[int(fp[j, 0])], pos[int(fp[j, 1])]
            n = crane.flange_normal[j]
            assert int(fp[j, 0]) in wheel and int(fp[j, 1]) in zone
            assert np.max(np.abs(f - (r + crane.flange_gap[j] * n))) < TOL
            # The rail side's outward normal; towards x = 0 for an inner flange.
            assert abs(r[0] - (x_axis + n[0] * 0.5 * geo.rail_width)) < TOL
            assert (n[0] * x_axis < 0.0) == bool(crane.flange_inner[j])
            assert zt - geo.flange_depth - TOL <= r[2] <= zt + TOL
            assert abs(r[1] - centres[k - 1][1]) <= 0.5 * geo.wheel_length + TOL
    # The flange pairs are mirror symmetric like the mesh: in x = 0 (inner flanges onto
    # inner flanges) and, with the trolley at mid-span, y = span/2.
    for axis, c in geo.mirror_planes():
        for inner in (True, False):
            sel = crane.flange_inner == inner
            xyz = np.array([np.concatenate([pos[int(a)], pos[int(b)]]) for a, b in fp[sel]])
            image = xyz.copy()
            image[:, [axis, axis + 3]] = 2.0 * c - image[:, [axis, axis + 3]]
            assert {tuple(p) for p in np.round(image + 0.0, 9)} == {
                tuple(p) for p in np.round(xyz + 0.0, 9)
            }
    # The wheel/rail pairs are still coincident pairs on the rail top.
    for w, r in crane.pairs:
        assert np.max(np.abs(pos[int(w)] - pos[int(r)])) < TOL and abs(pos[int(w)][2] - zt) < TOL


@pytest.mark.gmsh
@pytest.mark.parametrize(
    "change",
    [
        # Clearance 0: flange and rail side coincide, and the flange patch shares its top row
        # with the wheel bottom (the wheel as wide as the rail).
        {"flange_clearance": 0.0},
        # A narrower wheel and the trolley off mid-span (mirrored in x = 0 only).
        {"flange_clearance": 0.003, "wheel_width": 0.04, "trolley_position": 1.5},
    ],
)
def test_flange_patches_are_paired_one_to_one(change) -> None:
    """gmsh-level pairs of other flange geometries: each flange node the translate of one
    rail-side node by the clearance, one to one, on all four wheels; the inner flange faces
    x = 0; the patches conform across the mirror planes (equal pair counts)."""
    if COMM.rank != 0:
        pytest.skip("gmsh runs on rank 0 only")
    geo = dataclasses.replace(FLANGED, size=0.1, fine=0.03, **change)
    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        info = build_crane_model(geo)
        tags, coords, _ = gmsh.model.mesh.getNodes()
        pos = dict(zip(tags.tolist(), coords.reshape(-1, 3), strict=True))
        volumes = {}
        for k in range(1, 5):
            (ent,) = gmsh.model.getEntitiesForPhysicalGroup(3, info.volume_groups[f"wheel_{k}"])
            tets = gmsh.model.mesh.getElementsByType(4, ent)[1].reshape(-1, 4)
            x = np.array([[pos[int(n)] for n in tet] for tet in tets])
            e = x[:, 1:] - x[:, :1]
            signed = np.einsum("ij,ij->i", e[:, 0], np.cross(e[:, 1], e[:, 2])) / 6.0
            assert np.all(signed > 0.0)
            volumes[k] = signed.sum()
    finally:
        gmsh.finalize()
    # Each wheel group is the wheel block with its two flanges (plates from flange_depth below
    # the rail top up to the frame, and the webs between the wheel and the plates).
    web = 0.5 * (geo.rail_width - geo.wheel_width) + geo.flange_clearance
    plate = geo.flange_thickness * (geo.flange_depth + geo.wheel_height)
    section = geo.wheel_width * geo.wheel_height + 2.0 * (plate + 0.5 * web * geo.wheel_height)
    for k in range(1, 5):
        assert volumes[k] == pytest.approx(geo.wheel_length * section, rel=1e-12)
    assert len(info.flange_pairs) == 8
    sizes = {fp.flange_nodes.size for fp in info.flange_pairs}
    assert len(sizes) == 1 and sizes.pop() >= 4
    seen = set()
    for fp in info.flange_pairs:
        x_axis = geo.wheel_centres()[fp.wheel - 1][0]
        assert fp.normal_x * x_axis < 0.0 if fp.inner else fp.normal_x * x_axis > 0.0
        seen.add((fp.wheel, fp.inner))
        assert np.unique(fp.rail_nodes).size == fp.rail_nodes.size
        np.testing.assert_allclose(fp.gap, geo.flange_clearance, rtol=0, atol=TOL)
        for f, r in zip(fp.flange_nodes.tolist(), fp.rail_nodes.tolist(), strict=True):
            assert f != r
            shift = np.array([fp.normal_x * geo.flange_clearance, 0.0, 0.0])
            assert np.max(np.abs(pos[f] - pos[r] - shift)) < TOL
    assert seen == {(k, inner) for k in range(1, 5) for inner in (True, False)}
