"""Compiled (numba) kernels: the explicit micro steps, the small exact LCP, and the MPI calls
they make; they see arrays only (their owners unpack the PETSc and dolfinx objects once).

Their on-disk cache (``cache=True``) lives in a directory named after a digest of this
package's sources: numba checks a cached function against its own file only, so after an
edit of a kernel another module calls (``kernels/friction.py`` called from
``kernels/explicit.py``) the caller's cache would keep the old callee compiled in. A source
change now starts a fresh cache. ``NUMBA_CACHE_DIR``, when set, is left as it is.
"""

import hashlib
import os
from pathlib import Path

import numba

__all__: list[str] = []

_HERE = Path(__file__).parent
if "NUMBA_CACHE_DIR" not in os.environ:
    _DIGEST = hashlib.sha256(
        b"".join(p.name.encode() + p.read_bytes() for p in sorted(_HERE.glob("*.py")))
    ).hexdigest()[:16]
    numba.config.CACHE_DIR = str(_HERE / "__pycache__" / f"numba-{_DIGEST}")  # type: ignore[attr-defined]
