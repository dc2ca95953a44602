"""The frame's sections: ``[model] kind = "frame"`` (a user's gmsh line mesh), its beams'
``[[section]]`` entries, its ``[[contact]]`` types ``point-on-line`` and ``point-on-plane``
and its ``[[rope]]`` entries."""

# Pydantic copies a field's default into each instance; ruff cannot see across modules that
# Section is a pydantic model.
# ruff: noqa: RUF012

from __future__ import annotations

import functools
import math
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import Field, field_validator, model_validator

from crane_fem.scenario.base import NonNegativeFloat, PositiveFloat, Section, Vector3

__all__ = ["SHAPE_KEYS", "BeamSection", "FrameModel", "LineContact", "PlaneContact", "Rope"]


@functools.lru_cache(maxsize=8)
def _line_names(path: str, mtime: float) -> Any:
    from crane_fem.geometry.gmsh_file import read_physical_names

    return read_physical_names(path, cells=1)


class FrameModel(Section):
    """A user's frame: the gmsh ``.msh`` file ``mesh`` of 2-node lines in 3D, whose named line
    groups are its members (``[[section]]``, ``[[material]]`` and ``[[subdomain]] groups``)
    and whose named point groups are its supports, carried masses, contact points and rope
    ends. Without ``[[subdomain]]`` entries the whole frame is one explicit body."""

    kind: Literal["frame"]
    mesh: str

    @field_validator("mesh")
    @classmethod
    def _readable(cls, mesh: str) -> str:
        from crane_fem.errors import ScenarioError

        path = Path(mesh)
        try:
            _line_names(str(path), path.stat().st_mtime if path.is_file() else 0.0)
        except ScenarioError as exc:
            raise ValueError(str(exc).removeprefix("model.mesh: ")) from None
        return mesh

    def names(self) -> Any:
        """The file's named physical groups (crane_fem.geometry.gmsh_file.PhysicalNames)."""
        path = Path(self.mesh)
        return _line_names(str(path), path.stat().st_mtime if path.is_file() else 0.0)

    @property
    def groups(self) -> list[str]:
        return list(self.names().lines)

    @property
    def point_groups(self) -> list[str]:
        return list(self.names().points)


#: The keys of each section shape (``None``: the properties given directly).
SHAPE_KEYS: dict[str | None, tuple[str, ...]] = {
    "rectangle": ("b", "h"),
    "box": ("b", "h", "t_web", "t_flange"),
    "circle": ("d",),
    "tube": ("d", "t"),
    None: ("A", "I1", "I2", "J"),
}


class BeamSection(Section):
    """The cross-section of some line groups' beams, and their orientation.

    ``orientation``: a vector not parallel to the members, fixing their local axis 2 (it is
    made orthogonal to each member; axis 1 = axis 2 × the member's tangent), as OpenSees'
    ``vecxz``. The shape: ``rectangle`` (``b`` along axis 1, ``h`` along axis 2), ``box``
    (``b``, ``h``, ``t_web``, ``t_flange``), ``circle`` (``d``), ``tube`` (``d``, ``t``), or
    the properties given directly (``A``, ``I1``, ``I2``, ``J``; optional ``k1``, ``k2``, the
    shear factors, default 5/6, and ``c1``, ``c2``, the extreme-fibre distances along the
    axes, for the stress). Metres. ``rotary_scale`` multiplies the members' rotary inertia in
    the masses (default 1; more lengthens the explicit step a stocky member's rotary terms
    set: a lever to measure, not a default)."""

    groups: list[str]
    orientation: Vector3
    shape: Literal["rectangle", "box", "circle", "tube"] | None = None
    b: float | None = None
    h: float | None = None
    t_web: float | None = None
    t_flange: float | None = None
    d: float | None = None
    t: float | None = None
    A: float | None = None
    I1: float | None = None
    I2: float | None = None
    J: float | None = None
    k1: float | None = None
    k2: float | None = None
    c1: float | None = None
    c2: float | None = None
    rotary_scale: PositiveFloat = 1.0

    @model_validator(mode="after")
    def _complete(self) -> BeamSection:
        if not self.groups:
            raise ValueError("groups: give at least one line group")
        if not any(self.orientation):
            raise ValueError("orientation: must not be the zero vector")
        need = SHAPE_KEYS[self.shape]
        what = f"shape {self.shape!r}" if self.shape else "a section without shape"
        for key in need:
            value = getattr(self, key)
            if value is None:
                raise ValueError(f"{key}: missing ({what} takes {', '.join(need)})")
            if not value > 0.0:
                raise ValueError(f"{key}: must be positive, got {value}")
        direct = ("k1", "k2", "c1", "c2")
        for key in direct:
            value = getattr(self, key)
            if value is not None and not value > 0.0:
                raise ValueError(f"{key}: must be positive, got {value}")
        others = [
            k
            for k in ("b", "h", "t_web", "t_flange", "d", "t", "A", "I1", "I2", "J")
            if getattr(self, k) is not None and k not in need
        ]
        if others:
            raise ValueError(f"{others[0]}: does not apply to {what} (it takes {', '.join(need)})")
        if self.shape is not None and any(getattr(self, k) is not None for k in direct):
            raise ValueError(
                "k1, k2, c1, c2 apply to a section given by its properties (A, I1, I2, J), "
                f"not to shape {self.shape!r}"
            )
        if self.shape == "box":
            assert self.b is not None and self.h is not None
            assert self.t_web is not None and self.t_flange is not None
            if 2 * self.t_web >= self.b or 2 * self.t_flange >= self.h:
                raise ValueError("t_web and t_flange: the walls must leave the box hollow")
        if self.shape == "tube":
            assert self.d is not None and self.t is not None
            if 2 * self.t >= self.d:
                raise ValueError(f"t = {self.t}: the wall must be thinner than d/2")
        return self

    def properties(self, nu: float) -> Any:
        """Its :class:`crane_fem.formulations.sections.Section` (ν for a round section's
        shear factor)."""
        from crane_fem.formulations import sections as s

        if self.shape == "rectangle":
            return s.rectangle(self.b, self.h)  # type: ignore[arg-type]
        if self.shape == "box":
            return s.box(self.b, self.h, self.t_web, self.t_flange)  # type: ignore[arg-type]
        if self.shape == "circle":
            return s.circle(self.d, nu)  # type: ignore[arg-type]
        if self.shape == "tube":
            return s.tube(self.d, self.t, nu)  # type: ignore[arg-type]
        assert self.A is not None and self.I1 is not None
        assert self.I2 is not None and self.J is not None
        c1 = self.c1 if self.c1 is not None else math.sqrt(self.I2 / self.A)
        c2 = self.c2 if self.c2 is not None else math.sqrt(self.I1 / self.A)
        return s.Section(
            self.A,
            self.I1,
            self.I2,
            self.J,
            self.k1 if self.k1 is not None else 5.0 / 6.0,
            self.k2 if self.k2 is not None else 5.0 / 6.0,
            c1,
            c2,
        )


class LineContact(Section):
    """The points of a point group on the members of a line group (``type = "point-on-
    line"``): each point is paired with the element below it and slides along the line
    across elements. ``offset``: the contact surface's distance from the line's axis along
    ``normal`` (a rail top above a girder's axis; m); ``friction``: Coulomb's μ; with
    ``clearance`` (m), also a lateral pair of unilateral contacts (flanges), that far either
    side across the line, frictionless: their contact groups are named ``flange_names`` (the
    side of −l first, l = n × t across the line), default ``<name>_flange_in``, ``_out``.
    ``rolling``: a free-rolling wheel, its friction across the line only (none along it)."""

    type: Literal["point-on-line"]
    points: str
    line: str
    offset: NonNegativeFloat = 0.0
    normal: Vector3 = [0.0, 0.0, 1.0]
    friction: NonNegativeFloat = 0.0
    clearance: NonNegativeFloat | None = None
    name: str | None = None
    flange_names: Annotated[list[str], Field(min_length=2, max_length=2)] | None = None
    rolling: bool = False

    @model_validator(mode="after")
    def _normal(self) -> LineContact:
        if not any(self.normal):
            raise ValueError("normal: must not be the zero vector")
        if self.flange_names is not None and self.clearance is None:
            raise ValueError("flange_names: applies to a contact with a clearance (flanges)")
        if self.rolling and self.friction <= 0.0:
            raise ValueError("rolling: applies to a contact with friction")
        return self

    @property
    def lateral_names(self) -> list[str]:
        """The names of the lateral rows' groups (the −l side's, then the +l side's)."""
        if self.flange_names is not None:
            return list(self.flange_names)
        return [f"{self.label}_flange_in", f"{self.label}_flange_out"]

    @property
    def label(self) -> str:
        return self.name if self.name is not None else self.points


class PlaneContact(Section):
    """The points of a point group against a fixed rigid plane through ``origin`` facing
    along ``normal`` (``type = "point-on-plane"``), moved by the ground motion; Coulomb's
    ``friction``."""

    type: Literal["point-on-plane"]
    points: str
    origin: Vector3 = [0.0, 0.0, 0.0]
    normal: Vector3 = [0.0, 0.0, 1.0]
    friction: NonNegativeFloat = 0.0
    name: str | None = None

    @model_validator(mode="after")
    def _normal(self) -> PlaneContact:
        if not any(self.normal):
            raise ValueError("normal: must not be the zero vector")
        return self

    @property
    def label(self) -> str:
        return self.name if self.name is not None else self.points


class Rope(Section):
    """A tension-only rope: the line group ``line``, one 2-node element between its two
    ends (no ``[[section]]``: it is no beam). Its force is ``stiffness`` (N/m) × (its length
    − ``length``, m) along it while longer than ``length``, none while slack; its direction
    follows its ends. An end on no beam (a hanging load: give it a ``[[mass]]``) has its
    rotations held."""

    line: str
    length: float
    stiffness: PositiveFloat
    name: str | None = None

    @field_validator("length")
    @classmethod
    def _length(cls, length: float) -> float:
        if not length > 0.0:
            raise ValueError(f"a rope needs a positive length (m), got {length}")
        return length

    @property
    def label(self) -> str:
        return self.name if self.name is not None else self.line
