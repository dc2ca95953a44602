"""The documentation cannot silently rot: its command lines, TOML snippets, scenario keys and
summary keys are checked against the code (no solver is run; each rank may run these tests on
its own: nothing is written).

- every ``crane-fem run|check|mesh`` line of a fenced block in README.md and
  docs/user-guide.md parses with the CLI's own parser, names an existing scenario file and
  its ``--set``/``--unset`` overrides validate (:func:`crane_fem.scenario.load_scenario`);
- every TOML snippet of docs/user-guide.md and docs/scenarios.md that is a whole scenario
  validates (:func:`crane_fem.scenario.parse_scenario`); of a fragment, every key exists in the
  schema and the values it gives are valid;
- every key of the schema (every section, every model kind's fields, nested tables) is named
  in docs/scenarios.md;
- every ``summary.json`` key that crane_fem/coupled_run.py (and the summary's common tail,
  crane_fem/run_record.py) writes is named in docs/user-guide.md;
- the guide's sample run output is in the format ``run`` prints now, and a figure it quotes
  (the cabinet demo's support reaction) is what the demo's mesh and scene give.
"""

from __future__ import annotations

import ast
import re
import shlex
import textwrap
import tomllib
import types
import typing
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from pydantic import BaseModel, ValidationError

from crane_fem.cli import _parser
from crane_fem.errors import ScenarioError
from crane_fem.scenario import MODEL_KINDS, Scenario, load_scenario, parse_scenario

pytestmark = pytest.mark.no_kernels

ROOT = Path(__file__).resolve().parents[1]
COMMAND_DOCS = ("README.md", "docs/user-guide.md")
TOML_DOCS = ("docs/user-guide.md", "docs/scenarios.md")
KEYS_DOC = "docs/scenarios.md"
GUIDE = "docs/user-guide.md"
#: Scenario files a doc tells the reader to create (the guide's "build your own crane"):
#: their command lines are parsed, not loaded.
USER_FILES = {"demos/my_crane.toml"}
#: The model kinds' sections (``model`` is one of them, by ``kind``).
KINDS: dict[str, type[BaseModel]] = {
    k: typing.cast(type[BaseModel], m) for k, m in MODEL_KINDS.items()
}
#: The required sections of a whole scenario.
REQUIRED = [k for k, f in Scenario.model_fields.items() if f.is_required()]

#: A fenced block (indented in a list item too): its info string and its text.
FENCE = re.compile(r"^[ \t]*```(\w*)[^\n]*\n(.*?)^[ \t]*```[ \t]*$", re.M | re.S)
CRANE_FEM = re.compile(r"(?:^|\s)(?:\S*/)?crane-fem\s+(run|check|mesh)\s")


def _read(doc: str) -> str:
    return (ROOT / doc).read_text(encoding="utf-8")


# --- command lines ---------------------------------------------------------------------------


def _command_lines() -> list[tuple[str, str, str]]:
    """(doc, line, the error it prints) of every crane-fem run/check/mesh command in a fenced
    block; the error is the ``crane-fem: error: …`` line of its output in a console block."""
    out = []
    for doc in COMMAND_DOCS:
        for _, block in FENCE.findall(_read(doc)):
            lines = [x.strip() for x in block.splitlines()]
            for i, line in enumerate(lines):
                command = line.removeprefix("$ ")
                if not CRANE_FEM.search(command):
                    continue
                error = ""
                for after in lines[i + 1 :]:
                    if after.startswith("$ "):
                        break
                    if after.startswith("crane-fem: error: "):
                        error = after.removeprefix("crane-fem: error: ")
                out.append((doc, command, error))
    return out


COMMANDS = _command_lines()


def test_docs_have_command_lines() -> None:
    docs = {doc for doc, _, _ in COMMANDS}
    assert docs == set(COMMAND_DOCS), (
        f"no crane-fem command lines found in {set(COMMAND_DOCS) - docs}"
    )


@pytest.mark.parametrize(
    ("doc", "line", "error"), COMMANDS, ids=[f"{d}:{i}" for i, (d, _, _) in enumerate(COMMANDS)]
)
def test_command_line(doc: str, line: str, error: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """The command parses and its scenario validates; a command shown refused by the
    scenario's validation prints the error the code gives now (one refused at run time, such
    as Δt above the critical step, validates)."""
    words = shlex.split(line, comments=True)
    i = next(k for k, w in enumerate(words) if w.endswith("crane-fem"))
    argv = words[i + 1 :]
    try:
        args = _parser().parse_args(argv)
    except SystemExit:
        pytest.fail(f"{doc}: `{line}`: the crane-fem parser refuses these arguments")
    scenario = str(args.scenario)
    if scenario in USER_FILES:
        return
    assert (ROOT / scenario).is_file(), f"{doc}: `{line}`: scenario file {scenario} does not exist"
    monkeypatch.chdir(ROOT)  # the docs' commands run from the repository (errors name the path)
    try:
        load_scenario(scenario, args.overrides, args.unset, read_mesh=args.command != "mesh")
    except ScenarioError as exc:
        assert error, f"{doc}: `{line}`: {exc}"
        assert error == str(exc), (
            f"{doc}: `{line}`: the doc shows the error {error!r}, the code gives {str(exc)!r}"
        )


# --- TOML snippets ---------------------------------------------------------------------------


def _snippets() -> list[tuple[str, int, str]]:
    """(doc, index, text) of every ```toml block."""
    out = []
    for doc in TOML_DOCS:
        blocks = [text for info, text in FENCE.findall(_read(doc)) if info == "toml"]
        out += [(doc, k, textwrap.dedent(text)) for k, text in enumerate(blocks)]
    return out


SNIPPETS = _snippets()


def _models(annotation: Any) -> list[type[BaseModel]]:
    """The pydantic models an annotation may hold (through unions, lists, Annotated)."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return [annotation]
    out: list[type[BaseModel]] = []
    origin = typing.get_origin(annotation)
    if origin is dict:  # a mapping of names (spectra.points): no keys of the schema inside
        return out
    if origin is typing.Annotated:
        return _models(typing.get_args(annotation)[0])
    if origin in (typing.Union, types.UnionType, list):
        for arg in typing.get_args(annotation):
            out += [m for m in _models(arg) if m not in out]
    return out


def _fields(models: list[type[BaseModel]]) -> dict[str, Any]:
    """Field name -> annotation of a section that may be any of ``models``."""
    out: dict[str, Any] = {}
    for m in models:
        for name, f in m.model_fields.items():
            out.setdefault(name, f.annotation)
    return out


def _unknown_keys(data: dict[str, Any], models: list[type[BaseModel]], where: str) -> list[str]:
    """The keys of ``data`` (a table of a section that is one of ``models``) not in the schema."""
    if where == "model" and isinstance(data.get("kind"), str) and data["kind"] in KINDS:
        models = [KINDS[data["kind"]]]
    fields = _fields(models)
    bad = []
    for key, value in data.items():
        path = f"{where}.{key}" if where else key
        if key not in fields:
            bad.append(path)
            continue
        inner = list(KINDS.values()) if path == "model" else _models(fields[key])
        for table in value if isinstance(value, list) else [value]:
            if inner and isinstance(table, dict):
                bad += _unknown_keys(table, inner, path)
    return bad


def test_docs_have_toml_snippets() -> None:
    docs = {doc for doc, _, _ in SNIPPETS}
    assert GUIDE in docs, f"no ```toml blocks found in {GUIDE}"


@pytest.mark.parametrize(("doc", "k", "text"), SNIPPETS, ids=[f"{d}:{k}" for d, k, _ in SNIPPETS])
def test_toml_snippet(doc: str, k: int, text: str) -> None:
    where = f"{doc}: TOML block {k + 1} ({text.strip().splitlines()[0]!r} …)"
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        pytest.fail(f"{where}: TOML syntax error: {exc}")
    if "scene" in data:  # a study file (crane-fem study): its schema, strictly
        from crane_fem.study import StudySpec

        try:
            StudySpec.model_validate(data)
        except ValidationError as exc:
            pytest.fail(f"{where}: not a valid study file: {exc}")
        return
    if all(s in data for s in REQUIRED):  # a whole scenario
        try:
            parse_scenario(data, where)
        except ScenarioError as exc:
            pytest.fail(str(exc))
        return
    # A fragment: its keys exist, and the values it gives are valid (missing keys allowed).
    bad = _unknown_keys(data, [Scenario], "")
    assert not bad, f"{where}: keys not in the scenario schema: {', '.join(bad)}"
    try:
        Scenario.model_validate(data)
    except ValidationError as exc:
        wrong = [e for e in exc.errors() if e["type"] != "missing"]
        msgs = [".".join(str(p) for p in e["loc"]) + f": {e['msg']}" for e in wrong]
        assert not msgs, f"{where}: invalid values: {'; '.join(msgs)}"


# --- every schema key documented -------------------------------------------------------------


def _schema_keys() -> list[tuple[str, str | None]]:
    """(key path, the path of the table holding it when nested in a section's key) of every
    key of the schema: ``name``, ``model.span``, ``material.damping``,
    ``material.damping.ratio``, ``subdomain.modes`` (arrays of tables as their entries)."""
    out: list[tuple[str, str | None]] = []

    def walk(models: list[type[BaseModel]], prefix: str, parent: str | None) -> None:
        for key, ann in _fields(models).items():
            path = f"{prefix}{key}"
            if (path, parent) not in out:
                out.append((path, parent))
            inner = _models(ann)
            if inner:
                walk(inner, f"{path}.", path)

    for key, f in Scenario.model_fields.items():
        models = list(KINDS.values()) if key == "model" else _models(f.annotation)
        if models:
            walk(models, f"{key}.", None)  # a section: its keys, not itself
        else:
            out.append((key, None))
    return out


def _documented_keys(text: str) -> dict[str, list[str]]:
    """Key path -> the table rows naming it in their first cell.

    The first cell's `code` spans are read in order: ``[[subdomain]]`` or ``[spectra]`` opens a
    section, a dotted ``material.damping`` names a key (``model.kind = "crane"``: the part
    before ``=``), a bare ``girder_width`` a sibling of the last dotted key (or a key of the
    section opened), ``…record`` a key inside the last dotted key (``loading.ground_motion``),
    which carries over to the next rows."""
    keys: dict[str, list[str]] = {}
    siblings, base = "", ""
    for line in text.splitlines():
        if not line.startswith("|") or line.startswith("|---"):
            continue
        cells = re.split(r"(?<!\\)\|", line)
        for token in re.findall(r"`([^`]+)`", cells[1]):
            token = token.split("=")[0].strip()
            section = re.fullmatch(r"\[\[?([\w.]+)\]\]?", token)
            if section:
                siblings, base = f"{section[1]}.", section[1]
                continue
            if token.startswith("…"):
                path = f"{base}.{token[1:]}"
            elif "." in token:
                path, base = token, token
                siblings = token.rsplit(".", 1)[0] + "."
            elif re.fullmatch(r"\w+", token):
                path = f"{siblings}{token}"
            else:
                continue
            keys.setdefault(path, []).append(line)
    return keys


def test_every_schema_key_documented() -> None:
    documented = _documented_keys(_read(KEYS_DOC))
    missing = []
    for path, parent in _schema_keys():
        if path in documented:
            continue
        # A nested table's key may be given in its table's row: `{ratio, f1, f2}`.
        leaf = path.rsplit(".", 1)[1]
        rows = documented.get(parent, []) if parent else []
        if any(re.search(rf"(?<![\w.]){re.escape(leaf)}(?!\w)", row) for row in rows):
            continue
        missing.append(path)
    assert not missing, f"{KEYS_DOC}: scenario keys not documented: {', '.join(missing)}"


def test_documented_keys_exist() -> None:
    """The other way round: a key named in a first cell of docs/scenarios.md is in the schema
    (a key renamed or removed in the code leaves no stale row)."""
    schema = {path for path, _ in _schema_keys()} | {k for k in Scenario.model_fields}
    stale = sorted(set(_documented_keys(_read(KEYS_DOC))) - schema)
    assert not stale, f"{KEYS_DOC}: documented keys not in the scenario schema: {', '.join(stale)}"


# --- summary.json keys documented ------------------------------------------------------------


def _summary_keys(source: Path) -> list[str]:
    """The keys a module writes into a mapping named ``summary``: ``summary["k"] = …``,
    ``summary: … = {"k": …}`` and ``summary.update({"k": …})``."""
    keys: list[str] = []

    def add(d: ast.AST) -> None:
        if isinstance(d, ast.Dict):
            keys.extend(
                k.value for k in d.keys if isinstance(k, ast.Constant) and isinstance(k.value, str)
            )

    def is_summary(n: ast.AST) -> bool:
        return isinstance(n, ast.Name) and n.id == "summary"

    for node in ast.walk(ast.parse(source.read_text(encoding="utf-8"))):
        if (
            isinstance(node, ast.Subscript)
            and is_summary(node.value)
            and isinstance(node.ctx, ast.Store)
        ):
            if isinstance(node.slice, ast.Constant) and isinstance(node.slice.value, str):
                keys.append(node.slice.value)
        elif isinstance(node, ast.Assign | ast.AnnAssign):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            if any(is_summary(t) for t in targets) and node.value is not None:
                add(node.value)
        elif (
            isinstance(node, ast.Call)
            and isinstance(node.func, ast.Attribute)
            and node.func.attr == "update"
            and is_summary(node.func.value)
            and node.args
        ):
            add(node.args[0])
    return list(dict.fromkeys(keys))


def test_summary_keys_documented() -> None:
    keys = []
    for module in (
        "crane_fem/coupled_run.py",
        "crane_fem/run_record.py",
        "crane_fem/monitors/bridge_stress.py",
        "crane_fem/monitors/support_reactions.py",
    ):
        found = _summary_keys(ROOT / module)
        assert found, f"{module}: no summary keys found (the regex of this test is stale)"
        keys += [(module, k) for k in found]
    guide = _read(GUIDE)
    missing = [f"{k} ({m})" for m, k in keys if f"`{k}`" not in guide]
    assert not missing, f"{GUIDE}: summary.json keys not documented: {', '.join(missing)}"


# --- sample outputs and figures the guide quotes -----------------------------------------------

#: The first line a refining coupled run prints (crane_fem.io.results.run_line).
_REFINING_RUN = re.compile(
    r"crane-fem: (\w+): (\d+) macro steps \((\d+) of ΔT = (\S+) s, m = (\d+); (\d+) of "
    r"m = (\d+) around impacts\), (\d+) micro steps of Δt = (\S+) s \(critical (\S+) s\) in "
    r"(\S+) s; energy balance error (\S+); (\d+) contact interval\(s\)"
)


def test_guide_sample_run_is_what_run_prints() -> None:
    """§1's sample of `crane-fem run` (issue 32: it showed 77 macro steps of a fixed ratio
    where the refining scene prints 473): its first line is the one
    :func:`~crane_fem.io.results.run_line` prints for its own numbers, in the refining run's
    format, and those numbers add up (coarse + fine macro steps; coarse × m + fine × m_fine
    micro steps; ΔT = mΔt; the scene's ratios); its table has every header the end table of
    a crane run with slip prints."""
    from crane_fem.io.results import results_lines, run_line

    command = "$ .venv/bin/crane-fem run demos/crane_quick.toml -o /tmp/gq --set time.end=0.01"
    block = next(b for _, b in FENCE.findall(_read(GUIDE)) if command in b)
    first = block.split(command)[1].strip().splitlines()[0]
    m = _REFINING_RUN.fullmatch(first)
    assert m, f"{GUIDE} §1: not the line a refining run prints now: {first!r}"
    name, steps, coarse, dT, ratio, fine, fine_ratio, micro, dt, crit, wall, err, cont = m.groups()
    summary = {
        "steps_done": int(steps),
        "micro_steps_done": int(micro),
        "dT": float(dT),
        "dt": float(dt),
        "dt_critical": float(crit),
        "wall_time_s": float(wall),
        "energy_balance_error": float(err),
        "contact_intervals": int(cont),
        "adaptive": {
            "coarse_steps": int(coarse),
            "coarse_ratio": int(ratio),
            "fine_steps": int(fine),
            "fine_ratio": int(fine_ratio),
        },
    }
    assert f"crane-fem: {run_line(name, summary)}" == first
    assert int(coarse) + int(fine) == int(steps)
    assert int(coarse) * int(ratio) + int(fine) * int(fine_ratio) == int(micro)
    assert float(dT) == pytest.approx(int(ratio) * float(dt), rel=1e-4)
    sc = load_scenario(ROOT / "demos" / "crane_quick.toml")
    assert sc.coupling is not None
    assert (sc.coupling.ratio, sc.coupling.fine_ratio) == (int(ratio), int(fine_ratio))
    assert int(micro) * float(dt) == pytest.approx(0.01, abs=float(dT))
    wheel = {
        "peak_force_N": 1.0,
        "peak_force_time_s": 0.0,
        "max_uplift_m": 0.0,
        "lift_offs": {"count": 0},
        "max_slip_across_m": 0.0,
        "max_slip_along_m": 0.0,
        "slip_reach_m": 0.0,
    }
    headers = [ln for ln in results_lines({"wheels": {"1": wheel}}) if "(mm)" in ln]
    assert len(headers) == 2
    for header in headers:
        assert f"crane-fem: {header}\n" in block, f"{GUIDE} §1: the table lacks {header!r}"


def _group_volumes(mesh: Path) -> dict[str, float]:
    """The volume of each named volume group of a .msh (m³), from its tetrahedra (gmsh, in
    this process)."""
    import gmsh

    gmsh.initialize(interruptible=False)
    gmsh.option.setNumber("General.Terminal", 0)
    try:
        gmsh.open(str(mesh))
        tags, xyz, _ = gmsh.model.mesh.getNodes()
        where = np.empty(int(tags.max()) + 1, dtype=np.int64)
        where[tags] = np.arange(tags.size)
        xyz = xyz.reshape(-1, 3)
        out = {}
        for dim, tag in gmsh.model.getPhysicalGroups(3):
            volume = 0.0
            for entity in gmsh.model.getEntitiesForPhysicalGroup(dim, tag):
                _, _, nodes = gmsh.model.mesh.getElements(3, entity)
                x = xyz[where[np.asarray(nodes[0], dtype=np.int64).reshape(-1, 4)]]
                volume += float(np.sum(np.abs(np.linalg.det(x[:, 1:] - x[:, :1]))) / 6.0)
            out[gmsh.model.getPhysicalName(dim, tag)] = volume
        return out
    finally:
        gmsh.finalize()


def test_guide_cabinet_reaction_is_slab_plus_cabinet() -> None:
    """§10's static support reaction of the cabinet demo (issue 32: it was called "its
    weight", the cabinet's) is the weight of the slab and the cabinet with its carried mass,
    from the mesh's group volumes and the scene's densities; the cabinet's share, which its
    feet carry, is the smaller number the guide gives beside it."""
    scene = ROOT / "demos" / "own_model" / "cabinet_on_slab.toml"
    sc = load_scenario(scene)
    volumes = _group_volumes(ROOT / "demos" / "own_model" / "cabinet_on_slab.msh")
    g = -sc.loading.gravity[2]
    carried = {m.group: m.mass for m in sc.mass}
    weight = {
        group: (mat.rho * volumes[group] + carried.get(group, 0.0)) * g
        for groups, mat in sc.materials
        for group in groups or []
    }
    text = " ".join(_read(GUIDE).split())
    m = re.search(
        r"a static support reaction of ([\d.]+) kN: the weight of the slab and of the "
        r"cabinet with its (\d+) kg of equipment \(the cabinet's share, ([\d.]+) kN",
        text,
    )
    assert m, f"{GUIDE} §10: the cabinet demo's support reaction is not described as expected"
    total, equipment, share = float(m[1]), float(m[2]), float(m[3])
    assert equipment == carried["cabinet"]
    assert total == pytest.approx(sum(weight.values()) / 1e3, abs=0.005)
    assert share == pytest.approx(weight["cabinet"] / 1e3, abs=0.005)
