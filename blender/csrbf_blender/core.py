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


def handles(obj) -> list:
    """The object's handles: empties (role "handle") whose owner is the
    object, in the order they were made."""
    seen, out = set(), []
    col = _collection(obj)
    for e in list(obj.children) + (list(col.objects) if col is not None else []):
        if e.name not in seen and e.get(ROLE) == "handle" and owner_of(e) == obj:
            seen.add(e.name)
            out.append(e)
    return sorted(out, key=lambda e: (int(e.get(PAIR, -1)), e.name))


def world(x, depsgraph=None):
    """An object's world matrix: as evaluated in `depsgraph` when given (a
    frame of a render or of playback, whose animated values the original
    objects do not hold), else the object's own."""
    return (x if depsgraph is None else x.evaluated_get(depsgraph)).matrix_world


def control_pairs(obj, depsgraph=None) -> Controls:
    """The object's control vectors (positions as evaluated in `depsgraph`
    when given: see `world`). A start and a destination pair when
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
    inv = world(obj, depsgraph).inverted()
    starts_xyz = np.array([tuple(inv @ world(s, depsgraph).translation) for s, _ in pairs], dtype=np.float64)
    targets_xyz = np.array([tuple(inv @ world(t, depsgraph).translation) for _, t in pairs], dtype=np.float64)
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


def bpy_object(name: str):
    import bpy

    return bpy.data.objects[name]


def owner_mesh(obj):
    """The mesh an operator acts on when `obj` is active: the object itself
    when a mesh, the control's mesh when one of its empties, else None."""
    if obj is not None and obj.type == "EMPTY" and obj.get(ROLE):
        obj = owner_of(obj)
    return obj if obj is not None and obj.type == "MESH" else None


class Groups:
    """An object's vertex groups, read once (a pass over the vertices costs
    about 30 ms for 50k of them, too much for each frame of playback): a
    group's vertices with a weight above 0, and their weights. Make a new
    one after the groups or their weights change."""

    def __init__(self, obj):
        self._obj = obj
        self._read = None  # group name -> (vertices, weights)
        self._rest = None

    def get(self, name: str):
        """(vertices uint32, weights float32) of the group, or None when the
        object has no such group."""
        obj = self._obj
        if obj.vertex_groups.get(name) is None:
            return None
        if self._read is None or name not in self._read:
            names = {g.index: g.name for g in obj.vertex_groups}
            lists: dict[int, tuple[list, list]] = {i: ([], []) for i in names}
            for v in obj.data.vertices:
                for g in v.groups:
                    if g.weight > 0.0 and g.group in lists:
                        lists[g.group][0].append(v.index)
                        lists[g.group][1].append(g.weight)
            self._read = {names[i]: (np.asarray(a, dtype=np.uint32), np.asarray(b, dtype=np.float32))
                          for i, (a, b) in lists.items()}
        return self._read[name]

    def vertices(self, name: str, what: str) -> np.ndarray:
        """The group's vertices; ValueError naming `what` needs it when the
        object has no such group or no vertex of it has a weight above 0."""
        got = self.get(name)
        obj = self._obj
        if got is None:
            have = ", ".join(repr(g.name) for g in obj.vertex_groups) or "none"
            raise ValueError(f"{what}: {obj.name!r} has no vertex group {name!r} (its vertex groups: {have})")
        if len(got[0]) == 0:
            raise ValueError(f"{what}: vertex group {name!r} has no vertex with a weight above 0")
        return got[0]

    def weights_region(self, name: str) -> dict | None:
        """The group as a `weights` region (vertex numbers and weights, as
        lists: made once, not on every frame), or None when every weight
        is 1 (the group by name then means the same)."""
        cache = self.__dict__.setdefault("_weights", {})
        if name not in cache:
            idx, w = self.get(name)
            cache[name] = {"weights": {"vertices": idx.tolist(), "weights": w.tolist()}} if (w < 1.0).any() else None
        return cache[name]

    @property
    def rest(self) -> np.ndarray:
        if self._rest is None:
            self._rest = rest_positions(self._obj)
        return self._rest

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The rest shape's bounding box (lowest and highest corner)."""
        if "_bounds" not in self.__dict__:
            self._bounds = (self.rest.min(axis=0), self.rest.max(axis=0))
        return self._bounds


def group_vertices(obj, name: str) -> np.ndarray | None:
    """Indices of the vertices in a vertex group (any weight > 0), or None
    when the object has no such group."""
    got = Groups(obj).get(name)
    return None if got is None else got[0]


def resolve_groups(spec, obj, groups: Groups | None = None):
    """A control file (parsed JSON) with every region that names a part
    (`{"group": name}`, in `region`, a handle's `select` or an `anchor`)
    turned into the vertex list of the object's vertex group of that name
    (its vertices with a weight above 0). Raises ValueError naming a group
    the object does not have."""
    groups = groups or Groups(obj)
    if isinstance(spec, dict):
        out = {k: resolve_groups(v, obj, groups) for k, v in spec.items()}
        name = out.get("group")
        if isinstance(name, str):
            got = groups.get(name)
            if got is None:
                have = ", ".join(repr(g.name) for g in obj.vertex_groups) or "none"
                raise ValueError(f"{obj.name!r} has no vertex group {name!r} (its vertex groups: {have})")
            del out["group"]
            out["vertices"] = got[0].tolist()
        return out
    if isinstance(spec, list):
        if spec and not isinstance(spec[0], (dict, list)):
            return spec  # numbers (a point, a vertex list): nothing to resolve
        return [resolve_groups(v, obj, groups) for v in spec]
    return spec


def region_spec(obj, settings, groups: Groups) -> dict | None:
    """The panel's Region in the control file's form, or None for the whole
    mesh. A vertex group with weights below 1 (and Use Weights on) is the
    `weights` region, by vertex number: each vertex takes its weight's
    share of the deformation. Raises ValueError for a group the object does
    not have or one with no weight above 0 (it would move nothing)."""
    s = settings
    kind = s.region
    if kind == "ALL" and s.vertex_group and not s.is_property_set("region"):
        kind = "GROUP"  # a file from before the region kinds: a group was the only one
    if kind == "ALL":
        return None
    if kind == "GROUP":
        if not s.vertex_group:
            raise ValueError("Region is Vertex Group, but no group is chosen")
        groups.vertices(s.vertex_group, "Region")  # refused when missing or empty
        if s.use_weights:
            weighted = groups.weights_region(s.vertex_group)
            if weighted is not None:
                return weighted
        return {"group": s.vertex_group}
    if kind == "SURFACE":
        return {"connected": {"distance": s.surface_distance, "from": s.surface_from.lower()}}
    if kind == "SPHERE":
        region = {"sphere": {"center": list(s.sphere_center), "radius": s.sphere_radius}}
    else:
        region = {"box": {"min": list(s.box_min), "max": list(s.box_max)}}
    if s.falloff > 0.0:
        region["falloff"] = s.falloff
    return region


def rest_matrix(e):
    """A handle's rest transform (in its mesh's local space)."""
    from mathutils import Matrix

    r = list(e.csrbf.rest)
    return Matrix([r[0:4], r[4:8], r[8:12], r[12:16]])


def set_rest(e, obj, depsgraph=None) -> None:
    """Makes the handle's present transform its rest: it does not move now."""
    m = world(obj, depsgraph).inverted() @ world(e, depsgraph)
    e.csrbf.rest = [x for row in m for x in row]


def handle_spec(obj, e, groups: Groups, depsgraph=None) -> tuple[dict, dict | None]:
    """A handle's `handle` and `anchor` in the control file's form: its
    vertex group moves by the empty's motion from its rest (a turn about the
    rest position, an even scale, a move), its anchor group stays. Raises
    ValueError naming the handle for a group that is missing or has no
    vertex, a pivot far outside the mesh, or a motion that is not a turn,
    an even scale and a move (a mirrored or unevenly scaled empty)."""
    from mathutils import Matrix

    what = f"handle {e.name!r}"
    sel = groups.vertices(e.csrbf.handle_group, what) if e.csrbf.handle_group else None
    if sel is None:
        raise ValueError(f"{what}: no vertex group chosen for it to move")
    rest = rest_matrix(e)
    pivot = rest.translation
    lo, hi = groups.bounds
    size = float(np.linalg.norm(hi - lo)) or 1.0
    outside = float(np.linalg.norm(np.maximum(0.0, np.maximum(lo - np.array(pivot), np.array(pivot) - hi))))
    if outside > size:
        raise ValueError(f"{what}: its pivot ({pivot.x:.4g}, {pivot.y:.4g}, {pivot.z:.4g}) lies {outside:.4g} outside "
                         f"{obj.name!r}, farther than the object's size ({size:.4g}): put the handle's rest on the part it turns "
                         "(move the empty there and Set Rest)")
    t = world(obj, depsgraph).inverted() @ world(e, depsgraph) @ rest.inverted()
    a = t.to_3x3()
    det = a.determinant()
    if not det > 0.0:
        raise ValueError(f"{what}: its empty is mirrored or flattened (a negative or zero scale): "
                         "a handle turns, scales evenly and moves")
    scale = det ** (1.0 / 3.0)
    rot = a * (1.0 / scale)
    off = rot @ rot.transposed() - Matrix.Identity(3)
    if max(abs(x) for row in off for x in row) > 1e-4:
        raise ValueError(f"{what}: its empty is scaled unevenly ({tuple(round(x, 4) for x in e.scale)}): "
                         "a handle scales the same in every direction")
    axis, angle = rot.to_quaternion().to_axis_angle()
    moved = t @ pivot - pivot
    handle = {
        "select": {"group": e.csrbf.handle_group},
        "rotate": {"axis": list(axis), "angle_deg": float(np.degrees(angle)), "pivot": list(pivot)},
        "scale": float(scale),
        "translate": list(moved),
    }
    anchor = None
    if e.csrbf.anchor_group:
        groups.vertices(e.csrbf.anchor_group, f"{what}'s anchor")
        anchor = {"group": e.csrbf.anchor_group}
    return handle, anchor


def control_file(obj, settings, depsgraph=None, groups: Groups | None = None, controls: Controls | None = None) -> dict:
    """The object's control vectors, handles and panel settings as a control
    file in the CLI's format (local coordinates, vertex groups by name but
    a weighted Region by vertex number), written by the package's edit
    layer (`csrbf.control_file`), which checks it as `csrbf deform` would.
    Positions as evaluated in `depsgraph` when given (a frame). The control
    vectors and the first handle make one deformation (fitted together);
    each further handle one more, applied in turn. `controls`: the
    object's `control_pairs` when already read."""
    import csrbf

    groups = groups or Groups(obj)
    c = controls if controls is not None else control_pairs(obj, depsgraph)
    hs = handles(obj)
    if len(c.starts) == 0 and not hs:
        left = f" ({'; '.join(c.problems)})" if c.problems else ""
        raise ValueError(f"{obj.name!r} has no control vectors or handles: add one first{left}")
    s = settings
    common = dict(kernel=s.kernel, polynomial=s.polynomial, region=region_spec(obj, s, groups), sweep=bool(s.sweep))
    none = np.zeros((0, 3))
    layers = []
    for k, h in enumerate(hs or [None]):
        handle, anchor = handle_spec(obj, h, groups, depsgraph) if h is not None else (None, None)
        starts, targets = (c.starts, c.targets) if k == 0 else (none, none)
        name = (s.layer or None) if k == 0 else h.name
        layers.append(csrbf.control_file(starts, targets, s.radius, name=name, handle=handle, anchor=anchor, **common))
    return layers[0] if len(layers) == 1 else {"deformations": layers}


def nearest_on_surface(obj, points):
    """The point of the object's rest surface nearest each of `points`
    (local space), as Vectors: the rest shape's, not a posed one (a live
    shape key moves the evaluated mesh that `closest_point_on_mesh` reads).
    None for a point with no surface within the object's size."""
    from mathutils import Vector
    from mathutils.bvhtree import BVHTree

    rest = rest_positions(obj)
    tree = BVHTree.FromPolygons(rest.tolist(), triangles(obj).tolist())
    size = diagonal(rest) or 1.0
    out = []
    for p in points:
        hit = tree.find_nearest(Vector(p), size)
        out.append(None if hit[0] is None else hit[0])
    return out


def read_control_file(path: str) -> dict:
    with open(path, encoding="utf-8-sig") as f:
        return json.load(f)


def write_shape_key(obj, name: str, positions: np.ndarray, value: float | None = 1.0):
    """Writes `positions` into the shape key `name` (made, with a Basis
    holding the rest shape, when missing) and sets its value (None: keeps
    it, which may be keyframed; a new key's is 1); returns the key."""
    if obj.data.shape_keys is None:
        obj.shape_key_add(name="Basis", from_mix=False)
    key = obj.data.shape_keys.key_blocks.get(name)
    if key is None:
        key = obj.shape_key_add(name=name, from_mix=False)
        value = 1.0 if value is None else value
    key.data.foreach_set("co", np.ascontiguousarray(positions, dtype=np.float32).ravel())
    if value is not None:
        key.value = value
    obj.data.update()
    return key


def shape_key_positions(obj, name: str) -> np.ndarray | None:
    keys = obj.data.shape_keys
    if keys is None or name not in keys.key_blocks:
        return None
    co = np.empty(len(obj.data.vertices) * 3, dtype=np.float32)
    keys.key_blocks[name].data.foreach_get("co", co)
    return co.reshape(-1, 3)
