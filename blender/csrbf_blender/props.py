"""The settings of an object's csrbf deformation: a PropertyGroup on the object."""

from __future__ import annotations

import bpy
from bpy.props import (
    BoolProperty,
    EnumProperty,
    FloatProperty,
    FloatVectorProperty,
    IntProperty,
    PointerProperty,
    StringProperty,
)

KERNELS = [
    ("c0", "C0", "(1-r)^2: continuous, the most local; fold-free for moves up to 0.5 R"),
    ("c2", "C2", "(1-r)^4(4r+1): smooth (the papers'); fold-free up to 0.474 R"),
    ("c4", "C4", "(1-r)^6(35r^2+18r+3): smoother; fold-free up to 0.400 R"),
    ("c6", "C6", "(1-r)^8(32r^3+25r^2+8r+1): smoothest; fold-free up to 0.355 R"),
]
POLYNOMIALS = [
    ("none", "None", "Purely local: nothing farther than R from every start moves"),
    ("linear", "Linear", "Adds an affine part (the papers'): reproduces rotations and scalings, moves the whole model"),
]

REGIONS = [
    ("ALL", "Whole Mesh", "Every vertex may move"),
    ("GROUP", "Vertex Group", "Only the vertices of a vertex group move; with Use Weights each takes its weight's share of the deformation (1 fully, 0.5 half, 0 not at all): a painted falloff"),
    ("SPHERE", "Sphere", "Only the vertices inside a sphere move (Falloff blends its edge)"),
    ("BOX", "Box", "Only the vertices inside a box move (Falloff blends its edge)"),
    ("SURFACE", "Along the Surface", "Only the vertices within a distance of the handle (or the moving starts) measured along the surface move, so an arm's edit does not reach the body beside it"),
]
SURFACE_FROM = [
    ("HANDLE", "Handle", "Measured from the handle's vertices"),
    ("STARTS", "Moving Starts", "Measured from the starts of the control vectors that move"),
]
BAKE_FRAMES = [
    ("KEYED", "Keyed Frames", "A shape key at each frame where a control, a handle or the mesh has a keyframe; between them the keys blend linearly"),
    ("EVERY", "Every Step", "A shape key every Step frames of the scene's range (Step 1: exact at every frame)"),
]


def _live_changed(self, context):
    from . import live

    live.set_enabled(self.id_data, self.live)  # the object these settings are on
    if self.live and context is not None and context.scene is not None:
        # A render poses the mesh from its own thread: Blender's interface
        # must not read the mesh meanwhile (Render > Lock Interface).
        context.scene.render.use_lock_interface = True


class CsrbfSettings(bpy.types.PropertyGroup):
    """csrbf's settings of one mesh object."""

    layer: StringProperty(name="Layer", default="csrbf", description="The shape key the deformation is written to")
    radius: FloatProperty(
        name="Radius",
        default=0.5,
        min=0.0,
        soft_min=1e-4,
        precision=4,
        subtype="DISTANCE",
        description="Radius of support R in the object's local units: how far a control vector reaches",
    )
    kernel: EnumProperty(name="Kernel", items=KERNELS, default="c2")
    polynomial: EnumProperty(name="Polynomial", items=POLYNOMIALS, default="none")
    sweep: BoolProperty(
        name="Fold-free sweep",
        default=False,
        description="Take the deformation as a chain of small steps along each control's path, each certified not to fold: no face turns inside out (slower: several fits per move)",
    )
    region: EnumProperty(name="Region", items=REGIONS, default="ALL", description="Which vertices the deformation may move")
    vertex_group: StringProperty(
        name="Group", default="", description="Only the vertices of this vertex group move"
    )
    use_weights: BoolProperty(
        name="Use Weights",
        default=True,
        description="Each vertex of the group takes its weight's share of the deformation (1 fully, 0.5 half, 0 stays): paint the falloff. Off: every vertex of the group moves fully",
    )
    sphere_center: FloatVectorProperty(name="Centre", size=3, subtype="TRANSLATION", description="The sphere's centre (local space)")
    sphere_radius: FloatProperty(name="Radius", default=1.0, min=0.0, subtype="DISTANCE", description="The sphere's radius (local units)")
    box_min: FloatVectorProperty(name="Min", size=3, default=(-1.0, -1.0, -1.0), subtype="TRANSLATION", description="The box's lowest corner (local space)")
    box_max: FloatVectorProperty(name="Max", size=3, default=(1.0, 1.0, 1.0), subtype="TRANSLATION", description="The box's highest corner (local space)")
    falloff: FloatProperty(
        name="Falloff", default=0.0, min=0.0, subtype="DISTANCE",
        description="Width of the sphere's or box's edge over which the deformation fades out (0: a sharp edge)",
    )
    surface_distance: FloatProperty(
        name="Distance", default=0.5, min=0.0, subtype="DISTANCE",
        description="How far along the surface the deformation reaches (local units)",
    )
    surface_from: EnumProperty(name="From", items=SURFACE_FROM, default="HANDLE")
    bake_frames: EnumProperty(name="Frames", items=BAKE_FRAMES, default="KEYED")
    bake_step: IntProperty(name="Step", default=1, min=1, description="Frames between baked shape keys")
    live: BoolProperty(
        name="Live",
        default=False,
        update=_live_changed,
        description="Keep the shape key posed from the controls: while a destination or a handle moves (one solve per move), on every frame change, in playback and in renders (keyframed or driven controls animate)",
    )
    initialised: BoolProperty(default=False, options={"HIDDEN"})  # R set by the first Add Control Vector
    collection: PointerProperty(
        type=bpy.types.Collection, options={"HIDDEN"}, description="On a mesh: the collection its control empties are made in"
    )
    # On a control empty (role and pair number are its custom properties).
    owner: PointerProperty(type=bpy.types.Object, options={"HIDDEN"}, description="The mesh this control empty belongs to")
    partner: PointerProperty(
        type=bpy.types.Object, options={"HIDDEN"}, description="The other empty of this control vector (start or destination)"
    )
    next_pair: IntProperty(default=0, options={"HIDDEN"})
    # On a handle's empty: its vertices, its anchor, and its rest transform
    # (local to the mesh): the handle's motion is the empty's transform
    # against it.
    handle_group: StringProperty(name="Vertices", default="", description="The vertex group the handle moves as one")
    anchor_group: StringProperty(
        name="Anchor", default="", description="A vertex group held still while the handle moves (empty: none)"
    )
    rest: FloatVectorProperty(size=16, options={"HIDDEN"}, description="The handle's rest transform in the mesh's local space")
    # The last deformation's diagnostics, for the panel (moved -1: none, or
    # Live has posed the mesh since Deform).
    moved: IntProperty(default=-1, options={"HIDDEN"})
    inside_out: IntProperty(default=0, options={"HIDDEN"})
    fold_phase: FloatProperty(default=-1.0, options={"HIDDEN"})
    largest_move: FloatProperty(default=0.0, options={"HIDDEN"})
    largest_stretch: FloatProperty(default=0.0, options={"HIDDEN"})
    stretched: IntProperty(default=0, options={"HIDDEN"})
    intersections: IntProperty(default=-1, options={"HIDDEN"})  # -1: not looked for
    warnings: StringProperty(default="", options={"HIDDEN"})
    advice: StringProperty(default="", options={"HIDDEN"})  # the remedies, when the edit folds


CLASSES = (CsrbfSettings,)


def register():
    for c in CLASSES:
        bpy.utils.register_class(c)
    bpy.types.Object.csrbf = bpy.props.PointerProperty(type=CsrbfSettings)


def unregister():
    del bpy.types.Object.csrbf
    for c in reversed(CLASSES):
        bpy.utils.unregister_class(c)
