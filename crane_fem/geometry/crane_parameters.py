"""The crane mock-up's parameters: dimensions and mesh sizes, checked before any meshing."""

from __future__ import annotations

from dataclasses import dataclass

from crane_fem.errors import ScenarioError

__all__ = ["CraneGeometry"]


@dataclass(frozen=True)
class CraneGeometry:
    """Dimensions in metres; ``size`` is the coarse element size, ``fine`` the one at contacts."""

    span: float = 4.0
    girder_spacing: float = 1.0
    girder_width: float = 0.12
    girder_height: float = 0.20
    end_carriage_length: float = 1.6
    end_carriage_width: float = 0.15
    end_carriage_height: float = 0.15
    rail_width: float = 0.05
    rail_height: float = 0.04
    trolley_position: float = 2.0
    wheel_base: float = 0.6
    wheel_width: float = 0.05
    wheel_length: float = 0.08
    wheel_height: float = 0.06
    frame_overhang: float = 0.10
    frame_length: float = 0.8
    frame_thickness: float = 0.05
    zone_margin: float = 0.06
    zone_depth: float = 0.0
    size: float = 0.12
    fine: float = 0.04
    flanges: bool = False
    flange_clearance: float = 0.005
    flange_depth: float = 0.02
    flange_thickness: float = 0.02
    #: The trolley's plate's element size (None: the graded sizes' ``size``, as before).
    trolley_size: float | None = None

    def validate(self) -> None:
        """Raise ScenarioError naming the first parameter out of range (before any meshing)."""
        signed = ("trolley_position", "zone_depth", "flanges", "flange_clearance")
        positive = [
            k for k, v in self.__dict__.items() if k not in signed and v is not None and v <= 0
        ]
        if positive:
            raise ScenarioError(
                f"geometry.{positive[0]} must be > 0, got {getattr(self, positive[0])}"
            )
        if self.wheel_width > self.rail_width:
            raise ScenarioError(
                f"geometry.wheel_width = {self.wheel_width} is wider than the rail "
                f"(geometry.rail_width = {self.rail_width})"
            )
        if self.rail_width > self.girder_width:
            raise ScenarioError("geometry.rail_width must not exceed geometry.girder_width")
        half = 0.5 * max(self.wheel_base + self.wheel_length, self.frame_length)
        if not half <= self.trolley_position <= self.span - half:
            raise ScenarioError(
                f"geometry.trolley_position = {self.trolley_position} puts the trolley off the "
                f"girders (allowed: [{half:g}, {self.span - half:g}] for span {self.span})"
            )
        zone = self.wheel_length + 2.0 * self.zone_margin
        if zone >= self.wheel_base:
            raise ScenarioError(
                f"geometry.zone_margin = {self.zone_margin}: the explicit rail zones of a "
                f"trolley's two wheels on one rail overlap (wheel_length + 2 zone_margin = "
                f"{zone:g} m, not less than wheel_base = {self.wheel_base})"
            )
        ends = (
            self.trolley_position - 0.5 * (self.wheel_base + zone),
            self.trolley_position + 0.5 * (self.wheel_base + zone),
        )
        if ends[0] < self.end_carriage_width or ends[1] > self.span - self.end_carriage_width:
            raise ScenarioError(
                f"geometry.zone_margin = {self.zone_margin}: the explicit rail zones reach "
                f"y = {ends[0]:g}–{ends[1]:g} m, past the end carriages (rails from "
                f"{self.end_carriage_width:g} to {self.span - self.end_carriage_width:g} m)"
            )
        if self.end_carriage_length < self.girder_spacing + self.girder_width:
            raise ScenarioError("geometry.end_carriage_length must span both girders")
        if self.girder_spacing <= self.girder_width:
            raise ScenarioError("geometry.girder_spacing must exceed geometry.girder_width")
        if not 0.0 <= self.zone_depth < self.girder_height:
            raise ScenarioError(
                f"geometry.zone_depth = {self.zone_depth} must lie in [0, girder_height = "
                f"{self.girder_height})"
            )
        if self.fine > self.size:
            raise ScenarioError("geometry.fine must not exceed geometry.size")
        if self.trolley_size is not None and self.trolley_size > self.size:
            raise ScenarioError(
                f"geometry.trolley_size = {self.trolley_size} must not exceed geometry.size "
                f"= {self.size}"
            )
        if self.flange_clearance < 0.0:
            raise ScenarioError(
                f"geometry.flange_clearance = {self.flange_clearance} must be >= 0 (the lateral "
                "gap between a flange and the rail side)"
            )
        if self.flanges:
            self._validate_flanges()

    def _validate_flanges(self) -> None:
        if not self.flange_depth < self.rail_height:
            raise ScenarioError(
                f"geometry.flange_depth = {self.flange_depth} must be < geometry.rail_height = "
                f"{self.rail_height} (the flanges would reach the girder top)"
            )
        if not self.flange_reach < 0.5 * self.girder_spacing:
            raise ScenarioError(
                f"geometry.flange_thickness = {self.flange_thickness}: the inner flanges reach "
                f"{self.flange_reach:g} from their rail's axis (rail_width/2 + flange_clearance + "
                f"flange_thickness), past the crane's centre plane x = 0 "
                f"(girder_spacing/2 = {0.5 * self.girder_spacing:g})"
            )

    @property
    def rail_top(self) -> float:
        return self.end_carriage_height + self.girder_height + self.rail_height

    @property
    def flange_reach(self) -> float:
        """Distance from a rail's axis to the outer face of its wheel's flanges (m)."""
        return 0.5 * self.rail_width + self.flange_clearance + self.flange_thickness

    def part_at(self, x: float, y: float, z: float) -> str:
        """The bridge part a point lies in (its peak stress's "part" in THEORY.md §8 (b)):
        ``end carriage 1`` (y = 0) or ``2``, ``girder 1`` (x < 0) or ``2``, ``rail 1`` or
        ``2`` above its girder's top."""
        side = 1 if x < 0.0 else 2
        if z < self.end_carriage_height:
            return f"end carriage {1 if y < 0.5 * self.span else 2}"
        if z > self.end_carriage_height + self.girder_height:
            return f"rail {side}"
        return f"girder {side}"

    def mirror_planes(self) -> list[tuple[int, float]]:
        """(axis, coordinate) of the planes of symmetry the mesh is mirrored in: x = 0 always
        (the girders and the trolley are centred on it), y = span/2 with the trolley there."""
        planes = [(0, 0.0)]
        if abs(self.trolley_position - 0.5 * self.span) <= 1e-12 * self.span:
            planes.append((1, 0.5 * self.span))
        return planes

    def wheel_centres(self) -> list[tuple[float, float]]:
        """(x, y) of wheels 1–4: girder 1 (x < 0) rear/front, then girder 2."""
        xs = (-0.5 * self.girder_spacing, 0.5 * self.girder_spacing)
        ys = (
            self.trolley_position - 0.5 * self.wheel_base,
            self.trolley_position + 0.5 * self.wheel_base,
        )
        return [(x, y) for x in xs for y in ys]
