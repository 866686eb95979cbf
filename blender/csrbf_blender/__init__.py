"""csrbf in Blender: pose and animate meshes with control vectors.

A control vector is a pair of empties on a mesh object (a start on the
surface and a destination you move with G/R). Deform fits them with csrbf
(compactly supported radial basis functions: every start goes exactly to
its destination, nothing farther than the radius moves) and writes the
result into a shape key, which Blender animates, mixes and exports (glTF
morph targets) as it does any shape key: a key at value t is exactly the
deformation at phase t. Live keeps the key updated while a destination moves.
"""

from . import live, operators, props, ui


def register():
    import bpy

    props.register()
    for c in operators.CLASSES:
        bpy.utils.register_class(c)
    ui.register()
    live.register()


def unregister():
    import bpy

    live.unregister()
    ui.unregister()
    for c in reversed(operators.CLASSES):
        bpy.utils.unregister_class(c)
    props.unregister()
