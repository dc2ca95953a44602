"""MPI from compiled kernels: a halo exchange and a small allreduce on any communicator.

numba-mpi shows the way (MPI functions called from ``@njit`` code) but is bound to
``MPI_COMM_WORLD`` and, through ctypes pointers, cannot be cached; these take the
communicator's handle, so a kernel works on the mesh's communicator as the rest of the library
does, and bind the MPI functions by name (numba ``ExternalFunction``), so the kernels that call
them are cached on disk. The library is the one mpi4py is linked to.
"""

from __future__ import annotations

import ctypes
from pathlib import Path
from typing import Any

import llvmlite.binding
import numba
import numpy as np
import numpy.typing as npt
from mpi4py import MPI
from numba import types

__all__ = [
    "RequestArray",
    "allreduce_sum",
    "comm_handle",
    "create_requests",
    "halo_finish",
    "halo_start",
]


def _mpi_library() -> str:
    """Path of the MPI library this process loaded through mpi4py (Linux: from its maps)."""
    maps = Path("/proc/self/maps")
    if maps.is_file():
        for line in maps.read_text().splitlines():
            path = line.split()[-1] if line.split() else ""
            if "/libmpi" in path and ".so" in path and "mpicxx" not in path:
                return path
    return str(MPI.__file__)  # its dependencies resolve the MPI symbols


llvmlite.binding.load_library_permanently(_mpi_library())

# MPICH's handles are ints, Open MPI's pointers; pointers are passed as integers (intp).
_INT_HANDLES = MPI._sizeof(MPI.Comm) == ctypes.sizeof(ctypes.c_int)
_h = types.int32 if _INT_HANDLES else types.intp
_p = types.intp
_i = types.int32
# (Typed Any: mypy does not know numba's external functions are callable in njit code.)
_allreduce: Any = types.ExternalFunction("MPI_Allreduce", _i(_p, _p, _i, _h, _h, _h))
_isend: Any = types.ExternalFunction("MPI_Isend", _i(_p, _i, _h, _i, _i, _h, _p))
_irecv: Any = types.ExternalFunction("MPI_Irecv", _i(_p, _i, _h, _i, _i, _h, _p))
_waitall: Any = types.ExternalFunction("MPI_Waitall", _i(_i, _p, _p))

_REQUEST_DTYPE = np.intc if MPI._sizeof(MPI.Request) == ctypes.sizeof(ctypes.c_int) else np.intp
#: An MPI_Status is a few ints (5 in MPICH, 6 in Open MPI); its room is counted in requests.
_STATUS_SLOTS = 8
_TAG = 7

RequestArray = npt.NDArray[Any]


def comm_handle(comm: MPI.Comm) -> npt.NDArray[np.int64]:
    """The handles a kernel needs: (communicator, MPI_DOUBLE, MPI_SUM) (not collective)."""
    signed = ctypes.c_int if _INT_HANDLES else ctypes.c_ssize_t
    handles = (MPI._handleof(comm), MPI._handleof(MPI.DOUBLE), MPI._handleof(MPI.SUM))
    return np.array([signed(h).value for h in handles], dtype=np.int64)


def create_requests(n: int) -> RequestArray:
    """Room for ``n`` MPI requests followed by their statuses (not collective)."""
    return np.zeros(n * (1 + _STATUS_SLOTS), dtype=_REQUEST_DTYPE)


@numba.njit(cache=True)
def allreduce_sum(
    send: npt.NDArray[np.float64], recv: npt.NDArray[np.float64], mpi: npt.NDArray[np.int64]
) -> int:
    """``recv = Σ_ranks send`` (collective over the communicator of ``mpi``); the MPI error."""
    return _allreduce(send.ctypes.data, recv.ctypes.data, send.size, mpi[1], mpi[2], mpi[0])


@numba.njit(cache=True)
def halo_start(
    x: npt.NDArray[np.float64],
    neighbours: npt.NDArray[np.int32],
    send_ptr: npt.NDArray[np.int64],
    send_idx: npt.NDArray[np.int64],
    recv_ptr: npt.NDArray[np.int64],
    send_buf: npt.NDArray[np.float64],
    recv_buf: npt.NDArray[np.float64],
    requests: RequestArray,
    mpi: npt.NDArray[np.int64],
) -> int:
    """Post the exchange: ``x[send_idx]`` packed per neighbour (``send_ptr`` offsets), the
    receives into ``recv_buf`` (``recv_ptr`` offsets). Collective with the neighbours;
    complete it with :func:`halo_finish`. Returns the MPI error codes or-ed."""
    n = neighbours.size
    for k in range(send_idx.size):
        send_buf[k] = x[send_idx[k]]
    base = requests.ctypes.data
    step = requests.itemsize
    err = 0
    for k in range(n):
        a, b = recv_ptr[k], recv_ptr[k + 1]
        err |= _irecv(
            recv_buf.ctypes.data + 8 * a,
            b - a,
            mpi[1],
            neighbours[k],
            _TAG,
            mpi[0],
            base + k * step,
        )
    for k in range(n):
        a, b = send_ptr[k], send_ptr[k + 1]
        err |= _isend(
            send_buf.ctypes.data + 8 * a,
            b - a,
            mpi[1],
            neighbours[k],
            _TAG,
            mpi[0],
            base + (n + k) * step,
        )
    return err


@numba.njit(cache=True)
def halo_finish(
    x: npt.NDArray[np.float64],
    n_neighbours: int,
    recv_idx: npt.NDArray[np.int64],
    recv_buf: npt.NDArray[np.float64],
    requests: RequestArray,
) -> int:
    """Wait for :func:`halo_start` and write the received values to ``x[recv_idx]``."""
    if n_neighbours == 0:
        return 0
    n_req = 2 * n_neighbours
    base = requests.ctypes.data
    err = _waitall(n_req, base, base + n_req * requests.itemsize)
    for k in range(recv_idx.size):
        x[recv_idx[k]] = recv_buf[k]
    return err
