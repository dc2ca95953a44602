"""The crane mesh's groups and contact node pairs, read from the current gmsh model.

Wheel/rail pairs come from gmsh's periodic node correspondence; flange/rail-side pairs from the
translation by the clearance each flange patch was meshed with. A ``.msh`` file stores the
names, the periodic correspondence and the patches' nodes: a mesh read back gives the same pairs.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import gmsh
import numpy as np
import numpy.typing as npt

from crane_fem.errors import ScenarioError
from crane_fem.geometry.groups import CRANE_FLANGE_SURFACES, CRANE_SURFACES, CRANE_VOLUMES

__all__ = ["CraneMeshInfo", "FlangePairs", "mesh_info"]


class FlangePairs(NamedTuple):
    """The node pairs of one flange and the rail side facing it (gmsh node tags, sorted by the
    flange node's tag). ``normal_x`` (±1) is the x component of the unit normal pointing from
    the rail towards the flange (the rail side's outward normal); ``gap`` (m) is each pair's
    initial gap, (x_flange − x_rail)·normal_x: the clearance, to round-off."""

    wheel: int
    inner: bool
    flange_nodes: npt.NDArray[np.int64]
    rail_nodes: npt.NDArray[np.int64]
    normal_x: float
    gap: npt.NDArray[np.float64]


@dataclass
class CraneMeshInfo:
    """Names of the physical groups, the wheel/rail node pairs and, with flanges, the
    flange/rail-side node pairs (gmsh node tags)."""

    volume_groups: dict[str, int]
    surface_groups: dict[str, int]
    contact_pairs: list[tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]]
    flange_pairs: list[FlangePairs] = field(default_factory=list)


def mesh_info() -> CraneMeshInfo:
    """Groups, wheel/rail node pairs and flange/rail-side node pairs (none without flanges) of
    the crane mesh in the current gmsh model (built by :func:`.crane_build.build_crane_model`
    or read from a ``.msh`` file: the physical names, the wheel/rail periodic node
    correspondence and the flange patches' coordinates are stored in it)."""
    names = {
        (dim, tag): gmsh.model.getPhysicalName(dim, tag)
        for dim, tag in gmsh.model.getPhysicalGroups()
    }
    volume_groups = {n: t for (d, t), n in names.items() if d == 3}
    surface_groups = {n: t for (d, t), n in names.items() if d == 2}
    for dim, wanted, have in (
        (3, CRANE_VOLUMES, volume_groups),
        (2, CRANE_SURFACES, surface_groups),
    ):
        missing = [n for n in wanted if n not in have]
        if missing:
            kind = "volume" if dim == 3 else "surface"
            raise ScenarioError(
                f"not a crane mesh: no {kind} group {missing[0]!r} (a crane mesh has "
                f"{', '.join(wanted)}; write one with crane-fem mesh)"
            )
    contact_pairs = []
    for k in range(1, 5):
        name = f"wheel_patch_{k}"
        if name not in surface_groups:
            raise ScenarioError(f"crane mesh: no surface group {name!r}")
        (face,) = gmsh.model.getEntitiesForPhysicalGroup(2, surface_groups[name])
        _, nodes, master_nodes, _ = gmsh.model.mesh.getPeriodicNodes(
            2, int(face), includeHighOrderNodes=False
        )
        if len(nodes) == 0:
            raise ScenarioError(f"crane mesh: {name} has no periodic (paired) nodes")
        # gmsh lists the correspondence in no fixed order (it varies between runs): sort by
        # the wheel node's tag, so pair k is the same node pair in every run.
        wheel_nodes = np.asarray(nodes, dtype=np.int64)
        order = np.argsort(wheel_nodes, kind="stable")
        contact_pairs.append((wheel_nodes[order], np.asarray(master_nodes, dtype=np.int64)[order]))
    flange_pairs = _flange_pairs(surface_groups)
    return CraneMeshInfo(volume_groups, surface_groups, contact_pairs, flange_pairs)


def _group_nodes(
    surface_groups: dict[str, int], name: str
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64]]:
    """Tags and coordinates of the nodes of a physical surface group of the current model."""
    tags, xyz = gmsh.model.mesh.getNodesForPhysicalGroup(2, surface_groups[name])
    return np.asarray(tags, dtype=np.int64), np.asarray(xyz, dtype=np.float64).reshape(-1, 3)


def _flange_pairs(surface_groups: dict[str, int]) -> list[FlangePairs]:
    """The flange/rail-side node pairs of the current model (none without flange groups).

    Each flange patch is a copy of the rail side patch facing it translated in x (the periodic
    constraint it was meshed with); its nodes are paired with the rail's by that translation,
    one to one, to round-off. (gmsh's own correspondence cannot serve here: it pairs the nodes
    an entity owns, and the rail side patch shares its top row with the rail top patch when
    the wheel is as wide as the rail.)

    Raises:
        ScenarioError: some flange groups but not all, or patches that are not translated
            copies of each other on the right sides of their rail.
    """
    have = [n for n in CRANE_FLANGE_SURFACES if n in surface_groups]
    if not have:
        return []
    missing = [n for n in CRANE_FLANGE_SURFACES if n not in surface_groups]
    if missing:
        raise ScenarioError(f"crane mesh: flange groups without the surface group {missing[0]!r}")
    out = []
    for k in range(1, 5):
        _, wheel_xyz = _group_nodes(surface_groups, f"wheel_patch_{k}")
        axis = 0.5 * (wheel_xyz[:, 0].min() + wheel_xyz[:, 0].max())  # the rail's axis
        for side in ("in", "out"):
            f_tags, f_xyz = _group_nodes(surface_groups, f"flange_patch_{side}_{k}")
            r_tags, r_xyz = _group_nodes(surface_groups, f"rail_side_patch_{side}_{k}")
            tol = 1e-9 * (1.0 + np.abs(r_xyz).max())
            where = f"crane mesh: flange patch {side} of wheel {k}"
            if np.ptp(f_xyz[:, 0]) > tol or np.ptp(r_xyz[:, 0]) > tol:
                raise ScenarioError(f"{where} or its rail side is not a plane x = const")
            normal_x = 1.0 if r_xyz[0, 0] > axis else -1.0  # the rail side's outward normal
            if (normal_x * axis < 0.0) != (side == "in"):
                raise ScenarioError(f"{where} is on the other side of its rail")
            # Match (y, z): the translation is along x.
            dist = np.abs(f_xyz[:, None, 1:] - r_xyz[None, :, 1:]).max(axis=2)
            match = np.argmin(dist, axis=1)
            if (
                f_tags.size != r_tags.size
                or np.any(dist[np.arange(f_tags.size), match] > tol)
                or np.unique(match).size != match.size
            ):
                raise ScenarioError(f"{where} is not a translated copy of its rail side patch")
            gap = normal_x * (f_xyz[:, 0] - r_xyz[match, 0])
            if np.any(gap < -tol):
                raise ScenarioError(f"{where} lies inside its rail")
            order = np.argsort(f_tags, kind="stable")
            out.append(
                FlangePairs(
                    k, side == "in", f_tags[order], r_tags[match][order], normal_x, gap[order]
                )
            )
    return out
