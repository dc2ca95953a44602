"""Reading a scenario: TOML file -> mapping -> unsets, overrides, relative paths, the
crane's mesh geometry -> a validated :class:`Scenario`."""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from crane_fem.errors import ScenarioError
from crane_fem.scenario.messages import format_error
from crane_fem.scenario.model import MESH_KEYS, CraneModel
from crane_fem.scenario.overrides import apply_overrides, apply_unsets
from crane_fem.scenario.root import Scenario

__all__ = ["load_scenario", "parse_scenario"]


def parse_scenario(data: dict[str, Any], source: str = "<scenario>") -> Scenario:
    """Validate a scenario mapping.

    Raises:
        ScenarioError: with a one-line message naming the key and what is allowed.
    """
    try:
        return Scenario.model_validate(data)
    except ValidationError as exc:
        raise ScenarioError(format_error(source, exc)) from None


def _resolve_paths(data: dict[str, Any], base: Path) -> None:
    """Make the scenario's relative file paths relative to the scenario file's directory:
    ``model.mesh`` and every ground-motion record that is a file (not a bundled name, not
    ``synthetic``), as an include would be; ``--set`` values included."""
    from crane_fem.loading.accelerogram import BUNDLED

    mdl = data.get("model")
    if isinstance(mdl, dict) and isinstance(mdl.get("mesh"), str):
        mesh = Path(mdl["mesh"])
        if not mesh.is_absolute():
            mdl["mesh"] = str(base / mesh)
    loading = data.get("loading")
    gm = loading.get("ground_motion") if isinstance(loading, dict) else None
    for motion in gm if isinstance(gm, list) else [gm]:
        if not isinstance(motion, dict):
            continue
        record = motion.get("record")
        if not isinstance(record, str) or record == "synthetic" or record in BUNDLED:
            continue
        if not Path(record).is_absolute():
            motion["record"] = str(base / record)


def _fill_from_mesh(mdl: dict[str, Any]) -> tuple[list[str], dict[str, float | None] | None]:
    """Give a crane's geometry keys that the scenario leaves out the values its
    ``model.mesh`` was written with (the mesh's sidecar, crane_fem.geometry.crane.mesh_sidecar).
    Returns the keys the scenario gives and the mesh's geometry (None: no sidecar)."""
    from crane_fem.geometry.crane import read_mesh_sidecar

    given = [k for k in MESH_KEYS if k in mdl]
    written = read_mesh_sidecar(mdl["mesh"]) if Path(mdl["mesh"]).is_file() else None
    if written is not None:
        for key in MESH_KEYS:
            mdl.setdefault(key, written[key])
    return given, written


def _check_mesh_geometry(
    mdl: CraneModel, given: list[str], written: dict[str, float | None] | None
) -> None:
    """A crane's ``model.mesh`` exists and its geometry keys given in the scenario are those
    it was written with. Not collective (every rank reads the same files, before any
    collective call).

    Raises:
        ScenarioError: the mesh is not a file; a geometry key differs from the mesh's; the
            mesh has no sidecar while geometry keys are given (they cannot be checked).
    """
    from crane_fem.geometry.crane import mesh_sidecar

    assert mdl.mesh is not None
    mesh = Path(mdl.mesh)
    if not mesh.is_file():
        raise ScenarioError(f"model.mesh: {mesh} is not a file (write it with crane-fem mesh)")
    if written is None:
        if given:
            keys = ", ".join(f"model.{k}" for k in given)
            raise ScenarioError(
                f"model.mesh: {mesh} has no {mesh_sidecar(mesh).name} recording the geometry "
                f"it was made from, so {keys} cannot be checked against it: write it with "
                "crane-fem mesh, or drop those keys to take the mesh as it is"
            )
        return
    for key in given:
        value, was = getattr(mdl, key), written[key]
        if value is None or was is None:
            same = value is was
        else:
            same = abs(float(value) - was) <= 1e-12 * max(abs(was), 1.0)
        if not same:
            raise ScenarioError(
                f"model.{key} = {_shown(value)} disagrees with model.mesh {mesh} (made with "
                f"{key} = {_shown(was)}, {mesh_sidecar(mesh).name}): drop the key to use "
                "that mesh, or unset model.mesh to mesh the geometry (crane-fem mesh writes it)"
            )


def _shown(value: float | None) -> str:
    """A geometry key's value in an error (``none``: a key not given, e.g. trolley_size)."""
    return "none" if value is None else f"{value:g}"


def load_scenario(
    path: str | Path,
    overrides: list[str] | None = None,
    unset: list[str] | None = None,
    *,
    read_mesh: bool = True,
) -> Scenario:
    """Read, unset keys (``unset``), override (``overrides``) and validate a scenario file.

    Relative paths (``model.mesh``, record files) are relative to the scenario file. A
    crane's ``model.mesh`` is checked against its geometry keys unless ``read_mesh`` is
    False (``crane-fem mesh``, which writes the mesh from them).

    Not collective: every rank may call it; all ranks raise the same error on bad input.

    Raises:
        ScenarioError: missing/unreadable file, TOML syntax, a key to unset that is not
            there, invalid keys/values, or geometry keys that disagree with the mesh.
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
    apply_unsets(data, unset or [])
    apply_overrides(data, overrides or [])
    _resolve_paths(data, p.parent)
    mdl = data.get("model")
    mesh = isinstance(mdl, dict) and mdl.get("kind") == "crane" and isinstance(mdl.get("mesh"), str)
    mesh = mesh and read_mesh
    try:
        # The keys are validated with the mesh's geometry, then compared with it.
        given, written = _fill_from_mesh(mdl) if mesh and isinstance(mdl, dict) else ([], None)
        sc = parse_scenario(data, str(p))
        if mesh:
            assert isinstance(sc.model, CraneModel)
            _check_mesh_geometry(sc.model, given, written)
    except ScenarioError as exc:
        msg = str(exc)
        raise ScenarioError(msg if msg.startswith(f"{p}: ") else f"{p}: {msg}") from None
    return sc
