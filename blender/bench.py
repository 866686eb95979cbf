"""Figures of the Blender extension (headless; not a test):

- live updates per second on a ~50k-vertex mesh with 20 control vectors
  (the depsgraph handler's own work: read the empties, one solve, the
  kernel sums through the binding, write the shape key);
- a frame change of playback on that mesh with 20 keyframed controls, a
  keyframed handle and a region (along the surface from the handle; a
  painted, weighted vertex group): `scene.frame_set`, Blender's evaluation
  and Live's pose together, against the 41.7 ms of a 24 fps frame; and
  Bake to Shape Keys of 100 frames;
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


def add_controls(obj, k, rng, among=None):
    rest = core.rest_positions(obj)
    idx = rng.choice(len(rest) if among is None else among, size=k, replace=False)
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


def animated(rng):
    """Playback's frame changes and a bake, with keyframed controls, a
    keyframed handle and each region kind an animator paints or grows."""
    from csrbf_blender import operators

    for region in ("SURFACE", "GROUP"):
        bpy.ops.wm.read_factory_settings(use_empty=True)
        csrbf_blender.register()
        obj = sphere(256, 196)
        n = len(obj.data.vertices)
        rest = core.rest_positions(obj)
        # The controls where the region lets them act: between the handle
        # and the equator.
        targets = add_controls(obj, 20, rng, among=np.flatnonzero((rest[:, 2] > 0.1) & (rest[:, 2] < 0.7)))
        for t in targets:
            home = t.location.copy()
            for f in (1, 25, 50, 75, 100):
                t.location = home * (1.0 + 0.05 * rng.random())
                t.keyframe_insert("location", frame=f)
        cap = rest[:, 2] > 0.8
        group = obj.vertex_groups.new(name="cap")
        group.add(np.flatnonzero(cap).tolist(), 1.0, "REPLACE")
        col = obj.csrbf.collection
        h = operators._empty(col, obj, "handle", "ARROWS", 0.1, (0.0, 0.0, 0.8), "handle", 99)
        h.rotation_mode = "AXIS_ANGLE"
        h.csrbf.handle_group = "cap"
        bpy.context.view_layer.update()
        core.set_rest(h, obj)
        for f, deg in ((1, 0.0), (50, 30.0), (100, 10.0)):
            h.rotation_axis_angle = (np.radians(deg), 1.0, 0.0, 0.0)
            h.keyframe_insert("rotation_axis_angle", frame=f)
        s = obj.csrbf
        s.radius = 0.3
        if region == "SURFACE":
            s.region, s.surface_distance, s.surface_from = "SURFACE", 1.2, "HANDLE"
            what = "along the surface (1.2) from the handle"
        else:
            paint = obj.vertex_groups.new(name="paint")
            w = np.clip(rest[:, 2] + 0.5, 0.0, 1.0)  # a painted falloff over half the sphere
            for i in np.flatnonzero(w > 0):
                paint.add([int(i)], float(w[i]), "REPLACE")
            s.region, s.vertex_group = "GROUP", "paint"
            what = f"a weighted vertex group ({int((w > 0).sum())} vertices)"
        scene = bpy.context.scene
        scene.frame_start, scene.frame_end = 1, 100
        scene.frame_set(1)
        bpy.context.view_layer.objects.active = obj
        s.live = True
        assert not s.warnings.startswith("live:"), s.warnings
        frame = [1]

        def step():
            frame[0] = frame[0] % 100 + 1
            scene.frame_set(frame[0])

        ms = median_ms(step, 60)
        assert not s.warnings.startswith("live:"), s.warnings
        s.live = False
        scene.frame_set(1)
        t0 = time.perf_counter()
        s.bake_frames, s.bake_step = "EVERY", 1
        assert bpy.ops.csrbf.bake() == {"FINISHED"}
        bake = time.perf_counter() - t0
        print(f"playback: {n} vertices, 20 keyed controls, a keyed handle on {int(cap.sum())} vertices, region "
              f"{what}: {ms:.1f} ms a frame change (median of 60; 41.7 ms is 24 fps); bake of 100 frames {bake:.2f} s")
        csrbf_blender.unregister()


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
    animated(rng)  # registers and unregisters on its own
    csrbf_blender.register()

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
