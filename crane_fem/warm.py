"""The kernels a scene runs, compiled ahead of its runs in two halves on two processes.

A scene's first run compiles the explicit step's call graph (about 70 s of numba on a fresh
install, one core: ``crane_fem.kernels.explicit.run_steps`` and the ~40 functions it calls,
each cached on disk as it is compiled). Two runs started side by side (``make demo``) each
compile all of it. Here the leaves of that graph are shared out instead: each of two
processes sets the scene up (the kernels' argument types are its zone's), then compiles one
:data:`HALVES` of the callees; the runs that follow load them from the cache and compile only
the step itself (``_micro``, ``run_steps``). A callee compiled here with other argument types
than the step passes it is only time lost: the step compiles its own.

    python -m crane_fem.warm SCENE HALF     # HALF: 0 or 1; run both at once
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numba
from numba import types

__all__ = ["HALVES", "compile_half"]

_B = types.Array(types.boolean, 1, "C")
_F = types.Array(types.float64, 1, "C")
_I = types.Array(types.int64, 1, "C")
_F2 = types.Array(types.float64, 2, "C")


def _contacts(z: Any, op: Any, st: Any) -> list[tuple[Callable[..., Any], tuple[Any, ...]]]:
    """The chain the step waits on: the frictional contact solve, then the contact LCP and
    the interface solve that call it."""
    from crane_fem.kernels import friction, interface

    return [
        (friction.contacts_friction, (z, st, _B, _F, _I)),
        (interface.contacts_exact, (z, st, _B, _F, _I)),
        (interface.solve_mixed, (z, op, st, types.float64, _B, _I)),
    ]


def _beside(z: Any, op: Any, st: Any) -> list[tuple[Callable[..., Any], tuple[Any, ...]]]:
    """What the chain does not call, and (first, before the chain reaches it) the coupled
    points' Coulomb solver."""
    from crane_fem.kernels import explicit, friction, interface, lcp, stiffness

    return [
        (friction.solve_coulomb, (_F2, _F, _I, _F, _F)),
        (lcp.lcp_exact, (_F2, _F)),
        (stiffness.free_rows, (z, st, _I, _F, types.float64, types.boolean)),
        (stiffness.stiffness_velocity, (z, st)),
        (explicit._ropes, (z, _F, _F, _B, types.int64, types.float64)),
        (interface.apply_operator, (op, types.float64, _F, _F)),
    ]


#: The two halves of the step's callees.
HALVES = (_contacts, _beside)


def compile_half(scene: Path, half: int) -> float:
    """Set ``scene`` up on this process alone and compile :data:`HALVES` [``half``] for its
    explicit zone's types; the seconds spent compiling (0: nothing to do, the step is in the
    cache already, or the scene has no explicit zone)."""
    from mpi4py import MPI

    from crane_fem.integrators.explicit_zone import ExplicitZone
    from crane_fem.pipeline import create_simulation
    from crane_fem.scenario import load_scenario

    ExplicitZone.compile_on_setup = False
    import crane_fem.kernels  # noqa: F401  (sets numba's cache directory)

    if any(Path(numba.config.CACHE_DIR).rglob("explicit.run_steps-*.nbi")):  # type: ignore[attr-defined]
        return 0.0  # compiled already: the runs load the step from the cache
    sim = create_simulation(load_scenario(scene, []), MPI.COMM_SELF)
    try:
        zone = sim.integrators.explicit
        if zone is None:
            return 0.0
        z, op, st = (numba.typeof(a) for a in (zone.zone, zone._no_op, zone.state))
        t0 = time.perf_counter()
        for fn, sig in HALVES[half](z, op, st):
            fn.compile(sig)  # type: ignore[attr-defined]
        return time.perf_counter() - t0
    finally:
        sim.destroy()


if __name__ == "__main__":
    import dolfinx_solver  # noqa: F401  (before dolfinx and petsc4py)

    spent = compile_half(Path(sys.argv[1]), int(sys.argv[2]))
    print(f"crane_fem.warm: half {sys.argv[2]} compiled in {spent:.1f} s")
