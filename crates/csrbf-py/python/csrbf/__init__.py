"""csrbf: real-time mesh deformation with compactly supported radial basis functions.

Control vectors (a start point and its destination) and a radius of support R
give a smooth, local space map D built from Wendland functions: every start
goes exactly to its destination, and (with ``polynomial="none"``) nothing
farther than R from every start moves. The engine is Rust; every call takes
numpy arrays, keeps float32 as float32, and releases the GIL while it works.

>>> import numpy as np, csrbf
>>> d = csrbf.fit(starts, targets, radius=0.3)        # a Deformation
>>> moved = d.deform(vertices, phase=1.0)              # vertices + D(vertices)
>>> s = csrbf.System(starts, radius=0.3)               # factor once ...
>>> d2 = s.solve(new_targets)                          # ... solve many
>>> mesh = csrbf.read_mesh("head.off")
>>> out, report = csrbf.deform_mesh(mesh, "smile.json")
>>> csrbf.write_mesh(out, "smile.ply")
>>> live = csrbf.Session(mesh)                         # a live edit:
>>> live.update_positions(controls)                    # a drag step, solved again
>>> report = live.update(controls)                     # on release, checked

Concepts:

- radius (R): how far a control vector reaches, in the model's units. Start
  from 5-15 % of the bounding-box diagonal (``Mesh.diagonal``) for local
  edits, 30 % and more for broad bends; a larger R is smoother and slower.
- kernel: the Wendland function, ``"c0"``, ``"c2"`` (default), ``"c4"``,
  ``"c6"``: smoother with the number, and a smaller fold-free move.
- polynomial: ``"none"`` keeps edits local; ``"linear"`` reproduces affine
  maps (rotations, scalings given by the vectors) but moves the whole model.
- phase: in [0, 1], 0 the rest shape and 1 the full deformation: the
  positions are x + phase * D(x).

``import csrbf.pyvista`` adds ``mesh.csrbf.deform(...)`` to PyVista meshes.
"""

from ._csrbf import (
    Binding,
    Deformation,
    Error,
    Mesh,
    Report,
    Session,
    System,
    __version__,
    build_profile,
    control_file,
    deform_many,
    deform_mesh,
    find_symmetry,
    fit,
    mirror_onto_surface,
    read_mesh,
    symmetry_plane,
    write_mesh,
)

__all__ = [
    "Binding",
    "Deformation",
    "Error",
    "Mesh",
    "Report",
    "Session",
    "System",
    "__version__",
    "build_profile",
    "control_file",
    "deform_many",
    "deform_mesh",
    "find_symmetry",
    "fit",
    "mirror_onto_surface",
    "read_mesh",
    "symmetry_plane",
    "write_mesh",
]
