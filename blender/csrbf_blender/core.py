"""Blender data in and out of csrbf: no bpy operator state here.

Control vectors are pairs of empties parented to the mesh object, in a
collection named after it: the start (a small sphere) and the destination
(an arrow). Their positions are read in the object's local space, which is
where the mesh's vertices are, so a deformation is a shape key of the mesh.
"""

from __future__ import annotations

import json

import numpy as np

ROLE = "csrbf_role"  # "start" or "target"
PAIR = "csrbf_pair"  # the control's number within its object
OWNER = "csrbf_object"  # the mesh object's name


def collection_name(obj) -> str:
    return f"csrbf {obj.name}"


def rest_positions(obj) -> np.ndarray:
    """The vertices at rest, (N, 3) float32 in local space: the Basis shape
    key when the mesh has shape keys (so running again does not deform a
    deformed mesh), else the mesh's vertices."""
    me = obj.data
    keys = me.shape_keys
    src = keys.reference_key.data if keys is not None else me.vertices
    co = np.empty(len(me.vertices) * 3, dtype=np.float32)
    src.foreach_get("co", co)
    return co.reshape(-1, 3)


def triangles(obj) -> np.ndarray:
    """The mesh's triangles (its polygons' fan triangulation), (M, 3) uint32."""
    me = obj.data
    me.calc_loop_triangles()
    tri = np.empty(len(me.loop_triangles) * 3, dtype=np.uint32)
    me.loop_triangles.foreach_get("vertices", tri)
    return tri.reshape(-1, 3)


def diagonal(points: np.ndarray) -> float:
    if len(points) == 0:
        return 0.0
    return float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)))


def controls(obj):
    """The object's control vectors as (starts, targets), (K, 3) float64 in
    its local space, ordered by pair number; pairs missing an empty are
    left out."""
    col = _collection(obj)
    if col is None:
        return np.zeros((0, 3)), np.zeros((0, 3))
    inv = obj.matrix_world.inverted()
    pairs: dict[int, dict[str, object]] = {}
    for e in col.objects:
        role = e.get(ROLE)
        if e.get(OWNER) == obj.name and role in ("start", "target"):
            pairs.setdefault(int(e.get(PAIR, -1)), {})[role] = inv @ e.matrix_world.translation
    whole = [pairs[k] for k in sorted(pairs) if len(pairs[k]) == 2]
    starts = np.array([tuple(p["start"]) for p in whole], dtype=np.float64).reshape(-1, 3)
    targets = np.array([tuple(p["target"]) for p in whole], dtype=np.float64).reshape(-1, 3)
    return starts, targets


def control_empties(obj):
    """Every empty of the object's control vectors."""
    col = _collection(obj)
    if col is None:
        return []
    return [e for e in col.objects if e.get(OWNER) == obj.name and e.get(ROLE)]


def _collection(obj):
    import bpy

    return bpy.data.collections.get(collection_name(obj))


def group_vertices(obj, name: str) -> np.ndarray | None:
    """Indices of the vertices in a vertex group (any weight > 0), or None
    when the object has no such group."""
    vg = obj.vertex_groups.get(name)
    if vg is None:
        return None
    gi = vg.index
    out = [v.index for v in obj.data.vertices if any(g.group == gi and g.weight > 0.0 for g in v.groups)]
    return np.asarray(out, dtype=np.uint32)


def resolve_groups(spec, obj):
    """A control file (parsed JSON) with every region that names a part
    (`{"group": name}`, in `region`, a handle's `select` or an `anchor`)
    turned into the vertex list of the object's vertex group of that name.
    Names that are not vertex groups are left for the engine to refuse."""
    if isinstance(spec, dict):
        out = {}
        for k, v in spec.items():
            out[k] = resolve_groups(v, obj)
        name = out.get("group")
        if isinstance(name, str):
            idx = group_vertices(obj, name)
            if idx is not None:
                del out["group"]
                out["vertices"] = idx.tolist()
        return out
    if isinstance(spec, list):
        return [resolve_groups(v, obj) for v in spec]
    return spec


def control_file(obj, settings) -> dict:
    """The object's control vectors and panel settings as a control file in
    the CLI's format (local coordinates)."""
    starts, targets = controls(obj)
    spec = {
        "name": settings.layer,
        "kernel": settings.kernel,
        "radius": settings.radius,
        "polynomial": settings.polynomial,
        "controls": [
            {"from": [float(x) for x in s], "to": [float(x) for x in t]} for s, t in zip(starts, targets)
        ],
    }
    if settings.vertex_group:
        spec["region"] = {"group": settings.vertex_group}
    if settings.sweep:
        spec["sweep"] = True
    return spec


def read_control_file(path: str) -> dict:
    with open(path, encoding="utf-8-sig") as f:
        return json.load(f)


def write_shape_key(obj, name: str, positions: np.ndarray):
    """Writes `positions` into the shape key `name` (made, with a Basis
    holding the rest shape, when missing) at value 1.0; returns the key."""
    if obj.data.shape_keys is None:
        obj.shape_key_add(name="Basis", from_mix=False)
    key = obj.data.shape_keys.key_blocks.get(name)
    if key is None:
        key = obj.shape_key_add(name=name, from_mix=False)
    key.data.foreach_set("co", np.ascontiguousarray(positions, dtype=np.float32).ravel())
    key.value = 1.0
    obj.data.update()
    return key


def shape_key_positions(obj, name: str) -> np.ndarray | None:
    keys = obj.data.shape_keys
    if keys is None or name not in keys.key_blocks:
        return None
    co = np.empty(len(obj.data.vertices) * 3, dtype=np.float32)
    keys.key_blocks[name].data.foreach_get("co", co)
    return co.reshape(-1, 3)
