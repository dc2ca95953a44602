"""Point-on-surface projection, compiled: each contact point on the triangle (or the vertex)
chosen among its candidates, with no NumPy temporaries (the crane's sliding contacts project
32 points on 84 triangles at every macro step: in NumPy, 2 ms of call overhead for 10 µs of
arithmetic; ``crane_fem.contact.surface`` states the rule this implements).
"""

from __future__ import annotations

import numba
import numpy as np
import numpy.typing as npt

__all__ = ["offsets_over_pairings", "select_triangles", "select_vertices"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


@numba.njit(cache=True)
def _edges(
    xyz: FloatArray, triangles: IntArray, t: int
) -> tuple[float, float, float, float, float, float, float, float, float]:
    """Triangle t's edges e1 = b − a, e2 = c − a and its normal e1 × e2 (not unit)."""
    a, b, c = triangles[t, 0], triangles[t, 1], triangles[t, 2]
    e10 = xyz[b, 0] - xyz[a, 0]
    e11 = xyz[b, 1] - xyz[a, 1]
    e12 = xyz[b, 2] - xyz[a, 2]
    e20 = xyz[c, 0] - xyz[a, 0]
    e21 = xyz[c, 1] - xyz[a, 1]
    e22 = xyz[c, 2] - xyz[a, 2]
    n0 = e11 * e22 - e12 * e21
    n1 = e12 * e20 - e10 * e22
    n2 = e10 * e21 - e11 * e20
    return e10, e11, e12, e20, e21, e22, n0, n1, n2


@numba.njit(cache=True)
def select_triangles(
    x: FloatArray,
    xyz: FloatArray,
    triangles: IntArray,
    candidates: IntArray,
    reach: float,
    inside_tol: float,
    strict_tol: float,
    triangle: IntArray,
    xi: FloatArray,
    normal: FloatArray,
    gap: FloatArray,
) -> None:
    """For each point x[i] (p, 3), among the triangles ``candidates[i]`` (p, k; −1 ends a
    row), the one holding its projection (barycentric coordinates ≥ −``strict_tol``, else
    ≥ −``inside_tol``) within ``reach`` of its plane, the nearest along its normal (the
    lowest index among equals); written into ``triangle`` (−1: none, the other outputs
    then untouched), ``xi`` (clipped to [0, 1] and summed to 1), ``normal`` (unit, of the
    triangle's orientation) and ``gap`` (signed distance along it). Not collective.

    Where the pairs outnumber the triangles, each triangle's centroid c, unit normal and
    circumradius R about c are formed first, and a pair whose point lies farther than
    1.01 R from c within the triangle's plane is passed over: a projection with barycentric
    coordinates ≥ −ε lies within (1 + 3ε) R of c (the farthest at a vertex of that
    polytope, (1 + 2ε, −ε, −ε): c + (1 + 3ε)(v₀ − c)), so for ε = ``inside_tol`` ≤ 3e-3 no
    pair that could be chosen is passed over: the same choice, with a fifth of the
    arithmetic on a rail's top."""
    n_t = triangles.shape[0]
    cull = x.shape[0] * candidates.shape[1] >= n_t and inside_tol <= 3e-3
    box = np.empty((n_t if cull else 0, 7))
    if cull:
        for t in range(n_t):
            a, b, c = triangles[t, 0], triangles[t, 1], triangles[t, 2]
            c0 = (xyz[a, 0] + xyz[b, 0] + xyz[c, 0]) / 3.0
            c1 = (xyz[a, 1] + xyz[b, 1] + xyz[c, 1]) / 3.0
            c2 = (xyz[a, 2] + xyz[b, 2] + xyz[c, 2]) / 3.0
            r2 = 0.0
            for v in (a, b, c):
                d0, d1, d2 = xyz[v, 0] - c0, xyz[v, 1] - c1, xyz[v, 2] - c2
                r2 = max(r2, d0 * d0 + d1 * d1 + d2 * d2)
            n0, n1, n2 = _edges(xyz, triangles, t)[6:]
            norm = np.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
            box[t, 0], box[t, 1], box[t, 2] = c0, c1, c2
            box[t, 3], box[t, 4], box[t, 5] = n0 / norm, n1 / norm, n2 / norm
            box[t, 6] = 1.0201 * r2
    for i in range(x.shape[0]):
        best_rank = 2
        best_gap = np.inf
        best_t = -1
        bx0 = bx1 = bx2 = 0.0
        bn0 = bn1 = bn2 = 0.0
        bg = 0.0
        for jj in range(candidates.shape[1]):
            t = candidates[i, jj]
            if t < 0:
                break
            if cull:
                d0 = x[i, 0] - box[t, 0]
                d1 = x[i, 1] - box[t, 1]
                d2 = x[i, 2] - box[t, 2]
                dn = d0 * box[t, 3] + d1 * box[t, 4] + d2 * box[t, 5]
                if d0 * d0 + d1 * d1 + d2 * d2 - dn * dn > box[t, 6]:
                    continue
            a = triangles[t, 0]
            e10, e11, e12, e20, e21, e22, n0, n1, n2 = _edges(xyz, triangles, t)
            nn = n0 * n0 + n1 * n1 + n2 * n2
            d0 = x[i, 0] - xyz[a, 0]
            d1 = x[i, 1] - xyz[a, 1]
            d2 = x[i, 2] - xyz[a, 2]
            dist = (d0 * n0 + d1 * n1 + d2 * n2) / nn
            # Projection onto the plane, then Cramer's rule on the in-plane system.
            p0 = x[i, 0] - dist * n0
            p1 = x[i, 1] - dist * n1
            p2 = x[i, 2] - dist * n2
            q0 = p0 - xyz[a, 0]
            q1 = p1 - xyz[a, 1]
            q2 = p2 - xyz[a, 2]
            d11 = e10 * e10 + e11 * e11 + e12 * e12
            d12 = e10 * e20 + e11 * e21 + e12 * e22
            d22 = e20 * e20 + e21 * e21 + e22 * e22
            r1 = q0 * e10 + q1 * e11 + q2 * e12
            r2 = q0 * e20 + q1 * e21 + q2 * e22
            det = d11 * d22 - d12 * d12
            s = (d22 * r1 - d12 * r2) / det
            w = (d11 * r2 - d12 * r1) / det
            l0 = 1.0 - s - w
            low = min(l0, s, w)
            norm = np.sqrt(nn)
            u0, u1, u2 = n0 / norm, n1 / norm, n2 / norm
            g = (x[i, 0] - p0) * u0 + (x[i, 1] - p1) * u1 + (x[i, 2] - p2) * u2
            if low < -inside_tol or abs(g) > reach:
                continue
            rank = 0 if low >= -strict_tol else 1
            if rank < best_rank or (
                rank == best_rank and (abs(g) < best_gap or (abs(g) == best_gap and t < best_t))
            ):
                best_rank, best_gap, best_t = rank, abs(g), t
                bx0, bx1, bx2 = l0, s, w
                bn0, bn1, bn2 = u0, u1, u2
                bg = g
        if best_t < 0:
            continue
        bx0 = min(max(bx0, 0.0), 1.0)
        bx1 = min(max(bx1, 0.0), 1.0)
        bx2 = min(max(bx2, 0.0), 1.0)
        total = bx0 + bx1 + bx2
        triangle[i] = best_t
        xi[i, 0], xi[i, 1], xi[i, 2] = bx0 / total, bx1 / total, bx2 / total
        normal[i, 0], normal[i, 1], normal[i, 2] = bn0, bn1, bn2
        gap[i] = bg


@numba.njit(cache=True)
def select_vertices(
    x: FloatArray,
    xyz: FloatArray,
    triangles: IntArray,
    holder: IntArray,
    candidates: IntArray,
    triangle: IntArray,
    xi: FloatArray,
    normal: FloatArray,
    gap: FloatArray,
) -> None:
    """For each point x[i] (p, 3), the vertex v among ``candidates[i]`` (p, k; indices into
    ``xyz``) nearest to it (the first of equals), written as a point of the triangle
    ``holder[v]`` that holds it: ``triangle``, ``xi`` (that vertex's e_k), ``normal`` (the
    triangle's unit normal) and ``gap`` (the distance from v along it). Not collective."""
    for i in range(x.shape[0]):
        best = np.inf
        v = -1
        for jj in range(candidates.shape[1]):
            w = candidates[i, jj]
            d0 = x[i, 0] - xyz[w, 0]
            d1 = x[i, 1] - xyz[w, 1]
            d2 = x[i, 2] - xyz[w, 2]
            d = d0 * d0 + d1 * d1 + d2 * d2
            if d < best:
                best, v = d, w
        t = holder[v]
        n0, n1, n2 = _edges(xyz, triangles, t)[6:]
        norm = np.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
        n0, n1, n2 = n0 / norm, n1 / norm, n2 / norm
        triangle[i] = t
        for k in range(3):
            xi[i, k] = 1.0 if triangles[t, k] == v else 0.0
        normal[i, 0], normal[i, 1], normal[i, 2] = n0, n1, n2
        gap[i] = (
            n0 * (x[i, 0] - xyz[v, 0]) + n1 * (x[i, 1] - xyz[v, 1]) + n2 * (x[i, 2] - xyz[v, 2])
        )


@numba.njit(cache=True)
def offsets_over_pairings(
    x: FloatArray,
    point: IntArray,
    vertex: IntArray,
    xi: FloatArray,
    normal: FloatArray,
    tangential_of: npt.NDArray[np.bool_],
    along: FloatArray,
    tangential: FloatArray,
) -> None:
    """For each paired point i, d = x[point[i]] − Σ_k xi[i, k] x[vertex[i, k]] split along
    its normal: ``along[i]`` = n·d, ``tangential[i]`` = d − (n·d) n where ``tangential_of[i]``
    (zeros elsewhere). Not collective."""
    for i in range(point.size):
        p = point[i]
        a, b, c = vertex[i, 0], vertex[i, 1], vertex[i, 2]
        d0 = x[p, 0] - (xi[i, 0] * x[a, 0] + xi[i, 1] * x[b, 0] + xi[i, 2] * x[c, 0])
        d1 = x[p, 1] - (xi[i, 0] * x[a, 1] + xi[i, 1] * x[b, 1] + xi[i, 2] * x[c, 1])
        d2 = x[p, 2] - (xi[i, 0] * x[a, 2] + xi[i, 1] * x[b, 2] + xi[i, 2] * x[c, 2])
        dn = normal[i, 0] * d0 + normal[i, 1] * d1 + normal[i, 2] * d2
        along[i] = dn
        if tangential_of[i]:
            tangential[i, 0] = d0 - dn * normal[i, 0]
            tangential[i, 1] = d1 - dn * normal[i, 1]
            tangential[i, 2] = d2 - dn * normal[i, 2]
        else:
            tangential[i, 0] = tangential[i, 1] = tangential[i, 2] = 0.0
