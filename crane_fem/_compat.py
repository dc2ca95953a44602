"""Import-order and version shims for the dolfinx/PETSc stack (the only place for them)."""

import dolfinx_solver  # noqa: F401  (orders mpi4py.MPI ahead of the compiled bindings)

# h5py before dolfinx.fem.petsc: that module loads PETSc and its HDF5 (1.14) into the global
# symbol scope, after which h5py's own HDF5 (2.0) binds to the wrong library ("Not a
# datatype" at import). Loaded first, each keeps its own.
import h5py  # noqa: F401  isort: skip

__all__: list[str] = []
