"""`crane-fem modes` on a frame (Timoshenko beams, 6 DOFs per node: the translations carry
the mass's shaking, the rotations the supports' moments).

Verification: a steel cantilever's bending frequencies and effective masses against
Euler–Bernoulli, its support's static force and moment against statics; the same beam propped
at its tip by a point-on-plane contact (tied closed) against the clamped–pinned beam. Input: a
frame held by pinned supports alone is solved when they leave it no rigid mode, refused when
they do."""

import json
import math
from pathlib import Path
from typing import Any

import meshio
import numpy as np
import pytest
from conftest import COMM

from crane_fem.errors import ScenarioError
from crane_fem.modes import run_modes
from crane_fem.scenario import parse_scenario

pytestmark = [pytest.mark.gmsh, pytest.mark.no_kernels]

#: The cantilever: steel, L = 4 m along x, b = 0.05 m (across, y) × h = 0.1 m (vertical, z).
E, RHO, L, B, H = 2.1e11, 7800.0, 4.0, 0.05, 0.1
G = 9.81
#: β_n L of a cantilever's first two bending modes, and the fractions of its mass that they
#: carry (Euler–Bernoulli).
BETA_L = np.array([1.875104069, 4.694091133])
EB_MASS_FRACTION = np.array([0.6131, 0.1883])
#: β_1 L of a clamped–pinned beam.
BETA_L_PROPPED = 3.926602312
#: The shaking: El Centro 1940's vertical component.
MOTION = {"record": "el_centro_1940_up", "direction": [0, 0, 1]}


def _frame(
    tmp: Path, members: list[tuple[tuple, tuple, int]], points: list[tuple], tip: bool = False
) -> Path:
    """A frame's line mesh (one line group ``beam``, one point group ``supports`` and, with
    ``tip``, a point group ``tip`` at (L, 0, 0)), drawn on rank 0; its path on every rank."""
    from crane_fem.geometry.frame_sketch import FrameSketch

    path = tmp / "frame.msh"
    if COMM.rank == 0:
        sketch = FrameSketch()
        for a, b, n in members:
            sketch.member("beam", a, b, elements=n)
        sketch.points("supports", points)
        if tip:
            sketch.points("tip", [(L, 0.0, 0.0)])
        sketch.write(path)
    COMM.barrier()
    return path


def _scene(
    mesh: Path, dofs: str, contact: list[dict[str, Any]] | None = None, **loading: Any
) -> Any:
    """The frame of the mesh ``mesh``, of the module's beam section and steel, its point group
    ``supports`` held by ``dofs`` (clamped or pinned)."""
    return parse_scenario(
        {
            "name": "frame",
            "model": {"kind": "frame", "mesh": str(mesh)},
            "section": [
                {"groups": ["beam"], "orientation": [0, 0, 1], "shape": "rectangle", "b": B, "h": H}
            ],
            "material": {"E": E, "nu": 0.3, "rho": RHO},
            "support": [{"group": "supports", "dofs": dofs}],
            "contact": contact or [],
            "loading": loading,
            "time": {"end": 0.5, "dt_factor": 0.9},
        }
    )


def test_cantilever_against_euler_bernoulli(shared_tmp: Path) -> None:
    """A clamped cantilever of 32 beam elements shaken vertically (El Centro, up): its first
    four modes, two bending modes in each plane, are Euler–Bernoulli's f_n = (β_n L)²/(2π)
    √(EI/(ρA L⁴)) within 1 % (measured 0.15 %; Timoshenko's shear and rotary inertia lower
    them slightly, the mesh raises them); its first two vertical modes carry 61.3 % and 18.8 %
    of the mass within 1 % (measured 0.16 %); the effective masses in z sum to at most the free
    mass (the mass not on the clamped node), itself at most ρAL, and to 90 % of it by the
    twelfth mode (measured 94.0 %: five vertical modes). The support's static force and moment
    are the weight ρALg and ρALg L/2; its seismic vertical force (SRSS) is that of the modal
    base shears m_eff,i Sa_i (measured 4e-11 relative)."""
    mesh = _frame(shared_tmp, [((0, 0, 0), (L, 0, 0), 32)], [(0, 0, 0)])
    sc = _scene(mesh, "clamped", gravity=[0, 0, -G], ground_motion=MOTION)
    out = shared_tmp / "modes"
    report = run_modes(sc, COMM, 12, out)
    basis = report.basis
    mass = RHO * B * H * L
    assert report.mass_total == pytest.approx(mass, rel=1e-12)

    f = basis.frequency
    I_z, I_y = B * H**3 / 12, H * B**3 / 12  # vertical (z) and lateral (y) bending
    eb = {
        axis: BETA_L**2 / (2 * math.pi) * math.sqrt(E * inertia / (RHO * B * H * L**4))
        for axis, inertia in (("y", I_y), ("z", I_z))
    }
    # The lateral plane is the more flexible (I_y = I_z / 4): y, z, y, z.
    expected = np.array([eb["y"][0], eb["z"][0], eb["y"][1], eb["z"][1]])
    error = np.abs(f[:4] / expected - 1.0)
    assert np.all(error < 0.01), (f[:4], expected)
    frac = basis.effective_fraction
    assert np.all(np.argmax(frac[:4], axis=1) == [1, 2, 1, 2]), frac[:4]

    free = basis.total_mass
    assert np.all(free <= mass * (1 + 1e-12)), free
    m_eff = basis.effective_mass
    assert np.all(m_eff.sum(axis=0) <= free * (1 + 1e-12)), (m_eff.sum(axis=0), free)
    vertical = m_eff[[1, 3], 2] / mass
    assert np.all(np.abs(vertical / EB_MASS_FRACTION - 1.0) < 0.01), vertical
    assert basis.cumulative_fraction[-1, 2] >= 0.90, basis.cumulative_fraction[:, 2]

    est = report.estimate
    assert est is not None
    weight = mass * G
    assert est.static.support[0] == pytest.approx([0.0, 0.0, weight], abs=1e-9 * weight)
    # The support's moment on the beam about the root holds the weight at L/2: −ρALg L/2 e_y.
    assert est.static.moment[0] == pytest.approx([0.0, -weight * L / 2, 0.0], abs=1e-9 * weight)
    # Mode i's base shear is ω_i² Γ_i (the rows of K sum to zero on a rigid translation), so
    # its peak, ω_i² Γ_i · Γ_i Sa_i / ω_i², is the classical m_eff,i Sa_i.
    modal = m_eff[:, 2] * est.sa[:, 2]
    assert est.srss.support[0, 2] == pytest.approx(np.sqrt(np.sum(modal**2)), rel=1e-9)

    data = json.loads((out / "modes.json").read_text(encoding="utf-8"))
    assert len(data["modes"]) == 12
    assert "peak_moment_Nm" in data["response_spectrum"]["supports"]["1"]
    shapes = meshio.read(out / "modes.xdmf")  # translations and rotations per node
    assert shapes.points.shape == (33, 3) and shapes.cells[0].type == "line"
    assert shapes.point_data["mode_1"].shape == (33, 3)
    assert shapes.point_data["rotation_1"].shape == (33, 3)


def test_propped_cantilever(shared_tmp: Path) -> None:
    """The cantilever's tip on a plane (a point-on-plane contact touching at t = 0, tied
    closed in its normal and tangents like the static preload): a clamped–pinned beam. Its
    first two modes, lateral and vertical bending, are Euler–Bernoulli's (β_1 L = 3.9266)
    within 1 % (measured 0.14 %), and the root carries 5/8 of the weight within 0.1 %
    (measured 0.024 %; the Timoshenko beam's shear flexibility, 1.0e-4 converged)."""
    mesh = _frame(shared_tmp, [((0, 0, 0), (L, 0, 0), 32)], [(0, 0, 0)], tip=True)
    plane = {"type": "point-on-plane", "points": "tip"}
    sc = _scene(mesh, "clamped", [plane], gravity=[0, 0, -G], ground_motion=MOTION)
    report = run_modes(sc, COMM, 2, shared_tmp / "modes")
    f = report.basis.frequency
    expected = [
        BETA_L_PROPPED**2 / (2 * math.pi) * math.sqrt(E * inertia / (RHO * B * H * L**4))
        for inertia in (H * B**3 / 12, B * H**3 / 12)
    ]
    assert np.all(np.abs(f / expected - 1.0) < 0.01), (f, expected)
    assert report.estimate is not None
    root = report.estimate.static.support[0, 2]
    assert root == pytest.approx(5 / 8 * RHO * B * H * L * G, rel=1e-3)


def test_pinned_supports(shared_tmp: Path) -> None:
    """A triangle of beams pinned at its three corners has no rigid mode: it is solved (its
    lowest frequency well above zero); a cantilever pinned at its root alone turns about it
    freely: its three rigid modes are refused, on every rank."""
    corners = [(0.0, 0.0, 0.0), (3.0, 0.0, 0.0), (3.0, 3.0, 0.0)]
    members = [(corners[i], corners[(i + 1) % 3], 8) for i in range(3)]
    sc = _scene(_frame(shared_tmp / "triangle", members, corners), "pinned")
    report = run_modes(sc, COMM, 4, shared_tmp / "triangle" / "modes")
    assert report.estimate is None
    assert report.basis.frequency[0] > 1.0, report.basis.frequency

    mesh = _frame(shared_tmp / "pinned", [((0, 0, 0), (L, 0, 0), 8)], [(0, 0, 0)])
    with pytest.raises(ScenarioError, match="leave the structure 3 rigid mode"):
        run_modes(_scene(mesh, "pinned"), COMM, 4, shared_tmp / "pinned" / "modes")
