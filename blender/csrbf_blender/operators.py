"""The operators: add a control vector, deform into a shape key (from the
empties or from a control file), export the empties as a control file."""

from __future__ import annotations

import json
import os
import tempfile

import bpy
from bpy.props import StringProperty
from bpy_extras.io_utils import ExportHelper, ImportHelper

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
    settings.moved = report.moved
    settings.inside_out = report.inside_out_faces
    settings.fold_phase = -1.0 if report.fold_phase is None else report.fold_phase
    settings.largest_move = report.largest_move
    # The remedies' advice ("a radius 2.28x as large folds no face, or a
    # sweep cannot fold"), as `csrbf deform` prints it, when the edit folds.
    warnings = list(problems) + report.warnings + ([report.advice] if report.advice else [])
    settings.warnings = "\n".join(warnings)
    level = {"WARNING"} if warnings else {"INFO"}
    op.report(level, f"csrbf: {report.moved} of {len(rest)} vertices moved into shape key {name!r}"
              + (f"; {len(warnings)} warning(s): {warnings[0]}" if warnings else ""))
    return True


class CSRBF_OT_add_control(bpy.types.Operator):
    """Add a control vector: a start on the surface under the 3D cursor (or at each selected vertex in Edit Mode) and a destination to move with G/R"""

    bl_idname = "csrbf.add_control"
    bl_label = "Add Control Vector"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        obj = _mesh_object(self, context)
        if obj is None:
            return {"CANCELLED"}
        if obj.mode == "EDIT":
            obj.update_from_editmode()
            points = [v.co.copy() for v in obj.data.vertices if v.select]
            if not points:
                self.report({"ERROR"}, "csrbf: select a vertex to start a control vector at")
                return {"CANCELLED"}
            bpy.ops.object.mode_set(mode="OBJECT")
        else:
            if len(obj.data.polygons) == 0:
                self.report({"ERROR"}, f"csrbf: {obj.name!r} has no faces to place a start on")
                return {"CANCELLED"}
            cursor = obj.matrix_world.inverted() @ context.scene.cursor.location
            hit, location, _normal, _face = obj.closest_point_on_mesh(cursor)
            size = core.diagonal(core.rest_positions(obj))
            if not hit or (location - cursor).length > size:
                self.report({"ERROR"}, f"csrbf: the 3D cursor is farther from {obj.name!r} than the object's size: place it on the surface first")
                return {"CANCELLED"}
            points = [location]
        settings = obj.csrbf
        size = core.diagonal(core.rest_positions(obj)) or 1.0
        if not settings.initialised and not settings.is_property_set("radius"):
            settings.radius = 0.15 * size  # the user's own R is kept
        settings.initialised = True
        col = settings.collection or bpy.data.collections.get(core.collection_name(obj))
        if col is None:
            col = bpy.data.collections.new(core.collection_name(obj))
            context.scene.collection.children.link(col)
        settings.collection = col
        target = None
        for p in points:
            k = settings.next_pair
            settings.next_pair += 1
            start = _empty(col, obj, f"{obj.name} start {k}", "SPHERE", 0.01 * size, p, "start", k)
            target = _empty(col, obj, f"{obj.name} to {k}", "PLAIN_AXES", 0.03 * size, p, "target", k)
            start.csrbf.partner, target.csrbf.partner = target, start
            start.hide_select = False
        for o in context.view_layer.objects:
            o.select_set(False)
        if target is not None and target.name in context.view_layer.objects:
            target.select_set(True)
            context.view_layer.objects.active = target
        self.report({"INFO"}, f"csrbf: {len(points)} control vector(s) added; move the destination (G) and Deform")
        return {"FINISHED"}


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


class CSRBF_OT_deform(bpy.types.Operator):
    """Fit the object's control vectors and write the deformation into its shape key (value 1)"""

    bl_idname = "csrbf.deform"
    bl_label = "Deform"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        obj = _mesh_object(self, context)
        if obj is None:
            return {"CANCELLED"}
        controls = core.control_pairs(obj)
        if len(controls.starts) == 0:
            left = f" ({'; '.join(controls.problems)})" if controls.problems else ""
            self.report({"ERROR"}, f"csrbf: {obj.name!r} has no control vectors: add one first{left}")
            return {"CANCELLED"}
        settings = obj.csrbf
        if not settings.radius > 0.0:
            self.report({"ERROR"}, f"csrbf: the radius must be > 0, got {settings.radius}")
            return {"CANCELLED"}
        if settings.vertex_group and obj.vertex_groups.get(settings.vertex_group) is None:
            self.report({"ERROR"}, f"csrbf: {obj.name!r} has no vertex group {settings.vertex_group!r}")
            return {"CANCELLED"}
        csrbf = _engine()
        try:
            spec = core.control_file(obj, settings)
        except (csrbf.Error, ValueError, TypeError) as e:
            self.report({"ERROR"}, f"csrbf: {obj.name}: {e}")
            return {"CANCELLED"}
        with _ObjectMode(obj):
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
    """Write the object's control vectors (local coordinates) as a control file the csrbf CLI and csrbf-studio open"""

    bl_idname = "csrbf.export_controls"
    bl_label = "Export Control File"
    filename_ext = ".json"
    filter_glob: StringProperty(default="*.json", options={"HIDDEN"})

    def execute(self, context):
        obj = _mesh_object(self, context)
        if obj is None:
            return {"CANCELLED"}
        csrbf = _engine()
        try:
            spec = core.control_file(obj, obj.csrbf)
        except (csrbf.Error, ValueError, TypeError) as e:
            self.report({"ERROR"}, f"csrbf: {obj.name}: {e}")
            return {"CANCELLED"}
        if not spec["controls"]:
            self.report({"ERROR"}, f"csrbf: {obj.name!r} has no control vectors to export")
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
        self.report(level, f"csrbf: wrote {len(spec['controls'])} control vector(s) to {path}"
                    + (f"; {len(problems)} empty(ies) left out: {problems[0]}" if problems else ""))
        return {"FINISHED"}


CLASSES = (CSRBF_OT_add_control, CSRBF_OT_deform, CSRBF_OT_deform_from_file, CSRBF_OT_export_controls)
