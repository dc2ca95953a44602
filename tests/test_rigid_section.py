"""The rigid section's six rows (THEORY.md §11, issue 33's joint) on a face of a solid bar (its
end, and its long side, which two ranks share in the suite's mpiexec pass): the face's area,
centroid and second-moment tensor against the rectangle's closed forms; a rigid motion of the
face meets the rows with the beam node's (u_P, θ_P) = (a, θ); their transpose spreads a
resultant and a moment about G over the face's nodes exactly. On an axis-aligned and an
oblique bar; a face that is not planar or is empty is refused in one line."""

import dolfinx
import numpy as np
import pytest
from mpi4py import MPI
from scipy.spatial.transform import Rotation

from crane_fem.coupling.rigid_section import face_rows
from crane_fem.errors import ScenarioError

L, B, H = 0.3, 0.1, 0.08
SHIFT = np.array([1.0, -2.0, 0.5])
ROTATIONS = {
    "aligned": np.eye(3),
    "oblique": Rotation.from_euler("zyx", [0.4, -0.7, 1.1]).as_matrix(),
}


#: Each face of the bar: its normal axis, its in-plane axes with their extents, its centre
#: (bar coordinates).
FACES = {
    "end": (0, (1, B), (2, H), [L, B / 2, H / 2]),
    "side": (1, (0, L), (2, H), [L / 2, 0.0, H / 2]),
}


def _bar(R: np.ndarray, face: str = "end") -> tuple[dolfinx.fem.FunctionSpace, np.ndarray]:
    """A bar L × B × H of P1 tetrahedra, rotated by R and shifted; its vector space and the
    local facets of ``face`` (in the bar's own coordinates ξ)."""
    msh = dolfinx.mesh.create_box(
        MPI.COMM_WORLD,
        [np.zeros(3), np.array([L, B, H])],
        [6, 4, 3],
        dolfinx.mesh.CellType.tetrahedron,
        ghost_mode=dolfinx.mesh.GhostMode.shared_facet,
    )
    msh.geometry.x[:] = msh.geometry.x @ R.T + SHIFT
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    msh.topology.create_connectivity(2, 3)
    axis, _, _, centre = FACES[face]

    def on(x: np.ndarray) -> np.ndarray:
        return np.isclose(((x.T - SHIFT) @ R)[:, axis], centre[axis])

    return V, dolfinx.mesh.locate_entities_boundary(msh, 2, on)


def _closed_form(face: str, R: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """The rectangle's |S|, G and I_G = R diag(...) Rᵀ: about the normal the polar moment,
    about an in-plane axis the other's second moment."""
    n, (p, a), (q, b), centre = FACES[face]
    local = np.zeros((3, 3))
    local[n, n] = a * b * (a**2 + b**2) / 12
    local[p, p] = a * b**3 / 12
    local[q, q] = a**3 * b / 12
    return a * b, R @ np.asarray(centre) + SHIFT, R @ local @ R.T


@pytest.mark.parametrize("face", sorted(FACES))
@pytest.mark.parametrize("orientation", sorted(ROTATIONS))
def test_face_properties_are_the_rectangles(orientation: str, face: str) -> None:
    """|S|, G and I_G of the rectangle (quadrature of degree 2 is exact on flat triangles: to
    round-off), the normal along the face's axis."""
    R = ROTATIONS[orientation]
    V, facets = _bar(R, face)
    f = face_rows(V, facets, face)
    area, centroid, inertia = _closed_form(face, R)
    assert f.area == pytest.approx(area, rel=1e-12)
    np.testing.assert_allclose(f.centroid, centroid, rtol=0, atol=1e-13)
    np.testing.assert_allclose(f.inertia, inertia, rtol=0, atol=1e-12 * np.abs(inertia).max())
    assert abs(f.normal @ R[:, FACES[face][0]]) == pytest.approx(1.0, abs=1e-12)
    assert set(np.unique(f.rows)) <= set(range(6))


@pytest.mark.parametrize("face", sorted(FACES))
@pytest.mark.parametrize("orientation", sorted(ROTATIONS))
def test_rigid_motion_meets_the_rows_and_a_resultant_spreads_exactly(
    orientation: str, face: str
) -> None:
    """u = a + θ × (x − G) on the bar: the solid side's rows give (|S| a, I_G θ), the beam
    node's block times (a, θ) the same (the constraint's residual is round-off); the rows'
    transpose times (λ_f, λ_m) puts |S| λ_f as the nodal forces' resultant and I_G λ_m as their
    moment about G (P1 reproduces x − G: exact)."""
    R = ROTATIONS[orientation]
    V, facets = _bar(R, face)
    f = face_rows(V, facets, face)
    a = np.array([1e-3, -2e-3, 0.5e-3])
    theta = np.array([0.02, -0.01, 0.03])
    u = dolfinx.fem.Function(V)
    u.interpolate(lambda x: a[:, None] + np.cross(theta, (x.T - f.centroid)).T)
    n_owned = V.dofmap.index_map.size_local * 3
    rows = f.apply(u.x.array[:n_owned])
    expected = np.concatenate([f.area * a, f.inertia @ theta])
    np.testing.assert_allclose(rows, expected, rtol=0, atol=1e-12 * np.abs(expected).max())
    residual = rows - f.beam_block @ np.concatenate([a, theta])
    assert np.abs(residual).max() <= 1e-12 * np.abs(expected).max()

    lam = np.array([3.0, -1.0, 2.0, 0.5, 4.0, -2.5])
    forces = f.spread(lam, n_owned).reshape(-1, 3)
    x = V.tabulate_dof_coordinates()[: V.dofmap.index_map.size_local]
    comm = V.mesh.comm
    resultant = comm.allreduce(forces.sum(axis=0), op=MPI.SUM)
    moment = comm.allreduce(np.cross(x - f.centroid, forces).sum(axis=0), op=MPI.SUM)
    np.testing.assert_allclose(resultant, f.area * lam[:3], rtol=0, atol=1e-12 * f.area * 4)
    m_ref = f.inertia @ lam[3:]
    np.testing.assert_allclose(moment, m_ref, rtol=0, atol=1e-12 * np.abs(m_ref).max())
    # Only the face's nodes are loaded.
    axis, _, _, centre = FACES[face]
    on_face = np.isclose(((x - SHIFT) @ R)[:, axis], centre[axis])
    assert np.all(forces[~on_face] == 0.0)


def test_a_face_that_is_not_planar_or_empty_is_refused_in_one_line() -> None:
    V, end = _bar(ROTATIONS["oblique"])
    msh = V.mesh
    R = ROTATIONS["oblique"]
    side = dolfinx.mesh.locate_entities_boundary(
        msh, 2, lambda x: np.isclose(((x.T - SHIFT) @ R)[:, 1], 0.0)
    )
    with pytest.raises(ScenarioError, match=r"joint face 'bent' is not planar") as e:
        face_rows(V, np.union1d(end, side).astype(np.int32), "bent")
    assert "\n" not in str(e.value)
    with pytest.raises(ScenarioError, match=r"joint face 'none': no facet"):
        face_rows(V, np.zeros(0, dtype=np.int32), "none")
