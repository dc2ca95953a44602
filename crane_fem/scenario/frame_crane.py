"""``[model] kind = "frame_crane"``: the paper's own crane model, a frame of Timoshenko beams
with the 3D mock-up's parameters (crane_fem.geometry.frame_crane draws it and turns the scene
into a frame's)."""

# Pydantic copies a field's default into each instance; ruff cannot see across modules that
# Section is a pydantic model.

from __future__ import annotations

from typing import Literal

from pydantic import model_validator

from crane_fem.scenario.base import NonNegativeFloat, PositiveFloat, Section
from crane_fem.scenario.frame import SHAPE_KEYS

__all__ = ["FRAME_CRANE_GROUPS", "FrameCraneModel", "SectionShape"]


class SectionShape(Section):
    """A member's cross-section, as ``[[section]]``'s shape keys (no groups, no
    orientation: the crane's members are oriented by their position)."""

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

    @model_validator(mode="after")
    def _complete(self) -> SectionShape:
        need = SHAPE_KEYS[self.shape]
        what = f"shape {self.shape!r}" if self.shape else "a section without shape"
        for key in need:
            value = getattr(self, key)
            if value is None:
                raise ValueError(f"{key}: missing ({what} takes {', '.join(need)})")
            if not value > 0.0:
                raise ValueError(f"{key}: must be positive, got {value}")
        return self

    def entry(self, groups: list[str], orientation: list[float]) -> dict[str, object]:
        """Its ``[[section]]`` table for the line groups ``groups``."""
        out: dict[str, object] = {"groups": groups, "orientation": orientation}
        out.update({k: v for k, v in self.model_dump().items() if v is not None})
        return out


#: The frame crane's line groups: the members, each wheel's stub and each explicit girder zone.
FRAME_CRANE_GROUPS = [
    "end_carriage_1",
    "end_carriage_2",
    "girder_1",
    "girder_2",
    "links",
    "trolley",
    "hook",
    *(f"zone_{k}" for k in range(1, 5)),
    *(f"wheel_{k}" for k in range(1, 5)),
]


class FrameCraneModel(Section):
    """The bi-girder overhead crane as a frame (crane_fem.geometry.frame_crane): the mock-up's
    dimensions (as ``kind = "crane"``, metres) where they apply, beam sections for the
    members (default: the mock-up's rectangles, the rail joined to its girder), a hoisted mass
    rigidly attached to the trolley or hanging on a rope, girder elements of ``size`` and
    ``fine`` in the explicit zones (``zone_margin`` past each wheel at either end);
    ``rotary_scale`` raises the trolley's and the wheels' rotary inertia."""

    kind: Literal["frame_crane"]
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
    zone_margin: PositiveFloat = 0.1
    size: PositiveFloat = 0.1
    fine: PositiveFloat = 0.05
    flanges: bool = False
    flange_clearance: NonNegativeFloat = 0.005
    #: With ``wheel_zones = "solid"``: the flanges' plates, as the 3D mock-up's (hanging
    #: ``flange_depth`` below the rail top, ``flange_thickness`` thick).
    flange_depth: PositiveFloat = 0.02
    flange_thickness: PositiveFloat = 0.02
    hoisted_mass: NonNegativeFloat = 0.0
    hoist: Literal["rigid", "rope"] = "rigid"
    rope_length: PositiveFloat | None = None
    rope_stiffness: PositiveFloat | None = None
    #: The factor on the trolley's and the wheels' rotary inertia about their bending axes
    #: (at most their polar moment): their thin members' thickness-shear modes set the
    #: explicit step (THEORY.md §10's lever, measured in benchmarks/RESULTS.md).
    rotary_scale: PositiveFloat = 1.0
    girder: SectionShape | None = None
    end_carriage: SectionShape | None = None
    trolley: SectionShape | None = None
    #: The wheels' zones: beams with the wheels as points on their lines (``"lines"``), or
    #: 3D solids (``"solid"``: each girder's segment under its wheels with its rail, and the
    #: wheels as blocks, tied to the beams by joints; issue 33) of elements ``solid_size``.
    wheel_zones: Literal["lines", "solid"] = "lines"
    solid_size: PositiveFloat = 0.02
    #: With ``wheel_zones = "solid"``: how far each girder's solid segment reaches past its
    #: wheels, to its joints with the girder's beams (m; default one section depth,
    #: girder_height + rail_height: a joint disturbs the stresses over about that).
    solid_margin: PositiveFloat | None = None
    #: The trolley: a beam grillage in its plate's mid-plane (``"grillage"``), or, with
    #: ``wheel_zones = "solid"``, its plate as a 3D solid glued to the wheel blocks
    #: (``"solid"``: one explicit body, the hoisted mass spread over the plate as the 3D
    #: mock-up's; the grillage bends softer than the plate, benchmarks/RESULTS.md).
    trolley_body: Literal["grillage", "solid"] = "grillage"
    #: The solid trolley plate's elements (m; default ``solid_size``).
    trolley_size: PositiveFloat | None = None

    @model_validator(mode="after")
    def _consistent(self) -> FrameCraneModel:
        if self.hoist == "rope":
            if self.rope_length is None or self.rope_stiffness is None:
                raise ValueError("hoist = 'rope' needs rope_length (m) and rope_stiffness (N/m)")
            if self.hoisted_mass <= 0.0:
                raise ValueError("hoist = 'rope' needs a hoisted_mass > 0 (kg) on the rope")
        elif self.rope_length is not None or self.rope_stiffness is not None:
            raise ValueError("rope_length and rope_stiffness apply to hoist = 'rope'")
        half = 0.5 * max(self.wheel_base + self.wheel_length, self.frame_length)
        lo, hi = self.end_carriage_width, self.span - self.end_carriage_width
        if not lo + half <= self.trolley_position <= hi - half:
            raise ValueError(
                f"trolley_position = {self.trolley_position} puts the trolley off the girders "
                f"(allowed: [{lo + half:g}, {hi - half:g}] for span {self.span})"
            )
        if self.zone_margin >= 0.5 * self.wheel_base:
            raise ValueError(
                f"zone_margin = {self.zone_margin}: the explicit zones of a rail's two wheels "
                f"overlap (at most half the wheel_base, {0.5 * self.wheel_base:g})"
            )
        reach = self.trolley_position + 0.5 * self.wheel_base + self.zone_margin
        if reach > hi or self.trolley_position - 0.5 * self.wheel_base - self.zone_margin < lo:
            raise ValueError(
                f"zone_margin = {self.zone_margin}: the explicit zones reach past the end carriages"
            )
        if self.girder_spacing <= self.girder_width:
            raise ValueError("girder_spacing must exceed girder_width")
        if self.end_carriage_length < self.girder_spacing + self.girder_width:
            raise ValueError("end_carriage_length must span both girders")
        if self.fine > self.size:
            raise ValueError("fine must not exceed size")
        if self.trolley_size is not None and self.trolley_body != "solid":
            raise ValueError("trolley_size applies to trolley_body = 'solid'")
        if self.trolley_body == "solid":
            if self.wheel_zones != "solid":
                raise ValueError("trolley_body = 'solid' needs wheel_zones = 'solid'")
            if self.trolley is not None:
                raise ValueError(
                    "trolley: a grillage's section, not with trolley_body = 'solid' (the plate "
                    "is frame_length x (girder_spacing + 2 frame_overhang) x frame_thickness)"
                )
        if self.solid_margin is not None and self.wheel_zones != "solid":
            raise ValueError("solid_margin applies to wheel_zones = 'solid'")
        if self.wheel_zones == "solid":
            room = min(self.trolley_position - lo, hi - self.trolley_position)
            room -= 0.5 * (self.wheel_base + self.wheel_length)
            if self.segment_margin > room:
                raise ValueError(
                    f"solid_margin = {self.segment_margin:g}: the solid segments reach past the "
                    f"end carriages (at most {room:g} at trolley_position "
                    f"{self.trolley_position:g})"
                )
            if self.flanges and not self.flange_depth < self.rail_height:
                raise ValueError(
                    f"flange_depth = {self.flange_depth} must be < rail_height = "
                    f"{self.rail_height} (the flanges would reach the girder's top)"
                )
            if self.flanges and not self.flange_reach < 0.5 * self.girder_spacing:
                raise ValueError(
                    f"flange_thickness = {self.flange_thickness}: the inner flanges reach "
                    f"{self.flange_reach:g} from their rail's axis, past the crane's centre "
                    "plane x = 0"
                )
            for key, bad in (
                ("hoist", self.hoist == "rope"),
                ("girder", self.girder is not None),
            ):
                if bad:
                    raise ValueError(
                        f"{key}: not with wheel_zones = 'solid' yet (its beams run implicit "
                        "and a rope needs an explicit side, "
                        "the joints sit on the girder-and-rail section's centroid)"
                    )
        return self

    @property
    def segment_margin(self) -> float:
        """How far the solid segments reach past the wheels (m): ``solid_margin``, or one
        section depth (girder and rail)."""
        if self.solid_margin is not None:
            return self.solid_margin
        return self.girder_height + self.rail_height

    @property
    def rail_top(self) -> float:
        """The rails' top above the end carriages' base (m)."""
        return self.end_carriage_height + self.girder_height + self.rail_height

    @property
    def flange_reach(self) -> float:
        """Distance from a rail's axis to the outer face of its wheel's flanges (m)."""
        return 0.5 * self.rail_width + self.flange_clearance + self.flange_thickness

    @property
    def groups(self) -> list[str]:
        if self.wheel_zones == "solid":  # its beams, then its solids
            beams = ["end_carriage_1", "end_carriage_2", "links", "girder_1", "girder_2"]
            wheels = [f"wheel_{k}" for k in range(1, 5)]
            if self.trolley_body == "solid":
                return [*beams, "zone_1", "zone_2", *wheels, "trolley_plate"]
            stubs = [f"stub_{k}" for k in range(1, 5)]
            return [*beams, "trolley", "hook", *stubs, "zone_1", "zone_2", *wheels]
        return list(FRAME_CRANE_GROUPS) + (["rope"] if self.hoist == "rope" else [])
