# # Beams where the structure is smooth, a solid where a wheel strikes: a mixed gmsh model
#
# A crane runway girder, steel, 6 m between its pinned ends, modelled as Timoshenko beams
# except a 0.8 m segment at midspan meshed as a 3D solid, where a wheel stands: the wheel's
# load block (a steel block carrying the wheel load) rests on the segment's top by frictional
# node-to-surface contact. Each end face of the segment is tied to a beam node on its
# centroid by a `[[joint]]` (a rigid section: six rows, the face free to warp). This script
# writes `runway_girder.msh` beside it; `runway_girder.toml` runs it:
#
#     crane-fem run demos/own_mixed/runway_girder.toml
#
# The rules of a mixed model: the beams are 2-node lines in named line groups; the solids P1
# tetrahedra in named volume groups; a beam meets a solid only at a joint, its end node on the
# face's centroid (not a node of the solid: the two meshes are apart); the joint's face is a
# named surface group on one solid's boundary, its node a named point group of one vertex.
#
# Run it with `python demos/own_mixed/runway_girder.py` (one process: gmsh).

# +
import itertools
from pathlib import Path

import gmsh

out = Path(__file__).with_suffix(".msh")
span, b, h = 6.0, 0.15, 0.3  # m: the girder's span, width (y), depth (z)
seg = (2.6, 3.4)  # m: the solid segment (2.7 section depths: the joints' faces a section
# depth from the contact, where a rigid section's disturbance has died out)
block = 0.1  # m: the load block's side
h_solid, h_beam = 0.05, 0.1  # m: element sizes
# -

# ## Geometry: the segment, the block, the two beams

gmsh.initialize()
gmsh.option.setNumber("General.Terminal", 0)
gmsh.model.add("runway_girder")
occ = gmsh.model.occ
# The segment in three conforming parts along x: the wheel's contact surface is the middle
# part's top, whose edges stay off the joints' faces (a frictional contact may not touch the
# coupling's interface).
cuts = (seg[0], 2.9, 3.1, seg[1])
boxes = [occ.addBox(a, 0.0, 0.0, c - a, b, h) for a, c in itertools.pairwise(cuts)]
pieces, _ = occ.fragment([(3, boxes[0])], [(3, p) for p in boxes[1:]])
parts = sorted((t for _, t in pieces), key=lambda t: occ.getCenterOfMass(3, t)[0])
x0 = 0.5 * (span - block)
load_block = occ.addBox(x0, 0.5 * (b - block), h, block, block, block)
# The beams on the girder's axis (y = b/2, z = h/2), their inner ends on the faces' centroids.
axis = (0.5 * b, 0.5 * h)
ends = [occ.addPoint(x, *axis) for x in (0.0, seg[0], seg[1], span)]
left, right = occ.addLine(ends[0], ends[1]), occ.addLine(ends[2], ends[3])
occ.synchronize()


def face(vol: int, axis_: int, value: float) -> list[int]:
    """The boundary face of a volume lying in the plane x_axis = value."""
    found = []
    for dim, tag in gmsh.model.getBoundary([(3, vol)], oriented=False):
        bb = gmsh.model.getBoundingBox(dim, tag)
        if abs(bb[axis_] - value) < 1e-6 and abs(bb[axis_ + 3] - value) < 1e-6:
            found.append(abs(tag))
    return found


# ## Named groups: what the scenario refers to

gmsh.model.addPhysicalGroup(3, parts, name="segment")
gmsh.model.addPhysicalGroup(3, [load_block], name="load_block")
gmsh.model.addPhysicalGroup(2, face(parts[0], 0, seg[0]), name="segment_left")
gmsh.model.addPhysicalGroup(2, face(parts[2], 0, seg[1]), name="segment_right")
gmsh.model.addPhysicalGroup(2, face(parts[1], 2, h), name="segment_top")
gmsh.model.addPhysicalGroup(2, face(load_block, 2, h), name="block_bottom")
gmsh.model.addPhysicalGroup(1, [left, right], name="girder")
gmsh.model.addPhysicalGroup(0, [ends[0], ends[3]], name="ends")
gmsh.model.addPhysicalGroup(0, [ends[1]], name="joint_left")
gmsh.model.addPhysicalGroup(0, [ends[2]], name="joint_right")

# ## Mesh: P1 tetrahedra in the solids, 2-node lines on the beams

gmsh.model.mesh.setSize([(0, p) for p in ends], h_beam)  # the beams: 26 elements each
# The solids at h_solid: every point within the segment's span (the block stands on it).
gmsh.model.mesh.setSizeCallback(
    lambda dim, tag, x, y, z, lc: min(lc, h_solid) if seg[0] <= x <= seg[1] else lc
)
gmsh.model.mesh.generate(3)
gmsh.write(str(out))
n_tets = len(gmsh.model.mesh.getElementsByType(4)[0])
n_lines = len(gmsh.model.mesh.getElementsByType(1)[0])
gmsh.finalize()
print(f"{out.name}: {n_tets} tetrahedra, {n_lines} line elements (beams and the solids' edges)")
