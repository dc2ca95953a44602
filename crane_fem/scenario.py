"""Scenario files: TOML -> validated configuration, with one-line errors naming the key.

The format is documented in ``docs/scenarios.md``. Every rank reads and validates the same
file, so a bad scenario raises the same :class:`~crane_fem.errors.ScenarioError` on every rank
before any collective call is made.
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from crane_fem.errors import ScenarioError

__all__ = [
    "Contact",
    "Integrator",
    "Scenario",
    "apply_overrides",
    "load_scenario",
    "parse_scenario",
]

PositiveFloat = Annotated[float, Field(gt=0)]
NonNegativeFloat = Annotated[float, Field(ge=0)]
PositiveInt = Annotated[int, Field(gt=0)]
Pair = Annotated[list[float], Field(min_length=2, max_length=2)]
NonNegativePair = Annotated[list[NonNegativeFloat], Field(min_length=2, max_length=2)]
Vector3 = Annotated[list[float], Field(min_length=3, max_length=3)]


class _Section(BaseModel):
    """Strict section: no unknown keys, no string-to-number coercion (ints pass as floats)."""

    model_config = ConfigDict(strict=True, extra="forbid", frozen=True)


class SecondBar(_Section):
    """A second bar to the right of the first one, for node-to-node (two-body) contact."""

    length: PositiveFloat
    elements: PositiveInt
    area: PositiveFloat = 1.0
    velocity: float = 0.0


class BarModel(_Section):
    """1D bar along x (dolfinx interval mesh, P1); its left end faces the wall at x = 0."""

    kind: Literal["bar"]
    length: PositiveFloat
    elements: PositiveInt
    area: PositiveFloat = 1.0
    clamp: Literal["none", "right"] = "none"
    second_bar: SecondBar | None = None


class Material(_Section):
    """Linear elastic material; Rayleigh damping C = alpha M + beta K."""

    E: PositiveFloat
    rho: PositiveFloat
    rayleigh: NonNegativePair = [0.0, 0.0]


class Initial(_Section):
    """Initial state of the first bar: uniform velocity, linear displacement [left, right]."""

    velocity: float = 0.0
    displacement: Pair = [0.0, 0.0]


class Contact(_Section):
    """A unilateral frictionless contact.

    ``wall``: rigid plane x = 0 facing +x, the first bar's left end at x = gap.
    ``bars``: node-to-node between the first bar's right end and the second bar's left end,
    ``gap`` apart.
    """

    type: Literal["wall", "bars"]
    gap: NonNegativeFloat
    name: str | None = None

    @property
    def label(self) -> str:
        return self.name if self.name is not None else self.type


class Time(_Section):
    """End time and step: ``dt`` in seconds or ``dt_factor`` times the critical explicit step."""

    end: PositiveFloat
    dt: PositiveFloat | None = None
    dt_factor: PositiveFloat | None = None

    @model_validator(mode="after")
    def _one_step_spec(self) -> Time:
        if (self.dt is None) == (self.dt_factor is None):
            raise ValueError("give exactly one of time.dt (seconds) or time.dt_factor")
        return self


class Integrator(_Section):
    """Time integrator and its parameters."""

    scheme: Literal["cd-lagrange", "moreau-jean", "penalty"] = "cd-lagrange"
    theta: Annotated[float, Field(ge=0.5, le=1.0)] | None = None
    penalty: PositiveFloat | None = None

    @model_validator(mode="after")
    def _parameters_apply(self) -> Integrator:
        if self.theta is not None and self.scheme != "moreau-jean":
            raise ValueError(f"integrator.theta applies to 'moreau-jean' only, not {self.scheme!r}")
        if self.scheme == "penalty" and self.penalty is None:
            raise ValueError("integrator.penalty (contact stiffness, N/m) is required by 'penalty'")
        if self.penalty is not None and self.scheme != "penalty":
            raise ValueError(f"integrator.penalty applies to 'penalty' only, not {self.scheme!r}")
        return self

    @property
    def theta_value(self) -> float:
        return 0.5 if self.theta is None else self.theta


class Loading(_Section):
    """Body loads: gravity acceleration vector (m/s²); a bar uses its x component."""

    gravity: Vector3 = [0.0, 0.0, 0.0]


class Output(_Section):
    """What is written and how often."""

    every: PositiveInt = 1
    xdmf: bool = True
    xdmf_every: PositiveInt | None = None
    progress: bool | Literal["auto"] = "auto"


class Monitor(_Section):
    """Divergence detection: stop when the kinetic energy exceeds ``energy_growth`` times the
    energy supplied (initial energy + |external work|)."""

    energy_growth: Annotated[float, Field(gt=1)] = 10.0


class Scenario(_Section):
    """A whole scenario file."""

    name: str = "scenario"
    model: BarModel
    material: Material
    initial: Initial = Initial()
    contact: list[Contact] = []
    time: Time
    integrator: Integrator = Integrator()
    loading: Loading = Loading()
    output: Output = Output()
    monitor: Monitor = Monitor()

    @model_validator(mode="after")
    def _consistent(self) -> Scenario:
        types = [c.type for c in self.contact]
        for t in ("wall", "bars"):
            if types.count(t) > 1:
                raise ValueError(f"contact: at most one contact of type {t!r}")
        labels = [c.label for c in self.contact]
        if len(set(labels)) != len(labels):
            raise ValueError(f"contact: names must be unique, got {labels}")
        if ("bars" in types) != (self.model.second_bar is not None):
            raise ValueError(
                "contact type 'bars' and [model.second_bar] go together (one needs the other)"
            )
        if self.model.clamp == "right" and self.initial.displacement[1] != 0.0:
            raise ValueError("initial.displacement: the clamped right end must start at 0")
        if self.model.clamp == "right" and self.model.second_bar is not None:
            raise ValueError("model.clamp = 'right' cannot be combined with a second bar")
        if self.time.dt is not None and self.time.dt > self.time.end:
            raise ValueError(f"time.dt = {self.time.dt} exceeds time.end = {self.time.end}")
        return self


def _allowed_keys(section: type[BaseModel], loc: tuple[Any, ...]) -> list[str]:
    """Keys allowed at the parent of ``loc`` (for 'unknown key' messages)."""
    model: Any = section
    for part in loc[:-1]:
        if isinstance(part, int):
            continue
        field = model.model_fields.get(part)
        if field is None:
            return []
        ann = field.annotation
        candidates = [ann, *getattr(ann, "__args__", ())]
        for cand in candidates:
            inner = getattr(cand, "__args__", ())
            for c in (cand, *inner):
                if isinstance(c, type) and issubclass(c, BaseModel):
                    model = c
                    break
            else:
                continue
            break
    return sorted(model.model_fields)


def _format_error(source: str, exc: ValidationError) -> str:
    """One line: ``source: key.path: what is wrong (got value)``."""
    # An unknown key is usually the root cause (a typo that also leaves a key missing).
    errors = sorted(exc.errors(), key=lambda e: e["type"] != "extra_forbidden")
    err = errors[0]
    loc = tuple(err["loc"])
    path = ".".join(str(p) if not isinstance(p, int) else f"[{p}]" for p in loc).replace(".[", "[")
    kind = err["type"]
    if kind == "extra_forbidden":
        allowed = ", ".join(_allowed_keys(Scenario, loc))
        msg = f"unknown key; allowed here: {allowed}"
    elif kind == "missing":
        msg = "required key is missing"
    else:
        msg = err["msg"]
        if msg.startswith("Value error, "):
            msg = msg[len("Value error, ") :]
        if kind != "value_error":
            msg = f"{msg} (got {err['input']!r})"
    more = len(exc.errors()) - 1
    tail = f" [and {more} more problem{'s' if more > 1 else ''}]" if more else ""
    where = f"{path}: " if path else ""
    return f"{source}: {where}{msg}{tail}"


def parse_scenario(data: dict[str, Any], source: str = "<scenario>") -> Scenario:
    """Validate a scenario mapping.

    Raises:
        ScenarioError: with a one-line message naming the key and what is allowed.
    """
    try:
        return Scenario.model_validate(data)
    except ValidationError as exc:
        raise ScenarioError(_format_error(source, exc)) from None


def _parse_value(text: str, key: str) -> Any:
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        raise ScenarioError(
            f"--set {key}={text}: value is not a TOML value (quote strings: {key}='\"{text}\"')"
        ) from None


def apply_overrides(data: dict[str, Any], overrides: list[str]) -> dict[str, Any]:
    """Apply ``key.path=value`` overrides (values parsed as TOML) to a scenario mapping."""
    for item in overrides:
        if "=" not in item:
            raise ScenarioError(f"--set {item}: expected key.path=value")
        key, text = item.split("=", 1)
        key = key.strip()
        parts = key.split(".")
        if not key or any(not p for p in parts):
            raise ScenarioError(f"--set {item}: empty key")
        node: Any = data
        for i, part in enumerate(parts[:-1]):
            nxt = node.get(part) if isinstance(node, dict) else None
            if nxt is None:
                nxt = {}
                node[part] = nxt
            if not isinstance(nxt, dict):
                raise ScenarioError(
                    f"--set {key}: {'.'.join(parts[: i + 1])} is not a table and has no keys"
                )
            node = nxt
        node[parts[-1]] = _parse_value(text.strip(), key)
    return data


def load_scenario(path: str | Path, overrides: list[str] | None = None) -> Scenario:
    """Read, override and validate a scenario file.

    Not collective: every rank may call it; all ranks raise the same error on bad input.

    Raises:
        ScenarioError: missing/unreadable file, TOML syntax, or invalid keys/values.
    """
    p = Path(path)
    if not p.is_file():
        raise ScenarioError(f"{p}: scenario file not found")
    try:
        data = tomllib.loads(p.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{p}: TOML syntax error: {exc}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ScenarioError(f"{p}: cannot read the scenario: {exc}") from None
    data.setdefault("name", p.stem)
    apply_overrides(data, overrides or [])
    return parse_scenario(data, str(p))
