"""Bar on a rigid wall (THEORY.md §5): CD-Lagrange against the exact impact solution,
and the penalty and Moreau–Jean baselines on the same meshes."""

import math

import numpy as np
import pytest
from conftest import make_scenario, run

from crane_fem.exact import WallImpact

# (L, E, rho, v0, gap, elements, area): unit bar, steel bar, soft short bar, coarse mesh.
CASES = [
    (1.0, 1.0, 1.0, -1.0, 0.1, 100, 1.0),
    (2.0, 2.1e11, 7800.0, -5.0, 1.0e-4, 200, 1.0e-4),
    (0.5, 4.0e6, 1000.0, -0.3, 2.0e-3, 150, 2.0e-3),
    (3.0, 9.0, 1.0, -2.0, 0.5, 40, 1.0),
]


@pytest.mark.parametrize(("L", "E", "rho", "v0", "gap", "ne", "A"), CASES)
def test_cd_lagrange_wall_impact(shared_tmp, L, E, rho, v0, gap, ne, A) -> None:
    c = math.sqrt(E / rho)
    exact = WallImpact(L, c, v0, gap)
    sc = make_scenario(
        model={"length": L, "elements": ne, "area": A},
        material={"E": E, "rho": rho},
        initial={"velocity": v0},
        contact=[{"type": "wall", "gap": gap}],
        time={"end": exact.t_contact + 1.25 * exact.duration, "dt_factor": 0.9},
    )
    res = run(sc, shared_tmp)
    s, h = res.summary, res.history
    dt, hel = s["dt"], L / ne
    # The computed critical step of a uniform P1 bar with row-sum lumping is exactly h/c.
    assert s["dt_critical"] == pytest.approx(hel / c, rel=1e-9)

    # One contact interval, no chatter, lasting 2L/c within 2h/c + Δt.
    assert s["contact_intervals"] == 1
    ((t_first, t_last),) = s["contact_interval_times"]
    assert abs((t_last - t_first) - exact.duration) <= 2 * hel / c + dt
    assert abs(t_first - exact.t_contact) <= dt

    # Impulse of the multipliers: 2 ρ A L |v0| within 1 %.
    impulse = float(np.sum(h["contact_force"]) * dt)
    assert impulse == pytest.approx(2 * rho * A * L * abs(v0), rel=0.01)

    # The bar leaves with most of its kinetic energy (the impact law loses only what the
    # contact node carries: O(h/L)); at >= 100 elements at least 95 %.
    if ne >= 100:
        assert h["kinetic"][-1] >= 0.95 * h["kinetic"][0]
    assert h["velocity_bar1"][-1] == pytest.approx(-v0, rel=0.05 if ne >= 100 else 0.1)

    # Energy balance: the discrete balance of THEORY.md §1 closes to round-off; 1e-10
    # relative leaves a margin of ~1e3 over the accumulated round-off of these runs.
    total = h["total"]
    assert np.max(total - total[0]) <= 1e-10 * abs(total[0])
    assert s["energy_balance_error"] <= 1e-10
    # Contact only removes energy (velocity-level impact law with zero restitution).
    assert h["contact_dissipated"][-1] >= 0.0


def test_cd_lagrange_displacement_field_after_separation(shared_tmp) -> None:
    """The end state against d'Alembert: the rigid rebound u = 2v0(t_c + L/c) − v0 t."""
    sc = make_scenario(model={"elements": 400}, time={"end": 2.4})
    res = run(sc, shared_tmp)
    exact = WallImpact(1.0, 1.0, -1.0, 0.1)
    u_end = exact.displacement(np.array([0.0]), float(res.history["t"][-1]))[0]
    # The contact end position: gap + u(0); a P1 mesh delays the rebound by O(h/c), so its
    # position is off by at most a few |v0| h / c = 2.5e-3 each; we allow 4 element transits.
    assert res.history["gap_wall"][-1] == pytest.approx(0.1 + u_end, abs=4 * 1.0 / 400)


def test_penalty_chatter_and_energy_error_grow_with_stiffness(shared_tmp) -> None:
    """Penalty baseline: with k_p ≥ 10 EA/h the contact chatters and creates energy, which
    CD-Lagrange on the same mesh does not (Δt = 0.9 × each scheme's own limit)."""
    EA_over_h = 100.0
    intervals, energy_error = [], []
    for k in (0.1, 1.0, 10.0, 100.0):
        sc = make_scenario(integrator={"scheme": "penalty", "penalty": k * EA_over_h})
        res = run(sc, shared_tmp)
        assert res.summary["dt_critical_penalty"] < res.summary["dt_critical"]
        h = res.history
        intervals.append(res.summary["contact_intervals"])
        energy_error.append(abs(h["kinetic"][-1] / h["kinetic"][0] - 1.0))
    # Soft springs: one contact interval; stiff springs: many (chatter).
    assert intervals[0] == 1 and intervals[1] == 1
    assert intervals[2] > 10 and intervals[3] > 10
    # Energy error after separation: stiff penalty is an order of magnitude worse.
    assert min(energy_error[2:]) > 10 * max(energy_error[:2])
    cd = run(make_scenario(), shared_tmp).history
    assert abs(cd["kinetic"][-1] / cd["kinetic"][0] - 1.0) < 0.01 < min(energy_error[2:])


@pytest.mark.parametrize("factor", [2.0, 5.0])
@pytest.mark.parametrize("theta", [0.5, 1.0])
def test_moreau_jean_above_explicit_limit(shared_tmp, factor, theta) -> None:
    """Moreau–Jean is implicit: it runs at several times the explicit limit, with a balance that
    closes (its θ > ½ dissipation booked as numerical_dissipated) and a bounded energy."""
    sc = make_scenario(
        integrator={"scheme": "moreau-jean", "theta": theta}, time={"dt_factor": factor}
    )
    res = run(sc, shared_tmp)
    s, h = res.summary, res.history
    assert s["dt"] > s["dt_critical"]
    assert s["energy_balance_error"] <= 1e-10
    assert np.all(h["kinetic"] <= h["kinetic"][0] * (1 + 1e-12))
    # The bar still rebounds: the contact ends within a few steps of 2L/c after it began.
    t_first, _ = s["contact_interval_times"][0]
    _, t_last = s["contact_interval_times"][-1]
    assert abs((t_last - t_first) - 2.0) <= 2 * s["dt"] + 2 * 0.01
    assert h["velocity_bar1"][-1] > 0.5
    if theta == 1.0:
        assert h["numerical_dissipated"][-1] > 0.0
    else:
        assert abs(h["numerical_dissipated"][-1]) < 1e-12
