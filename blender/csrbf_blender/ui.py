"""The sidebar panel (3D view, N, tab csrbf) and the lines from each start to its destination."""

from __future__ import annotations

import textwrap

import bpy

from . import core


class CSRBF_PT_panel(bpy.types.Panel):
    bl_label = "csrbf"
    bl_idname = "CSRBF_PT_panel"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "csrbf"

    def draw(self, context):
        layout = self.layout
        obj = core.owner_mesh(context.active_object)  # a control's or a handle's empty active: its mesh
        if obj is None:
            layout.label(text="Select a mesh object", icon="INFO")
            return
        s = obj.csrbf
        layout.label(text=obj.name, icon="MESH_DATA")
        row = layout.row(align=True)
        row.operator("csrbf.add_control", icon="EMPTY_SINGLE_ARROW")
        sub = row.row(align=True)
        sub.enabled = obj.mode == "EDIT"  # a handle is the selected vertices
        sub.operator("csrbf.add_handle", icon="BONE_DATA")
        col = layout.column(align=True)
        col.prop(s, "radius")
        size = core.diagonal(core.rest_positions(obj)) if len(obj.data.vertices) else 0.0
        if size > 0:
            col.label(text=f"R = {100 * s.radius / size:.1f} % of the object's size")
        col.prop(s, "kernel")
        col.prop(s, "polynomial")
        col.prop(s, "sweep")
        col.prop(s, "layer")
        self.draw_region(layout, obj)
        for e in core.handles(obj):
            self.draw_handle(layout, obj, e)
        row = layout.row(align=True)
        row.operator("csrbf.mirror", icon="MOD_MIRROR")
        layout.label(text="Coordinates: the object's local space")
        row = layout.row(align=True)
        row.operator("csrbf.deform", icon="MOD_MESHDEFORM")
        row.prop(s, "live", toggle=True, icon="PLAY")
        box = layout.box()
        row = box.row(align=True)
        row.prop(s, "bake_frames", text="")
        if s.bake_frames == "EVERY":
            row.prop(s, "bake_step")
        box.operator("csrbf.bake", icon="REC")
        layout.operator("csrbf.deform_from_file", icon="FILE")
        layout.operator("csrbf.export_controls", icon="EXPORT")
        box = layout.box()
        width = max(20, int((context.region.width if context.region else 300) / 7))
        for text, icon in status_lines(obj):
            for k, part in enumerate(textwrap.wrap(text, width) or [""]):
                box.label(text=part, icon=icon if k == 0 else "BLANK1")

    @staticmethod
    def draw_region(layout, obj):
        s = obj.csrbf
        box = layout.box()
        kind = s.region
        if kind == "ALL" and s.vertex_group and not s.is_property_set("region"):
            kind = "GROUP"
        box.prop(s, "region")
        if kind == "GROUP":
            box.prop_search(s, "vertex_group", obj, "vertex_groups")
            box.prop(s, "use_weights")
        elif kind == "SPHERE":
            box.prop(s, "sphere_center")
            box.prop(s, "sphere_radius")
            box.prop(s, "falloff")
        elif kind == "BOX":
            box.prop(s, "box_min")
            box.prop(s, "box_max")
            box.prop(s, "falloff")
        elif kind == "SURFACE":
            box.prop(s, "surface_distance")
            box.prop(s, "surface_from")

    @staticmethod
    def draw_handle(layout, obj, e):
        box = layout.box()
        row = box.row(align=True)
        row.label(text=e.name, icon="BONE_DATA")
        row.operator("csrbf.handle_rest", text="Set Rest").handle = e.name
        box.prop_search(e.csrbf, "handle_group", obj, "vertex_groups")
        row = box.row(align=True)
        row.prop_search(e.csrbf, "anchor_group", obj, "vertex_groups")
        sub = row.row(align=True)
        sub.enabled = obj.mode == "EDIT"
        sub.operator("csrbf.handle_anchor", text="", icon="PINNED").handle = e.name
        col = box.column(align=True)
        if e.rotation_mode == "AXIS_ANGLE":
            col.prop(e, "rotation_axis_angle", text="Angle, Axis")
        elif e.rotation_mode == "QUATERNION":
            col.prop(e, "rotation_quaternion", text="Turn")
        else:
            col.prop(e, "rotation_euler", text="Turn")
        col.prop(e, "scale", text="Scale")
        col.prop(e, "location", text="Move to")


def status_lines(obj) -> list[tuple[str, str]]:
    """The panel's box as (text, icon) lines: the control vectors and
    handles, the last deformation's figures (never a past Deform's as the
    live pose's), the warnings and the remedies' advice."""
    s = obj.csrbf
    n, h = len(core.controls(obj)[0]), len(core.handles(obj))
    lines = [(f"{n} control vector(s)" + (f", {h} handle(s)" if h else ""), "NONE")]
    if s.moved >= 0:
        lines.append((f"{s.moved} vertices moved, largest {s.largest_move:.4g}", "NONE"))
        folds = f", folds from phase {s.fold_phase:.2f}" if s.fold_phase >= 0 else ""
        lines.append((f"{s.inside_out} face(s) inside out{folds}", "ERROR" if s.inside_out else "CHECKMARK"))
        if s.largest_stretch > 0:
            lines.append((f"largest stretch {s.largest_stretch:.3g}x" + (f", {s.stretched} face(s) past the limit" if s.stretched else ""),
                          "ERROR" if s.stretched else "NONE"))
        if s.intersections > 0:
            lines.append((f"{s.intersections} face pair(s) pass through each other", "ERROR"))
    elif s.live:
        lines.append(("Live pose: not checked for folds (Deform checks it)", "INFO"))
    lines += [(w, "ERROR") for w in s.warnings.splitlines()[:8]]
    if s.advice:
        lines.append((s.advice, "LIGHT"))
    return lines


_draw_handle = None


def _draw_lines():
    import gpu
    from gpu_extras.batch import batch_for_shader
    from mathutils import Vector

    coords = []
    for obj in bpy.context.scene.objects:
        if obj.type != "MESH":
            continue
        if core._collection(obj) is None and not obj.children:
            continue
        c = core.control_pairs(obj)
        m = obj.matrix_world
        for a, b in zip(c.starts, c.targets):
            coords += [tuple(m @ Vector(a)), tuple(m @ Vector(b))]
    if not coords:
        return
    shader = gpu.shader.from_builtin("UNIFORM_COLOR")
    batch = batch_for_shader(shader, "LINES", {"pos": coords})
    shader.uniform_float("color", (1.0, 0.75, 0.1, 1.0))
    gpu.state.line_width_set(2.0)
    batch.draw(shader)


CLASSES = (CSRBF_PT_panel,)


def register():
    global _draw_handle
    for c in CLASSES:
        bpy.utils.register_class(c)
    if not bpy.app.background:  # no viewport to draw in when headless
        _draw_handle = bpy.types.SpaceView3D.draw_handler_add(_draw_lines, (), "WINDOW", "POST_VIEW")


def unregister():
    global _draw_handle
    if _draw_handle is not None:
        bpy.types.SpaceView3D.draw_handler_remove(_draw_handle, "WINDOW")
        _draw_handle = None
    for c in reversed(CLASSES):
        bpy.utils.unregister_class(c)
