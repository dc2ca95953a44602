"""XDMF time series of nodal fields (ParaView's Xdmf3 reader opens them)."""

from __future__ import annotations

from pathlib import Path
from types import TracebackType
from typing import Any

import dolfinx
import dolfinx.io
import numpy as np
import numpy.typing as npt

from crane_fem.stress import VonMises

__all__ = ["XDMFSeries"]


class XDMFSeries:
    """Writes named P1 fields at given times; flushes after each time so a cut run stays valid.

    Collective over the mesh communicator. Fields are given as owned-DOF arrays and scattered
    to ghosts before writing. Optional cellwise (DG0) fields: ``constants`` are written with
    the same value at every time (e.g. the subdomain tag, so ParaView can colour by it at any
    time), and ``von_mises = (E, ν)`` adds the von Mises stress of the ``displacement`` field
    (linear elasticity, evaluated per cell; P1 strains are constant in a tetrahedron).
    """

    def __init__(
        self,
        path: Path,
        V: dolfinx.fem.FunctionSpace,
        names: list[str],
        constants: dict[str, float] | None = None,
        von_mises: tuple[float, float] | None = None,
    ) -> None:
        path.parent.mkdir(parents=True, exist_ok=True) if V.mesh.comm.rank == 0 else None
        V.mesh.comm.barrier()
        self._file = dolfinx.io.XDMFFile(V.mesh.comm, str(path), "w")
        self._file.write_mesh(V.mesh)
        self._functions = {}
        for name in names:
            f = dolfinx.fem.Function(V, name=name)
            self._functions[name] = f
        self._n = V.dofmap.index_map.size_local * V.dofmap.index_map_bs
        W = dolfinx.fem.functionspace(V.mesh, ("DG", 0))
        self._cells: list[dolfinx.fem.Function] = []
        for name, value in (constants or {}).items():
            c = dolfinx.fem.Function(W, name=name)
            c.x.array[:] = value
            self._cells.append(c)
        self._vm: VonMises | None = None
        if von_mises is not None:
            self._vm = VonMises(V, *von_mises)

    def write(self, t: float, fields: dict[str, npt.NDArray[np.float64]]) -> None:
        for name, values in fields.items():
            f = self._functions[name]
            f.x.array[: self._n] = values
            f.x.scatter_forward()
            self._file.write_function(f, t)
        if self._vm is not None:
            self._vm.evaluate(fields["displacement"])
            self._file.write_function(self._vm.field, t)
        for c in self._cells:
            self._file.write_function(c, t)
        self._file.flush()

    def close(self) -> None:
        self._file.close()

    def __enter__(self) -> XDMFSeries:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()


def read_xdmf(
    path: Path,
) -> tuple[
    npt.NDArray[np.float64], npt.NDArray[np.int64], dict[str, list[tuple[float, npt.NDArray[Any]]]]
]:
    """Read a dolfinx XDMF time series back (XML + HDF5, as ParaView's Xdmf3 reader does).

    meshio reads one grid per file and so cannot open dolfinx's one-collection-per-function
    layout; this reader follows the XDMF references instead.

    Returns:
        ``(geometry, topology, {field: [(t, values), ...]})``; node fields are (n_nodes, bs),
        cell fields (n_cells, 1), in the file's node and cell order.
    """
    import xml.etree.ElementTree as ET

    import h5py

    root = ET.parse(path).getroot()
    domain = root.find("Domain")
    if domain is None:
        raise ValueError(f"{path}: not an XDMF file (no Domain)")

    def h5(item: ET.Element | None) -> npt.NDArray[Any]:
        assert item is not None and item.text is not None
        fname, dset = item.text.strip().split(":")
        with h5py.File(path.parent / fname, "r") as f:
            return np.array(f[dset])

    geometry = h5(domain.find("Grid/Geometry/DataItem")).astype(np.float64)
    topology = h5(domain.find("Grid/Topology/DataItem")).astype(np.int64)
    fields: dict[str, list[tuple[float, npt.NDArray[Any]]]] = {}
    for coll in domain.findall("Grid[@GridType='Collection']"):
        for grid in coll.findall("Grid"):
            time = grid.find("Time")
            attr = grid.find("Attribute")
            assert time is not None and attr is not None
            name = attr.get("Name", "")
            fields.setdefault(name, []).append(
                (float(time.get("Value", "nan")), h5(attr.find("DataItem")))
            )
    return geometry, topology, fields
