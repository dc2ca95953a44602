"""A mixed model's joints (a beam node driving a solid's face, THEORY.md §11): each
``[[joint]]``'s face and node found on the subdomains, checked, and made into the GC
interface's rows (crane_fem.coupling.rigid_section), six per joint."""

from __future__ import annotations

from dataclasses import dataclass

import dolfinx.mesh
import numpy as np
import numpy.typing as npt
from mpi4py import MPI

from crane_fem.contact import ContactSet
from crane_fem.coupling.interface import zone_labels
from crane_fem.coupling.rigid_section import face_rows, joint_interface
from crane_fem.errors import ScenarioError
from crane_fem.geometry.tagged import TaggedMesh
from crane_fem.pipeline.mesh import MeshStage
from crane_fem.scenario import Scenario
from crane_fem.subdomains import Subdomain

__all__ = ["JointRows", "build_joints"]

IntArray = npt.NDArray[np.int64]


@dataclass(frozen=True)
class JointRows:
    """The joints' interface: the beam nodes' global ids (joint order), L_E and L_I (rows
    6j + 0…5), the explicit zone (connected solid) of each row and the faces' vertices."""

    nodes: IntArray
    l_explicit: ContactSet
    l_implicit: ContactSet
    zones: IntArray
    #: The global solid vertices of every joint's face (sorted): the explicit side's
    #: interface (a frictional contact may not touch it).
    face_vertices: IntArray


def _joint_facets(sub: Subdomain, tagged: TaggedMesh, name: str, key: str) -> npt.NDArray[np.int32]:
    """The explicit submesh's exterior facets of the parent's facet group ``name`` (those
    whose vertices are all the group's; collective).

    Raises:
        ScenarioError: a facet of the group between two cells (inside the solid, or on the
            face two zones share), or a group that is not all on the explicit solids.
    """
    msh = tagged.mesh
    fdim = msh.topology.dim - 1
    facets = tagged.facets(name)
    msh.topology.create_connectivity(fdim, fdim + 1)
    f2c = msh.topology.connectivity(fdim, fdim + 1)
    n_own = msh.topology.index_map(fdim).size_local
    mine = facets[facets < n_own]
    inside = int(np.count_nonzero(np.diff(f2c.offsets)[mine] > 1))
    if msh.comm.allreduce(inside, op=MPI.SUM):
        raise ScenarioError(
            f"{key}: face {name!r} lies between two cells (inside the solid, or shared by two "
            "zones): a joint's face is on one solid's boundary"
        )
    ids = tagged.global_vertices(tagged.facet_vertices(name))
    sm = sub.submesh
    sm.topology.create_connectivity(fdim, 0)
    sm.topology.create_connectivity(fdim, fdim + 1)
    ext = dolfinx.mesh.exterior_facet_indices(sm.topology)
    f2v = sm.topology.connectivity(fdim, 0)
    # Each exterior facet's vertices (a simplex's facet: fdim + 1 of them), all the group's?
    verts = f2v.array.reshape(-1, fdim + 1)[ext]
    on = np.all(np.isin(sub.vertex_global[verts], ids), axis=1)
    out = ext[on].astype(np.int32)
    found = sm.comm.allreduce(int(np.count_nonzero(out < sm.topology.index_map(fdim).size_local)))
    total = msh.comm.allreduce(int(mine.size), op=MPI.SUM)
    if found != total:
        raise ScenarioError(
            f"{key}: face {name!r} is not all on the explicit solids' boundary ({found} of its "
            f"{total} facets)"
        )
    return out


def build_joints(sc: Scenario, mesh: MeshStage, E_sub: Subdomain, I_sub: Subdomain) -> JointRows:
    """A mixed model's interface: each ``[[joint]]``'s six rows (collective).

    Raises:
        ScenarioError: a node group that is not one vertex, a face on two zones or inside
            the solid, a non-planar face or a node off its face's centroid.
    """
    assert mesh.beams is not None
    beams = mesh.beams.tagged
    faces, nodes, zones, on_faces = [], [], [], []
    for i, j in enumerate(sc.joint):
        key = f"joint[{i}]"
        node = beams.global_vertices(beams.facet_vertices(j.node))
        if node.size != 1:
            raise ScenarioError(
                f"{key}.node: point group {j.node!r} has {node.size} vertices; a joint's node "
                "is one beam node"
            )
        facets = _joint_facets(E_sub, mesh.tagged, j.face, f"{key}.face")
        faces.append(face_rows(E_sub.V, facets, j.label))
        nodes.append(int(node[0]))
        ids = mesh.tagged.global_vertices(mesh.tagged.facet_vertices(j.face))
        on_faces.append(ids)
        labels = np.unique(zone_labels(E_sub, ids))
        if labels.size != 1:
            raise ScenarioError(
                f"{key}.face: face {j.face!r} spans {labels.size} solids (zones); a joint's "
                "face is on one"
            )
        zones.append(int(labels[0]))
    node_ids = np.asarray(nodes, dtype=np.int64)
    node_x = np.array([beams.vertex_coordinates(np.array([n]))[0] for n in node_ids])
    le, li = joint_interface(E_sub, I_sub, faces, node_ids, node_x, [j.label for j in sc.joint])
    return JointRows(
        node_ids,
        le,
        li,
        np.repeat(np.asarray(zones, dtype=np.int64), 6),
        np.unique(np.concatenate(on_faces)).astype(np.int64),
    )
