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

__all__ = ["XDMFSeries", "read_xdmf", "truncate_xdmf", "xdmf_frames"]

XINCLUDE = "https://www.w3.org/2001/XInclude"


class XDMFSeries:
    """Writes named P1 fields at given times; flushes after each time so a cut run stays valid.

    Collective over the mesh communicator. Fields are given as owned-DOF arrays and scattered
    to ghosts before writing. Optional cellwise (DG0) fields: ``constants`` are written with
    the same value at every time (e.g. the subdomain tag, so ParaView can colour by it at any
    time), and ``von_mises = (E, ν)`` adds the von Mises stress of the ``displacement`` field
    (linear elasticity, evaluated per cell; P1 strains are constant in a tetrahedron).
    ``append``: continue the series already in ``path`` (a restarted run, after
    :func:`truncate_xdmf`) rather than start a new file.
    """

    def __init__(
        self,
        path: Path,
        V: dolfinx.fem.FunctionSpace,
        names: list[str],
        constants: dict[str, float] | None = None,
        von_mises: tuple[float, float] | None = None,
        append: bool = False,
    ) -> None:
        path.parent.mkdir(parents=True, exist_ok=True) if V.mesh.comm.rank == 0 else None
        V.mesh.comm.barrier()
        self._file = dolfinx.io.XDMFFile(V.mesh.comm, str(path), "a" if append else "w")
        if not append:
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


def xdmf_frames(path: Path) -> int:
    """Times written to the series in ``path`` (the frames of its first field; not
    collective)."""
    import xml.etree.ElementTree as ET

    root = ET.parse(path).getroot()
    coll = root.find("Domain/Grid[@GridType='Collection']")
    return 0 if coll is None else len(coll.findall("Grid"))


def truncate_xdmf(path: Path, frames: int) -> None:
    """Keep the first ``frames`` times of the series in ``path`` (every field's), drop the
    later ones from the XDMF file and their data sets from its HDF5 file (not collective:
    call it on one rank, with the file closed).

    Raises:
        ValueError: the series holds fewer frames, or the file is not a dolfinx series.
    """
    import xml.etree.ElementTree as ET

    import h5py

    ET.register_namespace("xi", XINCLUDE)
    tree = ET.parse(path)
    domain = tree.getroot().find("Domain")
    if domain is None:
        raise ValueError(f"{path}: not an XDMF file (no Domain)")
    dropped: list[str] = []
    for coll in domain.findall("Grid[@GridType='Collection']"):
        grids = coll.findall("Grid")
        if len(grids) < frames:
            raise ValueError(f"{path}: {len(grids)} frames, fewer than the {frames} expected")
        for grid in grids[frames:]:
            dropped += [d.text.strip() for d in grid.iter("DataItem") if d.text]
            coll.remove(grid)
    if not dropped:
        return
    ET.indent(tree, "  ")
    tmp = path.with_suffix(".xdmf.tmp")
    tree.write(tmp, encoding="unicode", xml_declaration=True)
    with h5py.File(path.parent / dropped[0].split(":")[0], "r+") as f:
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
