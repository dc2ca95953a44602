"""Mode shapes to one XDMF file (HDF5 data): the mesh's vertices and cells (tetrahedra, or a
frame's lines), and per mode one vector point field ``mode_<k>`` of the translations and, for
beams, one ``rotation_<k>`` of the rotations (meshio and ParaView read it)."""

from __future__ import annotations

from pathlib import Path

import dolfinx.mesh
import numpy as np
import numpy.typing as npt

from crane_fem.modes.eigen import ModalBasis
from crane_fem.modes.operators import ClosedStructure

__all__ = ["write_mode_shapes"]

FloatArray = npt.NDArray[np.float64]

#: meshio's cell type of each topological dimension's simplex.
CELL_TYPES = {1: "line", 2: "triangle", 3: "tetra"}


def write_mode_shapes(path: Path, st: ClosedStructure, basis: ModalBasis) -> Path:
    """Write the mass-normalised mode shapes at the mesh's vertices (a P2 shape by its vertex
    values): their translations (m/√kg) as ``mode_1`` … ``mode_n`` and, where the nodes have
    rotational DOFs (beams), their rotations (rad/√kg) as ``rotation_1`` … ``rotation_n``
    (collective: gathers the mesh and the shapes to rank 0, which writes; the frequencies are
    in ``modes.json``).

    Returns:
        ``path``.
    """
    comm = st.comm
    msh = st.V.mesh
    tdim = msh.topology.dim
    n_own = st.block_vertex.size
    n_modes = basis.omega.size
    bs, n_t = st.bs, st.translations
    # Points are numbered by the mesh file's node order (the geometry's input index), so
    # the file is the same whatever the number of ranks.
    msh.topology.create_connectivity(0, tdim)
    imap_v = msh.topology.index_map(0)
    n_v = imap_v.size_local + imap_v.num_ghosts
    geom = dolfinx.mesh.entities_to_geometry(msh, 0, np.arange(n_v, dtype=np.int32)).ravel()
    input_of = np.asarray(msh.geometry.input_global_indices, dtype=np.int64)[geom]
    glob = np.asarray(imap_v.local_to_global(np.arange(n_v, dtype=np.int32)), dtype=np.int64)
    order = np.argsort(glob)
    # The owned vertex blocks: their point, coordinates and mode values.
    full = np.zeros((n_modes, bs * n_own))
    full[:, st.free] = basis.shapes
    blocks = np.flatnonzero(st.block_vertex >= 0)
    local_v = order[np.searchsorted(glob[order], st.block_vertex[blocks])]
    xyz = st.V.tabulate_dof_coordinates()[blocks]
    values = full.reshape(n_modes, n_own, bs)[:, blocks, :]
    msh.topology.create_connectivity(tdim, 0)
    n_cells = msh.topology.index_map(tdim).size_local
    c2v = msh.topology.connectivity(tdim, 0).array.reshape(-1, tdim + 1)[:n_cells]
    parts = comm.gather((input_of[local_v], xyz, values, input_of[c2v]))
    if comm.rank == 0:
        import meshio

        assert parts is not None
        ids = np.unique(np.concatenate([p[0] for p in parts]))
        points = np.zeros((ids.size, 3))
        shapes = np.zeros((n_modes, ids.size, bs))
        for node, x, v, _ in parts:
            k = np.searchsorted(ids, node)
            points[k] = x
            shapes[:, k, :] = v
        topology = np.searchsorted(ids, np.concatenate([p[3] for p in parts]))
        topology = topology[np.lexsort(np.sort(topology, axis=1).T[::-1])]
        point_data = {
            f"mode_{k + 1}": np.ascontiguousarray(shapes[k, :, :n_t]) for k in range(n_modes)
        }
        if bs > n_t:
            point_data |= {
                f"rotation_{k + 1}": np.ascontiguousarray(shapes[k, :, n_t:])
                for k in range(n_modes)
            }
        mesh = meshio.Mesh(points, [(CELL_TYPES[tdim], topology)], point_data=point_data)
        path.parent.mkdir(parents=True, exist_ok=True)
        meshio.write(path, mesh, file_format="xdmf")
    comm.barrier()
    return path
