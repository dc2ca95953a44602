"""Crane mock-up geometry: parameter checks before meshing, groups, conforming contact patches."""

import dataclasses

import gmsh
import numpy as np
import pytest
from conftest import COMM

from crane_fem.errors import ScenarioError
from crane_fem.geometry.crane import CraneGeometry, build_crane_model


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
