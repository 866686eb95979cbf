"""Blender data in and out of csrbf: no bpy operator state here.

Control vectors are pairs of empties parented to the mesh object, in a
collection named after it: the start (a small sphere) and the destination
(an arrow). Each empty points at its mesh (`csrbf.owner`) and at the other
end of its pair (`csrbf.partner`), so renaming the mesh or duplicating a
pair keeps them apart. Their positions are read in the object's local space, which is
where the mesh's vertices are, so a deformation is a shape key of the mesh.
"""

from __future__ import annotations

import json

import numpy as np

ROLE = "csrbf_role"  # "start" or "target"
PAIR = "csrbf_pair"  # the control's number within its object
OWNER = "csrbf_object"  # the mesh object's name: files before the owner was a pointer (csrbf.owner)


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


class Controls:
    """An object's control vectors, read from its empties: `starts` and
    `targets` (K, 3) float64 in its local space, `names` the K starts'
    empties, and `problems`: one line for each empty left out (a start with
    no destination or a destination with no start), naming it."""

    def __init__(self, starts, targets, names, problems):
        self.starts, self.targets, self.names, self.problems = starts, targets, names, problems


def owner_of(e):
    """The mesh object a control empty belongs to, or None. Files from before
    the owner was a pointer name it by a string (read until migrated)."""
    owner = e.csrbf.owner
    if owner is None and isinstance(e.get(OWNER), str):
        import bpy

        owner = bpy.data.objects.get(e[OWNER])
    return owner


def control_empties(obj):
    """Every empty of the object's control vectors: in its collection or
    parented to it, whose owner is the object."""
    seen, out = set(), []
    col = _collection(obj)
    for e in list(obj.children) + (list(col.objects) if col is not None else []):
        if e.name not in seen and e.get(ROLE) in ("start", "target") and owner_of(e) == obj:
            seen.add(e.name)
            out.append(e)
    return out


def control_pairs(obj) -> Controls:
    """The object's control vectors. A start and a destination pair when
    each is the other's partner (so duplicating both empties makes a new
    pair, its partners the copies); empties from files made before the
    partners were kept pair by their number when that is unambiguous. Every
    other empty is left out and named in `problems`."""
    empties = control_empties(obj)
    starts = [e for e in empties if e[ROLE] == "start"]
    targets = [e for e in empties if e[ROLE] == "target"]
    pairs, paired = [], set()
    for s in starts:
        t = s.csrbf.partner
        if t is not None and t.get(ROLE) == "target" and t.csrbf.partner == s and owner_of(t) == obj:
            pairs.append((s, t))
            paired.update((s.name, t.name))
    # Legacy empties (owner by name, no partners): one start and one
    # destination a number. Empties that lost their partner are not legacy.
    legacy: dict[int, list] = {}
    for e in empties:
        if e.name not in paired and e.csrbf.owner is None and e.csrbf.partner is None:
            legacy.setdefault(int(e.get(PAIR, -1)), []).append(e)
    for group in legacy.values():
        if sorted(e[ROLE] for e in group) == ["start", "target"]:
            s, t = sorted(group, key=lambda e: e[ROLE])
            pairs.append((s, t))
            paired.update((s.name, t.name))
    problems = []
    for e in empties:
        if e.name in paired:
            continue
        if e[ROLE] == "start":
            problems.append(f"start {e.name!r} has no destination of its own (copied alone, or its destination "
                            "deleted?): left out; delete it or Add Control Vector for a whole pair")
        else:
            problems.append(f"destination {e.name!r} has no start of its own (copied alone, or its start "
                            "deleted?): left out; delete it or Add Control Vector for a whole pair")
    pairs.sort(key=lambda p: (int(p[0].get(PAIR, -1)), p[0].name))
    inv = obj.matrix_world.inverted()
    starts_xyz = np.array([tuple(inv @ s.matrix_world.translation) for s, _ in pairs], dtype=np.float64)
    targets_xyz = np.array([tuple(inv @ t.matrix_world.translation) for _, t in pairs], dtype=np.float64)
    return Controls(starts_xyz.reshape(-1, 3), targets_xyz.reshape(-1, 3), [s.name for s, _ in pairs], problems)


def controls(obj):
    """The object's control vectors as (starts, targets), (K, 3) float64 in
    its local space (see `control_pairs`, which also says what it left out)."""
    c = control_pairs(obj)
    return c.starts, c.targets


def migrate(obj=None) -> None:
    """Brings control empties saved by earlier versions up to date: the owner
    named by a string becomes a pointer (so renaming the mesh keeps its
    controls), each legacy pair's empties point at each other, and the
    mesh points at its collection. Every object when `obj` is None."""
    import bpy

    empties = [e for e in (bpy.data.objects if obj is None else control_empties(obj)) if e.get(ROLE)]
    legacy: dict[tuple[str, int], list] = {}
    for e in empties:
        owner = owner_of(e)
        if owner is None or e.csrbf.owner is not None:
            continue  # an empty that lost its partner is not legacy: never paired up
        e.csrbf.owner = owner
        if OWNER in e:
            del e[OWNER]
        if owner.csrbf.collection is None:
            owner.csrbf.collection = bpy.data.collections.get(collection_name(owner))
        if e.csrbf.partner is None:
            legacy.setdefault((owner.name, int(e.get(PAIR, -1))), []).append(e)
    for group in legacy.values():
        if sorted(e[ROLE] for e in group) == ["start", "target"]:
            group[0].csrbf.partner, group[1].csrbf.partner = group[1], group[0]


def follow_rename(obj) -> None:
    """After the mesh is renamed, its collection and control empties, still
    named after the old name ("csrbf Old", "Old start 0", "Old to 0"), take
    the new one. Names the user chose (anything else) are kept, and so is a
    name another collection already has."""
    import bpy

    col = obj.csrbf.collection
    want = collection_name(obj)
    if col is None or col.name == want or not col.name.startswith("csrbf "):
        return
    old = col.name.removeprefix("csrbf ")
    if bpy.data.collections.get(want) is None:
        col.name = want
    for e in control_empties(obj):
        for role in (" start ", " to "):
            number = e.name.removeprefix(old + role)
            if number != e.name and number.isdigit():
                e.name = f"{obj.name}{role}{number}"


def _collection(obj):
    import bpy

    return obj.csrbf.collection or bpy.data.collections.get(collection_name(obj))


def owner_mesh(obj):
    """The mesh an operator acts on when `obj` is active: the object itself
    when a mesh, the control's mesh when one of its empties, else None."""
    if obj is not None and obj.type == "EMPTY" and obj.get(ROLE):
        obj = owner_of(obj)
    return obj if obj is not None and obj.type == "MESH" else None


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
    Raises ValueError naming a group the object does not have."""
    if isinstance(spec, dict):
        out = {}
        for k, v in spec.items():
            out[k] = resolve_groups(v, obj)
        name = out.get("group")
        if isinstance(name, str):
            idx = group_vertices(obj, name)
            if idx is None:
                have = ", ".join(repr(g.name) for g in obj.vertex_groups) or "none"
                raise ValueError(f"{obj.name!r} has no vertex group {name!r} (its vertex groups: {have})")
            del out["group"]
            out["vertices"] = idx.tolist()
        return out
    if isinstance(spec, list):
        return [resolve_groups(v, obj) for v in spec]
    return spec


def control_file(obj, settings) -> dict:
    """The object's control vectors and panel settings as a control file in
    the CLI's format (local coordinates), written by the package's edit
    layer (`csrbf.control_file`), which checks it as `csrbf deform` would."""
    import csrbf

    starts, targets = controls(obj)
    return csrbf.control_file(
        starts, targets, settings.radius,
        kernel=settings.kernel, polynomial=settings.polynomial,
        region={"group": settings.vertex_group} if settings.vertex_group else None,
        sweep=bool(settings.sweep), name=settings.layer or None,
    )


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
