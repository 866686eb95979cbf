"""Makes assets/volume/sphere_in_box.msh with Gmsh (pip install gmsh): a box
[-1, 1]^3 around a sphere of radius 0.4, tetrahedra, physical groups `outer`
(the box's sides), `inner` (the sphere: the object's surface) and `fluid`
(the cells). Written by Gmsh itself (format 4.1, ASCII), so that csrbf's
reader is tested on a file a real mesher wrote."""

import sys
from pathlib import Path

import gmsh

out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).resolve().parents[1] / "assets/volume/sphere_in_box.msh"
gmsh.initialize()
gmsh.option.setNumber("General.Terminal", 0)
gmsh.model.add("sphere_in_box")
box = gmsh.model.occ.addBox(-1, -1, -1, 2, 2, 2)
ball = gmsh.model.occ.addSphere(0, 0, 0, 0.4)
cut, _ = gmsh.model.occ.cut([(3, box)], [(3, ball)])
gmsh.model.occ.synchronize()
faces = [t for _, t in gmsh.model.getEntities(2)]
inner = [f for f in faces if gmsh.model.getType(2, f) == "Sphere"]
outer = [f for f in faces if f not in inner]
gmsh.model.addPhysicalGroup(2, outer, 1, "outer")
gmsh.model.addPhysicalGroup(2, inner, 2, "inner")
gmsh.model.addPhysicalGroup(3, [cut[0][1]], 3, "fluid")
gmsh.option.setNumber("Mesh.MeshSizeMax", 0.4)
gmsh.option.setNumber("Mesh.MeshSizeMin", 0.1)
points = gmsh.model.getBoundary([(2, f) for f in inner], False, False, True)
gmsh.model.mesh.setSize(points, 0.12)
gmsh.model.mesh.generate(3)
gmsh.write(str(out))
gmsh.finalize()
