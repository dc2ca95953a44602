"""Pydantic validation errors -> one line naming the key, what is wrong and what is allowed."""

from __future__ import annotations

import re
from typing import Any

from pydantic import BaseModel, ValidationError

from crane_fem.scenario.frame import LineContact, PlaneContact
from crane_fem.scenario.model import MODEL_KINDS
from crane_fem.scenario.root import Scenario
from crane_fem.scenario.sections import Contact, SurfaceContact

#: The tables a ``[[contact]]`` entry's ``type`` selects (pydantic puts the type in the
#: error's location).
CONTACT_KINDS: dict[str, type[BaseModel]] = {
    "wall": Contact,
    "bars": Contact,
    "plane": Contact,
    "surface": SurfaceContact,
    "point-on-line": LineContact,
    "point-on-plane": PlaneContact,
}

__all__ = ["format_error"]


def _allowed_keys(section: type[BaseModel], loc: tuple[Any, ...]) -> list[str]:
    """Keys allowed at the parent of ``loc`` (for 'unknown key' messages)."""
    model: Any = section
    for i, part in enumerate(loc[:-1]):
        if isinstance(part, int):
            continue
        if part in MODEL_KINDS and i > 0 and loc[i - 1] == "model":
            model = MODEL_KINDS[part]
            continue
        if part in CONTACT_KINDS and i > 1 and loc[i - 2] == "contact":
            model = CONTACT_KINDS[part]
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


#: Union-branch tags pydantic inserts in error locations besides those with a "[" in them
#: ("list[...]", "literal['auto']", "function-after[...]"); no scenario key has these names.
_SCALAR_TAGS = {"bool", "int", "float", "str", "none", "constrained-float", "constrained-int"}


def _is_tag(part: Any) -> bool:
    """A union-branch tag in an error location, not a key."""
    return isinstance(part, str) and ("[" in part or part in _SCALAR_TAGS)


def _leaf(e: Any) -> bool:
    """The error is a union branch refusing the input as a whole (its type, or a literal):
    not a branch that took the input and then found a problem inside it."""
    return bool(e["loc"]) and _is_tag(e["loc"][-1]) and e["type"] != "value_error"


def _expected(e: Any) -> list[str]:
    """What a branch expected, as alternatives: "a table", "'auto'", "a valid boolean"."""
    if e["type"] in ("model_type", "model_attributes_type", "dict_type"):
        return ["a table"]
    if e["type"] == "list_type":
        of_tables = any(c.isupper() for c in e["loc"][-1])  # a list of a model class
        return ["an array of tables" if of_tables else "an array"]
    if e["type"] == "literal_error":
        return [x.strip() for x in str(e["ctx"]["expected"]).replace(" or ", ", ").split(",")]
    msg = str(e["msg"])
    return [msg.removeprefix("Input should be ")]


def _real_errors(errors: list[Any]) -> list[Any]:
    """The errors of the union branch the input was meant for: of ``[loading.ground_motion]``
    (a table or an array of tables) with a bad value, that value's error, not also "should
    be a valid list" from the other branch; where every branch refused the input as a whole
    (a string for a table, an unknown name), one error listing what it should be."""
    # Unions where some branch took the input: its errors are the real ones.
    taken = set()
    for e in errors:
        if _leaf(e):
            continue
        loc = e["loc"]
        taken |= {loc[:i] for i in range(len(loc)) if _is_tag(loc[i])}
    out: list[Any] = []
    merged: dict[tuple[Any, ...], Any] = {}
    for e in errors:
        if not _leaf(e):
            out.append(e)
            continue
        where = e["loc"][:-1]
        if where in taken:
            continue
        if where not in merged:
            merged[where] = {**e, "loc": where, "type": "union_type", "expected": []}
            out.append(merged[where])
        merged[where]["expected"] += [x for x in _expected(e) if x not in merged[where]["expected"]]
    for e in merged.values():
        alts = e["expected"]
        e["msg"] = "Input should be " + (
            alts[0] if len(alts) == 1 else f"{', '.join(alts[:-1])} or {alts[-1]}"
        )
    return out


def _path(loc: tuple[Any, ...]) -> str:
    """``model.length``, ``subdomain[1].modes``: the key of an error location, with the tags
    pydantic inserts dropped (the discriminator after "model", union branches)."""
    raw = tuple(p for p in loc if not _is_tag(p))
    key = tuple(
        p
        for i, p in enumerate(raw)
        if not (i > 0 and raw[i - 1] == "model" and p in MODEL_KINDS)
        and not (i > 1 and raw[i - 2] == "contact" and p in CONTACT_KINDS)
    )
    return ".".join(str(p) if not isinstance(p, int) else f"[{p}]" for p in key).replace(".[", "[")


def format_error(source: str, exc: ValidationError) -> str:
    """One line: ``source: key.path: what is wrong (got value)``, then the keys of any other
    distinct problems (``[also: material.E]``)."""

    # An unknown key is usually the root cause (a typo that also leaves a key missing); of a
    # union "table or array of tables", the table branch speaks for a table.
    def rank(e: Any) -> tuple[bool, bool]:
        in_list = any(isinstance(p, str) and p.startswith("list[") for p in e["loc"])
        return e["type"] != "extra_forbidden", in_list

    errors = sorted(_real_errors(exc.errors()), key=rank)
    err = errors[0]
    raw = tuple(p for p in err["loc"] if not _is_tag(p))
    path = _path(err["loc"])
    kind = err["type"]
    if kind == "union_tag_invalid":
        path = f"{path}.kind"
        kinds = ", ".join(repr(k) for k in MODEL_KINDS)
        msg = f"unknown kind {err['input'].get('kind')!r}; allowed: {kinds}"
    elif kind == "extra_forbidden":
        allowed = ", ".join(_allowed_keys(Scenario, raw))
        msg = f"unknown key; allowed here: {allowed}"
    elif kind == "missing":
        msg = "required key is missing"
    elif kind == "union_type":
        msg = f"{err['msg']} (got {err['input']!r})"
    elif kind in ("model_type", "model_attributes_type", "dict_type"):
        msg = f"Input should be a table (got {err['input']!r})"
    else:
        msg = err["msg"]
        if msg.startswith("Value error, "):
            msg = msg[len("Value error, ") :]
            # A table's validator naming one of its keys first ("b = -1: must be positive",
            # "h: missing"): that key is the location.
            head = re.match(r"([A-Za-z_][A-Za-z0-9_]*)(:| =)", msg)
            if head and path and head.group(1) in _allowed_keys(Scenario, (*raw, "_")):
                path = f"{path}.{head.group(1)}"
                msg = msg[len(head.group(1)) :].lstrip(": ") if head.group(2) == ":" else msg
        if kind != "value_error":
            msg = f"{msg} (got {err['input']!r})"
    others = [o or "(top level)" for o in dict.fromkeys(_path(e["loc"]) for e in errors[1:])]
    others = [o for o in others if o != (path or "(top level)")]
    tail = f" [also: {', '.join(others)}]" if others else ""
    where = f"{path}: " if path else ""
    return f"{source}: {where}{msg}{tail}"
