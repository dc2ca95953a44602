"""The [loading] section: gravity, a beam's tip traction, and the ground motion(s)."""

# Pydantic copies a field's default into each instance; ruff cannot see across modules that
# Section is a pydantic model.
# ruff: noqa: RUF012

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, model_validator

from crane_fem.scenario.base import NonNegativeFloat, PositiveFloat, Section, Vector3

__all__ = ["GroundMotion", "Loading", "TipTraction"]


class GroundMotion(Section):
    """Seismic ground acceleration a_g(t) (relative formulation: body force −ρ a_g(t) direction).

    ``record``: a bundled record name (``el_centro_1940_up``, ``el_centro_1940_180``,
    ``el_centro_1940_270``), a path to a PEER ``.AT2`` / ``.csv`` (t, a in ``units``: m/s² by
    default, or g; columns separated by commas, semicolons, tabs or spaces) file, or
    ``synthetic`` (band-limited enveloped noise: ``pga`` m/s², ``duration`` s, ``band`` Hz,
    ``seed``); several components are given as ``[[loading.ground_motion]]`` entries;
    ``scale`` multiplies it; ``direction`` is the unit vector of the shaking. ``start`` (s)
    is the record time at which the run begins (a strong-motion window), ``taper`` (s) the
    length of a half-cosine ramp from zero at the beginning of the run.
    """

    record: str
    scale: float = 1.0
    direction: Vector3 = [0.0, 0.0, 1.0]
    start: NonNegativeFloat = 0.0
    taper: NonNegativeFloat = 0.0
    pga: PositiveFloat | None = None
    duration: PositiveFloat | None = None
    band: Annotated[list[PositiveFloat], Field(min_length=2, max_length=2)] = [0.5, 15.0]
    seed: int = 0
    #: A .csv record's acceleration unit: "m/s2" (the default) or "g".
    units: Literal["m/s2", "g"] | None = None

    @model_validator(mode="after")
    def _synthetic(self) -> GroundMotion:
        if self.units is not None and not self.record.lower().endswith(".csv"):
            raise ValueError(
                "units applies to a .csv record (an .AT2 file is in g by its format, the "
                "bundled and synthetic records in m/s²)"
            )
        synth = self.record == "synthetic"
        if synth and (self.pga is None or self.duration is None):
            raise ValueError("record 'synthetic' needs pga (m/s²) and duration (s)")
        if not synth and (self.pga is not None or self.duration is not None):
            raise ValueError("pga and duration apply to record = 'synthetic' only")
        if synth and not self.band[0] < self.band[1]:
            raise ValueError(f"band must be [f_low, f_high] with f_low < f_high (got {self.band})")
        if not any(self.direction):
            raise ValueError("direction must not be the zero vector")
        return self


class TipTraction(Section):
    """Half-sine traction pulse t(s) = traction sin(π s / duration) on the beam's tip face."""

    traction: Vector3
    duration: PositiveFloat


class Loading(Section):
    """Body loads: gravity acceleration vector (m/s²); a bar uses its x component."""

    gravity: Vector3 = [0.0, 0.0, 0.0]
    tip_traction: TipTraction | None = None
    ground_motion: GroundMotion | list[GroundMotion] | None = None

    @property
    def ground_motions(self) -> list[GroundMotion]:
        gm = self.ground_motion
        return [] if gm is None else gm if isinstance(gm, list) else [gm]
