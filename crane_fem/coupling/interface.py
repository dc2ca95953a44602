"""Interface DOF maps between subdomains, matched by parent-mesh vertex (no coordinates)."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import scipy.sparse
import scipy.sparse.csgraph

from crane_fem.contact import ContactSet
from crane_fem.subdomains import Subdomain, global_ids

__all__ = ["build_interface", "constraint_set", "zone_labels"]

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

    Interface vertices are the parent vertices of both submeshes (on a solid's, their shared
    boundary; a frame's joint may be inside one of them: a trolley's wheel stub ends inside
    its grillage), minus clamped ones (fixed on both sides already). Works when the interface
    is split across ranks: each rank contributes the terms of the DOFs it owns (collective).

    Returns:
        ``(vertices, L_E, L_I)``: sorted global parent vertex ids and the two constraint sets
        with rows ``k·bs + c``.
    """
    comm = explicit.submesh.comm
    both = np.intersect1d(
        global_ids(comm, explicit.vertex_global), global_ids(comm, implicit.vertex_global)
    )
    fixed = np.union1d(explicit.fixed_vertices, implicit.fixed_vertices)
    vertices = np.setdiff1d(both, fixed).astype(np.int64)
    n = vertices.size * explicit.bs
    g0 = np.zeros(n)
    group = np.zeros(n, dtype=np.int64)
    le = constraint_set(explicit, vertices, 1.0, g0, ["interface"], group)
    li = constraint_set(implicit, vertices, -1.0, g0, ["interface"], group)
    return vertices, le, li


def zone_labels(explicit: Subdomain, vertices: IntArray) -> IntArray:
    """The connected component of ``explicit`` (any subdomain) that holds each interface row
    (``k·bs + c`` for ``vertices[k]``): 0, 1, … in the order of the components' smallest
    vertex (collective; the cells' vertices are gathered on every rank: the explicit zones
    are small by design, the implicit side's cells are gathered once at set-up)."""
    msh = explicit.submesh
    tdim = msh.topology.dim
    msh.topology.create_connectivity(tdim, 0)
    n_cells = msh.topology.index_map(tdim).size_local
    c2v = msh.topology.connectivity(tdim, 0)
    nv = tdim + 1  # simplices
    local = explicit.vertex_global[c2v.array[: c2v.offsets[n_cells]]].reshape(n_cells, nv)
    cells = np.concatenate(msh.comm.allgather(local.astype(np.int64)))
    ids, inv = np.unique(cells, return_inverse=True)
    inv = inv.reshape(cells.shape)
    nv = cells.shape[1]
    rows = np.repeat(inv[:, 0], nv - 1)
    cols = inv[:, 1:].ravel()
    graph = scipy.sparse.coo_matrix((np.ones(rows.size), (rows, cols)), shape=(ids.size, ids.size))
    _, comp = scipy.sparse.csgraph.connected_components(graph, directed=False)
    # Number the zones by their smallest vertex (independent of the partition).
    first = np.full(comp.max() + 1, np.iinfo(np.int64).max)
    np.minimum.at(first, comp, ids)
    rank = np.argsort(np.argsort(first))
    label = rank[comp[np.searchsorted(ids, vertices)]]
    return np.repeat(label, explicit.bs).astype(np.int64)
