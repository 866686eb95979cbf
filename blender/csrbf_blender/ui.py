"""The sidebar panel (3D view, N, tab csrbf) and the lines from each start to its destination."""

from __future__ import annotations

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
        obj = core.owner_mesh(context.active_object)  # a control's empty active: its mesh
        if obj is None:
            layout.label(text="Select a mesh object", icon="INFO")
            return
        s = obj.csrbf
        layout.label(text=obj.name, icon="MESH_DATA")
        layout.operator("csrbf.add_control", icon="EMPTY_SINGLE_ARROW")
        col = layout.column(align=True)
        col.prop(s, "radius")
        size = core.diagonal(core.rest_positions(obj)) if len(obj.data.vertices) else 0.0
        if size > 0:
            col.label(text=f"R = {100 * s.radius / size:.1f} % of the object's size")
        col.prop(s, "kernel")
        col.prop(s, "polynomial")
        col.prop(s, "sweep")
        col.prop_search(s, "vertex_group", obj, "vertex_groups")
        col.prop(s, "layer")
        layout.label(text="Coordinates: the object's local space")
        row = layout.row(align=True)
        row.operator("csrbf.deform", icon="MOD_MESHDEFORM")
        row.prop(s, "live", toggle=True, icon="PLAY")
        layout.operator("csrbf.deform_from_file", icon="FILE")
        layout.operator("csrbf.export_controls", icon="EXPORT")
        box = layout.box()
        for text, icon in status_lines(obj):
            box.label(text=text, icon=icon)


def status_lines(obj) -> list[tuple[str, str]]:
    """The panel's box as (text, icon) lines: the control vectors, the last
    deformation's figures (never a past Deform's as the live pose's) and the
    warnings."""
    s = obj.csrbf
    lines = [(f"{len(core.controls(obj)[0])} control vector(s)", "NONE")]
    if s.moved >= 0:
        lines.append((f"{s.moved} vertices moved, largest {s.largest_move:.4g}", "NONE"))
        folds = f", folds from phase {s.fold_phase:.2f}" if s.fold_phase >= 0 else ""
        lines.append((f"{s.inside_out} face(s) inside out{folds}", "ERROR" if s.inside_out else "CHECKMARK"))
    elif s.live:
        lines.append(("Live pose: not checked for folds (Deform checks it)", "INFO"))
    lines += [(w, "ERROR") for w in s.warnings.splitlines()[:6]]
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
