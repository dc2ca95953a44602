"""Command-line edits of a scenario mapping: ``--set key.path=value`` and ``--unset key.path``."""

from __future__ import annotations

import re
import tomllib
from typing import Any

from crane_fem.errors import ScenarioError

__all__ = ["apply_overrides", "apply_unsets"]


def _parse_value(text: str, key: str) -> Any:
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        raise ScenarioError(
            f"--set {key}={text}: value is not a TOML value (quote strings: {key}='\"{text}\"')"
        ) from None


def _check_indices(flag: str, key: str) -> None:
    """Refuse an array index written in brackets (``ground_motion[0]``): crane_fem's keys
    index an array of tables with a key of its own (``ground_motion.0``)."""
    if "[" in key or "]" in key:
        dotted = re.sub(r"\[\s*(\d+)\s*\]", r".\1", key)
        raise ScenarioError(
            f"{flag} {key}: an array of tables is indexed by a number as a key of its own, "
            f"not in brackets: {dotted}"
        )


def apply_overrides(data: dict[str, Any], overrides: list[str]) -> dict[str, Any]:
    """Apply ``key.path=value`` overrides (values parsed as TOML) to a scenario mapping; a
    number in the path indexes an array of tables (``subdomain.1.modes=100``)."""
    for item in overrides:
        if "=" not in item:
            raise ScenarioError(f"--set {item}: expected key.path=value")
        key, text = item.split("=", 1)
        key = key.strip()
        _check_indices("--set", key)
        parts = key.split(".")
        if not key or any(not p for p in parts):
            raise ScenarioError(f"--set {item}: empty key")
        node: Any = data
        for i, part in enumerate(parts[:-1]):
            here = ".".join(parts[: i + 1])
            if isinstance(node, list):
                if not part.isdigit() or int(part) >= len(node):
                    raise ScenarioError(
                        f"--set {key}: {here}: an array of {len(node)} tables takes an index "
                        f"0..{len(node) - 1}"
                    )
                node = node[int(part)]
                continue
            nxt = node.get(part) if isinstance(node, dict) else None
            if nxt is None:
                nxt = {}
                node[part] = nxt
            if not isinstance(nxt, dict | list):
                raise ScenarioError(f"--set {key}: {here} is not a table and has no keys")
            node = nxt
        if not isinstance(node, dict):
            raise ScenarioError(f"--set {key}: {'.'.join(parts[:-1])} is not a table")
        node[parts[-1]] = _parse_value(text.strip(), key)
    return data


def apply_unsets(data: dict[str, Any], keys: list[str]) -> dict[str, Any]:
    """Remove keys (``loading.ground_motion.pga``; a number in the path indexes an array of
    tables, as for :func:`apply_overrides`) from a scenario mapping, so that they take their
    defaults or, with ``--set``, other keys can replace them.

    Raises:
        ScenarioError: a key that is not in the scenario, naming it.
    """
    for key in keys:
        _check_indices("--unset", key.strip())
        parts = key.strip().split(".")
        if not key.strip() or any(not p for p in parts):
            raise ScenarioError(f"--unset {key}: empty key")
        node: Any = data
        for i, part in enumerate(parts):
            last = i == len(parts) - 1
            if isinstance(node, list) and part.isdigit() and int(part) < len(node):
                if last:
                    del node[int(part)]
                else:
                    node = node[int(part)]
                continue
            if not isinstance(node, dict) or part not in node:
                raise ScenarioError(f"--unset {key}: no key {'.'.join(parts[: i + 1])} to unset")
            if last:
                del node[part]
            else:
                node = node[part]
    return data
