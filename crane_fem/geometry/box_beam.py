"""A 3D box beam in two gmsh volumes with a conforming interface (gmsh OpenCASCADE)."""

from __future__ import annotations

from dataclasses import dataclass

import dolfinx.io.gmsh
import dolfinx.mesh
import gmsh
from mpi4py import MPI

from crane_fem.geometry import groups
from crane_fem.geometry.tagged import TaggedMesh

__all__ = ["BoxBeam", "create_box_beam"]


@dataclass(frozen=True)
class BoxBeam:
    """Beam [0, L] × [0, W] × [0, H] split at x = ``split``; tetrahedra of size ``h``."""

    length: float
    width: float
    height: float
    split: float
    h: float


def create_box_beam(comm: MPI.Comm, beam: BoxBeam) -> TaggedMesh:
    """Mesh the beam with gmsh on rank 0 and distribute it (collective).

    Cell groups ``part_a`` (x < split) and ``part_b``; facet groups ``clamped`` (x = 0) and
    ``tip`` (x = L). The shared face is fragmented, so both volumes' meshes conform there.
    """
    tol = 1e-6 * beam.length
    if comm.rank == 0:
        gmsh.initialize(interruptible=False)
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("box_beam")
        occ = gmsh.model.occ
        a = occ.addBox(0, 0, 0, beam.split, beam.width, beam.height)
        b = occ.addBox(beam.split, 0, 0, beam.length - beam.split, beam.width, beam.height)
        occ.fragment([(3, a)], [(3, b)])
        occ.synchronize()
        vols = gmsh.model.getEntities(3)
        part: dict[str, list[int]] = {groups.BEAM_PART_A: [], groups.BEAM_PART_B: []}
        for dim, tag in vols:
            x = gmsh.model.occ.getCenterOfMass(dim, tag)[0]
            part[groups.BEAM_PART_A if x < beam.split else groups.BEAM_PART_B].append(tag)
        gmsh.model.addPhysicalGroup(3, part[groups.BEAM_PART_A], 1, groups.BEAM_PART_A)
        gmsh.model.addPhysicalGroup(3, part[groups.BEAM_PART_B], 2, groups.BEAM_PART_B)
        big = 10 * (beam.width + beam.height)
        x0 = gmsh.model.getEntitiesInBoundingBox(-tol, -big, -big, tol, big, big, 2)
        xl = gmsh.model.getEntitiesInBoundingBox(
            beam.length - tol, -big, -big, beam.length + tol, big, big, 2
        )
        gmsh.model.addPhysicalGroup(2, [t for _, t in x0], 1, groups.BEAM_CLAMPED)
        gmsh.model.addPhysicalGroup(2, [t for _, t in xl], 2, groups.BEAM_TIP)
        gmsh.option.setNumber("Mesh.CharacteristicLengthMin", beam.h)
        gmsh.option.setNumber("Mesh.CharacteristicLengthMax", beam.h)
        gmsh.option.setNumber("Mesh.Algorithm3D", 1)
        gmsh.model.mesh.generate(3)
    partitioner = dolfinx.mesh.create_cell_partitioner(  # type: ignore[call-arg]
        dolfinx.mesh.GhostMode.shared_facet, 2
    )
    data = dolfinx.io.gmsh.model_to_mesh(gmsh.model, comm, 0, gdim=3, partitioner=partitioner)
    if comm.rank == 0:
        gmsh.finalize()
    assert data.cell_tags is not None and data.facet_tags is not None
    return TaggedMesh(
        data.mesh,
        data.cell_tags,
        data.facet_tags,
        {groups.BEAM_PART_A: 1, groups.BEAM_PART_B: 2},
        {groups.BEAM_CLAMPED: 1, groups.BEAM_TIP: 2},
    )
