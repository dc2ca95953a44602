"""The study file (``crane-fem study STUDY.toml``): one scene and the axes along which it
varies.

.. code-block:: toml

    scene = "../demos/frame_crane.toml"   # relative to the study file
    cases = "product"                      # or "list" ([[case]] tables)

    [set]                                  # keys common to every case
    "time.end" = 10.0

    [[axis]]                               # any key's values
    key = "model.trolley_position"
    values = [1.0, 2.0, 3.0]

    [records]                              # the record sets (one axis)
    component = { direction = [0.0, 0.0, 1.0] }   # defaults of every component
    files = ["matched/record_*.csv"]       # one set of one component per file
    [[records.set]]
    name = "el_centro"
    components = [{ record = "el_centro_1940_180", direction = [1.0, 0.0, 0.0] }]

    [angle]                                # the incident angle of the horizontal components
    degrees = [0.0, 90.0]

    [perturb]                              # the conditioning ensemble of every case
    epsilon = 0.005                        # record × (1 ± ε)
    dt = true                              # Δt × ½

Validated strictly (no unknown key) with pydantic, as a scenario is.
"""

from __future__ import annotations

import glob
import tomllib
from pathlib import Path
from typing import Any, Literal

from pydantic import Field, ValidationError, field_validator, model_validator

from crane_fem.errors import ScenarioError
from crane_fem.scenario.base import PositiveFloat, Section
from crane_fem.scenario.messages import format_error

__all__ = ["Axis", "CaseEntry", "Perturb", "RecordSet", "Records", "StudySpec", "load_study"]

Scalar = bool | int | float | str
Value = Scalar | list[Any] | dict[str, Any]


class Axis(Section):
    """One key of the scene and its values; ``names`` label them in case names."""

    key: str = Field(min_length=1)
    values: list[Value]
    names: list[str] | None = None

    @field_validator("values")
    @classmethod
    def _not_empty(cls, v: list[Value]) -> list[Value]:
        if not v:
            raise ValueError("an axis needs at least one value")
        return v

    @model_validator(mode="after")
    def _names(self) -> Axis:
        if self.names is not None and len(self.names) != len(self.values):
            raise ValueError(f"names: {len(self.names)} names for {len(self.values)} values")
        return self


class RecordSet(Section):
    """A set of components (``loading.ground_motion`` entries) applied together."""

    name: str = Field(min_length=1)
    components: list[dict[str, Any]] = Field(min_length=1)


class Records(Section):
    """The record sets: ``files`` (globs, one set of one component each, relative to the
    study file) and ``set`` tables; ``component`` gives every component's defaults."""

    component: dict[str, Any] = Field(default_factory=dict)
    files: list[str] = Field(default_factory=list)
    set: list[RecordSet] = Field(default_factory=list)


class Angle(Section):
    """Incident angles (degrees, about the vertical z axis) of the horizontal components."""

    degrees: list[float] = Field(min_length=1)


class Perturb(Section):
    """The conditioning ensemble run beside every case: the record × (1 − ε) and × (1 + ε),
    and Δt × ½ (sampled at the nominal run's instants) when ``dt``."""

    epsilon: PositiveFloat = 0.005
    dt: bool = False


class CaseEntry(Section):
    """One case of a ``cases = "list"`` study: its name and keys."""

    name: str = Field(min_length=1)
    set: dict[str, Value] = Field(default_factory=dict)


class StudySpec(Section):
    """A study: the scene, its axes (cartesian product) or its cases (list), the keys common
    to every case, and the conditioning ensemble."""

    scene: str
    cases: Literal["product", "list"] = "product"
    set: dict[str, Value] = Field(default_factory=dict)
    axis: list[Axis] = Field(default_factory=list)
    records: Records | None = None
    angle: Angle | None = None
    perturb: Perturb | None = None
    case: list[CaseEntry] = Field(default_factory=list)

    @model_validator(mode="after")
    def _shape(self) -> StudySpec:
        if self.cases == "list" and not self.case:
            raise ValueError("cases = 'list' needs [[case]] tables (name, set)")
        if self.cases == "product" and self.case:
            raise ValueError("[[case]] tables need cases = 'list'")
        names = [c.name for c in self.case]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ValueError(f"case name {dup[0]!r} given twice")
        keys = [a.key for a in self.axis]
        dup = sorted({k for k in keys if keys.count(k) > 1})
        if dup:
            raise ValueError(f"axis key {dup[0]!r} given twice")
        return self


def load_study(path: Path) -> tuple[StudySpec, Path, list[tuple[str, list[dict[str, Any]]]]]:
    """Read and validate a study file: the spec, its scene's path and its record sets
    (name, components with the defaults merged; files expanded, relative to the study).

    Raises:
        ScenarioError: missing/unreadable file, TOML syntax, an unknown or invalid key, a
            scene or a record glob that names no file.
    """
    if not path.is_file():
        raise ScenarioError(f"{path}: study file not found")
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{path}: TOML syntax error: {exc}") from None
    try:
        spec = StudySpec.model_validate(data)
    except ValidationError as exc:
        raise ScenarioError(format_error(str(path), exc)) from None
    scene = (path.parent / spec.scene).resolve()
    if not scene.is_file():
        raise ScenarioError(f"{path}: scene: {spec.scene} is not a file (relative to the study)")
    sets: list[tuple[str, list[dict[str, Any]]]] = []
    if spec.records is not None:
        defaults = spec.records.component
        for pattern in spec.records.files:
            full = pattern if Path(pattern).is_absolute() else str(path.parent / pattern)
            found = sorted(glob.glob(full))
            if not found:
                raise ScenarioError(f"{path}: records.files: {pattern!r} names no file")
            for f in found:
                sets.append((Path(f).stem, [{**defaults, "record": str(Path(f).resolve())}]))
        for s in spec.records.set:
            comps = [_resolve(path.parent, {**defaults, **c}) for c in s.components]
            sets.append((s.name, comps))
        if not sets:
            raise ScenarioError(f"{path}: records: no record set (give files or [[records.set]])")
        names = [n for n, _ in sets]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ScenarioError(f"{path}: records: two record sets named {dup[0]!r}")
    return spec, scene, sets


def _resolve(base: Path, component: dict[str, Any]) -> dict[str, Any]:
    """A component's record file relative to the study file (a bundled name is kept)."""
    rec = component.get("record")
    if isinstance(rec, str) and (base / rec).is_file():
        return {**component, "record": str((base / rec).resolve())}
    return component
