"""Scenario validation and the CLI: malformed input ends with one line naming the key."""

from pathlib import Path

import pytest

from crane_fem.cli import main
from crane_fem.errors import ScenarioError
from crane_fem.scenario import load_scenario

GOOD = """
name = "ok"
[model]
kind = "bar"
length = 1.0
elements = 10
[material]
E = 1.0
rho = 1.0
[initial]
velocity = -1.0
[[contact]]
type = "wall"
gap = 0.1
[time]
end = 0.5
dt_factor = 0.9
[integrator]
scheme = "cd-lagrange"
[output]
xdmf = false
"""


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "scenario.toml"
    path.write_text(text)
    return path


# (replace this, with that, expected fragments of the message)
BAD = [
    (
        "E = 1.0",
        "Young = 1.0",
        ["material.Young", "unknown key", "allowed here: E, damping, nu, rayleigh, rho"],
    ),
    ("E = 1.0", 'E = "steel"', ["material.E", "valid number", "'steel'"]),
    ("E = 1.0", "E = -2.0", ["material.E", "greater than 0", "-2.0"]),
    ("E = 1.0", "E = true", ["material.E", "valid number"]),
    ("end = 0.5", "", ["time.end", "required key is missing"]),
    ("dt_factor = 0.9", "dt_factor = 0.9\ndt = 1e-3", ["exactly one of time.dt"]),
    (
        'scheme = "cd-lagrange"',
        'scheme = "verlet"',
        ["integrator.scheme", "'cd-lagrange', 'moreau-jean' or 'penalty'", "'verlet'"],
    ),
    (
        'scheme = "cd-lagrange"',
        'scheme = "penalty"',
        ["integrator.penalty", "required by 'penalty'"],
    ),
    (
        'scheme = "cd-lagrange"',
        'scheme = "moreau-jean"\ntheta = 1.5',
        ["integrator.theta", "less than or equal to 1"],
    ),
    (
        'scheme = "cd-lagrange"',
        'scheme = "cd-lagrange"\ntheta = 0.5',
        ["integrator.theta applies to 'moreau-jean' only"],
    ),
    ("gap = 0.1", "gap = -0.1", ["contact[0].gap", "greater than or equal to 0"]),
    ('type = "wall"', 'type = "bars"', ["contact type 'bars' and [model.second_bar]"]),
    ('kind = "bar"', 'kind = "beam"', ["model.kind", "unknown kind 'beam'", "'bar', 'box_beam'"]),
    ("elements = 10", "elements = 10.5", ["model.elements", "valid integer"]),
    ("elements = 10", "elements = 0", ["model.elements", "greater than 0"]),
    (
        "[output]",
        "[loading]\ngravity = [0.0, -9.81]\n[output]",
        ["loading.gravity", "at least 3 items"],
    ),
    ("velocity = -1.0", "velocity = -1.0\ndisplacement = [0.1, 0.2]\n[model.clamp]", ["model"]),
    (
        "[time]",
        "[time]\nstart = 0.0",
        ["time.start", "unknown key", "allowed here: dt, dt_factor, end"],
    ),
    ("[output]", "[outputs]", ["outputs", "unknown key"]),
]


@pytest.mark.parametrize(("old", "new", "fragments"), BAD)
def test_bad_scenario_one_line_error(tmp_path, capsys, old, new, fragments) -> None:
    assert old in GOOD
    path = _write(tmp_path, GOOD.replace(old, new, 1))
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0, err
    assert err.startswith(f"crane-fem: error: {path}: ")
    for frag in fragments:
        assert frag in err, (frag, err)


def test_good_scenario_checks(tmp_path, capsys) -> None:
    path = _write(tmp_path, GOOD)
    assert main(["check", str(path)]) == 0
    sc = load_scenario(path)
    assert sc.name == "ok" and sc.model.elements == 10


def test_missing_file_and_toml_syntax(tmp_path, capsys) -> None:
    assert main(["check", str(tmp_path / "nope.toml")]) == 2
    assert "nope.toml: scenario file not found" in capsys.readouterr().err
    path = _write(tmp_path, GOOD + "\n[material\n")
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert "TOML syntax error" in err and err.count("\n") == 0


def test_set_overrides_are_toml_values(tmp_path, capsys) -> None:
    path = _write(tmp_path, GOOD)
    sc = load_scenario(
        path,
        [
            "integrator.scheme='penalty'",
            "integrator.penalty=1e3",
            "model.elements=20",
            "loading.gravity=[0, 0, -9.81]",
        ],
    )
    assert sc.integrator.scheme == "penalty" and sc.integrator.penalty == 1e3
    assert sc.model.elements == 20 and sc.loading.gravity == [0.0, 0.0, -9.81]
    assert main(["check", str(path), "--set", "integrator.scheme=penalty"]) == 2
    err = capsys.readouterr().err
    assert "not a TOML value" in err and "integrator.scheme" in err
    assert main(["check", str(path), "--set", "model.elements=abc"]) == 2
    assert main(["check", str(path), "--set", "model.elements.x=1"]) == 2
    assert "model.elements is not a table" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("scene", "override", "fragment"),
    [
        ("crane_quick.toml", "initial.velocity=1.0", "initial.velocity: model.kind 'crane' starts"),
        ("crane_quick.toml", "initial.displacement=[0.0, 1e-3]", "initial.displacement: model"),
        ("box_beam.toml", "initial.velocity=1.0", "initial.velocity: model.kind 'box_beam' starts"),
    ],
)
def test_initial_state_of_a_crane_or_box_beam_is_refused(scene, override, fragment) -> None:
    """A crane starts at rest in its static preload, a box beam at rest: initial.* (a bar's
    or a block's) is refused with one line, not ignored."""
    demos = Path(__file__).parent.parent / "demos"
    with pytest.raises(ScenarioError) as err:
        load_scenario(demos / scene, [override])
    assert fragment in str(err.value) and "\n" not in str(err.value), str(err.value)
