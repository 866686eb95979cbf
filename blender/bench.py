"""Figures of the Blender extension (headless; not a test):

- live updates per second on a ~50k-vertex mesh with 20 control vectors
  (the depsgraph handler's own work: read the empties, one solve, the
  kernel sums through the binding, write the shape key);
- `csrbf.deform` on a ~1M-vertex mesh against what a user would otherwise
  script in Blender's Python: a proportional-editing style falloff per
  control in numpy (not an interpolation: starts do not reach their
  destinations) and the same through mathutils.kdtree.

Run: ~/.cache/csrbf/venv-blender/bin/python blender/bench.py

with a release build of csrbf in that venv, as users install it (the tests
put a dev build there, slower; the script says which it times):

    scripts/build-blender-extension.sh
    ~/.cache/csrbf/venv-blender/bin/python -m pip install --force-reinstall \
        --no-deps target/blender-wheel/csrbf-*.whl
"""

import statistics
import sys
import time
from pathlib import Path

import bpy
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import csrbf_blender  # noqa: E402
from csrbf_blender import core, live  # noqa: E402


def sphere(segments, rings):
    bpy.ops.mesh.primitive_uv_sphere_add(segments=segments, ring_count=rings, radius=1.0)
    return bpy.context.active_object


def add_controls(obj, k, rng):
    rest = core.rest_positions(obj)
    idx = rng.choice(len(rest), size=k, replace=False)
    col = bpy.data.collections.new(core.collection_name(obj))
    bpy.context.scene.collection.children.link(col)
    obj.csrbf.collection = col
    targets = []
    for n, i in enumerate(idx):
        pair = []
        for role, p in (("start", rest[i]), ("target", rest[i] * 1.05)):
            e = bpy.data.objects.new(f"{role} {n}", None)
            col.objects.link(e)
            e.parent = obj
            e.location = tuple(float(x) for x in p)
            e[core.ROLE], e[core.PAIR] = role, n
            e.csrbf.owner = obj
            pair.append(e)
        pair[0].csrbf.partner, pair[1].csrbf.partner = pair[1], pair[0]
        targets.append(pair[1])
    bpy.context.view_layer.update()
    return targets


def median_ms(f, runs):
    t = []
    for _ in range(runs):
        t0 = time.perf_counter()
        f()
        t.append((time.perf_counter() - t0) * 1e3)
    return statistics.median(t)


def main():
    import csrbf

    print(f"csrbf {csrbf.__version__} ({csrbf.build_profile} build), Blender {bpy.app.version_string}")
    if csrbf.build_profile != "release":
        print("warning: a dev build of csrbf (the tests'), slower than users' release build: see this "
              "script's docstring for the figures", file=sys.stderr)
    rng = np.random.default_rng(1)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    csrbf_blender.register()
    obj = sphere(256, 196)
    n = len(obj.data.vertices)
    targets = add_controls(obj, 20, rng)
    obj.csrbf.radius = 0.3
    bpy.app.handlers.depsgraph_update_post.remove(live._on_depsgraph)
    assert live.refresh(obj) == "rebuilt"
    step = [0]

    def move():
        step[0] += 1
        targets[step[0] % 20].location.z += 1e-3
        bpy.context.view_layer.update()
        assert live.refresh(obj) == "solved"

    ms = median_ms(move, 40)
    print(f"live: {n} vertices, 20 controls: {ms:.1f} ms a move (median of 40) = {1e3 / ms:.0f} updates/s")
    rebuild = median_ms(lambda: (setattr(obj.csrbf, "radius", obj.csrbf.radius * 1.0001), live.refresh(obj)), 10)
    print(f"live: a new radius (system and binding rebuilt): {rebuild:.1f} ms")

    csrbf_blender.unregister()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    csrbf_blender.register()
    obj = sphere(1024, 980)
    n = len(obj.data.vertices)
    add_controls(obj, 100, rng)
    obj.csrbf.radius = 0.2
    bpy.context.view_layer.objects.active = obj
    ms = median_ms(lambda: bpy.ops.csrbf.deform(), 5)
    print(f"csrbf.deform: {n} vertices, 100 controls: {ms:.0f} ms (median of 5; fit, diagnostics, shape key)")

    starts, dests = core.controls(obj)
    r = 0.2

    def numpy_falloff():
        v = core.rest_positions(obj).astype(np.float64)
        out = v.copy()
        for s, t in zip(starts, dests):
            d = np.linalg.norm(v - s, axis=1) / r
            w = np.clip(1.0 - d, 0.0, None) ** 2
            out += w[:, None] * (t - s)
        core.write_shape_key(obj, "numpy", out)

    ms = median_ms(numpy_falloff, 3)
    print(f"numpy falloff per control (no interpolation): {ms:.0f} ms (median of 3)")

    import mathutils

    def kdtree_falloff():
        v = core.rest_positions(obj)
        tree = mathutils.kdtree.KDTree(len(v))
        for i, p in enumerate(v):
            tree.insert(p, i)
        tree.balance()
        out = v.astype(np.float64)
        for s, t in zip(starts, dests):
            for _co, i, dist in tree.find_range(s, r):
                out[i] += (1.0 - dist / r) ** 2 * (t - s)
        core.write_shape_key(obj, "kdtree", out)

    ms = median_ms(kdtree_falloff, 1)
    print(f"mathutils.kdtree falloff (no interpolation): {ms:.0f} ms (one run)")


if __name__ == "__main__":
    main()
