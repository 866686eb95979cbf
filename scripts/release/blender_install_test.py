"""Installs a csrbf Blender extension zip into headless Blender as a user does
(Install from Disk: Blender unpacks the zip and installs its wheel) and
deforms a mesh with it. Run by the bpy venv's Python, with HOME set to a
throwaway folder so nothing of the user's Blender is touched:

    HOME=$(mktemp -d) BPY_PYTHON blender_install_test.py ZIP [--profile release|dev]

(with no csrbf installed in that Python: as in Blender itself, the zip's
wheel must be the one imported).

Checks that the extension loaded, that the csrbf it imports is the zip's
wheel (installed under HOME, not a csrbf already in the venv) of the build
profile asked for, and that Add Control Vector and Deform move the sphere's
vertices near the control into a shape key while the far side stays put.
"""

import argparse
import os
import sys

import bpy

parser = argparse.ArgumentParser()
parser.add_argument("zip")
parser.add_argument("--profile", choices=["release", "dev"])
args = parser.parse_args()

home = os.path.realpath(os.environ["HOME"])
try:
    import csrbf as _already

    sys.exit(f"blender install test: a csrbf is already importable ({_already.__file__}): "
             "uninstall it from this Python first, so the zip's own wheel is what gets tested")
except ImportError:
    pass
result = bpy.ops.extensions.package_install_files(filepath=args.zip, repo="user_default", enable_on_install=True)
assert result == {"FINISHED"}, result
assert "bl_ext.user_default.csrbf" in sys.modules, "the extension did not load"

from bl_ext.user_default.csrbf import operators  # noqa: E402

csrbf = operators._engine()
where = os.path.realpath(csrbf.__file__)
assert where.startswith(home), f"the extension imported csrbf from {where}, not the zip's wheel under {home}"
if args.profile:
    assert csrbf.build_profile == args.profile, (csrbf.build_profile, args.profile)

bpy.ops.mesh.primitive_uv_sphere_add(segments=48, ring_count=24)
sphere = bpy.context.active_object
bpy.context.scene.cursor.location = (0.0, 0.0, 1.5)
assert bpy.ops.csrbf.add_control() == {"FINISHED"}
target = bpy.context.active_object
target.location.z += 0.2
bpy.context.view_layer.objects.active = target
assert bpy.ops.csrbf.deform() == {"FINISHED"}
keys = sphere.data.shape_keys.key_blocks
assert len(keys) == 2, [k.name for k in keys]
rest, key = keys[0], keys[1]
moves = [(a.co - b.co).length for a, b in zip(key.data, rest.data)]
top = max(range(len(moves)), key=lambda i: rest.data[i].co.z)
bottom = min(range(len(moves)), key=lambda i: rest.data[i].co.z)
assert abs(moves[top] - 0.2) < 0.02, f"the pole under the control moved {moves[top]}, not 0.2"
assert moves[bottom] == 0.0, f"the far pole moved {moves[bottom]}"
print(f"blender install test: {os.path.basename(args.zip)} installed, csrbf {csrbf.__version__} "
      f"({csrbf.build_profile}) from the zip's wheel; Deform moved {sum(m > 0 for m in moves)} of "
      f"{len(moves)} vertices, the pole by {moves[top]:.3f}")
