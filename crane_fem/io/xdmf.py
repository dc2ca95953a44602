"""XDMF time series of a run's fields: one temporal collection, one grid per time holding the
mesh and every field (ParaView's Xdmf3 reader with MergeBlocks, meshio's TimeSeriesReader).

The layout (XDMF 3, heavy data in the HDF5 file beside it)::

    Domain
      Grid "solution" (Collection, Temporal)
        Grid "frame_0" (Uniform): Topology, Geometry (/Mesh/*), Time,
                                  Attribute per field (Node: /Function/<name>/0,
                                                       Cell: /Function/<name>/0 or /Cell/<name>)
        Grid "frame_1" ...        the same Topology and Geometry data sets, referenced again

Every grid references the one mesh written once, so a reader taking one grid (meshio, or
ParaView's MergeBlocks over the time series' blocks) finds every field on it. Nodes and cells
are written in an order that does not depend on the partition (nodes by their input index,
cells by their nodes): a two-rank run's file holds the serial run's arrays row for row.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path
from types import TracebackType
from typing import Any

import dolfinx
import numpy as np
import numpy.typing as npt
from mpi4py import MPI
from mpi4py.util.dtlib import from_numpy_dtype

from crane_fem.formulations import SECTION_FORCES
from crane_fem.stress import CellStress

__all__ = ["XDMFSeries", "read_xdmf", "truncate_xdmf", "xdmf_frames"]

XINCLUDE = "https://www.w3.org/2001/XInclude"

#: dolfinx cell name -> (XDMF topology type, nodes per cell); simplices only: their vertex
#: order is the same in dolfinx and XDMF (not so for quadrilaterals and hexahedra).
_TOPOLOGY = {
    "interval": ("Polyline", 2),
    "triangle": ("Triangle", 3),
    "tetrahedron": ("Tetrahedron", 4),
}
_HEAD = (
    '<?xml version="1.0"?>\n<!DOCTYPE Xdmf SYSTEM "Xdmf.dtd" []>\n<Xdmf Version="3.0">\n'
    '  <Domain>\n    <Grid Name="solution" GridType="Collection" CollectionType="Temporal">\n'
)
_TAIL = "    </Grid>\n  </Domain>\n</Xdmf>\n"


def _gather_rows(
    comm: MPI.Comm, rows: npt.NDArray[Any], counts: npt.NDArray[np.int64]
) -> npt.NDArray[Any] | None:
    """The ranks' ``rows`` (n_r, k), stacked in rank order on rank 0 (None elsewhere);
    ``counts``: every rank's n_r (collective)."""
    rows = np.ascontiguousarray(rows)
    k = int(np.prod(rows.shape[1:], dtype=np.int64))
    if comm.size == 1:
        return rows.copy()
    out = (
        np.empty((int(counts.sum()), *rows.shape[1:]), dtype=rows.dtype) if comm.rank == 0 else None
    )
    sizes = counts * k
    displs = np.r_[0, np.cumsum(sizes)[:-1]]
    mpi_type = from_numpy_dtype(rows.dtype)
    recv = [out, sizes, displs, mpi_type] if comm.rank == 0 else None
    comm.Gatherv([rows, mpi_type], recv, root=0)
    return out


def _item(dims: tuple[int, ...], dtype: str, h5: str, dset: str) -> str:
    kind, precision = ("Int", 8) if dtype == "int" else ("Float", 8)
    shape = " ".join(str(d) for d in dims)
    return (
        f'<DataItem Dimensions="{shape}" NumberType="{kind}" Precision="{precision}" '
        f'Format="HDF">{h5}:{dset}</DataItem>'
    )


class _FileOrder:
    """The partition-independent order of a mesh's nodes and cells in the file, and the file's
    mesh arrays (collective at construction; the arrays on rank 0 only).

    Nodes are ordered by their input index (``geometry.input_global_indices``: the index in
    the mesh as read, kept by sub-meshes), cells by their sorted node positions.
    """

    def __init__(self, mesh: dolfinx.mesh.Mesh) -> None:
        comm = mesh.comm
        tdim = mesh.topology.dim
        self.n_nodes = mesh.geometry.index_map().size_local
        self.n_cells = mesh.topology.index_map(tdim).size_local
        self.node_counts = np.array(comm.allgather(self.n_nodes), dtype=np.int64)
        self.cell_counts = np.array(comm.allgather(self.n_cells), dtype=np.int64)
        igi = np.asarray(mesh.geometry.input_global_indices, dtype=np.int64)
        x_dofmap = np.asarray(mesh.geometry.dofmaps[0])[: self.n_cells]
        gdim = mesh.geometry.dim
        # dolfinx's convention: a 1D mesh is written with an (x, 0) geometry.
        x = mesh.geometry.x[: self.n_nodes, : max(gdim, 2)]
        keys = _gather_rows(comm, igi[: self.n_nodes], self.node_counts)
        xyz = _gather_rows(comm, x, self.node_counts)
        cells = _gather_rows(comm, igi[x_dofmap], self.cell_counts)
        self.node_pos: npt.NDArray[np.int64] | None = None
        self.cell_pos: npt.NDArray[np.int64] | None = None
        self.geometry: npt.NDArray[np.float64] | None = None
        self.topology: npt.NDArray[np.int64] | None = None
        if comm.rank == 0:
            assert keys is not None and xyz is not None and cells is not None
            order = np.argsort(keys, kind="stable")
            self.node_pos = np.empty_like(order)
            self.node_pos[order] = np.arange(order.size)
            self.geometry = np.empty_like(xyz)
            self.geometry[self.node_pos] = xyz
            topology = np.searchsorted(keys[order], cells).astype(np.int64)
            by_nodes = np.sort(topology, axis=1)
            c_order = np.lexsort(by_nodes.T[::-1])
            self.cell_pos = np.empty_like(c_order)
            self.cell_pos[c_order] = np.arange(c_order.size)
            self.topology = np.empty_like(topology)
            self.topology[self.cell_pos] = topology

    def nodes(self, comm: MPI.Comm, rows: npt.NDArray[Any]) -> npt.NDArray[Any] | None:
        """The owned nodes' ``rows`` of all ranks in file order, on rank 0 (collective)."""
        return self._place(_gather_rows(comm, rows, self.node_counts), self.node_pos)

    def cells(self, comm: MPI.Comm, rows: npt.NDArray[Any]) -> npt.NDArray[Any] | None:
        """The owned cells' ``rows`` of all ranks in file order, on rank 0 (collective)."""
        return self._place(_gather_rows(comm, rows, self.cell_counts), self.cell_pos)

    @staticmethod
    def _place(
        rows: npt.NDArray[Any] | None, pos: npt.NDArray[np.int64] | None
    ) -> npt.NDArray[Any] | None:
        if rows is None or pos is None:
            return None
        out = np.empty_like(rows)
        out[pos] = rows
        return out


class XDMFSeries:
    """Writes named P1 fields at given times, every time one grid with all of them; flushes
    after each time so a cut run stays valid.

    Collective over the mesh communicator: the owned values are gathered to rank 0, which
    alone writes the files (h5py). Fields are given as owned-DOF arrays and scattered to
    ghosts before they are read at the owned mesh nodes; every time must give every name.
    Optional cellwise (DG0) fields: ``constants`` are written once and referenced at every
    time (e.g. the subdomain tag, so ParaView can colour by it at any time), and ``stress``
    (a formulation's stress recovery on ``V``, crane_fem.formulations) adds the von Mises
    stress (Pa) of the ``displacement`` field per cell, and a beam's section forces (``N``,
    ``V1``, ``V2`` in N, ``T``, ``M1``, ``M2`` in N·m). A beam's node fields (6 components)
    are written as their translations (``<name>``) and rotations (``<name>_rotation``).
    ``append``: continue the series already in ``path`` (a restarted run, after
    :func:`truncate_xdmf`) rather than start a new file.

    Raises:
        ValueError: ``V`` is not a P1 space on a simplex mesh, or (``append``) the file in
            ``path`` is not a series of this layout on this mesh (on every rank).
    """

    def __init__(
        self,
        path: Path,
        V: dolfinx.fem.FunctionSpace,
        names: list[str],
        constants: dict[str, float] | None = None,
        stress: CellStress | None = None,
        append: bool = False,
    ) -> None:
        mesh = V.mesh
        self._comm = comm = mesh.comm
        cell = mesh.topology.cell_name()
        if cell not in _TOPOLOGY or V.dofmap.list.shape[1] != mesh.geometry.dofmaps[0].shape[1]:
            raise ValueError(f"XDMFSeries: a P1 space on a simplex mesh expected ({cell})")
        self.path = path
        self._cell_name = cell
        self._h5name = path.with_suffix(".h5").name
        self.names = list(names)
        self._order = _FileOrder(mesh)
        self._bs = V.dofmap.index_map_bs
        self._n = V.dofmap.index_map.size_local * self._bs
        # Each owned mesh node's DOF (P1: the same local numbering of a cell's nodes).
        node_dof = np.empty(mesh.geometry.x.shape[0], dtype=np.int64)
        node_dof[np.asarray(mesh.geometry.dofmaps[0]).ravel()] = np.asarray(V.dofmap.list).ravel()
        self._node_dof = node_dof[: self._order.n_nodes]
        self._functions = {name: dolfinx.fem.Function(V, name=name) for name in names}
        self._constants = dict(constants or {})
        self._vm = stress
        self._cell_dof = np.zeros(0, dtype=np.int64)
        if stress is not None:
            W = stress.field.function_space  # type: ignore[attr-defined]
            self._cell_dof = np.asarray(W.dofmap.list)[: self._order.n_cells, 0]
        self._h5: Any = None
        self._xml: Any = None
        self._pos = 0
        self._frames = 0
        error = None
        if comm.rank == 0:
            try:
                self._open(append)
            except (OSError, ValueError, KeyError) as exc:
                error = f"{path}: {exc}"
        error = comm.bcast(error, root=0)
        if error is not None:
            raise ValueError(error)

    # -- rank 0: the files ------------------------------------------------------------------
    def _open(self, append: bool) -> None:
        import h5py

        order = self._order
        assert order.geometry is not None and order.topology is not None
        self.path.parent.mkdir(parents=True, exist_ok=True)
        h5name = self._h5name
        n_nodes, n_cells = order.geometry.shape[0], order.topology.shape[0]
        grids: list[bytes] = []
        if append:
            grids = self._existing_grids(n_nodes, n_cells)
            self._h5 = h5py.File(self.path.parent / h5name, "a")
        else:
            self._h5 = h5py.File(self.path.parent / h5name, "w")
            self._h5.create_dataset("Mesh/geometry", data=order.geometry)
            self._h5.create_dataset("Mesh/topology", data=order.topology)
            for name, value in self._constants.items():
                self._h5.create_dataset(f"Cell/{name}", data=np.full((n_cells, 1), float(value)))
            self._h5.flush()
        self._frames = len(grids)
        self._xml = self.path.open("wb")
        head = _HEAD.encode() + b"".join(grids)
        self._xml.write(head + _TAIL.encode())
        self._xml.flush()
        self._pos = len(head)

    def _existing_grids(self, n_nodes: int, n_cells: int) -> list[bytes]:
        """The grids of the series in ``path`` as XML text (they are written again as read)."""
        domain = ET.parse(self.path).getroot().find("Domain")
        coll = None if domain is None else domain.find("Grid[@CollectionType='Temporal']")
        geo = None if coll is None else coll.find("Grid/Geometry/DataItem")
        topo = None if coll is None else coll.find("Grid/Topology/DataItem")
        if domain is None or coll is None or len(domain) != 1 or geo is None or topo is None:
            raise ValueError("not a series of crane-fem's XDMF layout (one temporal collection)")
        dims = (geo.get("Dimensions", ""), topo.get("Dimensions", ""))
        if (int(dims[0].split()[0]), int(dims[1].split()[0])) != (n_nodes, n_cells):
            raise ValueError(
                f"its mesh ({dims}) is not this run's ({n_nodes} nodes, {n_cells} cells)"
            )
        out = []
        for grid in coll.findall("Grid"):
            ET.indent(grid, "  ", level=3)
            grid.tail = "\n"
            out.append(b"      " + ET.tostring(grid, encoding="utf-8"))
        return out

    def _grid(self, t: float, k: int, node_bs: list[tuple[str, int]], cells: list[str]) -> str:
        order = self._order
        assert order.geometry is not None and order.topology is not None
        h5 = self._h5name
        n, c = order.geometry.shape[0], order.topology.shape[0]
        gdim = order.geometry.shape[1]
        kind, per = _TOPOLOGY[self._cell_name]
        i6, i8, i10 = " " * 6, " " * 8, " " * 10
        lines = [
            f'{i6}<Grid Name="frame_{k}" GridType="Uniform">',
            f'{i8}<Topology TopologyType="{kind}" NumberOfElements="{c}" NodesPerElement="{per}">',
            f"{i10}{_item((c, per), 'int', h5, '/Mesh/topology')}",
            f"{i8}</Topology>",
            f'{i8}<Geometry GeometryType="{"XYZ" if gdim == 3 else "XY"}">',
            f"{i10}{_item((n, gdim), 'float', h5, '/Mesh/geometry')}",
            f"{i8}</Geometry>",
            f'{i8}<Time Value="{float(t)!r}"/>',
        ]
        for name, bs in node_bs:
            kind_a = "Vector" if bs == 3 else "Scalar" if bs == 1 else "Matrix"
            lines += [
                f'{i8}<Attribute Name="{name}" AttributeType="{kind_a}" Center="Node">',
                f"{i10}{_item((n, bs), 'float', h5, f'/Function/{name}/{k}')}",
                f"{i8}</Attribute>",
            ]
        for name in cells:
            dset = f"/Cell/{name}" if name in self._constants else f"/Function/{name}/{k}"
            lines += [
                f'{i8}<Attribute Name="{name}" AttributeType="Scalar" Center="Cell">',
                f"{i10}{_item((c, 1), 'float', h5, dset)}",
                f"{i8}</Attribute>",
            ]
        lines.append(f"{i6}</Grid>\n")
        return "\n".join(lines)

    # -- collective -------------------------------------------------------------------------
    def write(self, t: float, fields: dict[str, npt.NDArray[np.float64]]) -> None:
        """Write the time ``t`` (s): the owned-DOF arrays ``fields`` (one per name given at
        construction, SI units) and the von Mises stress if asked for (collective)."""
        missing = set(self.names) - set(fields)
        if missing:
            raise ValueError(f"XDMFSeries.write: no values for {sorted(missing)}")
        bs = self._bs
        columns = []
        for name in self.names:
            f = self._functions[name]
            f.x.array[: self._n] = fields[name]
            f.x.scatter_forward()
            columns.append(f.x.array.reshape(-1, bs)[self._node_dof])
        node_rows = np.hstack(columns) if columns else np.zeros((self._order.n_nodes, 0))
        nodes = self._order.nodes(self._comm, node_rows)
        cell_rows = None
        if self._vm is not None:
            self._vm.evaluate(fields["displacement"])
            rows = self._vm.field.x.array[self._cell_dof].reshape(-1, 1)  # type: ignore[attr-defined]
            forces = getattr(self._vm, "last_forces", None)
            if forces is not None:  # a beam's section forces, of the same evaluation
                rows = np.hstack([rows, forces])
            cell_rows = self._order.cells(self._comm, rows)
        error = None
        if self._comm.rank == 0:
            assert nodes is not None
            try:
                self._write_frame(t, nodes, cell_rows)
            except (OSError, ValueError) as exc:
                error = f"{self.path}: {exc}"
        error = self._comm.bcast(error, root=0)
        if error is not None:
            raise OSError(error)

    def _node_fields(self) -> list[tuple[str, int, int]]:
        """(name, first column, components) of each node field in the file: a beam's
        translations and rotations apart."""
        bs = self._bs
        out = []
        for i, name in enumerate(self.names):
            if bs == 6:
                out += [(name, i * bs, 3), (f"{name}_rotation", i * bs + 3, 3)]
            else:
                out.append((name, i * bs, bs))
        return out

    def _write_frame(self, t: float, nodes: npt.NDArray[Any], vm: npt.NDArray[Any] | None) -> None:
        k = self._frames

        def put(dset: str, data: npt.NDArray[Any]) -> None:
            if dset in self._h5:  # a frame a cut run wrote past its checkpoint
                del self._h5[dset]
            self._h5.create_dataset(dset, data=data)

        node_fields = self._node_fields()
        for name, first, count in node_fields:
            put(f"Function/{name}/{k}", nodes[:, first : first + count])
        cells = list(self._constants)
        if vm is not None:
            names = ["von_mises", *SECTION_FORCES[: vm.shape[1] - 1]]
            for j, name in enumerate(names):
                put(f"Function/{name}/{k}", vm[:, j : j + 1])
            cells = [*names, *cells]
        self._h5.flush()
        grid = self._grid(t, k, [(n, c) for n, _, c in node_fields], cells).encode()
        # The XML after the data it references; the tail rewritten after each grid.
        self._xml.seek(self._pos)
        self._xml.write(grid + _TAIL.encode())
        self._xml.truncate()
        self._xml.flush()
        self._pos += len(grid)
        self._frames = k + 1

    def close(self) -> None:
        """Close the files (not collective: rank 0's)."""
        for f in (self._xml, self._h5):
            if f is not None:
                f.close()
        self._xml = self._h5 = None

    def __enter__(self) -> XDMFSeries:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()


def xdmf_frames(path: Path) -> int:
    """Times written to the series in ``path`` (the grids of its first temporal collection;
    not collective)."""
    root = ET.parse(path).getroot()
    coll = root.find("Domain/Grid[@GridType='Collection']")
    return 0 if coll is None else len(coll.findall("Grid"))


def truncate_xdmf(path: Path, frames: int) -> None:
    """Keep the first ``frames`` times of the series in ``path``, drop the later ones from the
    XDMF file and the data sets only they reference from its HDF5 file (not collective: call
    it on one rank, with the file closed).

    Raises:
        ValueError: the series holds fewer frames, or the file is not an XDMF series.
    """
    import h5py

    ET.register_namespace("xi", XINCLUDE)
    tree = ET.parse(path)
    domain = tree.getroot().find("Domain")
    if domain is None:
        raise ValueError(f"{path}: not an XDMF file (no Domain)")
    dropped: set[str] = set()
    for coll in domain.findall("Grid[@GridType='Collection']"):
        grids = coll.findall("Grid")
        if len(grids) < frames:
            raise ValueError(f"{path}: {len(grids)} frames, fewer than the {frames} expected")
        for grid in grids[frames:]:
            dropped |= {d.text.strip() for d in grid.iter("DataItem") if d.text}
            coll.remove(grid)
    # The mesh and the constant cell fields are referenced by the kept frames too.
    dropped -= {d.text.strip() for d in domain.iter("DataItem") if d.text}
    if not dropped:
        return
    ET.indent(tree, "  ")
    tmp = path.with_suffix(".xdmf.tmp")
    tree.write(tmp, encoding="unicode", xml_declaration=True)
    with h5py.File(path.parent / next(iter(dropped)).split(":")[0], "r+") as f:
        for item in dropped:
            dset = item.split(":")[1]
            if dset in f:
                del f[dset]
    tmp.replace(path)


def read_xdmf(
    path: Path,
) -> tuple[
    npt.NDArray[np.float64], npt.NDArray[np.int64], dict[str, list[tuple[float, npt.NDArray[Any]]]]
]:
    """Read an XDMF time series back (XML + HDF5): this module's layout or dolfinx's (one
    collection per function), not collective.

    Returns:
        ``(geometry, topology, {field: [(t, values), ...]})``; node fields are (n_nodes, bs),
        cell fields (n_cells, 1), in the file's node and cell order. A field written once and
        referenced at every time (a constant cell field) is listed at every time.
    """
    import h5py

    root = ET.parse(path).getroot()
    domain = root.find("Domain")
    if domain is None:
        raise ValueError(f"{path}: not an XDMF file (no Domain)")
    cache: dict[str, npt.NDArray[Any]] = {}

    def h5(item: ET.Element | None) -> npt.NDArray[Any]:
        assert item is not None and item.text is not None
        key = item.text.strip()
        if key not in cache:
            fname, dset = key.split(":")
            with h5py.File(path.parent / fname, "r") as f:
                cache[key] = np.array(f[dset])
        return cache[key]

    geometry = h5(domain.find(".//Geometry/DataItem")).astype(np.float64)
    topology = h5(domain.find(".//Topology/DataItem")).astype(np.int64)
    fields: dict[str, list[tuple[float, npt.NDArray[Any]]]] = {}
    for coll in domain.findall("Grid[@GridType='Collection']"):
        for grid in coll.findall("Grid"):
            time = grid.find("Time")
            assert time is not None
            t = float(time.get("Value", "nan"))
            for attr in grid.findall("Attribute"):
                name = attr.get("Name", "")
                fields.setdefault(name, []).append((t, h5(attr.find("DataItem"))))
    return geometry, topology, fields
