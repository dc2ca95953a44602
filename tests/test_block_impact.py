"""A wheel's flange striking its rail's side at v0, verified by the bar-impact laws (issue 16
item 5): demos/block_impact.toml, a block with ν = 0 striking a rigid face at v0. Its stress
is then uniaxial, so it is a bar of length L: from the first contact at t = gap/v0 the face
pushes with ρ c A v0 (c = √(E/ρ)) for 2 L/c, an impulse of 2 M v0, and the block leaves at v0.
CD-Lagrange stops the contact nodes at each impact (their kinetic energy is lost), so the
impulse and rebound converge at O(h) (the bar's first order, issue 2)."""

import math
from pathlib import Path

import numpy as np
import pytest
from conftest import COMM

from crane_fem.driver import run_scenario
from crane_fem.scenario import load_scenario

SCENE = Path(__file__).parent.parent / "demos" / "block_impact.toml"
E, RHO, V0, L, A, GAP = 1e8, 1000.0, 0.1, 0.1, 0.01, 1e-4
C = math.sqrt(E / RHO)
F0, T_C, M = RHO * C * A * V0, 2.0 * L / C, RHO * A * L


@pytest.fixture(scope="module")
def impacts(tmp_path_factory) -> dict[float, tuple[dict, dict]]:
    root = Path(COMM.bcast(str(tmp_path_factory.mktemp("block_impact")), root=0))
    out = {}
    for h in (0.0125, 0.00625):  # 8 and 16 layers along the impact
        sc = load_scenario(SCENE, [f"model.h={h}"])
        run = run_scenario(sc, root / f"h{h:g}", COMM, progress=False)
        out[h] = (run.history, run.summary)
    return out


def test_block_strikes_a_rigid_face_by_the_bar_impact_laws(impacts) -> None:
    """Measured (h = 0.0125, 0.00625 m): plateau force (the median while in contact)
    −0.87 %, −0.15 % of ρ c A v0 (asserted 1 %); time above half of it −2.1 %, −0.15 % of
    2 L/c (asserted 3 %); impulse −3.9 %, −2.3 % of 2 M v0 (asserted 5 %, and smaller on the
    finer mesh: the contact layer's lost kinetic energy); the first contact within a step of
    gap/v0; the energy balance, with the contact's dissipation, to 1e-13 (asserted 1e-10)."""
    deficits = []
    for h, (hist, s) in impacts.items():
        t, f, dt = hist["t"], hist["force_plane"], s["dt"]
        assert s["status"] == "completed" and np.all(np.diff(t) == pytest.approx(dt, rel=1e-9))
        touching = f > 0.0
        assert np.median(f[touching]) == pytest.approx(F0, rel=0.01), h
        assert np.count_nonzero(f > 0.5 * F0) * dt == pytest.approx(T_C, rel=0.03), h
        onset = t[np.argmax(touching)]
        assert GAP / V0 <= onset <= GAP / V0 + dt, h
        impulse = float(np.sum(f) * dt)
        deficit = 1.0 - impulse / (2.0 * M * V0)
        assert 0.0 < deficit < 0.05, h
        deficits.append(deficit)
        # The block leaves with the impulse's velocity, away from the face.
        assert hist["vz_mean"][-1] == pytest.approx(impulse / M - V0, rel=1e-9), h
        assert s["energy_balance_error"] <= 1e-10, h
    assert deficits[1] < 0.7 * deficits[0]
