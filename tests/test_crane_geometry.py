"""Crane mock-up geometry: parameter checks before meshing, groups, conforming contact patches."""

import dataclasses

import dolfinx.mesh
import gmsh
import numpy as np
import pytest
from conftest import COMM

from crane_fem.errors import ScenarioError
from crane_fem.geometry.crane import CraneGeometry, build_crane_model, create_crane_mesh


@pytest.mark.parametrize(
    ("change", "fragment"),
    [
        ({"span": 0.0}, "geometry.span must be > 0"),
        ({"span": -3.0}, "geometry.span must be > 0"),
        ({"wheel_width": 0.06}, "wheel_width = 0.06 is wider than the rail"),
        ({"trolley_position": 3.9}, "puts the trolley off the girders"),
        ({"trolley_position": 0.1}, "puts the trolley off the girders"),
        ({"end_carriage_length": 0.5}, "end_carriage_length must span both girders"),
    ],
)
def test_bad_geometry_is_refused_before_meshing(change, fragment) -> None:
    geo = dataclasses.replace(CraneGeometry(), **change)
    with pytest.raises(ScenarioError, match=fragment):
        geo.validate()


@pytest.mark.gmsh
def test_crane_mesh_groups_and_conforming_patches() -> None:
    if COMM.rank != 0:
        pytest.skip("gmsh runs on rank 0 only")
    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        info = build_crane_model(CraneGeometry(size=0.1, fine=0.03))
        for name in ["bridge_implicit", "trolley_frame"] + [
            f"{p}_{k}" for p in ("zone", "wheel") for k in range(1, 5)
        ]:
            assert name in info.volume_groups
        tags, coords, _ = gmsh.model.mesh.getNodes()
        pos = dict(zip(tags, coords.reshape(-1, 3), strict=True))
        top = CraneGeometry().rail_top
        assert len(info.contact_pairs) == 4
        for wheel_nodes, rail_nodes in info.contact_pairs:
            assert wheel_nodes.size >= 4 and wheel_nodes.size == rail_nodes.size
            # Distinct nodes (two bodies), at the same place (conforming patch meshes), on the
            # rail top: exact copies, so 1e-12 m covers round-off of the OCC coordinates.
            assert not set(wheel_nodes) & set(rail_nodes)
            for a, b in zip(wheel_nodes, rail_nodes, strict=True):
                assert np.max(np.abs(pos[a] - pos[b])) < 1e-12
                assert abs(pos[a][2] - top) < 1e-12
    finally:
        gmsh.finalize()


@pytest.mark.gmsh
def test_crane_distributed_mesh_contact_pairs() -> None:
    """The wheel/rail pairs survive distribution: two distinct vertices at the same place,
    found on whichever ranks own them (serial and mpiexec -n 2 alike)."""
    geo = CraneGeometry(size=0.1, fine=0.03)
    crane = create_crane_mesh(COMM, geo)
    mesh = crane.tagged.mesh
    assert crane.pairs.shape[1] == 2 and crane.pairs.shape[0] >= 16
    assert set(np.unique(crane.wheel).tolist()) == {1, 2, 3, 4}
    assert np.all(crane.pairs[:, 0] != crane.pairs[:, 1])
    # Coordinates of the pair vertices, gathered from their owners.
    mesh.topology.create_connectivity(0, mesh.topology.dim)
    imap = mesh.topology.index_map(0)
    n_own = imap.size_local
    glob = np.asarray(imap.local_to_global(np.arange(n_own, dtype=np.int32)))
    geom = dolfinx.mesh.entities_to_geometry(mesh, 0, np.arange(n_own, dtype=np.int32)).ravel()
    xyz = mesh.geometry.x[geom]
    mine = {int(g): xyz[i] for i, g in enumerate(glob) if g in set(crane.pairs.ravel().tolist())}
    allpos = {k: v for part in COMM.allgather(mine) for k, v in part.items()}
    top = geo.rail_top
    for w, r in crane.pairs:
        assert np.max(np.abs(allpos[int(w)] - allpos[int(r)])) < 1e-12
        assert abs(allpos[int(w)][2] - top) < 1e-12
    # Explicit-zone and wheel cells exist somewhere.
    for name in ("zone_1", "wheel_4", "bridge_implicit"):
        assert COMM.allreduce(crane.tagged.cells([name]).size) > 0


@pytest.mark.gmsh
@pytest.mark.slow
def test_crane_scenario_runs_coupled_with_wheel_contacts(shared_tmp) -> None:
    """Smoke test of the crane pathway: three macro steps of the quick crane scene from its
    preload; the coupled balance closes, the four wheel contacts are active (the trolley's
    weight presses them from t = 0) and never pull."""
    from pathlib import Path

    from conftest import run

    from crane_fem.scenario import load_scenario

    demo = Path(__file__).parent.parent / "demos" / "crane_quick.toml"
    sc = load_scenario(demo, ["time.end=3e-4", "output.xdmf=false"])
    res = run(sc, shared_tmp)
    s, h = res.summary, res.history
    assert s["interface_dofs"] > 0 and s["energy_balance_error"] <= 1e-10
    assert s["contact_intervals"] >= 1
    for k in range(1, 5):
        assert np.all(h[f"force_wheel_{k}"] >= 0.0)
    assert np.max(sum(h[f"force_wheel_{k}"] for k in range(1, 5))) > 0.0
    # Node-pair histories: velocity-level contact lets a pair interpenetrate by at most one
    # step of approach, Δt × the largest wheel speed (here the pairs stay together: 0).
    for k in range(1, 5):
        gap = h[f"gap_wheel_{k}"]  # smallest gap of the wheel's pairs (0 after the preload)
        vmax = np.max(np.abs(h[f"wheel{k}_wheel_vz"]))
        assert vmax > 0.0 and np.all(gap >= -s["dt"] * vmax)


def _mesh_nodes_and_cells() -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Node coordinates (by tag − 1) and each volume group's tetrahedra of the current model."""
    tags, coords, _ = gmsh.model.mesh.getNodes()
    xyz = np.empty((int(tags.max()), 3))
    xyz[tags.astype(np.int64) - 1] = coords.reshape(-1, 3)
    cells = {}
    for dim, tag in gmsh.model.getPhysicalGroups(3):
        name = gmsh.model.getPhysicalName(dim, tag)
        conn = [
            gmsh.model.mesh.getElementsByType(4, e)[1]
            for e in gmsh.model.getEntitiesForPhysicalGroup(dim, tag)
        ]
        cells[name] = np.concatenate(conn).astype(np.int64).reshape(-1, 4) - 1
    return xyz, cells


def _as_set(points: np.ndarray) -> set[tuple[float, ...]]:
    # An image 2c − x of a node can differ from the stored node by the last bit (the mirror
    # builder and this test round 2c − x once each); 1e-12 m is far below any mesh size, and
    # adding 0.0 merges −0.0 with 0.0.
    return {tuple(p) for p in np.round(points + 0.0, 12)}


@pytest.mark.gmsh
@pytest.mark.parametrize("position", [2.0, 1.5])
def test_crane_mesh_is_mirror_symmetric(position) -> None:
    """The mesh is its own mirror image in x = 0 and, with the trolley at mid-span, in
    y = span/2: the scene's symmetry is the mesh's, so a vertical load cannot rock or pitch the
    trolley through the mesh alone. Every tetrahedron has a positive volume (the mirrored ones
    were turned right side out), and each wheel's group is the image of the others'."""
    if COMM.rank != 0:
        pytest.skip("gmsh runs on rank 0 only")
    geo = CraneGeometry(size=0.1, fine=0.03, trolley_position=position)
    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        info = build_crane_model(geo)
        xyz, cells = _mesh_nodes_and_cells()
    finally:
        gmsh.finalize()
    nodes = _as_set(xyz)
    planes = geo.mirror_planes()
    assert len(planes) == (2 if position == 0.5 * geo.span else 1)
    for axis, c in planes:
        image = xyz.copy()
        image[:, axis] = 2.0 * c - image[:, axis]
        assert _as_set(image) == nodes
        for name, tets in cells.items():
            # The cell centroids of each group map onto those of the group's image.
            centroids = xyz[tets].mean(axis=1)
            mirrored = centroids.copy()
            mirrored[:, axis] = 2.0 * c - mirrored[:, axis]
            k = name.rpartition("_")[2]
            if k.isdigit():  # wheels 1 ↔ 3 (x), 1 ↔ 2 (y): the image of wheel k
                x, y = geo.wheel_centres()[int(k) - 1]
                img = [x, y]
                img[axis] = 2.0 * c - img[axis]
                (j,) = [
                    i for i, w in enumerate(geo.wheel_centres()) if np.allclose(w, img, atol=1e-9)
                ]
                other = f"{name.rpartition('_')[0]}_{j + 1}"
            else:
                other = name
            target = xyz[cells[other]].mean(axis=1)
            assert _as_set(np.round(mirrored, 9)) == _as_set(np.round(target, 9))
    for tets in cells.values():
        e = xyz[tets[:, 1:]] - xyz[tets[:, :1]]
        assert np.all(np.einsum("ij,ij->i", e[:, 0], np.cross(e[:, 1], e[:, 2])) > 0.0)
    assert all(w.size == info.contact_pairs[0][0].size for w, _ in info.contact_pairs)


def test_scenario_defaults_are_the_geometry_defaults() -> None:
    """[model] of kind "crane" spells the geometry's defaults again (with their pydantic
    bounds): both lists must agree, or a mesh built from CraneGeometry() would differ from
    the scene's."""
    from crane_fem.scenario import CraneModel

    fields = CraneModel.model_fields
    shared = [f for f in dataclasses.fields(CraneGeometry) if f.name in fields]
    assert len(shared) >= 20, [f.name for f in shared]
    for f in shared:
        assert fields[f.name].default == f.default, f.name
