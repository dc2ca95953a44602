"""The whole structure as one linear elastic body with its contacts closed: stiffness and
consistent mass on the free DOFs, the rows of the clamped DOFs, and the wheel/rail ties.

All subdomains are one body on the parent mesh (the subdomain split is a choice of time
integrators, not of mechanics). For the crane, every wheel/rail node pair is tied by a stiff
spring k_p in all three components, k_p the largest diagonal entry of K (the preload's spring,
:mod:`crane_fem.preload.crane`). Why all three and not the normal (z) alone:

* with z alone the trolley keeps three rigid modes (x, y translation, rotation about z), K is
  singular and shift-and-invert at σ = 0 cannot factor it; the preload's cure, an isostatic
  point support, would hold the trolley horizontally by single vertices, whose point-spring
  flexibility in a 3D continuum depends on the mesh (it diverges logarithmically with
  refinement), so the trolley's horizontal modes would too;
* tying the three components over every pair of the four wheel patches is the closed contact
  with sticking friction: a well-defined, mesh-independent linearisation. It is exact for the
  vertical (normal) contact, the direction of the scenes' shaking. Horizontally it holds the
  wheels on the rails, which the flanges (across) and rolling resistance (along) do only in
  part: horizontal results are those of a trolley that does not slide.

The flange pairs have clearance: they are left open. Clamped DOFs are removed (submatrices
of the free DOFs), so K_ff and M_ff are symmetric positive definite and the eigenproblem
has no spurious eigenvalue from Dirichlet rows.
"""

from __future__ import annotations

from dataclasses import dataclass

import dolfinx
import dolfinx.fem.petsc
import numpy as np
import numpy.typing as npt
import ufl
from mpi4py import MPI
from petsc4py import PETSc

from crane_fem.formulations import coefficient
from crane_fem.pipeline.mesh import MeshStage
from crane_fem.subdomains import PointMasses

__all__ = ["ClosedStructure", "assemble_closed_structure", "vertex_of_block"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


@dataclass
class ClosedStructure:
    """K φ = ω² M φ of the structure with closed contacts (collective objects over ``comm``).
    Owns ``K``, ``M``, ``K_cf``: call :meth:`destroy` (collective).

    DOFs are those of the space ``V`` (block size ``bs``: 3 for a solid, 6 for a beam), in
    dolfinx's owned ordering; ``free``/``clamped`` are owned local DOF indices (block × bs +
    component, sorted), the local rows of ``K``/``M`` and of ``K_cf`` in that order.

    Attributes:
        V: the displacement space on the parent mesh (P1 or P2).
        K: stiffness on the free DOFs with the ties, N/m.
        M: consistent mass on the free DOFs, kg.
        K_cf: rows of the clamped DOFs of the unconstrained stiffness, columns of the free
            DOFs: the support's force on the structure is K_cf u_f (N).
        free, clamped: owned local DOF indices.
        block_vertex: global parent vertex of every owned DOF block (−1 for a P2 edge DOF).
        pairs: (p, 2) global vertex ids (wheel, rail) of the tied pairs; (0, 2) if none.
        wheel: wheel number (1–4) of each pair.
        k_p: the ties' stiffness, N/m (0 without pairs).
        gravity_load: owned free-DOF body load of gravity, ∫ ρ g·w dx (N).
        gravity_clamped: the same load on the owned clamped DOFs (N).
        mass_total: ∫ ρ dx over the whole mesh (kg, global).
        faces: the global vertex ids of each support face (a gmsh model's ``[[support]]``
            groups), or empty: the faces found by position (crane_fem.reactions.face_labels).
    """

    comm: MPI.Comm
    V: dolfinx.fem.FunctionSpace
    K: PETSc.Mat
    M: PETSc.Mat
    K_cf: PETSc.Mat
    free: IntArray
    clamped: IntArray
    block_vertex: IntArray
    pairs: IntArray
    wheel: IntArray
    k_p: float
    gravity_load: FloatArray
    gravity_clamped: FloatArray
    mass_total: float
    faces: tuple[IntArray, ...] = ()
    #: DOFs per node, and how many of them are translations (a beam's 6 and 3).
    bs: int = 3
    translations: int = 3

    @property
    def n_free(self) -> int:
        """Free DOFs (global)."""
        return int(self.K.getSize()[0])

    def destroy(self) -> None:
        """Destroy the PETSc matrices (collective)."""
        for mat in (self.K, self.M, self.K_cf):
            mat.destroy()


def vertex_of_block(V: dolfinx.fem.FunctionSpace) -> IntArray:
    """Global parent vertex id of every local DOF block (owned, then ghosts) of a Lagrange
    space, −1 for blocks on edges, faces or cells (not collective)."""
    msh = V.mesh
    tdim = msh.topology.dim
    msh.topology.create_connectivity(tdim, 0)
    c2v = msh.topology.connectivity(tdim, 0).array.reshape(-1, tdim + 1)
    imap = V.dofmap.index_map
    n_blocks = imap.size_local + imap.num_ghosts
    local = np.full(n_blocks, -1, dtype=np.int32)
    layout = V.dofmap.dof_layout
    cells = V.dofmap.list
    for i in range(tdim + 1):  # the cell's i-th vertex holds these local DOFs
        for d in layout.entity_dofs(0, i):
            local[cells[:, d]] = c2v[:, i]
    out = np.full(n_blocks, -1, dtype=np.int64)
    on_vertex = local >= 0
    out[on_vertex] = msh.topology.index_map(0).local_to_global(local[on_vertex])
    return out


def _clamped_blocks(V: dolfinx.fem.FunctionSpace, fixed_vertices: IntArray) -> IntArray:
    """Local DOF blocks (owned and ghost) on the clamped vertices and, for P2, on the edges
    joining two clamped vertices (not collective)."""
    vb = vertex_of_block(V)
    blocks = np.flatnonzero(np.isin(vb, fixed_vertices))
    if V.element.basix_element.degree > 1:
        msh = V.mesh
        msh.topology.create_connectivity(1, 0)
        msh.topology.create_connectivity(1, msh.topology.dim)
        e2v = msh.topology.connectivity(1, 0).array.reshape(-1, 2)
        gv = np.asarray(msh.topology.index_map(0).local_to_global(e2v.ravel().astype(np.int32)))
        edges = np.flatnonzero(np.isin(gv, fixed_vertices).reshape(-1, 2).all(axis=1))
        edge_blocks = dolfinx.fem.locate_dofs_topological(V, 1, edges.astype(np.int32))
        blocks = np.union1d(blocks, edge_blocks)
    return blocks.astype(np.int64)


def _global_blocks(V: dolfinx.fem.FunctionSpace, vertices: IntArray) -> dict[int, int]:
    """Global DOF block of each of ``vertices`` (global ids), on every rank (collective)."""
    imap = V.dofmap.index_map
    n_own = imap.size_local
    vb = vertex_of_block(V)[:n_own]
    sel = np.flatnonzero(np.isin(vb, vertices))
    gb = np.asarray(imap.local_to_global(sel.astype(np.int32)), dtype=np.int64)
    out: dict[int, int] = {}
    for ids, blocks in V.mesh.comm.allgather((vb[sel], gb)):
        out.update(zip(ids.tolist(), blocks.tolist(), strict=True))
    return out


def _add_ties(K: PETSc.Mat, V: dolfinx.fem.FunctionSpace, pairs: IntArray, k_p: float) -> None:
    """Add k_p [[1, −1], [−1, 1]] between the wheel and rail DOFs of every pair, in each
    translation; each rank adds the pairs whose wheel block it owns (collective: assembles)."""
    bs = V.dofmap.index_map_bs
    block_of = _global_blocks(V, pairs.ravel())
    lo, hi = V.dofmap.index_map.local_range
    K.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)  # type: ignore[arg-type]
    ke = (k_p * np.array([[1.0, -1.0], [-1.0, 1.0]])).ravel().tolist()
    for w, r in pairs.tolist():
        bw, br = block_of[w], block_of[r]
        if not lo <= bw < hi:
            continue
        for c in range(3):
            idx = [bs * bw + c, bs * br + c]
            K.setValues(idx, idx, ke, addv=True)  # addv=True: ADD_VALUES
    K.assemble()


def _add_bonded(K: PETSc.Mat, V: dolfinx.fem.FunctionSpace, mesh: MeshStage, k_p: float) -> None:
    """The contact points that touch what they meet at t = 0 tied to it in each direction:
    a gmsh model's points on their triangles, k_p (w wᵀ ⊗ I₃) with w = [1, −ξ_a, −ξ_b, −ξ_c],
    a frame's points on their line or plane, k_p Σ_d r_d r_dᵀ over its three rows (the
    static preload's springs, crane_fem.preload.bonded); each rank adds the points whose
    vertex block it owns (collective: assembles)."""
    from crane_fem.pipeline.frame import frame_bonded_points
    from crane_fem.pipeline.models import TOUCHING, bonded_points

    fc = mesh.frame_contacts
    pts = frame_bonded_points(fc) if fc is not None else bonded_points(mesh)
    bs = V.dofmap.index_map_bs
    touching = np.flatnonzero(pts.gap <= TOUCHING * mesh.extent())
    block_of = _global_blocks(V, pts.ids.ravel())
    lo, hi = V.dofmap.index_map.local_range
    K.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)  # type: ignore[arg-type]
    for i in touching.tolist():
        ids = pts.ids[i].tolist()
        if not lo <= block_of[ids[0]] < hi:
            continue
        idx = [bs * block_of[v] + c for v in ids for c in range(bs)]
        ke = pts.spring(i, k_p, bs)
        K.setValues(idx, idx, ke.ravel().tolist(), addv=True)  # addv=True: ADD_VALUES
    K.assemble()


def _add_ropes(
    K: PETSc.Mat, V: dolfinx.fem.FunctionSpace, mesh: MeshStage, gravity: FloatArray
) -> None:
    """A frame's ropes, taut under the load hanging on them: each the spring k d dᵀ along it
    and its tension's geometric stiffness (T/ℓ)(I − d dᵀ) across it (a pendulum's), T the
    weight of the point masses on its end that hangs (on no beam); each rank adds the
    ropes whose first end's block it owns (collective: assembles)."""
    fc = mesh.frame_contacts
    assert fc is not None and fc.ropes is not None
    spec = fc.ropes
    d, length = fc.rope_chords()
    ends = np.r_[spec.a, spec.b]
    block_of = _global_blocks(V, ends)
    lo, hi = V.dofmap.index_map.local_range
    bs = V.dofmap.index_map_bs
    g = float(np.linalg.norm(gravity))
    pm = mesh.point_masses
    K.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)  # type: ignore[arg-type]
    for r in range(spec.n):
        a, b = int(spec.a[r]), int(spec.b[r])
        if not lo <= block_of[a] < hi:
            continue
        hanging = b if b in set(mesh.held_rotations.tolist()) else a
        mass = 0.0
        if pm is not None and hanging in set(pm.vertices.tolist()):
            mass = float(pm.values[np.searchsorted(pm.vertices, hanging), 0])
        D = np.outer(d[r], d[r])
        k = spec.stiffness[r] * D + (mass * g / length[r]) * (np.eye(3) - D)
        idx = [bs * block_of[v] + c for v in (a, b) for c in range(3)]
        ke = np.block([[k, -k], [-k, k]])
        K.setValues(idx, idx, ke.ravel().tolist(), addv=True)  # addv=True: ADD_VALUES
    K.assemble()


def assemble_closed_structure(
    mesh: MeshStage, E: float, nu: float, rho: float, gravity: FloatArray, degree: int = 1
) -> ClosedStructure:
    """Assemble K (with the wheel/rail ties), the consistent M and the clamped rows of the
    structure on the parent mesh (collective over ``mesh.comm``).

    Args:
        mesh: the pipeline's mesh stage: clamped vertices, the crane's pairs, and the
            per-cell density (carrying a hoisted mass) when it has one.
        E, nu: Young's modulus (Pa) and Poisson's ratio, used where the mesh stage has no
            per-cell materials (a ``materials`` record with cellwise ``E``, ``nu``).
        rho: density (kg/m³), used where ``mesh.density`` is None.
        gravity: gravity vector (m/s²), for the static load.
        degree: Lagrange degree of the displacement (1 as the runs; 2 for references).

    Returns:
        The operators; the caller destroys them.
    """
    msh = mesh.tagged.mesh
    comm = msh.comm
    formulation = mesh.formulation
    fields = mesh.fields
    if degree == 1:
        V = formulation.space(msh)
    else:  # a P2 reference of a solid
        V = dolfinx.fem.functionspace(msh, ("Lagrange", degree, (3,)))
    bs = V.dofmap.index_map_bs
    forms = formulation.forms(V, fields)
    w = ufl.TestFunction(V)
    dx = ufl.dx(domain=msh)
    K_all = dolfinx.fem.petsc.assemble_matrix(dolfinx.fem.form(forms.stiffness))
    K_all.assemble()
    M_all = dolfinx.fem.petsc.assemble_matrix(dolfinx.fem.form(forms.mass))
    M_all.assemble()
    density = coefficient(msh, fields.rho)
    n_t = formulation.translations
    g = dolfinx.fem.Constant(msh, np.asarray(gravity, dtype=np.float64)[:n_t])
    w_u = ufl.as_vector([w[i] for i in range(n_t)]) if bs > n_t else w
    area = fields.section.A if fields.section is not None else 1.0
    line = coefficient(msh, area)
    fvec = dolfinx.fem.petsc.assemble_vector(
        dolfinx.fem.form(density * line * ufl.inner(g, w_u) * dx)
    )
    fvec.ghostUpdate(addv=True, mode="reverse")  # addv=True: ADD_VALUES
    f_own = np.array(fvec.array_r, dtype=np.float64)
    fvec.destroy()
    mass_total = comm.allreduce(
        float(np.real(dolfinx.fem.assemble_scalar(dolfinx.fem.form(density * line * dx)))),
        op=MPI.SUM,
    )
    point = mesh.point_masses
    if point is not None and point.vertices.size:
        _add_point_masses(M_all, V, point)
        f_own += _point_weights(V, point, np.asarray(gravity, dtype=np.float64))
        mass_total += float(point.values[:, 0].sum())

    pairs = np.zeros((0, 2), dtype=np.int64)
    wheel = np.zeros(0, dtype=np.int64)
    k_p = 0.0
    if mesh.crane is not None and mesh.crane.pairs.size:
        pairs = np.asarray(mesh.crane.pairs, dtype=np.int64)
        wheel = np.asarray(mesh.crane.wheel, dtype=np.int64)
        diag = K_all.getDiagonal()
        k_p = comm.allreduce(float(np.max(diag.array_r, initial=0.0)), op=MPI.MAX)
        diag.destroy()
        _add_ties(K_all, V, pairs, k_p)

    fc = mesh.frame_contacts
    if mesh.surface_contacts or (fc is not None and (fc.lines or fc.planes)):
        diag = K_all.getDiagonal()
        k_p = comm.allreduce(float(np.max(diag.array_r, initial=0.0)), op=MPI.MAX)
        diag.destroy()
        _add_bonded(K_all, V, mesh, k_p)
    if fc is not None and fc.ropes is not None:
        _add_ropes(K_all, V, mesh, np.asarray(gravity, dtype=np.float64))

    imap = V.dofmap.index_map
    n_own = imap.size_local
    fixed_blocks = _clamped_blocks(V, mesh.fixed_vertices)
    fixed_blocks = fixed_blocks[fixed_blocks < n_own]
    is_fixed = np.zeros(bs * n_own, dtype=bool)
    is_fixed[(bs * fixed_blocks[:, None] + np.arange(bs)).ravel()] = True
    pinned = _clamped_blocks(V, mesh.pinned_vertices)
    pinned = pinned[pinned < n_own]
    is_fixed[(bs * pinned[:, None] + np.arange(n_t)).ravel()] = True
    # A rope's hanging end has no rotation (held: neither free nor a support's).
    held = _clamped_blocks(V, mesh.held_rotations)
    held = held[held < n_own]
    is_held = np.zeros(bs * n_own, dtype=bool)
    is_held[(bs * held[:, None] + np.arange(n_t, bs)).ravel()] = True
    free = np.flatnonzero(~is_fixed & ~is_held).astype(np.int64)
    clamped = np.flatnonzero(is_fixed).astype(np.int64)
    start = bs * imap.local_range[0]
    is_free = PETSc.IS().createGeneral((free + start).astype(np.int32), comm=comm)
    is_clamped = PETSc.IS().createGeneral((clamped + start).astype(np.int32), comm=comm)
    K = K_all.createSubMatrix(is_free, is_free)
    M = M_all.createSubMatrix(is_free, is_free)
    K_cf = K_all.createSubMatrix(is_clamped, is_free)
    for obj in (K_all, M_all, is_free, is_clamped):
        obj.destroy()
    return ClosedStructure(
        comm=comm,
        V=V,
        K=K,
        M=M,
        K_cf=K_cf,
        free=free,
        clamped=clamped,
        block_vertex=vertex_of_block(V)[:n_own],
        pairs=pairs,
        wheel=wheel,
        k_p=k_p,
        gravity_load=f_own[free],
        gravity_clamped=f_own[clamped],
        mass_total=float(mass_total),
        faces=mesh.support_faces,
        bs=bs,
        translations=n_t,
    )


def _point_rows(V: dolfinx.fem.FunctionSpace, point: PointMasses) -> tuple[IntArray, FloatArray]:
    """The owned DOFs of the point masses' vertices and their values (not collective)."""
    bs = V.dofmap.index_map_bs
    n_own = V.dofmap.index_map.size_local
    vb = vertex_of_block(V)[:n_own]
    at = np.flatnonzero(np.isin(vb, point.vertices))
    rows = np.searchsorted(point.vertices, vb[at])
    dofs = (at[:, None] * bs + np.arange(bs)).ravel()
    return dofs.astype(np.int64), point.values[rows, :bs].ravel()


def _add_point_masses(M: PETSc.Mat, V: dolfinx.fem.FunctionSpace, point: PointMasses) -> None:
    """The point masses on M's diagonal (collective)."""
    dofs, values = _point_rows(V, point)
    vec = M.createVecRight()
    vec.array[dofs] = values
    M.setDiagonal(vec, addv=True)  # addv=True: ADD_VALUES
    vec.destroy()


def _point_weights(
    V: dolfinx.fem.FunctionSpace, point: PointMasses, gravity: FloatArray
) -> FloatArray:
    """The point masses' weights on the owned DOFs (N)."""
    bs = V.dofmap.index_map_bs
    out = np.zeros(V.dofmap.index_map.size_local * bs)
    dofs, values = _point_rows(V, point)
    comp = dofs % bs
    trans = comp < 3
    out[dofs[trans]] = values[trans] * gravity[comp[trans]]
    return out
