"""crane_fem.warm (``make demo``'s two-process compilation of the step's callees): its
signatures are the ones the step itself compiles, so that the runs load them instead of
compiling them again."""

from __future__ import annotations

from pathlib import Path

import numba
import pytest
from mpi4py import MPI

from crane_fem.pipeline import create_simulation
from crane_fem.scenario import load_scenario
from crane_fem.warm import HALVES

DEMO = Path(__file__).parent.parent / "demos" / "crane.toml"


@pytest.mark.serial  # one process's numba cache
def test_warm_halves_are_the_steps_own_callees() -> None:
    """The demo scene set up (its step compiled or loaded from the cache, callees included):
    each callee of both halves, compiled for the zone's types, is a cache hit — a signature
    the step does not call would be compiled afresh (a miss) and the runs would compile the
    one they need themselves — and no callee is in both halves."""
    sim = create_simulation(load_scenario(DEMO, []), MPI.COMM_SELF)
    try:
        zone = sim.integrators.explicit
        assert zone is not None
        types = [numba.typeof(a) for a in (zone.zone, zone._no_op, zone.state)]
        names = []
        for half in HALVES:
            for fn, sig in half(*types):
                misses = sum(fn.stats.cache_misses.values())
                fn.compile(sig)
                assert sum(fn.stats.cache_misses.values()) == misses, fn.__name__
                assert tuple(sig) in fn.signatures, fn.__name__
                names.append(fn.__name__)
        assert len(set(names)) == len(names)  # no callee compiled by both processes
    finally:
        sim.destroy()
