"""The BLAS threads of a rank's dense products (numpy's and scipy's OpenBLAS).

Ranks that share a node each run one thread: ``mpiexec -n N`` puts a rank on a core, and two
BLAS threads per rank on those cores oversubscribe them (on 2 cores, a small product then takes
10× as long; benchmarks/RESULTS.md, session 34). A process alone on its node keeps BLAS as it
was given (the environment's ``OPENBLAS_NUM_THREADS``, else a thread per core): there its
threads speed up the large products (a reduced side's field expansion 1.6× on 2 cores).
"""

from __future__ import annotations

from contextlib import AbstractContextManager, nullcontext
from typing import Any

from mpi4py import MPI

__all__ = ["rank_blas_threads"]


def rank_blas_threads(comm: MPI.Comm) -> AbstractContextManager[Any]:
    """A context in which BLAS runs one thread per rank when ranks of ``comm`` share a node,
    and as it was given otherwise (collective)."""
    local = comm.Split_type(MPI.COMM_TYPE_SHARED)
    shared = local.size > 1
    local.Free()
    if not shared:
        return nullcontext()
    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=1, user_api="blas")
