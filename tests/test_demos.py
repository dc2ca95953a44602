"""Demos: every scenario file validates; the literate demo runs in serial and in parallel."""

import runpy
from pathlib import Path

import pytest
from conftest import COMM

from crane_fem.scenario import load_scenario

DEMOS = Path(__file__).parent.parent / "demos"


@pytest.mark.parametrize("path", sorted(DEMOS.glob("*.toml")), ids=lambda p: p.name)
def test_demo_scenarios_validate(path: Path) -> None:
    sc = load_scenario(path)
    assert sc.name == path.stem


@pytest.mark.demo
def test_demo_bar_impact(shared_tmp, monkeypatch, capsys) -> None:
    monkeypatch.chdir(shared_tmp)
    runpy.run_path(str(DEMOS / "demo_bar_impact.py"), run_name="__main__")
    if COMM.rank == 0:
        out = capsys.readouterr().out
        ratio = float(out.split("check: impulse/exact = ")[1].split()[0])
        assert ratio == pytest.approx(1.0, rel=0.01)
        assert (shared_tmp / "out/demo_bar_impact/bar_impact.png").stat().st_size > 0
