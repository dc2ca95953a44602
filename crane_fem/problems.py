"""Scenario -> problem: mesh, structural model, contact set, load and initial state."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import dolfinx
import numpy as np
import numpy.typing as npt
from mpi4py import MPI

from crane_fem.contact import ContactSet
from crane_fem.formulations import AxialBar, CellFields
from crane_fem.loading.body import AffineLoad
from crane_fem.mesh import BarMesh, Segment, create_bar_mesh
from crane_fem.model import StructuralModel, assemble_operators
from crane_fem.scenario import BarModel, Contact, Scenario

__all__ = ["Body", "Problem", "create_problem"]

FloatArray = npt.NDArray[np.float64]


@dataclass
class Body:
    """A body of the problem and its owned DOFs (for per-body output)."""

    name: str
    owned: npt.NDArray[np.int64]
    mass: float


@dataclass
class Problem:
    """Everything an integrator needs; owns the model (``destroy``, collective)."""

    model: StructuralModel
    contacts: ContactSet
    load: AffineLoad
    u0: FloatArray
    v0: FloatArray
    h_min: float
    wave_speed: float
    bodies: list[Body] = field(default_factory=list)

    def destroy(self) -> None:
        self.model.destroy()


def _input_node_of_dof(bar: BarMesh, V: dolfinx.fem.FunctionSpace) -> npt.NDArray[np.int64]:
    """Input node index of every local DOF (owned and ghost); P1 DOFs sit on the nodes."""
    mesh = bar.mesh
    geom = mesh.geometry.dofmaps[0]
    dofs = V.dofmap.list
    n_local = V.dofmap.index_map.size_local + V.dofmap.index_map.num_ghosts
    out = np.full(n_local, -1, dtype=np.int64)
    out[dofs.ravel()] = np.asarray(mesh.geometry.input_global_indices, dtype=np.int64)[geom.ravel()]
    return out


def create_problem(comm: MPI.Comm, sc: Scenario) -> Problem:
    """Build the bar problem of a validated scenario (collective over ``comm``)."""
    mdl = sc.model
    assert isinstance(mdl, BarModel), "the single-scheme path handles bars only"
    contacts = {c.type: c for c in sc.contact if isinstance(c, Contact)}
    x0 = contacts["wall"].gap if "wall" in contacts else 0.0
    segments = [Segment(x0, mdl.length, mdl.elements, mdl.area)]
    if mdl.second_bar is not None:
        sb = mdl.second_bar
        segments.append(
            Segment(x0 + mdl.length + contacts["bars"].gap, sb.length, sb.elements, sb.area)
        )
    bar = create_bar_mesh(comm, segments)
    mesh = bar.mesh
    V = dolfinx.fem.functionspace(mesh, ("Lagrange", 1))

    # Cross-section area per cell (DG0), from the input cell numbering.
    Q = dolfinx.fem.functionspace(mesh, ("DG", 0))
    area = dolfinx.fem.Function(Q)
    cells_input = np.asarray(mesh.topology.original_cell_index, dtype=np.int64)
    areas = np.array([s.area for s in segments])
    n_cells = mesh.topology.index_map(mesh.topology.dim).size_local
    area.x.array[:n_cells] = areas[bar.segment_of_cell(cells_input[:n_cells])]
    area.x.scatter_forward()

    node = _input_node_of_dof(bar, V)
    n_own = V.dofmap.index_map.size_local
    first_right = bar.first_node[0] + segments[0].elements

    fixed_local = (
        np.flatnonzero(node == first_right) if mdl.clamp == "right" else np.zeros(0, dtype=np.int64)
    )
    mat = sc.uniform_material
    cell_area = np.asarray(area.x.array[area.function_space.dofmap.list[:, 0]])
    K, mass, _ = assemble_operators(
        AxialBar(), V, CellFields(mat.E, mat.nu, mat.rho, cell_area), fixed_local
    )
    fixed = np.zeros(n_own, dtype=bool)
    fixed[fixed_local[fixed_local < n_own]] = True
    alpha, beta = sc.uniform_material.rayleigh_coefficients
    model = StructuralModel(V, K, mass, fixed, alpha, beta)

    # Contact points: terms on the DOFs this rank owns.
    owned_node = node[:n_own]
    g0: list[float] = []
    rows: list[int] = []
    dofs: list[int] = []
    coeffs: list[float] = []
    group: list[int] = []
    names: list[str] = []

    def add_point(gap: float, terms: list[tuple[int, float]], name: str) -> None:
        p = len(g0)
        g0.append(gap)
        group.append(len(names))
        names.append(name)
        for input_node, coeff in terms:
            for d in np.flatnonzero(owned_node == input_node):
                rows.append(p)
                dofs.append(int(d))
                coeffs.append(coeff)

    for c in sc.contact:
        assert isinstance(c, Contact)  # a bar's contacts: wall and bars
        if c.type == "wall":
            add_point(c.gap, [(int(bar.first_node[0]), 1.0)], c.label)
        else:
            add_point(c.gap, [(int(first_right), -1.0), (int(bar.first_node[1]), 1.0)], c.label)
    contact_set = ContactSet(
        comm,
        np.array(g0, dtype=np.float64),
        np.array(rows, dtype=np.int64),
        np.array(dofs, dtype=np.int64),
        np.array(coeffs, dtype=np.float64),
        np.array(group, dtype=np.int64),
        names,
    )

    # Initial state: first bar linear displacement and uniform velocity; second bar velocity.
    seg_of_dof = bar.segment_of_node(owned_node)
    x = V.tabulate_dof_coordinates()[:n_own, 0]
    s0 = segments[0]
    ul, ur = sc.initial.displacement
    u0 = np.where(seg_of_dof == 0, ul + (ur - ul) * (x - s0.x0) / s0.length, 0.0)
    v0 = np.where(seg_of_dof == 0, sc.initial.velocity, 0.0)
    if mdl.second_bar is not None:
        v0 = np.where(seg_of_dof == 1, mdl.second_bar.velocity, v0)
    u0[fixed] = 0.0
    v0[fixed] = 0.0

    gx = float(sc.loading.gravity[0])
    f_gravity = np.where(fixed, 0.0, mass * gx)

    load = AffineLoad(f_gravity)

    bodies = []
    for i, name in enumerate(["bar1", "bar2"][: len(segments)]):
        owned = np.flatnonzero(seg_of_dof == i).astype(np.int64)
        m_body = comm.allreduce(float(mass[owned].sum()), op=MPI.SUM)
        bodies.append(Body(name, owned, m_body))

    return Problem(
        model=model,
        contacts=contact_set,
        load=load,
        u0=u0,
        v0=v0,
        h_min=min(s.h for s in segments),
        wave_speed=math.sqrt(sc.uniform_material.E / sc.uniform_material.rho),
        bodies=bodies,
    )
