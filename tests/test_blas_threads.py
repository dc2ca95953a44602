"""The BLAS threads of a rank's dense products (crane_fem.blas_threads)."""

from __future__ import annotations

import numpy  # noqa: F401  (loads numpy's BLAS, for threadpoolctl to see)
import pytest
from mpi4py import MPI
from threadpoolctl import threadpool_info, threadpool_limits

from crane_fem.blas_threads import rank_blas_threads

pytestmark = pytest.mark.no_kernels


def _blas_threads() -> dict[str, int]:
    return {i["filepath"]: i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"}


def test_ranks_on_one_node_run_one_blas_thread_a_process_alone_keeps_its_own() -> None:
    """Given two BLAS threads (numpy's and scipy's OpenBLAS take them; basix's is built with
    one): ranks sharing the node (mpiexec -n 2 here) run one inside the context, a process
    alone keeps the two; both get the two back after it."""
    with threadpool_limits(limits=2, user_api="blas"):
        given = _blas_threads()
        two = [lib for lib, n in given.items() if n == 2]
        assert any("numpy" in lib for lib in two), given
        with rank_blas_threads(MPI.COMM_WORLD):
            inside = _blas_threads()
        assert _blas_threads() == given
    want = 1 if MPI.COMM_WORLD.size > 1 else 2
    assert {lib: inside[lib] for lib in two} == dict.fromkeys(two, want)
