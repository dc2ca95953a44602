"""The compiled explicit kernel against its NumPy twin (crane_fem.kernels.reference) on every
branch it has: bar and 3D zones, Rayleigh damping with a stiffness part, the exact LCP with
diagonal and coupled contact rows, the penalty law, bilateral rows, interface rows solved by
each form of the interface operator or imposed, an interface row that shares a DOF with a
contact; and the small exact LCP and the interface operator on their own."""

from pathlib import Path

import numpy as np
import pytest
from conftest import COMM, make_scenario

from crane_fem.contact import ContactSet, solve_lcp
from crane_fem.coupling.operator import create_interface_operator
from crane_fem.errors import CraneFemError
from crane_fem.integrators.explicit_zone import ExplicitZone
from crane_fem.kernels import explicit as kx
from crane_fem.kernels import reference as twin
from crane_fem.kernels.lcp import lcp_exact
from crane_fem.pipeline import create_simulation
from crane_fem.scenario import load_scenario

DEMOS = Path(__file__).parent.parent / "demos"
pytestmark = pytest.mark.serial  # the twin runs on one rank


def _twin_zone(E: ExplicitZone) -> ExplicitZone:
    """A second zone on the same model, loads and constraints, in the same state."""
    rows = E.stack.subset(np.arange(E.stack.p) < E.n_gamma)
    F = ExplicitZone(E.model, E.load, E.dt, E.u.copy(), E.v0, rows, E.contacts)
    F.restore(E.save())
    F.zone = F.zone._replace(W_cc_inv=E.zone.W_cc_inv)
    return F


def _compare(
    E: ExplicitZone, ctl: kx.Steps, op: kx.InterfaceOp | None = None, rtol: float = 1e-11
) -> None:
    """n micro steps by the kernel on E and by the twin on a copy: the same state, impulses,
    gaps and sums to round-off, ``rtol`` of each array's scale (the twin sums in other
    orders, applies A_k⁻¹ as an assembled matrix, and solves the non-diagonal LCPs with
    SciPy's NNLS where the kernel runs its own active-set method)."""
    F = _twin_zone(E)
    out = E.advance(ctl, op)
    ref = kx.StepsOut(
        np.zeros_like(out.lam),
        np.zeros_like(out.gaps),
        np.zeros_like(out.active),
        np.zeros_like(out.group_impulse),
        np.zeros_like(out.group_gap),
        np.zeros_like(out.sums),
        np.zeros_like(out.impulse_trap),
        np.zeros_like(out.impulse_sum),
        np.zeros_like(out.impulses),
        np.zeros_like(out.w),
        np.zeros_like(out.flags),
    )
    twin.run_steps(F.zone, op if op is not None else E._no_op, F.state, ctl, ref)

    def close(a: np.ndarray, b: np.ndarray, what: str, like: np.ndarray | None = None) -> None:
        scale = max(float(np.max(np.abs(b if like is None else like), initial=0.0)), 1e-300)
        assert np.max(np.abs(a - b), initial=0.0) <= rtol * scale, what

    for name in ("u", "vh", "v_int", "ku"):
        close(getattr(E, name), getattr(F, name), name)
    close(out.lam, ref.lam, "lam")
    close(out.gaps, ref.gaps, "gaps")
    close(out.impulse_trap, ref.impulse_trap, "impulse_trap")
    close(out.impulse_sum, ref.impulse_sum, "impulse_sum")
    close(out.impulses, ref.impulses, "impulses")
    close(out.w, ref.w, "w")
    assert np.array_equal(out.active, ref.active)
    close(out.group_impulse, ref.group_impulse, "group_impulse")
    fin = np.isfinite(ref.group_gap)  # (a group without points has no gap)
    assert np.array_equal(fin, np.isfinite(out.group_gap))
    # (in the scale of all the gaps: the closed groups' gaps are round-off)
    close(out.group_gap[fin], ref.group_gap[fin], "group_gap", like=ref.gaps)
    assert np.array_equal(out.flags, ref.flags)
    energy = max(float(np.max(np.abs(ref.sums[:4]))), 1e-300)
    assert np.max(np.abs(out.sums[:4] - ref.sums[:4])) <= rtol * energy
    link = max(float(np.max(np.abs(ref.sums[4:]))), 1e-300)
    assert np.max(np.abs(out.sums[4:] - ref.sums[4:])) <= rtol * link
    assert any(np.any(a != 0.0) for a in (E.u, E.vh))  # something moved
    F.destroy()


def _bar(**kw) -> ExplicitZone:
    sc = make_scenario(coupling={"method": "monolithic", "scheme": "cd-lagrange"}, **kw)
    sim = create_simulation(sc, COMM)
    return sim.integrators.explicit


@pytest.mark.parametrize("beta", [0.0, 1e-4])
def test_bar_on_the_wall_exact_contact_and_damping(beta) -> None:
    """1D bar hitting the wall (bs = 1), mass and stiffness proportional damping."""
    E = _bar(material={"E": 1.0, "rho": 1.0, "rayleigh": [0.3, beta]}, time={"end": 0.5})
    n = 120  # past the impact at t = 0.1
    _compare(E, E.steps(0.0, n, h0=0.5 * E.dt, move0=False))
    _compare(E, E.steps(n * E.dt, 50))


def test_bar_penalty_law() -> None:
    E = _bar(time={"end": 0.5})
    _compare(E, E.steps(0.0, 150, law=kx.LAW_PENALTY, penalty=50.0))


def test_coupled_contacts_and_an_interface_row_on_a_contact_dof() -> None:
    """A bar with non-diagonal contact rows (two rows on one DOF) and an interface row on the
    wall DOF (W_Γc ≠ 0): the mixed LCP through the Schur complement, solved and imposed."""
    E = _bar(time={"end": 0.5})
    c = E.contacts
    d0 = int(c.dofs[0])
    contacts = ContactSet(
        COMM,
        np.array([0.1, 0.12]),
        np.array([0, 1, 1]),
        np.array([d0, d0, d0 + 1]),
        np.array([1.0, 1.0, -0.5]),
        np.array([0, 0]),
        ["wall"],
    )
    rows = ContactSet(
        COMM,
        np.zeros(1),
        np.array([0]),
        np.array([d0]),
        np.array([1.0]),
        np.zeros(1, np.int64),
        ["interface"],
    )
    v0 = np.full(E.model.n_owned, -1.0)
    Z = ExplicitZone(E.model, E.load, E.dt, np.zeros_like(v0), v0, rows, contacts)
    assert not Z.zone.ec_zero and not Z.zone.cc_diagonal
    W_I = np.array([[0.7 / float(Z.zone.w_gamma[0])]])
    op, _ = create_interface_operator(Z.zone.w_gamma, W_I, 0.5, 10)
    j = np.arange(1, 61)
    ctl = Z.steps(
        0.0,
        60,
        mode=kx.SOLVED,
        targets=(np.array([-0.2]), np.array([0.1])),
        tc=np.column_stack([1.0 - j / 60, j / 60]),
        k_op=(j % 10 + 1).astype(float),
        keep_impulses=True,
    )
    _compare(Z, ctl, op)
    ctl = Z.steps(
        60 * Z.dt,
        40,
        mode=kx.IMPOSED,
        imposed=(np.array([0.3]), np.array([-0.1])),
        ic=np.column_stack([np.ones(40), np.linspace(0.0, 1.0, 40)]),
    )
    _compare(Z, ctl)
    Z.destroy()


def test_interface_rows_sharing_dofs() -> None:
    """Two interface rows on the same two DOFs (W_ΓΓ full, as a rigid section's six rows on
    one face) beside a contact on one of them: the kernel's interface bookkeeping (L V =
    q + W Λ with W_ΓΓ's terms off the diagonal) and its solve through the folded operator
    against the twin, solved and imposed."""
    E = _bar(time={"end": 0.5})
    d0 = int(E.contacts.dofs[0])
    rows = ContactSet(
        COMM,
        np.zeros(2),
        np.array([0, 0, 1, 1]),
        np.array([d0 + 1, d0 + 2, d0 + 1, d0 + 2]),
        np.array([1.0, 1.0, 0.5, -1.5]),
        np.zeros(2, np.int64),
        ["interface"],
    )
    v0 = np.full(E.model.n_owned, -1.0)
    Z = ExplicitZone(E.model, E.load, E.dt, np.zeros_like(v0), v0, rows, E.contacts)
    assert Z.zone.gg_ptr.size == 3 and Z.zone.gg_col.size == 2
    W_E = Z.W[:2, :2]
    W_I = 0.3 * W_E + np.diag([0.1, 0.2]) * float(np.max(W_E))
    op, _ = create_interface_operator(W_E, W_I, 0.5, 10)
    j = np.arange(1, 61)
    ctl = Z.steps(
        0.0,
        60,
        mode=kx.SOLVED,
        targets=(np.array([-0.2, 0.1]), np.array([0.1, 0.0])),
        tc=np.column_stack([1.0 - j / 60, j / 60]),
        k_op=(j % 10 + 1).astype(float),
        keep_impulses=True,
    )
    _compare(Z, ctl, op)
    ctl = Z.steps(
        60 * Z.dt,
        40,
        mode=kx.IMPOSED,
        imposed=(np.array([0.3, 0.0]), np.array([-0.1, 0.2])),
        ic=np.column_stack([np.ones(40), np.linspace(0.0, 1.0, 40)]),
    )
    _compare(Z, ctl)
    Z.destroy()
    dependent = ContactSet(
        COMM,
        np.zeros(2),
        np.array([0, 1]),
        np.array([d0 + 1, d0 + 1]),
        np.array([1.0, 2.0]),
        np.zeros(2, np.int64),
        ["interface"],
    )
    with pytest.raises(CraneFemError, match="independent"):
        ExplicitZone(E.model, E.load, E.dt, np.zeros_like(v0), v0, dependent, E.contacts)


def test_interface_operator_with_coupled_explicit_rows() -> None:
    """W_E,ΓΓ block diagonal (6 × 6 blocks, a rigid section's rows per face): A_k⁻¹ through
    the Cholesky fold against the inverse of W_E + 2kγ W_I, for every k and for k = m only;
    a truncation, or blocks that split a face's rows, refused."""
    rng = np.random.default_rng(2)
    n, gamma, m = 24, 0.5, 20
    blocks = np.repeat([0, 1], n // 2)
    W_E = np.zeros((n, n))
    W_I = np.zeros((n, n))
    for f in range(n // 6):
        sel = slice(6 * f, 6 * f + 6)
        A = rng.standard_normal((6, 6))
        W_E[sel, sel] = A @ A.T + 6.0 * np.eye(6)
    for b in (0, 1):
        sel = blocks == b
        B = rng.standard_normal((n // 2, n // 2))
        W_I[np.ix_(sel, sel)] = 0.05 * (B @ B.T)
    for fixed in (False, True):
        op, _ = create_interface_operator(W_E, W_I, gamma, m, blocks, fixed=fixed)
        for k in (1.0, 7.0, float(m)) if not fixed else (float(m),):
            exact = np.linalg.inv(W_E + 2 * k * gamma * W_I)
            assert np.max(np.abs(twin.operator_matrix(op, k) - exact)) <= 1e-12 * np.max(
                np.abs(exact)
            )
            x = rng.standard_normal(n)
            y = np.zeros(n)
            kx.apply_operator(op, k, x, y)
            assert np.max(np.abs(y - exact @ x)) <= 1e-12 * np.max(np.abs(exact @ x))
    with pytest.raises(ValueError, match="truncation"):
        create_interface_operator(W_E, W_I, gamma, m, blocks, truncation=0.05)
    with pytest.raises(ValueError, match="split"):
        create_interface_operator(W_E, W_I, gamma, m, np.arange(n) % 2)


@pytest.fixture(scope="module")
def crane_zone():
    """The quick crane scene's explicit zone (bs = 3, 444 interface rows, 32 contact pairs)
    and the exact GC operator."""
    sc = load_scenario(DEMOS / "crane_quick.toml", ["output.xdmf=false"])
    sim = create_simulation(sc, COMM)
    sim.integrators.method.initialize(sim.integrators.interface_force0)
    yield sim
    sim.destroy()


@pytest.mark.parametrize(
    "form",
    [{}, {"single": True}, {"truncation": 0.05}],
    ids=["exact", "single", "truncated"],
)
def test_crane_zone_gc_micro_steps(crane_zone, form) -> None:
    """GC micro steps of the crane zone, with each form of the interface operator."""
    sim = crane_zone
    E, I = sim.integrators.explicit, sim.integrators.implicit  # noqa: E741
    labels = np.arange(E.n_gamma) % 3  # three blocks, to exercise the block structure
    op, _ = create_interface_operator(E.zone.w_gamma, I.W, I.gamma, 100, labels, **form)
    m = 100
    j = np.arange(1, m + 1)
    rng = np.random.default_rng(2)
    targets = (1e-3 * rng.standard_normal(E.n_gamma), 1e-3 * rng.standard_normal(E.n_gamma))
    state = E.save()
    ctl = E.steps(
        1e-3,
        m,
        mode=kx.SOLVED,
        targets=targets,
        tc=np.column_stack([1 - j / m, j / m]),
        k_op=j.astype(float),
        watch=np.ones(E.contacts.p, bool),
    )
    # The interface rows are solved 100 times with A_k of condition up to ~1e2 (the kernel by
    # two products with Q, the twin with the assembled inverse): their round-off reaches the
    # velocities at 5e-11 of their scale after the 100 micro steps (measured); 1e-9 bounds it.
    _compare(E, ctl, op, rtol=1e-9)
    E.restore(state)


def test_crane_zone_bilateral_rows(crane_zone) -> None:
    """The linear probes of "ec" and "ph": contacts held as bilateral rows, interface imposed."""
    E = crane_zone.integrators.explicit
    state = E.save()
    n_g, p_c = E.n_gamma, E.contacts.p
    Winv = np.linalg.inv(E.W[n_g:, n_g:])
    E.with_bilateral_contacts(Winv)
    e = np.zeros(n_g)
    e[5] = 1.0
    ctl = E.steps(
        0.0,
        50,
        mode=kx.IMPOSED,
        law=kx.LAW_BILATERAL,
        imposed=(e, np.zeros(n_g)),
        ic=np.column_stack([np.linspace(0, 1, 50), np.zeros(50)]),
    )
    _compare(E, ctl)
    E.restore(state)
    assert p_c > 0


def test_lcp_exact_matches_nnls() -> None:
    """The compiled active-set LCP against the NNLS route (SciPy) on random SPD problems with
    active and inactive rows."""
    rng = np.random.default_rng(0)
    for n in (1, 2, 5, 12):
        for _ in range(20):
            B = rng.standard_normal((n, n))
            W = B @ B.T + 0.1 * np.eye(n)
            q = rng.standard_normal(n)
            lam, ok = lcp_exact(W, q)
            ref = solve_lcp(W, q, np.ones(n, bool), False)
            assert ok
            assert np.max(np.abs(lam - ref)) <= 1e-10 * max(np.max(np.abs(ref)), 1.0)
            w = q + W @ lam
            assert np.all(lam >= 0.0) and np.all(w >= -1e-10) and abs(lam @ w) <= 1e-10


def test_interface_operator_forms() -> None:
    """A_k⁻¹ of each form against the inverse of D + 2kγ W_I: blocks of a block-diagonal W_I
    exact; single precision within 1e-6; a truncation ε changes each dropped mode's
    component by at most ε (in the D-scaled norm); the compiled apply equals the twin's."""
    rng = np.random.default_rng(1)
    n, gamma, m = 40, 0.5, 50
    d = rng.uniform(1.0, 2.0, n)
    blocks = np.repeat([0, 1], n // 2)
    W = np.zeros((n, n))
    for b in (0, 1):
        sel = blocks == b
        B = rng.standard_normal((n // 2, n // 2))
        W[np.ix_(sel, sel)] = 0.02 * (B @ B.T) / n
    for k in (1.0, 17.0, float(m)):
        exact = np.linalg.inv(np.diag(d) + 2 * k * gamma * W)
        for form, tol in (({"blocks": blocks}, 1e-12), ({"single": True}, 1e-6)):
            op, report = create_interface_operator(d, W, gamma, m, **form)
            A = twin.operator_matrix(op, k)
            assert np.max(np.abs(A - exact)) <= tol * np.max(np.abs(exact))
            x = rng.standard_normal(n)
            y = np.zeros(n)
            kx.apply_operator(op, k, x, y)
            assert np.max(np.abs(y - A @ x)) <= 1e-12 * np.max(np.abs(A @ x))
        eps = 0.05
        op, report = create_interface_operator(d, W, gamma, m, truncation=eps)
        assert report.modes_kept < n
        sq = np.sqrt(d)
        err = sq[:, None] * (twin.operator_matrix(op, k) - exact) * sq[None, :]
        assert np.linalg.norm(err, 2) <= eps
    # The form for k = m only (gc-mean): each block A_m⁻¹ itself, one product per solve.
    exact = np.linalg.inv(np.diag(d) + 2 * m * gamma * W)
    for form, tol in (({"blocks": blocks}, 1e-12), ({"single": True}, 1e-6)):
        op, report = create_interface_operator(d, W, gamma, m, fixed=True, **form)
        A = twin.operator_matrix(op, m)
        assert np.max(np.abs(A - exact)) <= tol * np.max(np.abs(exact))
        x = rng.standard_normal(n)
        y = np.zeros(n)
        kx.apply_operator(op, float(m), x, y)
        assert np.max(np.abs(y - A @ x)) <= 1e-12 * np.max(np.abs(A @ x))
    assert report.work == n * n  # one block of n rows (no labels): n² multiply-adds
    with pytest.raises(ValueError, match="truncation"):
        create_interface_operator(d, W, gamma, m, truncation=1.0)


def test_contact_rows_replaced_between_calls(crane_zone) -> None:
    """`ExplicitZone.set_contacts` rebuilds the zone's constraint arrays between kernel calls
    (the hook of a re-pairing), the kernel reused as compiled: with the same rows the next
    macro step is the one without the call, to the bit; with the contact points halved (every
    other pair of the four wheels) the arrays follow (p, the Delassus block, the state's
    sizes) and the step runs."""
    sim = crane_zone
    E = sim.integrators.explicit
    state = E.save()
    ctl = E.steps(1e-3, 50, mode=kx.NONE, watch=np.ones(E.contacts.p, bool))
    ref = E.advance(ctl)
    u_ref = E.u.copy()
    E.restore(state)
    E.set_contacts(E.contacts)
    out = E.advance(ctl)
    assert np.array_equal(E.u, u_ref)
    assert np.array_equal(out.lam, ref.lam) and np.array_equal(out.group_impulse, ref.group_impulse)
    E.restore(state)
    keep = np.arange(E.contacts.p) % 2 == 0
    full = E.contacts
    E.set_contacts(full.subset(keep))
    try:
        assert E.zone.p == E.n_gamma + int(keep.sum())
        assert E.zone.W_cc.shape == (int(keep.sum()),) * 2
        assert E.state.lam.size == E.zone.p
        ctl = E.steps(1e-3, 50, mode=kx.NONE, watch=np.ones(int(keep.sum()), bool))
        half = E.advance(ctl)
        assert np.all(np.isfinite(E.u)) and np.all(half.lam[E.n_gamma :] >= 0.0)
    finally:
        E.restore(state)
        E.set_contacts(full)
