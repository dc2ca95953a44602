# # Your own structure: a cabinet resting on a floor slab, scripted with gmsh
#
# A gmsh script is all crane-fem needs of a structure: its bodies as named volume groups, and
# its supports and contact surfaces as named surface groups. This script writes
# `cabinet_on_slab.msh` beside it; `cabinet_on_slab.toml` runs it:
#
#     crane-fem run demos/own_model/cabinet_on_slab.toml
#
# The scene: a concrete floor slab clamped along its underside (it moves with the ground), and
# an equipment cabinet standing on it, held by friction only. The slab is two layers of one
# conforming mesh: a thin top layer, explicit with the cabinet (the frictional contact lives
# there), and the rest, implicit (Newmark) with a large step. The cabinet and the slab are
# meshed apart, with their own nodes on the contact plane z = 0: a contact surface is the
# boundary of a body, never fragmented with the body it touches.
#
# Run it with `python demos/own_model/cabinet_on_slab.py` (one process: gmsh).

# +
from pathlib import Path

import gmsh

out = Path(__file__).with_suffix(".msh")
slab = (2.0, 1.2, 0.20)  # m: length (x), width (y), thickness
top_layer = 0.05  # m: the explicit layer under the cabinet
cabinet = (0.5, 0.4, 1.0)  # m
h_slab, h_cabinet = 0.15, 0.10  # m: element sizes
# -

# ## Geometry
#
# The slab's two layers are fragmented together (one conforming mesh, the coupling's
# interface between them); the cabinet is added after, not fragmented with the slab.

gmsh.initialize(interruptible=False)
gmsh.option.setNumber("General.Terminal", 0)
gmsh.option.setNumber("General.NumThreads", 1)  # the same mesh on every run
gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
gmsh.model.add("cabinet_on_slab")
occ = gmsh.model.occ
lx, ly, t = slab
base = occ.addBox(0.0, 0.0, -t, lx, ly, t - top_layer)
layer = occ.addBox(0.0, 0.0, -top_layer, lx, ly, top_layer)
occ.fragment([(3, base)], [(3, layer)])
cx, cy, cz = cabinet
box = occ.addBox((lx - cx) / 2, (ly - cy) / 2, 0.0, cx, cy, cz)
occ.synchronize()


def faces_at(vol: int, z: float) -> list[int]:
    """The boundary faces of a volume lying in the plane at height z."""
    found = []
    for dim, tag in gmsh.model.getBoundary([(3, vol)], oriented=False):
        b = gmsh.model.getBoundingBox(dim, tag)
        if abs(b[2] - z) < 1e-6 and abs(b[5] - z) < 1e-6:
            found.append(tag)
    return found


# ## Named groups: what the scenario refers to

gmsh.model.addPhysicalGroup(3, [base], name="slab_base")
gmsh.model.addPhysicalGroup(3, [layer], name="slab_top_layer")
gmsh.model.addPhysicalGroup(3, [box], name="cabinet")
gmsh.model.addPhysicalGroup(2, faces_at(base, -t), name="slab_underside")
gmsh.model.addPhysicalGroup(2, faces_at(layer, 0.0), name="floor")
gmsh.model.addPhysicalGroup(2, faces_at(box, 0.0), name="cabinet_feet")

# ## Mesh: P1 tetrahedra

gmsh.model.mesh.setSize(gmsh.model.getBoundary([(3, base), (3, layer)], recursive=True), h_slab)
gmsh.model.mesh.setSize(gmsh.model.getBoundary([(3, box)], recursive=True), h_cabinet)
gmsh.model.mesh.generate(3)
gmsh.write(str(out))
n_nodes = len(gmsh.model.mesh.getNodes()[0])
n_tets = len(gmsh.model.mesh.getElementsByType(4)[0])
gmsh.finalize()
print(f"{out.name}: {n_nodes} nodes, {n_tets} tetrahedra")
