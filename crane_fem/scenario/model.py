"""The [model] section: one table per model kind (bar, crane, box_beam, block, gmsh), by
``kind``."""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import Field, field_validator, model_validator

from crane_fem.scenario.base import NonNegativeFloat, PositiveFloat, PositiveInt, Section
from crane_fem.scenario.frame import FrameModel
from crane_fem.scenario.frame_crane import FrameCraneModel

__all__ = [
    "MESH_KEYS",
    "MODEL_KINDS",
    "BarModel",
    "BlockModel",
    "BoxBeamModel",
    "CraneModel",
    "FrameCraneModel",
    "FrameModel",
    "GmshModel",
    "SecondBar",
]


class SecondBar(Section):
    """A second bar to the right of the first one, for node-to-node (two-body) contact."""

    length: PositiveFloat
    elements: PositiveInt
    area: PositiveFloat = 1.0
    velocity: float = 0.0


class BarModel(Section):
    """1D bar along x (dolfinx interval mesh, P1); its left end faces the wall at x = 0.

    ``split`` (distance from the left end, on a node) tags the cells ``left``/``right``.
    """

    kind: Literal["bar"]
    length: PositiveFloat
    elements: PositiveInt
    area: PositiveFloat = 1.0
    clamp: Literal["none", "right"] = "none"
    second_bar: SecondBar | None = None
    split: PositiveFloat | None = None

    @model_validator(mode="after")
    def _split_on_node(self) -> BarModel:
        if self.split is not None:
            k = self.split / self.length * self.elements
            if not 0 < self.split < self.length or abs(k - round(k)) > 1e-9:
                raise ValueError(
                    f"model.split = {self.split} must lie strictly inside the bar on a node "
                    f"(a multiple of length/elements = {self.length / self.elements:g})"
                )
        return self

    @property
    def groups(self) -> list[str]:
        return ["left", "right"] if self.split is not None else []


#: The crane's keys that are not dimensions of its geometry (nor recorded by its mesh).
_NOT_GEOMETRY = ("kind", "hoisted_mass", "mesh")


class CraneModel(Section):
    """Bi-girder overhead-crane mock-up (crane_fem.geometry.crane.CraneGeometry; any of its
    dimensions may be given, metres). Groups: ``bridge_implicit``, ``trolley_frame``,
    ``zone_1..4``, ``wheel_1..4``; clamped end-carriage faces; four wheel/rail node-to-node
    contacts. ``hoisted_mass`` (kg) is carried rigidly by the trolley frame (added to its
    density); ``mesh`` reads a ``.msh`` written by ``crane-fem mesh`` instead of meshing.
    ``flanges`` gives each wheel two flanges hanging ``flange_depth`` down either side of its
    rail, ``flange_clearance`` off the rail sides, ``flange_thickness`` thick (part of
    ``wheel_k``; the other flange keys are ignored without it): lateral flange/rail-side
    node-to-node contacts (CraneMesh.flange_pairs), frictionless unilateral rows named
    ``flange_in_k``/``flange_out_k``. ``trolley_size`` meshes the trolley's plate finer than
    ``size`` (P1 tetrahedra lock in its bending). The wheels' friction and brakes are the
    ``[wheel]`` section's."""

    kind: Literal["crane"]
    span: PositiveFloat = 4.0
    girder_spacing: PositiveFloat = 1.0
    girder_width: PositiveFloat = 0.12
    girder_height: PositiveFloat = 0.20
    end_carriage_length: PositiveFloat = 1.6
    end_carriage_width: PositiveFloat = 0.15
    end_carriage_height: PositiveFloat = 0.15
    rail_width: PositiveFloat = 0.05
    rail_height: PositiveFloat = 0.04
    trolley_position: float = 2.0
    wheel_base: PositiveFloat = 0.6
    wheel_width: PositiveFloat = 0.05
    wheel_length: PositiveFloat = 0.08
    wheel_height: PositiveFloat = 0.06
    frame_overhang: PositiveFloat = 0.10
    frame_length: PositiveFloat = 0.8
    frame_thickness: PositiveFloat = 0.05
    zone_margin: PositiveFloat = 0.06
    zone_depth: NonNegativeFloat = 0.0
    size: PositiveFloat = 0.12
    fine: PositiveFloat = 0.04
    flanges: bool = False
    flange_clearance: NonNegativeFloat = 0.005
    flange_depth: PositiveFloat = 0.02
    flange_thickness: PositiveFloat = 0.02
    trolley_size: PositiveFloat | None = None
    hoisted_mass: NonNegativeFloat = 0.0
    mesh: str | None = None

    @property
    def groups(self) -> list[str]:
        return ["bridge_implicit", "trolley_frame"] + [
            f"{p}_{k}" for p in ("zone", "wheel") for k in range(1, 5)
        ]

    def geometry(self) -> Any:
        from crane_fem.geometry.crane import CraneGeometry

        return CraneGeometry(**self.model_dump(exclude=set(_NOT_GEOMETRY)))


class BoxBeamModel(Section):
    """3D box beam [0, L]×[0, W]×[0, H] (gmsh, two volumes split at x = ``split``), clamped at
    x = 0; cell groups ``part_a`` (x < split) and ``part_b``; tetrahedra of size ``h``."""

    kind: Literal["box_beam"]
    length: PositiveFloat
    width: PositiveFloat
    height: PositiveFloat
    split: PositiveFloat
    h: PositiveFloat

    @model_validator(mode="after")
    def _inside(self) -> BoxBeamModel:
        if not self.split < self.length:
            raise ValueError(f"model.split = {self.split} must be < model.length = {self.length}")
        if self.h > min(self.width, self.height, self.split, self.length - self.split):
            raise ValueError(f"model.h = {self.h} is larger than a side of the beam parts")
        return self

    @property
    def groups(self) -> list[str]:
        return ["part_a", "part_b"]


class BlockModel(Section):
    """3D elastic box [0, lx] × [0, ly] × [gap, gap + lz] (``size`` = [lx, ly, lz], m) above
    the rigid plane z = 0 of its ``plane`` contact (gap: that contact's ``gap``), P1
    tetrahedra of size about ``h``; one explicit CD-Lagrange body (the fully explicit path,
    no ``[[subdomain]]``). Cell group ``block``; facet groups ``bottom`` (z = gap, every
    vertex a contact point) and ``top``."""

    kind: Literal["block"]
    size: Annotated[list[PositiveFloat], Field(min_length=3, max_length=3)]
    h: PositiveFloat

    @model_validator(mode="after")
    def _h_fits(self) -> BlockModel:
        if self.h > min(self.size):
            raise ValueError(f"model.h = {self.h} is larger than a side of the block")
        return self

    @property
    def groups(self) -> list[str]:
        return ["block"]


@functools.lru_cache(maxsize=8)
def _physical_names(path: str, mtime: float) -> Any:
    from crane_fem.geometry.gmsh_file import read_physical_names

    return read_physical_names(path)


class GmshModel(Section):
    """A user's own structure: the gmsh ``.msh`` file ``mesh`` (P1 tetrahedra) whose named
    volume groups are the bodies (``[[subdomain]] groups``, ``[[mass]] group``) and whose
    named surface groups are the supports (``[[support]] group``) and the contact points and
    surfaces (``[[contact]] type = "surface"``). Without ``[[subdomain]]`` entries the whole
    model is one explicit CD-Lagrange body."""

    kind: Literal["gmsh"]
    mesh: str

    @field_validator("mesh")
    @classmethod
    def _readable(cls, mesh: str) -> str:
        from crane_fem.errors import ScenarioError

        path = Path(mesh)
        try:
            _physical_names(str(path), path.stat().st_mtime if path.is_file() else 0.0)
        except ScenarioError as exc:
            raise ValueError(str(exc).removeprefix("model.mesh: ")) from None
        return mesh

    def names(self) -> Any:
        """The file's named physical groups (crane_fem.geometry.gmsh_file.PhysicalNames)."""
        path = Path(self.mesh)
        return _physical_names(str(path), path.stat().st_mtime if path.is_file() else 0.0)

    @property
    def groups(self) -> list[str]:
        """Its cell groups: the volume groups, then a mixed model's line groups."""
        return self.volume_groups + self.line_groups

    @property
    def volume_groups(self) -> list[str]:
        return list(self.names().volumes)

    @property
    def surface_groups(self) -> list[str]:
        return list(self.names().surfaces)

    @property
    def line_groups(self) -> list[str]:
        """Named line groups: beams (a mixed model of solids and beams); none for solids."""
        return list(self.names().lines)

    @property
    def point_groups(self) -> list[str]:
        return list(self.names().points)

    @property
    def mixed(self) -> bool:
        """Whether the file holds beams (line groups) beside its solids."""
        return bool(self.names().lines)


MODEL_KINDS = {
    "frame": FrameModel,
    "frame_crane": FrameCraneModel,
    "bar": BarModel,
    "box_beam": BoxBeamModel,
    "crane": CraneModel,
    "block": BlockModel,
    "gmsh": GmshModel,
}

#: The crane model's keys that describe its mesh (those of
#: :class:`crane_fem.geometry.crane.CraneGeometry`).
MESH_KEYS = tuple(k for k in CraneModel.model_fields if k not in _NOT_GEOMETRY)
