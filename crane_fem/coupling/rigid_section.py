"""A beam node driving a solid face: the six rows of a rigid section (THEORY.md §11; code_aster's
LIAISON_ELEM 3D_POU), an interface map known by its rows rather than by shared vertices.

On the face S (centroid G, area |S|, second-moment tensor I_G = ∫_S (|r|² 1 − r ⊗ r) dS, r =
x − G), the solid's displacement u = Σ_i N_i u_i and the beam node's (u_P, θ_P) are tied by

    Σ_i (∫_S N_i dS) u_i = |S| u_P,        Σ_i ∫_S r × N_i u_i dS = I_G θ_P,

a 6 × 3n block on the solid side and a 6 × 6 one, diag(|S| 1, I_G), on the beam's. A rigid
motion of the face, u = a + θ × r, meets them with (u_P, θ_P) = (a, θ); their transpose spreads a
resultant (F, M) about G over the face's nodes exactly (P1 reproduces r): the rows add no
stiffness and leave the face free to warp and contract (RBE3-like). Rows 0–2 are the
translations, 3–5 the rotations; as velocity rows L_E v_E = L_I v_I they are the GC interface
of one face: six unknowns.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import dolfinx
import numpy as np
import numpy.typing as npt
import ufl
from mpi4py import MPI

from crane_fem.contact import ContactSet
from crane_fem.errors import ScenarioError
from crane_fem.subdomains import Subdomain

__all__ = ["CENTROID_TOL", "FaceRows", "face_rows", "joint_interface"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

#: A joint face is planar when its vertices lie within this fraction of its size of the plane
#: through its centroid normal to its least second moment of area's axis.
PLANAR_TOL = 1e-6
#: A beam node joins a face when it lies within this fraction of the face's size (√|S|) of
#: its centroid.
CENTROID_TOL = 0.01


@dataclass(frozen=True)
class FaceRows:
    """The six rows of one face, the solid side's terms split by DOF owner.

    Attributes:
        comm: the solid mesh's communicator.
        area, centroid, inertia: |S|, G (3,), I_G (3, 3) (global: the same on every rank).
        normal: the face's unit normal (3,) (its sign as the first facet's outward normal).
        rows, dofs, coeffs: this rank's terms of the solid side: row (0–5), owned local DOF
            of the vector space (block × 3 + component), coefficient.
    """

    comm: MPI.Comm
    area: float
    centroid: FloatArray
    inertia: FloatArray
    normal: FloatArray
    rows: IntArray
    dofs: IntArray
    coeffs: FloatArray

    @property
    def beam_block(self) -> FloatArray:
        """The beam node's side, diag(|S| 1, I_G) (6, 6): rows against (u_P, θ_P)."""
        b = np.zeros((6, 6))
        b[:3, :3] = self.area * np.eye(3)
        b[3:, 3:] = self.inertia
        return b

    def apply(self, u: FloatArray) -> FloatArray:
        """The solid side's rows times this rank's owned DOF values ``u``, summed over the
        ranks (6,) (collective)."""
        local = np.bincount(self.rows, weights=self.coeffs * u[self.dofs], minlength=6)
        return np.asarray(self.comm.allreduce(local, op=MPI.SUM), dtype=np.float64)

    def spread(self, lam: FloatArray, n_owned: int) -> FloatArray:
        """The rows' transpose times ``lam`` (6,) on this rank's owned DOFs (n_owned,): the
        nodal forces of a resultant ``lam[:3]`` × |S| and moment ``I_G lam[3:]`` about G."""
        out = np.zeros(n_owned)
        np.add.at(out, self.dofs, self.coeffs * lam[self.rows])
        return out


def _sum(comm: MPI.Comm, form: ufl.Form) -> float:
    return float(comm.allreduce(dolfinx.fem.assemble_scalar(dolfinx.fem.form(form)), op=MPI.SUM))


def face_rows(V: dolfinx.fem.FunctionSpace, facets: npt.NDArray[np.int32], name: str) -> FaceRows:
    """The rows of the face made of the exterior ``facets`` (this rank's local facet indices)
    of the vector P1 space ``V``'s mesh (collective). ``name`` names the face in the one-line
    error raised when it is empty or not planar."""
    msh = V.mesh
    comm = msh.comm
    fdim = msh.topology.dim - 1
    order = np.argsort(facets)
    tags = dolfinx.mesh.meshtags(
        msh, fdim, facets[order].astype(np.int32), np.ones(facets.size, dtype=np.int32)
    )
    ds = ufl.Measure("ds", domain=msh, subdomain_data=tags, subdomain_id=1)
    area = _sum(comm, dolfinx.fem.Constant(msh, 1.0) * ds)
    if not area > 0.0:
        raise ScenarioError(f"joint face {name!r}: no facet of the solid's boundary")
    x = ufl.SpatialCoordinate(msh)
    g = np.array([_sum(comm, x[k] * ds) for k in range(3)]) / area
    r = x - dolfinx.fem.Constant(msh, g)
    inertia = np.array(
        [
            [_sum(comm, (ufl.dot(r, r) * float(k == m) - r[k] * r[m]) * ds) for m in range(3)]
            for k in range(3)
        ]
    )
    _check_planar(msh, facets, g, inertia, area, name)
    v = ufl.TestFunction(V)
    n = ufl.FacetNormal(msh)
    normal = np.array([_sum(comm, n[k] * ds) for k in range(3)])
    normal /= np.linalg.norm(normal)
    rows, dofs, coeffs = [], [], []
    n_owned = V.dofmap.index_map.size_local * V.dofmap.index_map_bs
    e = [ufl.as_vector([float(i == k) for i in range(3)]) for k in range(3)]
    forms = [v[k] * ds for k in range(3)] + [ufl.dot(ufl.cross(e[k], r), v) * ds for k in range(3)]
    for row, f in enumerate(forms):
        b = dolfinx.fem.assemble_vector(dolfinx.fem.form(f))
        b.scatter_reverse(dolfinx.la.InsertMode.add)
        vals = b.array[:n_owned]
        nz = np.flatnonzero(vals)
        rows.append(np.full(nz.size, row, dtype=np.int64))
        dofs.append(nz.astype(np.int64))
        coeffs.append(vals[nz].copy())
    return FaceRows(
        comm,
        area,
        g,
        inertia,
        normal,
        np.concatenate(rows),
        np.concatenate(dofs),
        np.concatenate(coeffs),
    )


def _check_planar(
    msh: dolfinx.mesh.Mesh,
    facets: npt.NDArray[np.int32],
    g: FloatArray,
    inertia: FloatArray,
    area: float,
    name: str,
) -> None:
    """One line naming the face when its vertices leave the plane through G normal to the
    axis of I_G's largest eigenvalue (a planar face's polar axis) by more than
    :data:`PLANAR_TOL` of its size (collective)."""
    fdim = msh.topology.dim - 1
    msh.topology.create_connectivity(fdim, 0)
    verts = np.unique(dolfinx.mesh.entities_to_geometry(msh, fdim, facets.astype(np.int32)))
    axis = np.linalg.eigh(inertia)[1][:, -1]
    local = float(np.max(np.abs((msh.geometry.x[verts] - g) @ axis), initial=0.0))
    off = msh.comm.allreduce(local, op=MPI.MAX)
    size = np.sqrt(area)
    if off > PLANAR_TOL * size:
        raise ScenarioError(
            f"joint face {name!r} is not planar: a vertex lies {off:.3g} m off its plane "
            f"(at most {PLANAR_TOL:g} of its size, {size:.3g} m)"
        )


def joint_interface(
    solid: Subdomain,
    beam: Subdomain,
    faces: Sequence[FaceRows],
    nodes: IntArray,
    node_x: FloatArray,
    names: Sequence[str],
) -> tuple[ContactSet, ContactSet]:
    """The GC interface of joints (collective): face ``faces[j]`` of the solid subdomain (its
    rows made on ``solid.V``) tied to the beam subdomain's node of global parent vertex
    ``nodes[j]`` at ``node_x[j]``; rows 6j + 0…5, L_E on the face's nodes and L_I =
    −diag(|S| 1, I_G) on the node's six DOFs, so that L_E V_E + L_I V_I = 0 is the rigid
    section's tie in velocities (six unknowns per face).

    Raises:
        ScenarioError: a node farther than :data:`CENTROID_TOL` of its face's size from the
            face's centroid, or a node that is not one of the beam subdomain's vertices.
    """
    comm = solid.submesh.comm
    n = len(faces)
    e_rows, e_dofs, e_vals, i_rows, i_dofs, i_vals = [], [], [], [], [], []
    for j, (face, node, x, name) in enumerate(zip(faces, nodes, node_x, names, strict=True)):
        size = float(np.sqrt(face.area))
        off = float(np.linalg.norm(np.asarray(x, dtype=np.float64) - face.centroid))
        if off > CENTROID_TOL * size:
            raise ScenarioError(
                f"joint {name!r}: the beam node lies {off:.3g} m from the face's centroid "
                f"(at most {CENTROID_TOL:g} of the face's size, {size:.3g} m)"
            )
        e_rows.append(6 * j + face.rows)
        e_dofs.append(face.dofs)
        e_vals.append(face.coeffs)
        blocks, _ = beam.owned_dofs_of(np.array([node], dtype=np.int64))
        found = comm.allreduce(int(blocks.size), op=MPI.SUM)
        if found != 1:
            raise ScenarioError(f"joint {name!r}: its node is not a vertex of the beams")
        for b in blocks:
            r, c = np.nonzero(face.beam_block)
            i_rows.append(6 * j + r)
            i_dofs.append(int(b) * beam.bs + c)
            i_vals.append(-face.beam_block[r, c])
    g0 = np.zeros(6 * n)
    group = np.zeros(6 * n, dtype=np.int64)

    def ints(a: list[IntArray]) -> IntArray:
        return np.concatenate(a).astype(np.int64) if a else np.zeros(0, np.int64)

    def rows(r: list[IntArray], d: list[IntArray], v: list[FloatArray]) -> ContactSet:
        vals = np.concatenate(v).astype(np.float64) if v else np.zeros(0)
        return ContactSet(comm, g0, ints(r), ints(d), vals, group, ["interface"])

    return rows(e_rows, e_dofs, e_vals), rows(i_rows, i_dofs, i_vals)
