"""Verification of the Timoshenko beam (crane_fem/formulations/beam.py, docs/theory-notes.md
§17) against exact solutions: a slender cantilever along an oblique axis (its bending frequencies
in both planes against Euler–Bernoulli, its torsion against the rod's, its tip deflection
under an end load along each local axis against the closed form with shear), the
reduced-integration element's convergence on a very slender cantilever (no shear locking),
a thick simply supported beam against Timoshenko's frequency equation; and the rectangle's
torsion constant (crane_fem/formulations/sections.py) against Saint-Venant's series.

Every structure goes through the pipeline (FrameSketch → ``[model] kind = "frame"`` →
build_mesh → assemble_closed_structure); the checks are global and collective, so they run
alike serially and on two ranks (the two-rank pass checks the partitioned assembly).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest
from conftest import COMM
from mpi4py import MPI
from petsc4py import PETSc

from crane_fem.formulations import sections
from crane_fem.geometry.frame_sketch import FrameSketch
from crane_fem.modes.eigen import solve_modes
from crane_fem.modes.operators import ClosedStructure, assemble_closed_structure
from crane_fem.pipeline import build_mesh
from crane_fem.scenario import parse_scenario

FloatArray = npt.NDArray[np.float64]

E, NU, RHO = 2.1e11, 0.3, 7800.0
G = E / (2.0 * (1.0 + NU))
#: b (along a1) × h (along a2): I1 = 4 I2, so the two planes' frequencies differ by 2.
B, H = 0.05, 0.1
SECTION = sections.rectangle(B, H)
#: The member's axis, oblique to every global axis, and an orientation vector not along it.
AXIS = np.array([1.0, 2.0, 0.5]) / math.sqrt(5.25)
ORIENTATION = np.array([0.0, 0.0, 1.0])
#: Euler–Bernoulli cantilever roots β_n L of cos βL cosh βL = −1.
BETA_L = np.array([1.8751, 4.6941, 7.8548])


def local_frame(t: FloatArray, v: FloatArray) -> tuple[FloatArray, FloatArray]:
    """(a1, a2) of the docs, written out here rather than taken from the formulation:
    a2 the orientation made orthogonal to t, a1 = a2 × t."""
    a2 = v - np.dot(v, t) * t
    a2 /= np.linalg.norm(a2)
    return np.cross(a2, t), a2


A1, A2 = local_frame(AXIS, ORIENTATION)


@dataclass
class Beam:
    """A straight member through the pipeline: its closed structure (owning K, M) and the
    owned coordinates of its DOF blocks."""

    st: ClosedStructure
    x: FloatArray

    def block(self, point: FloatArray) -> int | None:
        """The owned block at ``point``, or None on the ranks that do not own it."""
        d = np.linalg.norm(self.x - point, axis=1)
        i = int(np.argmin(d)) if d.size else -1
        return i if i >= 0 and d[i] < 1e-9 else None

    def owned(self, free_values: FloatArray) -> FloatArray:
        """(owned blocks, 6) of a free-DOF vector, zero on the supported DOFs."""
        z = np.zeros(self.x.shape[0] * 6)
        z[self.st.free] = free_values
        return z.reshape(-1, 6)


@contextmanager
def beam(
    tmp: Path,
    length: float,
    elements: int,
    supports: dict[str, str],
) -> Iterator[Beam]:
    """A member from the origin along AXIS, ``elements`` elements, section B × H oriented by
    ORIENTATION, with the supports {"root" | "tip": "clamped" | "pinned"} (collective; gmsh
    on rank 0, into ``tmp``, the same directory on every rank)."""
    path = tmp / f"beam_{length}_{elements}.msh"
    tip = length * AXIS
    if COMM.rank == 0:
        sketch = FrameSketch()
        sketch.member("beam", (0.0, 0.0, 0.0), tip, elements=elements)
        sketch.points("root", [(0.0, 0.0, 0.0)])
        sketch.points("tip", [tuple(tip)])
        sketch.write(path)
    COMM.barrier()
    sec = {"groups": ["beam"], "orientation": ORIENTATION.tolist()}
    sc = parse_scenario(
        {
            "model": {"kind": "frame", "mesh": str(path)},
            "section": [{**sec, "shape": "rectangle", "b": B, "h": H}],
            "material": {"E": E, "nu": NU, "rho": RHO},
            "support": [{"group": g, "dofs": d} for g, d in supports.items()],
            "time": {"end": 1.0, "dt_factor": 0.9},
        }
    )
    mesh = build_mesh(sc, COMM)
    st = assemble_closed_structure(mesh, E, NU, RHO, np.zeros(3))
    n_own = st.V.dofmap.index_map.size_local
    try:
        yield Beam(st, st.V.tabulate_dof_coordinates()[:n_own])
    finally:
        st.destroy()


def tip_displacement(b: Beam, tip: FloatArray, load: FloatArray) -> FloatArray:
    """The tip's displacement (global, 3) under the force ``load`` (N) there: K u = f on the
    free DOFs, LU (MUMPS) (collective)."""
    st = b.st
    f = st.K.createVecLeft()
    u = st.K.createVecRight()
    ksp = PETSc.KSP().create(st.comm)
    try:
        blk = b.block(tip)
        if blk is not None:
            rows = np.searchsorted(st.free, 6 * blk + np.arange(3))
            f.array[rows] = load
        ksp.setOptionsPrefix("test_beams_static_")
        ksp.setOperators(st.K)
        ksp.setType(PETSc.KSP.Type.PREONLY)
        ksp.getPC().setType(PETSc.PC.Type.LU)
        ksp.getPC().setFactorSolverType("mumps")
        ksp.setFromOptions()
        ksp.solve(f, u)
        assert ksp.getConvergedReason() > 0
        mine = b.owned(u.array_r)[blk, :3] if blk is not None else np.zeros(3)
    finally:
        for obj in (ksp, f, u):
            obj.destroy()
    return np.asarray(st.comm.allreduce(mine, op=MPI.SUM))


#: The kinds of a straight member's modes, by the components they move (each couples with no
#: other on a straight doubly symmetric member): bending along a2 (u·a2, θ·a1: rigidity EI1),
#: along a1 (u·a1, θ·a2: EI2), torsion (θ·t), axial (u·t).
KINDS = ("bend_a2", "bend_a1", "torsion", "axial")


def classify(b: Beam, shapes: FloatArray) -> tuple[list[str], FloatArray]:
    """Each mode's kind, and the fraction of its shape's squared norm in that kind's
    components (1 for a clean mode) (collective)."""
    kinds, purity = [], []
    for shape in shapes:
        z = b.owned(shape)
        u, th = z[:, :3], z[:, 3:]
        parts = np.array(
            [
                np.sum((u @ A2) ** 2) + np.sum((th @ A1) ** 2),
                np.sum((u @ A1) ** 2) + np.sum((th @ A2) ** 2),
                np.sum((th @ AXIS) ** 2),
                np.sum((u @ AXIS) ** 2),
            ]
        )
        parts = b.st.comm.allreduce(parts, op=MPI.SUM)
        k = int(np.argmax(parts))
        kinds.append(KINDS[k])
        purity.append(parts[k] / parts.sum())
    return kinds, np.array(purity)


def lowest(kinds: list[str], omega: FloatArray, kind: str, n: int) -> FloatArray:
    """The ``n`` lowest frequencies of the modes of ``kind``."""
    out = np.array([w for k, w in zip(kinds, omega, strict=True) if k == kind])[:n]
    assert out.size == n, (kind, kinds)
    return out


# --- the slender oblique cantilever: frequencies and static tip load ---------------------

#: L/h = 40 (L/b = 80): Timoshenko's correction to the third bending frequency is a few
#: tenths of a percent (shear and rotary inertia lower it), the 40 elements' discretisation
#: error of the same order and opposite sign (raising it). Measured: bending along a2
#: −0.04, −0.19, −0.39 %, along a1 −0.004, +0.07, +0.23 %, torsion +0.006 %; the tip
#: deflection −0.016 % along either axis (the −1/(4N²) of the locking test below).
L_CANT, N_CANT = 4.0, 40


@pytest.fixture(scope="module")
def cantilever(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Beam]:
    tmp = Path(COMM.bcast(str(tmp_path_factory.mktemp("beams")), root=0))
    with beam(tmp, L_CANT, N_CANT, {"root": "clamped"}) as b:
        yield b


@pytest.mark.gmsh
def test_cantilever_bending_and_torsion_frequencies(cantilever: Beam) -> None:
    """The first three bending frequencies in each plane within 1 % of Euler–Bernoulli's
    ω_n = (β_n L)² √(EI/(ρA L⁴)) (I1 for bending along a2, I2 along a1), and the first
    torsion frequency within 1 % of the rod's ω = (π/2L) √(GJ/(ρ Ip)), Ip = I1 + I2 the
    formulation's rotary inertia about the tangent. The modes are told apart by their
    shapes, each clean to 1e-6."""
    basis = solve_modes(cantilever.st, 8)
    kinds, purity = classify(cantilever, basis.shapes)
    s, L = SECTION, L_CANT
    errors = {}
    for kind, inertia in (("bend_a2", s.I1), ("bend_a1", s.I2)):
        exact = BETA_L**2 * math.sqrt(E * inertia / (RHO * s.A * L**4))
        errors[kind] = lowest(kinds, basis.omega, kind, 3) / exact - 1.0
    exact_t = math.pi / (2.0 * L) * math.sqrt(G * s.J / (RHO * (s.I1 + s.I2)))
    errors["torsion"] = lowest(kinds, basis.omega, "torsion", 1) / exact_t - 1.0
    assert np.all(purity > 1.0 - 1e-6), (kinds, purity)
    for kind, err in errors.items():
        assert np.all(np.abs(err) < 0.01), (kind, err)


@pytest.mark.gmsh
@pytest.mark.parametrize(("axis", "inertia", "k"), [("a2", "I1", "k2"), ("a1", "I2", "k1")])
def test_cantilever_tip_load(cantilever: Beam, axis: str, inertia: str, k: str) -> None:
    """A tip load P along a local axis: the tip moves along it by P L³/(3 E I) + P L/(k G A)
    within 0.5 % (I the inertia of that plane's bending), and not across it.

    The shear part is 5e-4 (along a2) and 1.2e-4 (along a1) of the whole here, below that
    tolerance; but the element with its residual bending flexibility has the exact
    stiffness of a two-node Timoshenko beam, so the tip's deflection under a tip load is
    exact: held to 1e-3 of the shear part (a check of the shear rigidity k G A and of the
    correction le²/(12 EI) together; without the correction the tip is short by
    P L³/(12 EI N²), 0.32 of the shear part here)."""
    s, L, P = SECTION, L_CANT, 1.0e3
    direction = A2 if axis == "a2" else A1
    u = tip_displacement(cantilever, L * AXIS, P * direction)
    inertia_, k_ = getattr(s, inertia), getattr(s, k)
    bending = P * L**3 / (3.0 * E * inertia_)
    shear = P * L / (k_ * G * s.A)
    along = float(u @ direction)
    assert abs(along / (bending + shear) - 1.0) < 0.005, along / (bending + shear) - 1.0
    assert abs(along - (bending + shear)) < 1e-3 * shear, (along - bending - shear) / shear
    assert np.linalg.norm(u - along * direction) < 1e-9 * along


# --- locking: the reduced-integration element on a very slender cantilever ---------------


@pytest.mark.gmsh
def test_slender_cantilever_is_not_locked(tmp_path: Path) -> None:
    """L/h = 200, a tip load P along a2, 8, 16 and 32 elements: no shear locking. (The same
    linear element with its shear integrated exactly, two points, locks: a 2-DOF-per-node
    NumPy twin of it gives 0.5 %, 2.0 %, 7.4 % of the closed form at 8, 16, 32 elements.)

    Why the tip is exact: the one-point element's constant moment in a cell is the exact
    moment at the midpoint (midpoint rule, exact for the linear moment), so the nodal
    rotations are exact; its deflection is the trapezoid rule of the exact quadratic
    rotation θ, θ'' = −P/(EI), short by le³ P/(12 EI) per cell, which the residual bending
    flexibility le²/(12 EI) added to the cell's shear compliance (constant shear P) gives
    back exactly. Without it the tip is too stiff by 1/(4N²) of the bending part (0.39 % at
    N = 8). Asserted to 1e-9 (round-off of K's condition here is below 1e-11)."""
    tmp = Path(COMM.bcast(str(tmp_path), root=0))
    s, L, P = SECTION, 200.0 * H, 1.0
    bending = P * L**3 / (3.0 * E * s.I1)
    exact = bending + P * L / (s.k2 * G * s.A)
    for n in (8, 16, 32):
        with beam(tmp, L, n, {"root": "clamped"}) as b:
            err = tip_displacement(b, L * AXIS, P * A2) @ A2 / exact - 1.0
        assert abs(err) < 1e-9, (n, err)


# --- a thick simply supported beam against Timoshenko's frequency equation ----------------


def timoshenko_simply_supported(n: int, L: float, inertia: float, k: float) -> float:
    """ω of the n-th bending mode of a simply supported Timoshenko beam (w = sin(nπs/L),
    ψ = cos(nπs/L)): with q = nπ/L, the lower root of
    ρI (ρ/(kG)) ω⁴ − (ρA + ρI q² (1 + E/(kG))) ω² + EI q⁴ = 0
    (the determinant of ρA ω² W = kGA q (q W − Ψ), ρI ω² Ψ = EI q² Ψ + kGA (Ψ − q W))."""
    A, q = SECTION.A, n * math.pi / L
    a = RHO * inertia * RHO / (k * G)
    b = RHO * A + RHO * inertia * q**2 * (1.0 + E / (k * G))
    c = E * inertia * q**4
    # The lower root in the form without cancellation (4ac ≪ b² on a slender beam).
    return math.sqrt(2.0 * c / (b + math.sqrt(b * b - 4.0 * a * c)))


def test_timoshenko_closed_form_tends_to_euler_bernoulli() -> None:
    """The frequency equation above, on a slender beam (L/h = 1000), is Euler–Bernoulli's
    ω_EB = q² √(EI/(ρA)) lowered by Timoshenko's first-order correction
    ½ (q r)² (1 + E/(kG)), r² = I/A (rotary inertia and shear): to 1 % of that correction;
    on a thick one (L/h = 5) it lies below Euler–Bernoulli by more than 5 %."""
    s = SECTION
    r2 = s.I1 / s.A
    for n in (1, 2, 3):
        for slenderness in (1000.0, 5.0):
            L = slenderness * H
            q = n * math.pi / L
            eb = q**2 * math.sqrt(E * s.I1 / (RHO * s.A))
            drop = 1.0 - timoshenko_simply_supported(n, L, s.I1, s.k2) / eb
            first_order = 0.5 * q**2 * r2 * (1.0 + E / (s.k2 * G))
            if slenderness > 100.0:
                assert abs(drop / first_order - 1.0) < 0.01, (n, drop, first_order)
            else:
                assert drop > 0.05, (n, drop)


def add_torsion_spring(b: Beam, point: FloatArray, stiffness: float) -> None:
    """Add stiffness · t⊗t on the rotations of the block at ``point`` (a spring against the
    turn about the member's axis there; collective: assembles K)."""
    K = b.st.K
    blk = b.block(point)
    if blk is not None:
        rows = np.searchsorted(b.st.free, 6 * blk + 3 + np.arange(3))
        idx = (rows + K.getOwnershipRange()[0]).astype(np.int32)
        block = stiffness * np.outer(AXIS, AXIS)
        K.setValues(idx, idx, block.ravel(), addv=PETSc.InsertMode.ADD_VALUES)
    K.assemble()


def simply_supported_errors(tmp: Path, elements: int) -> tuple[float, dict[str, FloatArray]]:
    """The L/h = 5 beam pinned at both ends, a torsion spring GJ/L at its root: the rigid
    turn's relative residual ‖K r‖/‖K‖ before the spring, and each plane's first three
    bending frequencies' relative errors against the closed form (collective)."""
    s, L = SECTION, 5.0 * H
    with beam(tmp, L, elements, {"root": "pinned", "tip": "pinned"}) as b:
        st = b.st
        r, Kr = st.K.createVecRight(), st.K.createVecLeft()
        turn = np.zeros((b.x.shape[0], 6))
        turn[:, 3:] = AXIS
        r.array[:] = turn.ravel()[st.free]
        st.K.mult(r, Kr)
        residual = Kr.norm(PETSc.NormType.INFINITY) / st.K.norm(PETSc.NormType.INFINITY)
        for vec in (r, Kr):
            vec.destroy()
        add_torsion_spring(b, np.zeros(3), G * s.J / L)
        basis = solve_modes(st, 12)
        kinds, purity = classify(b, basis.shapes)
    assert np.all(purity > 1.0 - 1e-6), (kinds, purity)
    errors = {}
    for kind, inertia, k in (("bend_a2", s.I1, s.k2), ("bend_a1", s.I2, s.k1)):
        exact = [timoshenko_simply_supported(n, L, inertia, k) for n in (1, 2, 3)]
        errors[kind] = lowest(kinds, basis.omega, kind, 3) / exact - 1.0
    return residual, errors


@pytest.mark.gmsh
def test_simply_supported_thick_beam_frequencies(tmp_path: Path) -> None:
    """L/h = 5, pinned at both ends (translations fixed, rotations free: zero end moments):
    the first three bending frequencies in each plane within 1 % of Timoshenko's closed form
    with 40 elements, and converging to it at second order (20 → 40 elements divides each
    error by 4 ± 0.5: the closed form is the limit, not an error it happens to fall near).

    Pinned at both ends, the member may still turn about its own axis: the rigid rotation
    θ = t, u = 0 at every node is a null vector of K (checked, to round-off of K's scale).
    A simple support in 3D is a fork that stops that turn, which the frame's supports
    (clamped, pinned) cannot express alone, and a clamp would not be a simple support. So a
    torsion spring GJ/L is added at one end, on the rotation about the axis only: on a
    straight doubly symmetric member the bending modes have θ·t = 0 everywhere and no
    coupling with torsion, so they, and their frequencies, are exactly those without it;
    only the torsion modes feel it (and are not checked here: the cantilever's are)."""
    tmp = Path(COMM.bcast(str(tmp_path), root=0))
    residual, coarse = simply_supported_errors(tmp, 20)
    assert residual < 1e-12, residual
    _, fine = simply_supported_errors(tmp, 40)
    for kind, err in fine.items():
        assert np.all(np.abs(err) < 0.01), (kind, err)
        assert np.all(np.abs(coarse[kind] / err - 4.0) < 0.5), (kind, coarse[kind], err)


# --- the sections' torsion constant ------------------------------------------------------


@pytest.mark.parametrize("aspect", [1.0, 2.0, 4.0, 10.0])
def test_rectangle_torsion_constant(aspect: float) -> None:
    """Roark's J of a rectangle (the torsion check above takes it as given) within 0.5 % of
    Saint-Venant's series J = a b³/3 [1 − (192/π⁵)(b/a) Σ_{n odd} tanh(nπa/2b)/n⁵], sides
    a ≥ b, whichever side is along a1."""
    a, b = aspect * 0.02, 0.02
    n = np.arange(1, 200, 2, dtype=np.float64)
    tail = np.sum(np.tanh(n * math.pi * a / (2.0 * b)) / n**5)
    series = a * b**3 / 3.0 * (1.0 - 192.0 / math.pi**5 * b / a * tail)
    for section in (sections.rectangle(a, b), sections.rectangle(b, a)):
        assert abs(section.J / series - 1.0) < 0.005, (aspect, section.J / series - 1.0)
