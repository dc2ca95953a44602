"""A frame's part of the mesh stage: each cell's material, section and local axes, the
supports' vertices and the point masses, from the scenario's entries on the line mesh."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from crane_fem.errors import ScenarioError
from crane_fem.formulations import CellFields, SectionFields, local_axes
from crane_fem.geometry.tagged import TaggedMesh
from crane_fem.scenario import Scenario
from crane_fem.subdomains import PointMasses

__all__ = ["frame_fields", "frame_point_masses", "frame_supports", "group_cells"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


def group_cells(tagged: TaggedMesh, names: list[str]) -> npt.NDArray[np.int32]:
    """Local cells (owned and ghost) of the named cell groups."""
    tags = [tagged.cell_groups[g] for g in names]
    return tagged.cell_tags.indices[np.isin(tagged.cell_tags.values, tags)].astype(np.int32)


def _tangents(tagged: TaggedMesh) -> FloatArray:
    """The unit tangent of every local cell (owned and ghost), from its first to its second
    vertex."""
    import dolfinx.mesh

    msh = tagged.mesh
    imap = msh.topology.index_map(1)
    cells = np.arange(imap.size_local + imap.num_ghosts, dtype=np.int32)
    X = msh.geometry.x[dolfinx.mesh.entities_to_geometry(msh, 1, cells)]
    d = X[:, 1] - X[:, 0]
    out: FloatArray = d / np.linalg.norm(d, axis=1)[:, None]
    return out


def frame_fields(sc: Scenario, tagged: TaggedMesh) -> CellFields:
    """E, ν, ρ, the section and the local axes of every local cell of a frame (collective:
    an orientation parallel to a member is refused on every rank).

    Raises:
        ScenarioError: a section's orientation vector is parallel to one of its members.
    """
    msh = tagged.mesh
    imap = msh.topology.index_map(1)
    n = imap.size_local + imap.num_ghosts
    E, nu, rho = np.zeros(n), np.zeros(n), np.zeros(n)
    for names, mat in sc.materials:
        cells = slice(None) if names is None else group_cells(tagged, names)
        E[cells], nu[cells], rho[cells] = mat.E, mat.nu, mat.rho
    props = {k: np.zeros(n) for k in ("A", "I1", "I2", "J", "k1", "k2", "c1", "c2", "Wt")}
    circular = np.zeros(n, dtype=bool)
    t = _tangents(tagged)
    a1, a2 = np.zeros((n, 3)), np.zeros((n, 3))
    error = None
    for i, sec in enumerate(sc.section):
        cells = group_cells(tagged, list(sec.groups))
        nu_sec = float(nu[cells[0]]) if cells.size else 0.3
        p = sec.properties(nu_sec)
        for k in props:
            props[k][cells] = getattr(p, k)
        circular[cells] = p.circular
        try:
            a1[cells], a2[cells] = local_axes(t[cells], np.asarray(sec.orientation))
        except ValueError:
            error = error or (
                f"section[{i}].orientation: {sec.orientation} is parallel to a member of "
                f"group(s) {', '.join(sec.groups)} (give a vector across the members: it fixes "
                "their local axis 2)"
            )
    errors = [e for e in msh.comm.allgather(error) if e is not None]
    if errors:
        raise ScenarioError(errors[0])
    section = SectionFields(circular=circular, t=t, a1=a1, a2=a2, **props)
    return CellFields(E, nu, rho, section=section)


def frame_supports(
    sc: Scenario, tagged: TaggedMesh
) -> tuple[IntArray, IntArray, tuple[IntArray, ...]]:
    """(clamped vertices, pinned vertices, each support group's vertices), global ids
    (collective)."""
    faces = tuple(tagged.global_vertices(tagged.facet_vertices(s.group)) for s in sc.support)
    none = np.zeros(0, dtype=np.int64)
    clamped = [f for f, s in zip(faces, sc.support, strict=True) if s.dofs == "clamped"]
    pinned = [f for f, s in zip(faces, sc.support, strict=True) if s.dofs == "pinned"]
    return (
        np.unique(np.concatenate([none, *clamped])),
        np.setdiff1d(np.unique(np.concatenate([none, *pinned])), np.concatenate([none, *clamped])),
        faces,
    )


def frame_point_masses(sc: Scenario, tagged: TaggedMesh) -> PointMasses | None:
    """The ``[[mass]]`` entries of a frame: each group's mass (and rotary inertia) shared
    equally by its vertices (collective)."""
    if not sc.mass:
        return None
    values: dict[int, FloatArray] = {}
    for ms in sc.mass:
        ids = tagged.global_vertices(tagged.facet_vertices(ms.group))
        share = np.zeros(6)
        share[:3] = ms.mass / ids.size
        if ms.inertia is not None:
            share[3:] = np.asarray(ms.inertia) / ids.size
        for v in ids.tolist():
            values[v] = values.get(v, np.zeros(6)) + share
    vertices = np.array(sorted(values), dtype=np.int64)
    return PointMasses(vertices, np.array([values[int(v)] for v in vertices]))
