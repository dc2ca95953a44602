"""Import-order and version shims for the dolfinx/PETSc stack (the only place for them)."""

import dolfinx_solver  # noqa: F401  (orders mpi4py.MPI ahead of the compiled bindings)

__all__: list[str] = []
