"""XDMF time series of nodal fields (ParaView's Xdmf3 reader opens them)."""

from __future__ import annotations

from pathlib import Path
from types import TracebackType

import dolfinx
import dolfinx.io
import numpy as np
import numpy.typing as npt

__all__ = ["XDMFSeries"]


class XDMFSeries:
    """Writes named P1 fields at given times; flushes after each time so a cut run stays valid.

    Collective over the mesh communicator. Fields are given as owned-DOF arrays and scattered
    to ghosts before writing.
    """

    def __init__(self, path: Path, V: dolfinx.fem.FunctionSpace, names: list[str]) -> None:
        path.parent.mkdir(parents=True, exist_ok=True) if V.mesh.comm.rank == 0 else None
        V.mesh.comm.barrier()
        self._file = dolfinx.io.XDMFFile(V.mesh.comm, str(path), "w")
        self._file.write_mesh(V.mesh)
        self._functions = {}
        for name in names:
            f = dolfinx.fem.Function(V, name=name)
            self._functions[name] = f
        self._n = V.dofmap.index_map.size_local * V.dofmap.index_map_bs

    def write(self, t: float, fields: dict[str, npt.NDArray[np.float64]]) -> None:
        for name, values in fields.items():
            f = self._functions[name]
            f.x.array[: self._n] = values
            f.x.scatter_forward()
            self._file.write_function(f, t)
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
