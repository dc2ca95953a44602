"""Compiled (numba) kernels: the explicit micro steps, the small exact LCP, and the MPI calls
they make; they see arrays only (their owners unpack the PETSc and dolfinx objects once)."""

__all__: list[str] = []
