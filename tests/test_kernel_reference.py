"""The compiled kernel against the Python path it replaced (issue 13): the small scenes of every
method, each history within 1e-10 of the one the Python path wrote (tests/data/reference; the
quick crane scene is compared in tests/test_crane_scene.py). These scenes are not chaotic: under
mpiexec -n 2 they equal the serial reference to round-off, so both passes compare to it."""

from pathlib import Path

import pytest
from conftest import REFERENCE_RTOL, assert_same_histories, reference, run

from crane_fem.scenario import load_scenario

DEMOS = Path(__file__).parent.parent / "demos"
NOXDMF = "output.xdmf=false"

CASES = [
    *(
        (f"box_{m}", "box_beam.toml", [f"coupling.method='{m}'"])
        for m in ("gc", "gc-mean", "ph", "ec", "hybrid", "monolithic")
    ),
    *(
        (f"split_{m}", "split_bar.toml", [f"coupling.method='{m}'"])
        for m in ("gc", "gc-mean", "hybrid")
    ),
    (
        "split_monolithic",
        "split_bar.toml",
        ["coupling.method='monolithic'", "coupling.scheme='cd-lagrange'"],
    ),
    ("bar_cd", "bar_impact.toml", []),
    ("bar_penalty", "bar_impact.toml", ["integrator.scheme='penalty'", "integrator.penalty=1e6"]),
    ("two_bars", "two_bars.toml", []),
]


@pytest.mark.parametrize(("ref", "scene", "sets"), CASES, ids=[c[0] for c in CASES])
def test_small_scenes_equal_the_python_path(shared_tmp, ref, scene, sets) -> None:
    res = run(load_scenario(DEMOS / scene, [NOXDMF, *sets]), shared_tmp)
    assert_same_histories(reference(ref), res.history, REFERENCE_RTOL)
