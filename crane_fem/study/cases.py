"""A study's cases: the cartesian product of its axes (or its list), each with the keys it
sets on the scene, and the conditioning ensemble's members beside each nominal case.

Every case is validated here, in the study's process, as ``crane-fem check`` would read it
(keys and values, without the mesh): an axis whose every value is refused is the study's
error (a key that does not exist); a case refused alone becomes a failed case, reported with
its one line while the others run.
"""

from __future__ import annotations

import itertools
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from crane_fem.errors import ScenarioError
from crane_fem.scenario import Scenario, load_scenario
from crane_fem.scenario.model import MESH_KEYS
from crane_fem.study.spec import StudySpec

__all__ = [
    "Case",
    "cli_arguments",
    "ensemble_members",
    "expand_cases",
    "halved_step",
    "load_case",
    "scaled_record",
    "toml_literal",
]

#: Settings of a case: key -> value (None: the key is removed).
Settings = dict[str, Any]


@dataclass(frozen=True)
class Case:
    """One run of a study. ``base`` names its nominal case (itself for a nominal);
    ``member`` is "" for a nominal, else the perturbation ("record × 0.995", "Δt × ½");
    ``labels`` the axes' values (axis -> label); ``error`` a refusal found before running."""

    name: str
    settings: Settings
    base: str
    member: str = ""
    labels: dict[str, str] = field(default_factory=dict)
    error: str = ""
    #: Δt × ½: sampled at the nominal run's instants (read from its summary when it ends).
    sample_like_base: bool = False

    @property
    def nominal(self) -> bool:
        return not self.member


def toml_literal(value: Any) -> str:
    """``value`` as a TOML literal (``--set KEY=VALUE``): booleans, numbers, strings, arrays
    and inline tables."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(value, dict):
        return "{" + ", ".join(f'"{k}" = {toml_literal(v)}' for k, v in value.items()) + "}"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(toml_literal(v) for v in value) + "]"
    if isinstance(value, float) and not math.isfinite(value):
        raise ValueError(f"{value!r} has no TOML literal here")
    return repr(value)


def cli_arguments(settings: Settings) -> list[str]:
    """``--unset``/``--set`` arguments of ``crane-fem run`` for ``settings``."""
    args: list[str] = []
    for k, v in settings.items():
        args += ["--unset", k] if v is None else ["--set", f"{k}={toml_literal(v)}"]
    return args


def _split(settings: Settings) -> tuple[list[str], list[str]]:
    sets = [f"{k}={toml_literal(v)}" for k, v in settings.items() if v is not None]
    return sets, [k for k, v in settings.items() if v is None]


def load_case(scene: Path, settings: Settings) -> Scenario:
    """The scenario of one case (validated as ``crane-fem check`` reads it, without the
    mesh)."""
    sets, unsets = _split(settings)
    return load_scenario(scene, sets, unsets, read_mesh=False)


def _label(value: Any) -> str:
    text = f"{value:g}" if isinstance(value, float) else str(value)
    return re.sub(r"[^A-Za-z0-9.+-]+", "-", text).strip("-") or "x"


def _short(key: str) -> str:
    return key.rsplit(".", 1)[-1]


def _geometry_unset(scene: Path, keys: list[str]) -> Settings:
    """A crane scene that names a committed mesh meshes each case when a case sets one of
    its geometry keys (the committed mesh is of the scene's own geometry)."""
    if not any(k.startswith("model.") and k.split(".", 1)[1] in MESH_KEYS for k in keys):
        return {}
    sc = load_scenario(scene, read_mesh=False)
    return {"model.mesh": None} if getattr(sc.model, "mesh", None) is not None else {}


def _rotated(sc: Scenario, degrees: float) -> Settings:
    """The settings that turn each horizontal component's direction by ``degrees`` about z."""
    gm = sc.loading.ground_motion
    if gm is None:
        raise ScenarioError("angle: the scene has no loading.ground_motion to turn")
    c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
    comps = gm if isinstance(gm, list) else [gm]
    out: Settings = {}
    for i, g in enumerate(comps):
        dx, dy, dz = g.direction
        key = (
            f"loading.ground_motion.{i}.direction"
            if isinstance(gm, list)
            else ("loading.ground_motion.direction")
        )
        out[key] = [c * dx - s * dy, s * dx + c * dy, dz]
    return out


def scaled_record(sc: Scenario, factor: float) -> Settings:
    """The settings that scale ``sc``'s ground motion by ``factor`` (each component of a
    multi-component record; a single record as a whole)."""
    gm = sc.loading.ground_motion
    if gm is None:
        raise ScenarioError("perturb: the scene has no loading.ground_motion to scale")
    if isinstance(gm, list):
        return {f"loading.ground_motion.{i}.scale": c.scale * factor for i, c in enumerate(gm)}
    return {"loading.ground_motion.scale": gm.scale * factor}


def halved_step(sc: Scenario) -> Settings:
    """The settings that halve ``sc``'s time step (its ``dt_factor``, its ``dt``, or the
    default factor 0.9)."""
    t = sc.time
    if t.dt_factor is not None:
        return {"time.dt_factor": t.dt_factor * 0.5}
    if t.dt is not None:
        return {"time.dt": t.dt * 0.5}
    return {"time.dt_factor": 0.45}


def ensemble_members(sc: Scenario, epsilon: float, dt: bool) -> list[tuple[str, str, Settings]]:
    """The conditioning ensemble of one run (THEORY.md §8): (name suffix, label, settings)
    of the record × (1 − ε), × (1 + ε) and, when ``dt``, Δt × ½ (to be sampled at the
    nominal run's instants). The study's and ``crane-fem bench ensemble``'s members."""
    out = [
        (f"x{f:.6g}", f"record × {f:.6g}", scaled_record(sc, f))
        for f in (1.0 - epsilon, 1.0 + epsilon)
    ]
    if dt:
        out.append(("dt0.5", "Δt × ½", halved_step(sc)))
    return out


def _product(
    spec: StudySpec, records: list[tuple[str, list[dict[str, Any]]]]
) -> list[tuple[str, Settings, dict[str, str], float | None]]:
    """(name, settings, labels, angle) of each nominal case of a product study."""
    axes: list[tuple[str, list[tuple[str, Settings]]]] = []
    for a in spec.axis:
        names = a.names or [_label(v) for v in a.values]
        axes.append(
            (_short(a.key), [(n, {a.key: v}) for n, v in zip(names, a.values, strict=True)])
        )
    if records:
        axes.append(("record", [(_label(n), {"loading.ground_motion": c}) for n, c in records]))
    angles: list[float | None] = list(spec.angle.degrees) if spec.angle is not None else [None]
    out = []
    for combo in itertools.product(*(vals for _, vals in axes)):
        for angle in angles:
            settings: Settings = {}
            labels: dict[str, str] = {}
            parts = []
            for (axis, _), (label, st) in zip(axes, combo, strict=True):
                settings.update(st)
                labels[axis] = label
                parts.append(f"{axis}={label}")
            if angle is not None:
                labels["angle"] = f"{angle:g}"
                parts.append(f"angle={angle:g}")
            out.append(("__".join(parts) or "nominal", settings, labels, angle))
    return out


def expand_cases(
    spec: StudySpec, scene: Path, records: list[tuple[str, list[dict[str, Any]]]]
) -> list[Case]:
    """Every case of the study, each nominal case followed by its ensemble members.

    Raises:
        ScenarioError: an axis whose every value the scene refuses (naming the axis and the
            first refusal); the scene itself refused.
    """
    load_scenario(scene, read_mesh=False)  # the scene as written: the study's own error
    nominal: list[tuple[str, Settings, dict[str, str], float | None]]
    if spec.cases == "list":
        nominal = [(c.name, dict(c.set), {"case": c.name}, None) for c in spec.case]
    else:
        nominal = _product(spec, records)
    all_keys = [k for _, st, _, _ in nominal for k in st]
    common: Settings = {**_geometry_unset(scene, all_keys + list(spec.set)), **spec.set}
    cases: list[Case] = []
    refused: dict[str, list[str]] = {}
    for name, st, labels, angle in nominal:
        settings: Settings = {**common, **st}
        try:
            sc = load_case(scene, settings)
            if angle is not None:
                settings.update(_rotated(sc, angle))
                sc = load_case(scene, settings)
        except ScenarioError as exc:
            cases.append(Case(name, settings, name, labels=labels, error=str(exc)))
            for a in spec.axis:
                if a.key in st:
                    refused.setdefault(a.key, []).append(str(exc))
            continue
        cases.append(Case(name, settings, name, labels=labels))
        if spec.perturb is not None:
            for suffix, label, extra in ensemble_members(sc, spec.perturb.epsilon, spec.perturb.dt):
                cases.append(
                    Case(
                        f"{name}__{suffix}",
                        {**settings, **extra},
                        name,
                        member=label,
                        labels=labels,
                        sample_like_base=label.startswith("Δt"),
                    )
                )
    for a in spec.axis:
        errors = refused.get(a.key, [])
        if errors and len(errors) == len(nominal):
            raise ScenarioError(f"axis {a.key}: refused by the scene for every value: {errors[0]}")
    return cases
