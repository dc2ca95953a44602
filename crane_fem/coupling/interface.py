"""Interface DOF maps between subdomains, matched by parent-mesh vertex (no coordinates)."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from crane_fem.contact import ContactSet
from crane_fem.subdomains import Subdomain

__all__ = ["build_interface", "constraint_set"]

IntArray = npt.NDArray[np.int64]


def constraint_set(
    sub: Subdomain,
    vertices: IntArray,
    coeff: float | npt.NDArray[np.float64],
    g0: npt.NDArray[np.float64],
    names: list[str],
    group: IntArray,
    components: list[int] | None = None,
) -> ContactSet:
    """Rows ``k·nc + c`` for vertex ``vertices[k]`` and component ``components[c]``.

    ``coeff`` is a scalar or an array (len(vertices), nc) of coefficients. Terms exist only on
    the rank owning the DOF; the row numbering is global (identical on all ranks).
    """
    bs = sub.bs
    comps = list(range(bs)) if components is None else components
    nc = len(comps)
    blocks, pos = sub.owned_dofs_of(vertices)
    coeffs = np.broadcast_to(np.asarray(coeff, dtype=np.float64), (vertices.size, nc))
    rows = (pos[:, None] * nc + np.arange(nc)[None, :]).ravel()
    dofs = (blocks[:, None] * bs + np.asarray(comps)[None, :]).ravel()
    vals = coeffs[pos].ravel()
    keep = vals != 0.0
    return ContactSet(
        sub.model.comm,
        g0,
        rows[keep].astype(np.int64),
        dofs[keep].astype(np.int64),
        vals[keep],
        group,
        names,
    )


def build_interface(
    explicit: Subdomain, implicit: Subdomain
) -> tuple[IntArray, ContactSet, ContactSet]:
    """Duplicated interface DOFs: constraint L_E V_E + L_I V_I = 0 (L_E = +1, L_I = −1).

    Interface vertices are the parent vertices on the boundary of both submeshes, minus clamped
    ones (fixed on both sides already). Works when the interface is split across ranks: each
    rank contributes the terms of the DOFs it owns (collective).

    Returns:
        ``(vertices, L_E, L_I)``: sorted global parent vertex ids and the two constraint sets
        with rows ``k·bs + c``.
    """
    both = np.intersect1d(explicit.boundary_vertices(), implicit.boundary_vertices())
    fixed = np.union1d(explicit.fixed_vertices, implicit.fixed_vertices)
    vertices = np.setdiff1d(both, fixed).astype(np.int64)
    n = vertices.size * explicit.bs
    g0 = np.zeros(n)
    group = np.zeros(n, dtype=np.int64)
    le = constraint_set(explicit, vertices, 1.0, g0, ["interface"], group)
    li = constraint_set(implicit, vertices, -1.0, g0, ["interface"], group)
    return vertices, le, li
