"""The operators: add a control vector, deform into a shape key (from the
empties or from a control file), export the empties as a control file."""

from __future__ import annotations

import json
import os
import tempfile

import bpy
import numpy as np
from bpy.props import EnumProperty, StringProperty
from bpy_extras.io_utils import ExportHelper, ImportHelper
from mathutils import Vector

from . import core


def _mesh_object(op, context):
    """The mesh to act on: the active object, or the mesh of the active
    control empty (Add Control Vector leaves its destination active)."""
    active = context.active_object
    obj = core.owner_mesh(active)
    if obj is None:
        what = "nothing" if active is None else f"{active.name!r} ({active.type.lower()})"
        op.report({"ERROR"}, f"csrbf: the active object must be a mesh or a control vector's empty, not {what}")
        return None
    core.migrate(obj)
    core.follow_rename(obj)
    return obj


class _ObjectMode:
    """Leaves Edit Mode for the duration (writing the mesh's edits back) and
    returns to it: a shape key written in Edit Mode is overwritten by the
    edit mesh's own copy when Edit Mode ends."""

    def __init__(self, obj):
        self.edit = obj.mode == "EDIT"

    def __enter__(self):
        if self.edit:
            bpy.ops.object.mode_set(mode="OBJECT")
        return self

    def __exit__(self, *exc):
        if self.edit:
            bpy.ops.object.mode_set(mode="EDIT")
        return False


def _engine():
    import csrbf  # the wheel the extension ships

    return csrbf


def _has_region(spec) -> bool:
    if not isinstance(spec, dict):
        return False
    return "region" in spec or any(_has_region(d) for d in spec.get("deformations", []))


def show_report(settings, report, problems=()) -> None:
    """A deformation's report into the panel's figures: moves, folds,
    stretch, faces passing through each other, the warnings (with the
    empties left out) and the remedies' advice ("a radius 2.28x as large
    folds no face, or a sweep cannot fold"), as `csrbf deform` prints them."""
    settings.moved = report.moved
    settings.inside_out = report.inside_out_faces
    settings.fold_phase = -1.0 if report.fold_phase is None else report.fold_phase
    settings.largest_move = report.largest_move
    settings.largest_stretch = report.largest_stretch
    settings.stretched = report.stretched_faces
    hits = report.self_intersections
    settings.intersections = -1 if hits is None else len(hits)
    settings.warnings = "\n".join(list(problems) + report.warnings)
    settings.advice = report.advice or ""


def apply_spec(op, obj, spec: dict, source: str, problems=()) -> bool:
    """Fits a control file (parsed JSON, regions by vertex group name) on the
    object's rest shape and writes the result into the shape key named after
    the first deformation's `name` (or the object's layer). Reports and
    changes nothing on any error, or when a start reaches no vertex.
    `problems` (empties left out) are reported as warnings with the rest."""
    csrbf = _engine()
    settings = obj.csrbf
    rest = core.rest_positions(obj)
    mesh = csrbf.Mesh(rest, core.triangles(obj))
    try:
        out, report = csrbf.deform_mesh(mesh, core.resolve_groups(spec, obj))
    except (csrbf.Error, ValueError, TypeError) as e:
        op.report({"ERROR"}, f"csrbf: {source}: {e}")
        return False
    far = [w for w, k in zip(report.warnings, report.warning_kinds) if k == "starts_far_from_mesh"]
    if far:
        where = "onto the mesh, inside the deformation's region," if _has_region(spec) else "onto the mesh"
        op.report({"ERROR"}, f"csrbf: {source}: {far[0]} (move the start {where} or raise the radius)")
        return False
    first = spec.get("deformations", [spec])[0] if isinstance(spec, dict) else {}
    name = first.get("name") if isinstance(first, dict) and isinstance(first.get("name"), str) else settings.layer
    core.write_shape_key(obj, name or settings.layer, out.vertices)
    show_report(settings, report, problems)
    warnings = list(problems) + report.warnings
    level = {"WARNING"} if warnings or report.advice else {"INFO"}
    op.report(level, f"csrbf: {report.moved} of {len(rest)} vertices moved into shape key {name!r}"
              + (f"; {len(warnings)} warning(s): {warnings[0]}" if warnings else "")
              + (f"; {report.advice}" if report.advice else ""))
    return True


def _selected_vertices(op, obj, what: str):
    """The vertices selected in Edit Mode (the edit mesh's selection written
    back first), or None with an error reported."""
    obj.update_from_editmode()
    sel = np.empty(len(obj.data.vertices), dtype=bool)
    obj.data.vertices.foreach_get("select", sel)
    idx = np.flatnonzero(sel)
    if len(idx) == 0:
        op.report({"ERROR"}, f"csrbf: select the vertices {what} (Edit Mode)")
        return None
    return idx


def _controls_collection(context, obj):
    settings = obj.csrbf
    col = settings.collection or bpy.data.collections.get(core.collection_name(obj))
    if col is None:
        col = bpy.data.collections.new(core.collection_name(obj))
        context.scene.collection.children.link(col)
    settings.collection = col
    return col


def _first_radius(obj, size: float) -> None:
    settings = obj.csrbf
    if not settings.initialised and not settings.is_property_set("radius"):
        settings.radius = 0.15 * size  # the user's own R is kept
    settings.initialised = True


class CSRBF_OT_add_control(bpy.types.Operator):
    """Add a control vector: a start on the surface under the 3D cursor (or at each selected vertex in Edit Mode, which it stays in) and a destination to move with G/R"""

    bl_idname = "csrbf.add_control"
    bl_label = "Add Control Vector"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        obj = _mesh_object(self, context)
        if obj is None:
            return {"CANCELLED"}
        edit = obj.mode == "EDIT"
        rest = core.rest_positions(obj)
        size = core.diagonal(rest) or 1.0
        if edit:
            idx = _selected_vertices(self, obj, "to start control vectors at")
            if idx is None:
                return {"CANCELLED"}
            points = [Vector(p) for p in rest[idx]]
        else:
            if len(obj.data.polygons) == 0:
                self.report({"ERROR"}, f"csrbf: {obj.name!r} has no faces to place a start on")
                return {"CANCELLED"}
            cursor = obj.matrix_world.inverted() @ context.scene.cursor.location
            location = core.nearest_on_surface(obj, [cursor])[0]
            if location is None or (location - cursor).length > size:
                self.report({"ERROR"}, f"csrbf: the 3D cursor is farther from {obj.name!r} than the object's size: place it on the surface first")
                return {"CANCELLED"}
            points = [location]
        _first_radius(obj, size)
        with _ObjectMode(obj):  # empties are linked in Object Mode; Edit Mode is kept
            col = _controls_collection(context, obj)
            target = None
            for p in points:
                _start, target = _pair(col, obj, p, p, size)
            if not edit:
                for o in context.view_layer.objects:
                    o.select_set(False)
                if target is not None and target.name in context.view_layer.objects:
                    target.select_set(True)
                    context.view_layer.objects.active = target
        then = "Tab to Object Mode, move the destination (G)" if edit else "move the destination (G)"
        self.report({"INFO"}, f"csrbf: {len(points)} control vector(s) added; {then} and Deform")
        return {"FINISHED"}


def _pair(col, obj, start, target, size, names=None):
    """A new control vector's two empties (names: the start's and the
    destination's, else numbered)."""
    settings = obj.csrbf
    k = settings.next_pair
    settings.next_pair += 1
    sn, tn = names or (f"{obj.name} start {k}", f"{obj.name} to {k}")
    s = _empty(col, obj, sn, "SPHERE", 0.01 * size, start, "start", k)
    t = _empty(col, obj, tn, "PLAIN_AXES", 0.03 * size, target, "target", k)
    s.csrbf.partner, t.csrbf.partner = t, s
    return s, t


def _empty(col, obj, name, display, size, local, role, pair):
    e = bpy.data.objects.new(name, None)
    e.empty_display_type = display
    e.empty_display_size = size
    col.objects.link(e)
    e.parent = obj
    e.matrix_parent_inverse.identity()
    e.location = local
    e[core.ROLE] = role
    e[core.PAIR] = pair
    e.csrbf.owner = obj
    return e


PIVOTS = [
    ("SELECTION", "Selection's Centre", "The handle turns and scales about the centre of the selected vertices"),
    ("CURSOR", "3D Cursor", "The handle turns and scales about the 3D cursor (a joint: put it on the shoulder)"),
]


class CSRBF_OT_add_handle(bpy.types.Operator):
    """Make the selected vertices (Edit Mode) a handle: they move as one, turned, scaled and moved by an empty (rotate it with R, or type the angle and axis in the panel), while the rest of the mesh follows smoothly"""

    bl_idname = "csrbf.add_handle"
    bl_label = "Add Handle"
    bl_options = {"REGISTER", "UNDO"}

    pivot: EnumProperty(name="Pivot", items=PIVOTS, default="SELECTION")

    def execute(self, context):
        obj = _mesh_object(self, context)
        if obj is None:
            return {"CANCELLED"}
        if obj.mode != "EDIT":
            self.report({"ERROR"}, "csrbf: select the vertices the handle moves in Edit Mode first")
            return {"CANCELLED"}
        idx = _selected_vertices(self, obj, "the handle moves")
        if idx is None:
            return {"CANCELLED"}
        rest = core.rest_positions(obj)
        size = core.diagonal(rest) or 1.0
        if self.pivot == "CURSOR":
            pivot = obj.matrix_world.inverted() @ context.scene.cursor.location
        else:
            pivot = Vector(rest[idx].mean(axis=0))
        lo, hi = rest.min(axis=0), rest.max(axis=0)
        outside = float(np.linalg.norm(np.maximum(0.0, np.maximum(lo - np.array(pivot), np.array(pivot) - hi))))
        if outside > size:
            self.report({"ERROR"}, f"csrbf: the pivot (the 3D cursor) lies {outside:.4g} outside {obj.name!r}, farther than "
                        f"the object's size ({size:.4g}): put the cursor on the joint the handle turns about")
            return {"CANCELLED"}
        _first_radius(obj, size)
        with _ObjectMode(obj):  # vertex groups take vertices in Object Mode only
            col = _controls_collection(context, obj)
            k = obj.csrbf.next_pair
            obj.csrbf.next_pair += 1
            name = f"{obj.name} handle {k}"
            group = obj.vertex_groups.new(name=name)
            group.add([int(i) for i in idx], 1.0, "REPLACE")
            e = _empty(col, obj, name, "ARROWS", 0.1 * size, pivot, "handle", k)
            e.rotation_mode = "AXIS_ANGLE"
            e.csrbf.handle_group = group.name
            context.view_layer.update()
            core.set_rest(e, obj)
        self.report({"INFO"}, f"csrbf: handle {name!r} on {len(idx)} vertices; turn its empty (R) or type its angle "
                    "in the panel, then Deform (or Live)")
        return {"FINISHED"}


class _HandleOperator:
    """An operator on one handle: the one named `handle`, else the active
    object when a handle; and its mesh."""

    handle: StringProperty(name="Handle", default="")

    def handle_and_mesh(self, context):
        """(the mesh, the handle's empty), or None with an error reported."""
        name = self.handle
        e = bpy.data.objects.get(name) if name else context.active_object
        if e is None or e.get(core.ROLE) != "handle" or core.owner_of(e) is None:
            self.report({"ERROR"}, f"csrbf: {'no handle named ' + repr(name) if name else 'the active object is not a handle'}")
            return None
        obj = core.owner_of(e)
        core.migrate(obj)
        return obj, e


class CSRBF_OT_handle_anchor(_HandleOperator, bpy.types.Operator):
    """Hold the selected vertices (Edit Mode) still while this handle moves: its anchor (a vertex group)"""

    bl_idname = "csrbf.handle_anchor"
    bl_label = "Anchor from Selection"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        got = self.handle_and_mesh(context)
        if got is None:
            return {"CANCELLED"}
        obj, e = got
        if obj.mode != "EDIT":
            self.report({"ERROR"}, f"csrbf: select the vertices of {obj.name!r} to hold still in Edit Mode first")
            return {"CANCELLED"}
        idx = _selected_vertices(self, obj, "to hold still")
        if idx is None:
            return {"CANCELLED"}
        moved = core.Groups(obj).get(e.csrbf.handle_group)
        if moved is not None and np.isin(idx, moved[0]).any():
            self.report({"ERROR"}, f"csrbf: {int(np.isin(idx, moved[0]).sum())} of the selected vertices are the handle's "
                        "own: an anchor holds other vertices still")
            return {"CANCELLED"}
        with _ObjectMode(obj):
            name = e.csrbf.anchor_group or f"{e.name} anchor"
            group = obj.vertex_groups.get(name) or obj.vertex_groups.new(name=name)
            group.remove(list(range(len(obj.data.vertices))))
            group.add([int(i) for i in idx], 1.0, "REPLACE")
            e.csrbf.anchor_group = group.name
        self.report({"INFO"}, f"csrbf: {len(idx)} vertices anchor handle {e.name!r}")
        return {"FINISHED"}


class CSRBF_OT_handle_rest(_HandleOperator, bpy.types.Operator):
    """Make the handle's present transform its rest (it then moves nothing): to put its pivot somewhere else, or start its motion over"""

    bl_idname = "csrbf.handle_rest"
    bl_label = "Set Rest"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        got = self.handle_and_mesh(context)
        if got is None:
            return {"CANCELLED"}
        obj, e = got
        core.set_rest(e, obj)
        self.report({"INFO"}, f"csrbf: handle {e.name!r} at rest where it is")
        return {"FINISHED"}


AXES = [("X", "X", "The plane normal to the object's X axis"), ("Y", "Y", "Normal to Y"), ("Z", "Z", "Normal to Z")]
PLANES = [
    ("ANY", "Found, Any Orientation", "The plane the model is most nearly mirror-symmetric about, of any orientation (a scan turned in its frame), found from its vertices"),
    ("FOUND", "Found, Normal to the Axis", "The plane normal to the axis the model is most nearly mirror-symmetric about, found from its vertices (as the studio's Mirror X, Y, Z)"),
    ("ZERO", "At 0", "The plane through the object's origin normal to the axis"),
]


def _side_names(name: str, positive: bool) -> tuple[str, str]:
    """The names of an empty and of its mirror image, as Blender names
    mirrored objects: its own name and the flipped one when it has a side
    (.L/.R, _L/_R, Left/Right), else .L and .R (the +X side is the
    character's left)."""
    flipped = bpy.utils.flip_name(name)
    if flipped != name:
        return name, flipped
    mine, other = (".L", ".R") if positive else (".R", ".L")
    return name + mine, name + other


class CSRBF_OT_mirror(bpy.types.Operator):
    """Mirror the selected control vectors (all when none is selected) across the model's plane of symmetry: each image's start is put on the surface, and the names get .L/.R"""

    bl_idname = "csrbf.mirror"
    bl_label = "Mirror Controls"
    bl_options = {"REGISTER", "UNDO"}

    axis: EnumProperty(name="Axis", items=AXES, default="X")
    plane: EnumProperty(name="Plane", items=PLANES, default="ANY")

    def execute(self, context):
        obj = _mesh_object(self, context)
        if obj is None:
            return {"CANCELLED"}
        csrbf = _engine()
        c = core.control_pairs(obj)
        pairs = [(core.bpy_object(n), i) for i, n in enumerate(c.names)]
        chosen = [i for (e, i) in pairs if e.select_get() or (e.csrbf.partner is not None and e.csrbf.partner.select_get())]
        chosen = chosen or list(range(len(c.names)))
        if not chosen:
            self.report({"ERROR"}, f"csrbf: {obj.name!r} has no control vectors to mirror")
            return {"CANCELLED"}
        rest = core.rest_positions(obj)
        mesh = csrbf.Mesh(rest, core.triangles(obj))
        axis = np.eye(3)["XYZ".index(self.axis)]
        if self.plane == "ANY":
            point, normal = csrbf.find_symmetry(mesh)
            where = (f"the plane through ({point[0]:.4g}, {point[1]:.4g}, {point[2]:.4g}) normal to "
                     f"({normal[0]:.3f}, {normal[1]:.3f}, {normal[2]:.3f})")
        else:
            at = csrbf.symmetry_plane(mesh, self.axis.lower()) if self.plane == "FOUND" else 0.0
            point, normal = axis * at, axis
            where = f"{self.axis} = {at:.6g}"
        r = obj.csrbf.radius if obj.csrbf.radius > 0 else core.diagonal(rest)
        size = core.diagonal(rest) or 1.0

        def flip(p, vector=False):
            p = np.asarray(p, dtype=np.float64)
            return p - 2.0 * ((p if vector else p - point) @ normal) * normal

        sources = np.array([c.starts[i] for i in chosen])
        # The images of starts on the surface go on the surface (its point
        # nearest the exact image: the edit layer's mirror); a start placed
        # in space is mirrored exactly.
        onto, gaps = csrbf.mirror_onto_surface(mesh, sources, point, normal)
        touching = [h is not None and (h - Vector(p)).length <= 1e-4 * size
                    for h, p in zip(core.nearest_on_surface(obj, sources), sources)]
        made, far, skipped = [], [], 0
        with _ObjectMode(obj):
            col = _controls_collection(context, obj)
            for k, i in enumerate(chosen):
                start = c.starts[i]
                side = float((start - point) @ normal)
                if abs(side) < 0.5e-6 * r:
                    skipped += 1  # on the plane: its own image
                    continue
                image = onto[k] if touching[k] else flip(start)
                gap = float(gaps[k]) if touching[k] else 0.0
                s_e = core.bpy_object(c.names[i])
                # Mirrored before: its image is where it lands, or (put on
                # the surface of a model not quite symmetric) the start of
                # its flipped name.
                twin = bpy.utils.flip_name(s_e.name)
                taken = np.linalg.norm(c.starts - image, axis=1).min() < 1e-6 * r or (twin != s_e.name and twin in c.names)
                if taken or any(np.linalg.norm(np.array(m[0]) - image) < 1e-6 * r for m in made):
                    skipped += 1
                    continue
                target = image + flip(c.targets[i] - start, vector=True)
                t_e = s_e.csrbf.partner
                s_own, s_img = _side_names(s_e.name, side > 0)
                t_own, t_img = _side_names(t_e.name, side > 0)
                if s_e.name != s_own:
                    s_e.name, t_e.name = s_own, t_own
                _pair(col, obj, tuple(image), tuple(target), size, names=(s_img, t_img))
                made.append((tuple(image), s_img))
                if gap > 0.05 * r:
                    far.append(f"{s_img!r} {gap / r:.2f} R")
        if not made:
            self.report({"ERROR"}, f"csrbf: nothing to mirror across {where}: each start is on the plane or has its image")
            return {"CANCELLED"}
        msg = f"csrbf: {len(made)} control vector(s) mirrored across {where}" + (f", {skipped} skipped (on the plane or already mirrored)" if skipped else "")
        if far:
            self.report({"WARNING"}, msg + f"; put on the surface from off it: {', '.join(far)} (is the model symmetric about this plane?)")
        else:
            self.report({"INFO"}, msg)
        return {"FINISHED"}


class CSRBF_OT_deform(bpy.types.Operator):
    """Fit the object's control vectors and handles and write the deformation into its shape key (value 1), with its checks (folds, stretch) and the remedies when it folds"""

    bl_idname = "csrbf.deform"
    bl_label = "Deform"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        obj = _mesh_object(self, context)
        if obj is None:
            return {"CANCELLED"}
        settings = obj.csrbf
        if not settings.radius > 0.0:
            self.report({"ERROR"}, f"csrbf: the radius must be > 0, got {settings.radius}")
            return {"CANCELLED"}
        csrbf = _engine()
        with _ObjectMode(obj):  # the vertex groups as edited
            controls = core.control_pairs(obj)
            try:
                spec = core.control_file(obj, settings, controls=controls)
            except (csrbf.Error, ValueError, TypeError) as e:
                self.report({"ERROR"}, f"csrbf: {obj.name}: {e}")
                return {"CANCELLED"}
            ok = apply_spec(self, obj, spec, obj.name, controls.problems)
        return {"FINISHED"} if ok else {"CANCELLED"}


class CSRBF_OT_deform_from_file(bpy.types.Operator, ImportHelper):
    """Deform the active mesh by a control file in the csrbf CLI's format (regions by vertex group name) into a shape key"""

    bl_idname = "csrbf.deform_from_file"
    bl_label = "Deform from Control File"
    bl_options = {"REGISTER", "UNDO"}
    filename_ext = ".json"
    filter_glob: StringProperty(default="*.json", options={"HIDDEN"})

    def execute(self, context):
        obj = _mesh_object(self, context)
        if obj is None:
            return {"CANCELLED"}
        path = self.filepath
        try:
            spec = core.read_control_file(path)
        except json.JSONDecodeError as e:
            self.report({"ERROR"}, f"csrbf: {path}: line {e.lineno}, column {e.colno}: {e.msg}")
            return {"CANCELLED"}
        except (OSError, UnicodeDecodeError) as e:
            self.report({"ERROR"}, f"csrbf: cannot read {path}: {e}")
            return {"CANCELLED"}
        with _ObjectMode(obj):
            ok = apply_spec(self, obj, spec, path)
        return {"FINISHED"} if ok else {"CANCELLED"}


class CSRBF_OT_export_controls(bpy.types.Operator, ExportHelper):
    """Write the object's control vectors and handles (local coordinates; vertex groups by name, a weighted Region by vertex number) as a control file the csrbf CLI and csrbf-studio open"""

    bl_idname = "csrbf.export_controls"
    bl_label = "Export Control File"
    filename_ext = ".json"
    filter_glob: StringProperty(default="*.json", options={"HIDDEN"})

    def execute(self, context):
        obj = _mesh_object(self, context)
        if obj is None:
            return {"CANCELLED"}
        csrbf = _engine()
        with _ObjectMode(obj):
            try:
                spec = core.control_file(obj, obj.csrbf)
            except (csrbf.Error, ValueError, TypeError) as e:
                self.report({"ERROR"}, f"csrbf: {obj.name}: {e}")
                return {"CANCELLED"}
        path = bpy.path.abspath(self.filepath)
        folder = os.path.dirname(path) or "."
        tmp = None
        try:  # whole or not at all: a temporary file beside the target, renamed
            fd, tmp = tempfile.mkstemp(prefix=".csrbf-", suffix=".tmp", dir=folder)
            with os.fdopen(fd, "w", encoding="utf-8") as f:
                json.dump(spec, f, indent=2)
            os.replace(tmp, path)
        except OSError as e:
            if tmp is not None and os.path.exists(tmp):
                os.remove(tmp)
            self.report({"ERROR"}, f"csrbf: cannot write {path}: {e}")
            return {"CANCELLED"}
        problems = core.control_pairs(obj).problems
        level = {"WARNING"} if problems else {"INFO"}
        layers = spec.get("deformations", [spec])
        what = f"{sum(len(d.get('controls', [])) for d in layers)} control vector(s)"
        if any("handle" in d for d in layers):
            what += f" and {sum('handle' in d for d in layers)} handle(s)"
        self.report(level, f"csrbf: wrote {what} to {path}"
                    + (f"; {len(problems)} empty(ies) left out: {problems[0]}" if problems else ""))
        return {"FINISHED"}


def fcurves(idb) -> list:
    """The F-curves animating a datablock (its action's, in its slot)."""
    ad = getattr(idb, "animation_data", None)
    if ad is None or ad.action is None:
        return []
    if hasattr(ad.action, "fcurves"):  # Blender before layered actions (4.3 and older)
        return list(ad.action.fcurves)
    from bpy_extras import anim_utils

    bag = anim_utils.action_get_channelbag_for_slot(ad.action, ad.action_slot)
    return [] if bag is None else list(bag.fcurves)


def keyed_frames(obj) -> set[int]:
    """The frames where the mesh, its control empties or its handles have a
    keyframe (the shape keys' values aside: those are the poses' phases)."""
    ids = [obj] + core.control_empties(obj) + core.handles(obj)
    return {int(round(k.co[0])) for x in ids for fc in fcurves(x) for k in fc.keyframe_points}


def baked_name(layer: str, frame: int) -> str:
    return f"{layer} f{frame}"


class CSRBF_OT_bake(bpy.types.Operator):
    """Pose the mesh at frames of the scene's range and write each pose into a shape key of its own, keyed so the file plays without csrbf (Live is turned off and its key muted)"""

    bl_idname = "csrbf.bake"
    bl_label = "Bake to Shape Keys"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        import re
        import time

        obj = _mesh_object(self, context)
        if obj is None:
            return {"CANCELLED"}
        csrbf = _engine()
        s, scene = obj.csrbf, context.scene
        first, last = scene.frame_start, scene.frame_end
        still = False  # nothing animated: one pose, into the layer's own key
        if s.bake_frames == "KEYED":
            keyed = keyed_frames(obj)
            frames = sorted(f for f in keyed if first <= f <= last)
            if not keyed:
                still, frames = True, [scene.frame_current]
            elif not frames:
                self.report({"ERROR"}, f"csrbf: no control, handle or the mesh {obj.name!r} has a keyframe within frames "
                            f"{first}-{last}: key one (I), widen the scene's range, or bake Every Step")
                return {"CANCELLED"}
        else:
            frames = sorted(set(range(first, last + 1, s.bake_step)) | {last})
        t0 = time.perf_counter()
        was_live, now = s.live, scene.frame_current
        s.live = False  # the handlers pose nothing while baking
        keys = obj.data.shape_keys
        live_key = None if keys is None else keys.key_blocks.get(s.layer)
        poses, peaks, folds, gap = [], [], [], (0.0, None)
        try:
            with _ObjectMode(obj):
                rest = core.rest_positions(obj)
                session = csrbf.Session(csrbf.Mesh(rest, core.triangles(obj)))
                groups = core.Groups(obj)

                def pose(f):
                    scene.frame_set(f)
                    depsgraph = context.evaluated_depsgraph_get()
                    spec = core.resolve_groups(core.control_file(obj, s, depsgraph, groups), obj, groups)
                    report = session.update(spec, remedies="off", self_intersections=False)
                    far = [w for w, k in zip(report.warnings, report.warning_kinds) if k == "starts_far_from_mesh"]
                    if far:
                        raise ValueError(f"frame {f}: {far[0]} (move the start onto the mesh or raise the radius)")
                    return session.vertices.copy(), report

                for f in frames:
                    p, report = pose(f)
                    poses.append(p)
                    peaks.append(1.0 if live_key is None or live_key.mute else float(live_key.value))
                    if report.inside_out_faces:
                        folds.append(f"frame {f}: {report.inside_out_faces}")
                # Between two keyed frames the keys blend linearly: how far
                # that is from the live pose, at the middle frame of each gap.
                if s.bake_frames == "KEYED":
                    for k in range(len(frames) - 1):
                        a, b = frames[k], frames[k + 1]
                        if b - a < 2:
                            continue
                        m = (a + b) // 2
                        u = (m - a) / (b - a)
                        want = poses[k] + (poses[k + 1] - poses[k]) * np.float32(u)
                        dev = float(np.linalg.norm(pose(m)[0] - want, axis=1).max())
                        if dev > gap[0]:
                            gap = (dev, m)
        except (csrbf.Error, ValueError, TypeError) as e:
            scene.frame_set(now)
            s.live = was_live
            self.report({"ERROR"}, f"csrbf: {obj.name}: bake: {e}")
            return {"CANCELLED"}
        if still:
            # The controls do not move: the pose is one shape key, which
            # plays without csrbf (its value, keyed or not, is the phase).
            core.write_shape_key(obj, s.layer, poses[0], value=None)
            scene.frame_set(now)
            self.report({"WARNING"} if folds else {"INFO"},
                        f"csrbf: nothing keyed moves the controls: the pose written into shape key {s.layer!r} "
                        "(its value, keyed or not, is the phase); Live off"
                        + (f"; faces inside out at {folds[0]}" if folds else ""))
            return {"FINISHED"}
        # Whole or not at all: every pose made before the first key is written.
        pattern = re.compile(re.escape(s.layer) + r" f-?\d+")
        keys = obj.data.shape_keys
        if keys is not None:
            for fc in fcurves(keys):
                name = fc.data_path.removeprefix('key_blocks["').removesuffix('"].value')
                if pattern.fullmatch(name):
                    _remove_fcurve(keys, fc)
            for kb in [kb for kb in keys.key_blocks if pattern.fullmatch(kb.name)]:
                obj.shape_key_remove(kb)
        for k, (f, p) in enumerate(zip(frames, poses)):
            key = core.write_shape_key(obj, baked_name(s.layer, f), p, value=0.0)
            marks = [(f, peaks[k])]
            if k > 0:
                marks.append((frames[k - 1], 0.0))
            if k + 1 < len(frames):
                marks.append((frames[k + 1], 0.0))
            for frame, value in marks:
                key.value = value
                key.keyframe_insert("value", frame=frame)
        path = re.compile(r'key_blocks\["' + pattern.pattern + r'"\]\.value')
        for fc in fcurves(obj.data.shape_keys):
            if path.fullmatch(fc.data_path):
                for point in fc.keyframe_points:
                    point.interpolation = "LINEAR"
        live_key = obj.data.shape_keys.key_blocks.get(s.layer)
        if live_key is not None:
            live_key.mute = True
        scene.frame_set(now)
        took = time.perf_counter() - t0
        size = core.diagonal(core.rest_positions(obj)) or 1.0
        msg = (f"csrbf: baked {len(frames)} frame(s) ({frames[0]}-{frames[-1]}) into shape keys "
               f"{baked_name(s.layer, frames[0])!r}... in {took:.2f} s; Live off"
               + (f", the key {s.layer!r} muted" if live_key is not None else ""))
        if gap[1] is not None:
            msg += (f"; between keyed frames the keys blend linearly: at frame {gap[1]} they are {gap[0]:.4g} "
                    f"({100 * gap[0] / size:.2g} % of the size) from the live pose (bake Every Step for an exact one)")
        if folds:
            self.report({"WARNING"}, msg + f"; faces inside out at {', '.join(folds[:5])}")
        else:
            self.report({"INFO"}, msg)
        return {"FINISHED"}


def _remove_fcurve(keys, fc) -> None:
    """Removes a shape key's value F-curve (a baked key's, before baking again)."""
    ad = keys.animation_data
    if hasattr(ad.action, "fcurves"):
        ad.action.fcurves.remove(fc)
        return
    from bpy_extras import anim_utils

    anim_utils.action_get_channelbag_for_slot(ad.action, ad.action_slot).fcurves.remove(fc)


CLASSES = (
    CSRBF_OT_add_control,
    CSRBF_OT_add_handle,
    CSRBF_OT_handle_anchor,
    CSRBF_OT_handle_rest,
    CSRBF_OT_mirror,
    CSRBF_OT_deform,
    CSRBF_OT_deform_from_file,
    CSRBF_OT_export_controls,
    CSRBF_OT_bake,
)
