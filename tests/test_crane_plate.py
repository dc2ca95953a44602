"""The mock-up's trolley plate meshed at its own size (``model.trolley_size``): P1 tetrahedra
lock in the plate's bending, so the converged-plate comparison of issue 33 needs a plate finer
than the bridge. The key is a geometry key like the others: checked before meshing, recorded
in the mesh's sidecar, checked against a given mesh; without it the committed mesh is written
bit for bit (tests/test_flanges.py)."""

import dataclasses
import itertools
import json
from pathlib import Path

import gmsh
import numpy as np
import pytest
from conftest import COMM

from crane_fem.errors import ScenarioError
from crane_fem.geometry.crane import CraneGeometry, read_mesh_sidecar, write_crane_mesh
from crane_fem.scenario import load_scenario

ROOT = Path(__file__).parent.parent
SCENE = ROOT / "demos" / "crane.toml"
PLAIN = CraneGeometry(size=0.12, fine=0.04)


def _edges(path: Path, group: str) -> np.ndarray:
    """Every edge length of the tetrahedra of physical volume ``group`` in a .msh file."""
    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.open(str(path))
        tags, xyz, _ = gmsh.model.mesh.getNodes()
        where = {int(t): i for i, t in enumerate(tags)}
        x = xyz.reshape(-1, 3)
        tag = next(
            t
            for d, t in gmsh.model.getPhysicalGroups(3)
            if gmsh.model.getPhysicalName(d, t) == group
        )
        lengths = []
        for entity in gmsh.model.getEntitiesForPhysicalGroup(3, tag):
            _, _, nodes = gmsh.model.mesh.getElements(3, entity)
            cells = np.vectorize(where.get)(nodes[0].reshape(-1, 4))
            for a, b in itertools.combinations(range(4), 2):
                lengths.append(np.linalg.norm(x[cells[:, a]] - x[cells[:, b]], axis=1))
        return np.concatenate(lengths)
    finally:
        gmsh.finalize()


@pytest.mark.gmsh
def test_trolley_size_meshes_the_plate_at_its_size(tmp_path) -> None:
    """0.025 m in the plate of a 0.12 m crane: its tetrahedra's mean edge is the target size
    (gmsh meets a size field's target on average within 20 %; measured 0.0288 m), where the
    graded crane's plate has edges of about 0.07 m; the sidecar records the key and a scene
    reading the mesh takes it from there."""
    if COMM.rank != 0:
        pytest.skip("gmsh runs on rank 0 only")
    fine = dataclasses.replace(PLAIN, trolley_size=0.025)
    info = write_crane_mesh(fine, tmp_path / "plate.msh")
    assert "32 wheel/rail node pairs" in info  # the contacts' zones as before
    plate = _edges(tmp_path / "plate.msh", "trolley_frame")
    assert plate.mean() <= 1.2 * 0.025, plate.mean()
    committed = _edges(ROOT / "meshes" / "crane.msh", "trolley_frame")
    assert committed.mean() > 2.0 * 0.025, committed.mean()
    side = read_mesh_sidecar(tmp_path / "plate.msh")
    assert side is not None and side["trolley_size"] == 0.025
    sc = load_scenario(SCENE, [f"model.mesh='{(tmp_path / 'plate.msh').as_posix()}'"])
    assert sc.model.geometry() == fine  # type: ignore[union-attr]


def test_sidecars_without_the_key_read_as_no_plate_size(tmp_path) -> None:
    """The committed sidecars record none (null), and one written before the key existed
    (the key absent) reads the same: the plate at the graded sizes."""
    side = read_mesh_sidecar(ROOT / "meshes" / "crane.msh")
    assert side is not None and side["trolley_size"] is None
    assert load_scenario(SCENE).model.geometry() == PLAIN  # type: ignore[union-attr]
    record = json.loads((ROOT / "meshes" / "crane.json").read_text())
    del record["geometry"]["trolley_size"]
    (tmp_path / "old.json").write_text(json.dumps(record))
    old = read_mesh_sidecar(tmp_path / "old.msh")
    assert old == side


def test_a_plate_size_above_the_crane_size_is_refused_before_meshing() -> None:
    with pytest.raises(ScenarioError, match=r"geometry\.trolley_size = 0\.2 must not exceed") as e:
        dataclasses.replace(PLAIN, trolley_size=0.2).validate()
    assert "\n" not in str(e.value)


@pytest.mark.parametrize(
    ("overrides", "fragment"),
    [
        (["model.trolley_size=0"], "model.trolley_size: Input should be greater than 0"),
        (["model.trolley_size=0.025"], "model.trolley_size = 0.025 disagrees with model.mesh"),
    ],
)
def test_bad_plate_size_in_a_scenario(overrides, fragment) -> None:
    """Out of range, or not the committed mesh's (made without it): one line naming the key."""
    with pytest.raises(ScenarioError, match=fragment) as err:
        load_scenario(SCENE, overrides)
    assert "\n" not in str(err.value)
