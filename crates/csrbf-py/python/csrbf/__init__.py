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
    VolumeMesh,
    VolumeReport,
    __version__,
    build_profile,
    control_file,
    deform_many,
    deform_mesh,
    find_symmetry,
    fit,
    mirror_onto_surface,
    morph_volume,
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
    "VolumeMesh",
    "VolumeReport",
    "__version__",
    "build_profile",
    "control_file",
    "deform_many",
    "deform_mesh",
    "find_symmetry",
    "fit",
    "mirror_onto_surface",
    "morph_volume",
    "read_mesh",
    "symmetry_plane",
    "write_mesh",
    "from_meshio",
    "to_meshio",
]


def to_meshio(mesh):
    """A VolumeMesh as a ``meshio.Mesh`` (needs meshio): its cell blocks,
    the zone of every cell as ``cell_data["gmsh:physical"]`` and the zones
    as ``field_data`` ({name: [tag, dim]}), as meshio keeps Gmsh's physical
    groups."""
    import meshio
    import numpy as np

    blocks = mesh.cells
    zones = mesh.cell_zones
    data, start = [], 0
    for _, cells in blocks:
        data.append(zones[start : start + len(cells)].astype(np.int32))
        start += len(cells)
    field = {name: np.array([tag, dim]) for name, (tag, dim) in mesh.zones.items()}
    return meshio.Mesh(
        mesh.points,
        blocks,
        cell_data={"gmsh:physical": data} if field else {},
        field_data=field,
    )


def from_meshio(m):
    """A ``meshio.Mesh`` as a VolumeMesh: its blocks of linear cells, zones
    from ``cell_data["gmsh:physical"]`` (or ``"CellEntityIds"``) named by
    ``field_data``."""
    import numpy as np

    blocks = [(b.type, b.data) for b in m.cells]
    zones = None
    for key in ("gmsh:physical", "CellEntityIds"):
        if key in m.cell_data:
            zones = np.concatenate([np.asarray(a).reshape(-1) for a in m.cell_data[key]])
            break
    names = {}
    for name, v in (m.field_data or {}).items():
        v = np.asarray(v).reshape(-1)
        if len(v) == 2:
            names[name] = (int(v[0]), int(v[1]))
    if zones is not None:
        dims = {}
        start = 0
        for kind, cells in blocks:
            dim = {"vertex": 0, "line": 1, "triangle": 2, "quad": 2}.get(kind, 3)
            for t in np.unique(zones[start : start + len(cells)]):
                dims.setdefault(int(t), dim)
            start += len(cells)
        known = {tag for tag, _ in names.values()}
        for tag, dim in dims.items():
            if tag != 0 and tag not in known:
                names[f"zone {tag}"] = (tag, dim)
    return VolumeMesh(m.points, blocks, zones, names or None)

