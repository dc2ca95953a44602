"""The XDMF time series (crane_fem.io.xdmf): one grid per time with every field, read back by
meshio's TimeSeriesReader; the same file from a distributed mesh as from a serial one."""

from pathlib import Path

import dolfinx
import meshio
import numpy as np
import pytest
from conftest import COMM
from mpi4py import MPI

from crane_fem.formulations import SolidVonMises
from crane_fem.io.xdmf import XDMFSeries, read_xdmf, truncate_xdmf, xdmf_frames

pytestmark = pytest.mark.no_kernels

E, NU = 2.0e11, 0.3
#: A uniform displacement gradient (the field is t·A·x): a constant strain, so the von Mises
#: stress of every cell is known exactly.
A = np.array([[1.0, 0.2, 0.0], [0.0, -0.5, 0.3], [0.4, 0.0, 2.0]]) * 1e-4
TIMES = [0.0, 0.5, 1.0]


def _von_mises(t: float) -> float:
    eps = 0.5 * t * (A + A.T)
    mu, lmbda = E / (2 * (1 + NU)), E * NU / ((1 + NU) * (1 - 2 * NU))
    sigma = 2 * mu * eps + lmbda * np.trace(eps) * np.eye(3)
    s = sigma - np.trace(sigma) / 3 * np.eye(3)
    return float(np.sqrt(1.5 * np.sum(s * s)))


def _fields(x: np.ndarray, t: float) -> dict[str, np.ndarray]:
    """Owned-DOF arrays of three vector fields at the owned DOF coordinates ``x``."""
    u = t * x @ A.T
    return {
        "displacement": u.ravel(),
        "velocity": (x @ A.T).ravel(),
        "contact_force": np.where(x[:, 2:3] > 0.4, [0.0, 0.0, t], 0.0).ravel(),
    }


def _write(comm: MPI.Comm, path: Path) -> None:
    mesh = dolfinx.mesh.create_box(
        comm, [[0.0, 0.0, 0.0], [2.0, 0.5, 0.5]], [6, 2, 2], dolfinx.mesh.CellType.tetrahedron
    )
    V = dolfinx.fem.functionspace(mesh, ("Lagrange", 1, (3,)))
    x = V.tabulate_dof_coordinates()[: V.dofmap.index_map.size_local]
    names = ["displacement", "velocity", "contact_force"]
    stress = SolidVonMises(V, E, NU)
    with XDMFSeries(path, V, names, constants={"subdomain": 1.0}, stress=stress) as w:
        for t in TIMES:
            w.write(t, _fields(x, t))


def _read(path: Path) -> tuple[np.ndarray, np.ndarray, list]:
    with meshio.xdmf.TimeSeriesReader(path) as reader:
        points, cells = reader.read_points_cells()
        steps = [reader.read_data(k) for k in range(reader.num_steps)]
    assert len(cells) == 1 and cells[0].type == "tetra"
    return points, cells[0].data, steps


def test_series_is_one_grid_per_time_with_every_field(shared_tmp: Path) -> None:
    """meshio's TimeSeriesReader finds every field with its shape at every time, each equal to
    what was written (exact fields of the file's points); the file written from the mesh
    distributed over the ranks holds the serial file's arrays (rank 0 writes both)."""
    path = shared_tmp / "dist" / "solution.xdmf"
    _write(COMM, path)
    if COMM.rank == 0:
        _write(MPI.COMM_SELF, shared_tmp / "serial" / "solution.xdmf")
    COMM.barrier()
    verdict = ""
    if COMM.rank == 0:
        try:
            points, tets, steps = _read(path)
            n, c = points.shape[0], tets.shape[0]
            assert (n, c) == (7 * 3 * 3, 6 * 2 * 2 * 6)
            assert [t for t, _, _ in steps] == TIMES
            for t, point_data, cell_data in steps:
                assert {k: v.shape for k, v in point_data.items()} == {
                    "displacement": (n, 3),
                    "velocity": (n, 3),
                    "contact_force": (n, 3),
                }
                assert {k: [a.shape for a in v] for k, v in cell_data.items()} == {
                    "von_mises": [(c, 1)],
                    "subdomain": [(c, 1)],
                }
                exact = _fields(points, t)
                for name, values in point_data.items():
                    # (The DOF coordinates the fields were made of are the nodes' to round-off.)
                    np.testing.assert_allclose(values.ravel(), exact[name], rtol=0, atol=1e-18)
                vm = cell_data["von_mises"][0]
                np.testing.assert_allclose(vm, _von_mises(t), rtol=1e-10, atol=1e-3)
                assert np.all(cell_data["subdomain"][0] == 1.0)
            # Serial and distributed: the same nodes and cells in the same order, the same
            # values to the round-off of the DOF coordinates they were made of.
            p_s, t_s, s_s = _read(shared_tmp / "serial" / "solution.xdmf")
            np.testing.assert_array_equal(points, p_s)
            np.testing.assert_array_equal(tets, t_s)
            for (_, pd, cd), (_, pd_s, cd_s) in zip(steps, s_s, strict=True):
                for name in pd:
                    np.testing.assert_allclose(pd[name], pd_s[name], rtol=0, atol=1e-18)
                for name in cd:
                    np.testing.assert_allclose(cd[name][0], cd_s[name][0], rtol=1e-14)
            # crane_fem's own reader takes the same layout.
            geometry, topology, fields = read_xdmf(path)
            np.testing.assert_array_equal(topology, tets)
            np.testing.assert_array_equal(geometry, points)
            assert set(fields) == {*steps[0][1], *steps[0][2]}
            assert all(len(v) == len(TIMES) for v in fields.values())
        except AssertionError as exc:
            verdict = repr(exc)
    verdict = COMM.bcast(verdict, root=0)
    assert not verdict, verdict


def test_truncated_series_continues(shared_tmp: Path) -> None:
    """A series cut to its first frames and continued (a restart): the mesh and the constant
    cell field stay, the dropped frames' data sets go, the new frames follow."""
    path = shared_tmp / "cut" / "solution.xdmf"
    _write(COMM, path)
    if COMM.rank == 0:
        truncate_xdmf(path, 2)
        assert xdmf_frames(path) == 2
    COMM.barrier()
    mesh = dolfinx.mesh.create_box(
        COMM, [[0.0, 0.0, 0.0], [2.0, 0.5, 0.5]], [6, 2, 2], dolfinx.mesh.CellType.tetrahedron
    )
    V = dolfinx.fem.functionspace(mesh, ("Lagrange", 1, (3,)))
    x = V.tabulate_dof_coordinates()[: V.dofmap.index_map.size_local]
    names = ["displacement", "velocity", "contact_force"]
    with XDMFSeries(
        path, V, names, constants={"subdomain": 1.0}, stress=SolidVonMises(V, E, NU), append=True
    ) as w:
        w.write(2.0, _fields(x, 2.0))
    COMM.barrier()
    verdict = ""
    if COMM.rank == 0:
        try:
            points, _, steps = _read(path)
            assert [t for t, _, _ in steps] == [*TIMES[:2], 2.0]
            np.testing.assert_allclose(
                steps[-1][1]["displacement"].ravel(),
                _fields(points, 2.0)["displacement"],
                rtol=0,
                atol=1e-18,
            )
            np.testing.assert_allclose(steps[-1][2]["von_mises"][0], _von_mises(2.0), 1e-10)
            assert np.all(steps[-1][2]["subdomain"][0] == 1.0)
        except AssertionError as exc:
            verdict = repr(exc)
    verdict = COMM.bcast(verdict, root=0)
    assert not verdict, verdict


def test_series_refuses_a_space_it_cannot_write() -> None:
    mesh = dolfinx.mesh.create_unit_square(COMM, 2, 2, dolfinx.mesh.CellType.quadrilateral)
    V = dolfinx.fem.functionspace(mesh, ("Lagrange", 1))
    with pytest.raises(ValueError, match="simplex"):
        XDMFSeries(Path("unused.xdmf"), V, ["u"])
