"""Mode shapes to one XDMF file (HDF5 data): the mesh's vertices and tetrahedra, and one P1
vector point field ``mode_<k>`` per mode (meshio and ParaView read it)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import numpy.typing as npt

from crane_fem.modes.eigen import ModalBasis
from crane_fem.modes.operators import ClosedStructure

__all__ = ["write_mode_shapes"]

FloatArray = npt.NDArray[np.float64]


def write_mode_shapes(path: Path, st: ClosedStructure, basis: ModalBasis) -> Path:
    """Write the mass-normalised mode shapes (m/√kg) at the mesh's vertices (a P2 shape by
    its vertex values) as ``mode_1`` … ``mode_n`` (collective: gathers the mesh and the
    shapes to rank 0, which writes; the frequencies are in ``modes.json``).

    Returns:
        ``path``.
    """
    comm = st.comm
    msh = st.V.mesh
    tdim = msh.topology.dim
    n_own = st.block_vertex.size
    # The owned vertex blocks: their global vertex, coordinates and mode values.
    full = np.zeros((basis.omega.size, 3 * n_own))
    full[:, st.free] = basis.shapes
    blocks = np.flatnonzero(st.block_vertex >= 0)
    xyz = st.V.tabulate_dof_coordinates()[blocks]
    values = full.reshape(basis.omega.size, n_own, 3)[:, blocks, :]
    imap_c = msh.topology.index_map(tdim)
    c2v = msh.topology.connectivity(tdim, 0).array.reshape(-1, tdim + 1)[: imap_c.size_local]
    cells = np.asarray(msh.topology.index_map(0).local_to_global(c2v.ravel()), dtype=np.int64)
    parts = comm.gather((st.block_vertex[blocks], xyz, values, cells.reshape(-1, tdim + 1)))
    if comm.rank == 0:
        import meshio

        assert parts is not None
        n_vertices = msh.topology.index_map(0).size_global
        points = np.zeros((n_vertices, 3))
        shapes = np.zeros((basis.omega.size, n_vertices, 3))
        for ids, x, v, _ in parts:
            points[ids] = x
            shapes[:, ids, :] = v
        topology = np.concatenate([c for *_, c in parts])
        mesh = meshio.Mesh(
            points,
            [("tetra", topology)],
            point_data={f"mode_{k + 1}": shapes[k] for k in range(basis.omega.size)},
        )
        path.parent.mkdir(parents=True, exist_ok=True)
        meshio.write(path, mesh, file_format="xdmf")
    comm.barrier()
    return path
