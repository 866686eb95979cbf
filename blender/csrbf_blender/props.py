"""The settings of an object's csrbf deformation: a PropertyGroup on the object."""

from __future__ import annotations

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, PointerProperty, StringProperty

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


def _live_changed(self, context):
    from . import live

    live.set_enabled(self.id_data, self.live)  # the object these settings are on


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
    vertex_group: StringProperty(
        name="Region", default="", description="Only the vertices of this vertex group move (empty: every vertex)"
    )
    live: BoolProperty(
        name="Live",
        default=False,
        update=_live_changed,
        description="Keep the shape key updated while a destination moves (one solve per move)",
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
    # The last deformation's diagnostics, for the panel (moved -1: none, or
    # Live has posed the mesh since Deform).
    moved: IntProperty(default=-1, options={"HIDDEN"})
    inside_out: IntProperty(default=0, options={"HIDDEN"})
    fold_phase: FloatProperty(default=-1.0, options={"HIDDEN"})
    largest_move: FloatProperty(default=0.0, options={"HIDDEN"})
    warnings: StringProperty(default="", options={"HIDDEN"})


CLASSES = (CsrbfSettings,)


def register():
    for c in CLASSES:
        bpy.utils.register_class(c)
    bpy.types.Object.csrbf = bpy.props.PointerProperty(type=CsrbfSettings)


def unregister():
    del bpy.types.Object.csrbf
    for c in reversed(CLASSES):
        bpy.utils.unregister_class(c)
