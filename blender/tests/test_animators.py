"""Issue 41: csrbf as an animator uses it in Blender (headless, the bpy
module): Live follows keyframed controls through frame changes and renders,
Bake to Shape Keys plays without the extension, handles and anchors and
every region kind made in the panel equal their control files, a weighted
group is a painted falloff, Mirror lands on the surface, Add keeps Edit
Mode, and bad input changes nothing."""

from __future__ import annotations

import json
import math
import subprocess
from pathlib import Path

import bpy
import csrbf
import numpy as np
import pytest
from test_blender import HEAD, ROOT, fresh, mesh_object  # noqa: F401 (fresh: the autouse fixture)
from test_exports import csrbf_bin

import csrbf_blender  # noqa: E402 (test_blender puts blender/ on the path)
from csrbf_blender import core, operators  # noqa: E402

SUZANNE = ROOT / "assets" / "models" / "assimp_Suzanne_248.obj"


def tube():
    """An arm: a cylinder along X from -1 to 1 (radius 0.25), many rings."""
    bpy.ops.mesh.primitive_cylinder_add(vertices=24, radius=0.25, depth=2.0, location=(0.0, 0.0, 0.0), rotation=(0.0, math.pi / 2, 0.0))
    obj = bpy.context.active_object
    bpy.ops.object.transform_apply(rotation=True)
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.mesh.subdivide(number_cuts=20)
    bpy.ops.object.mode_set(mode="OBJECT")
    return obj


def select_vertices(obj, mask) -> None:
    """Edit Mode with exactly the vertices of `mask` selected."""
    import bmesh

    bpy.context.view_layer.objects.active = obj
    if obj.mode != "EDIT":
        bpy.ops.object.mode_set(mode="EDIT")
    bm = bmesh.from_edit_mesh(obj.data)
    bm.verts.ensure_lookup_table()
    for f in bm.faces:
        f.select = False
    for e in bm.edges:
        e.select = False
    for v, on in zip(bm.verts, mask):
        v.select = bool(on)
    bm.select_flush_mode()
    bmesh.update_edit_mesh(obj.data)


def add_pair(obj, start, target):
    col = operators._controls_collection(bpy.context, obj)
    size = core.diagonal(core.rest_positions(obj))
    return operators._pair(col, obj, tuple(start), tuple(target), size)


def posed(obj, depsgraph=None):
    """The mesh as Blender evaluates it (every shape key mixed)."""
    depsgraph = depsgraph or bpy.context.evaluated_depsgraph_get()
    me = obj.evaluated_get(depsgraph).data
    co = np.empty(len(me.vertices) * 3, dtype=np.float32)
    me.vertices.foreach_get("co", co)
    return co.reshape(-1, 3)


def cli_deform(obj, controls: Path, tmp: Path) -> np.ndarray:
    """`csrbf deform` of the control file on the object's rest mesh."""
    mesh = tmp / "rest.ply"
    csrbf.write_mesh(csrbf.Mesh(core.rest_positions(obj), core.triangles(obj)), mesh, force=True)
    out = tmp / "out.ply"
    r = subprocess.run([str(csrbf_bin()), "deform", "-q", "--mesh", str(mesh), "--controls", str(controls),
                        "--out", str(out), "--force"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return csrbf.read_mesh(out).vertices


def keyed_head():
    """The head with two control vectors whose destinations are keyed at
    frames 1, 10 and 20 (Live on)."""
    head = csrbf.read_mesh(HEAD)
    obj = mesh_object(head)
    rest = core.rest_positions(obj)
    size = core.diagonal(rest)
    tip, chin = int(np.argmax(rest[:, 1])), int(np.argmin(rest[:, 2]))
    moves = []
    for i, way in ((tip, (0.0, 1.0, 0.2)), (chin, (0.2, 0.0, -1.0))):
        _s, t = add_pair(obj, rest[i], rest[i])
        for f, amount in ((1, 0.0), (10, 0.04), (20, 0.02)):
            t.location = tuple(rest[i] + amount * size * np.asarray(way))
            t.keyframe_insert("location", frame=f)
        moves.append(t)
    obj.csrbf.radius = 0.2 * size
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 20
    bpy.context.view_layer.objects.active = obj
    obj.csrbf.live = True
    return obj, size


def test_live_follows_keyframes_on_every_frame_change(tmp_path):
    obj, size = keyed_head()
    scene = bpy.context.scene
    seen = []
    for f in (1, 10, 20, 5):
        scene.frame_set(f)
        got = posed(obj)
        controls = tmp_path / f"frame{f}.json"
        bpy.context.view_layer.objects.active = obj
        assert bpy.ops.csrbf.export_controls(filepath=str(controls)) == {"FINISHED"}
        want = cli_deform(obj, controls, tmp_path)
        assert np.abs(got - want).max() <= 1e-6 * size, f
        seen.append(got)
    assert np.abs(seen[0] - core.rest_positions(obj)).max() == 0.0  # frame 1: at rest
    assert np.abs(seen[1] - seen[0]).max() > 0.03 * size  # frame 10: posed
    assert not np.array_equal(seen[3], seen[1])  # frame 5: between the keys, interpolated by Blender


def test_live_follows_keyframes_in_a_render(tmp_path):
    """A render of three frames (Cycles, on the CPU) draws each frame's pose:
    every image equals the render of that frame's pose written into a plain
    shape key with Live off."""
    obj, size = keyed_head()
    scene = bpy.context.scene
    rest = core.rest_positions(obj)
    centre = (rest.max(axis=0) + rest.min(axis=0)) / 2
    cam = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
    scene.collection.objects.link(cam)
    cam.location = tuple(centre + np.array([0.0, 1.2 * size, 0.0]))  # facing the nose (+Y)
    aim = bpy.data.objects.new("aim", None)
    scene.collection.objects.link(aim)
    aim.location = tuple(centre)
    track = cam.constraints.new("TRACK_TO")
    track.target, track.track_axis, track.up_axis = aim, "TRACK_NEGATIVE_Z", "UP_Y"
    scene.camera = cam
    sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
    scene.collection.objects.link(sun)
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 1
    scene.cycles.use_denoising = False
    scene.render.resolution_x, scene.render.resolution_y = 64, 64
    scene.render.image_settings.file_format = "PNG"
    scene.frame_start, scene.frame_end = 1, 3
    # Frames 1-3 of a faster animation: every frame poses differently.
    for e in core.control_empties(obj):
        for fc in operators.fcurves(e):
            for k in fc.keyframe_points:
                k.co[0] = {1: 1, 10: 2, 20: 3}[int(k.co[0])]
                k.handle_left[0], k.handle_right[0] = k.co[0] - 0.3, k.co[0] + 0.3
    scene.render.filepath = str(tmp_path / "live_")
    bpy.ops.render.render(animation=True)
    # The same frames from plain shape keys, Live off.
    obj.csrbf.live = False
    poses = []
    for f in (1, 2, 3):
        scene.frame_set(f)
        c = core.control_pairs(obj)
        poses.append(csrbf.fit(c.starts, c.targets, obj.csrbf.radius).deform(rest) if f > 1 else rest)
    means = []
    for f, pose in zip((1, 2, 3), poses):
        core.write_shape_key(obj, obj.csrbf.layer, pose, value=1.0)
        scene.frame_set(f)
        scene.render.filepath = str(tmp_path / f"still_{f:04d}")
        bpy.ops.render.render(write_still=True)
        live = np.array(bpy.data.images.load(str(tmp_path / f"live_{f:04d}.png")).pixels[:])
        still = np.array(bpy.data.images.load(str(tmp_path / f"still_{f:04d}.png")).pixels[:])
        assert np.array_equal(live, still), f"frame {f}: the render is not of the frame's pose"
        means.append(live.mean())
    assert len(set(means)) == 3, means  # three different pictures: the poses show


def test_bake_plays_without_the_extension():
    obj, size = keyed_head()
    scene = bpy.context.scene
    exact = {}
    for f in (1, 10, 15, 20):
        scene.frame_set(f)
        exact[f] = posed(obj)
    bpy.context.view_layer.objects.active = obj
    assert bpy.ops.csrbf.bake() == {"FINISHED"}
    keys = obj.data.shape_keys.key_blocks
    assert [k.name for k in keys if k.name.startswith("csrbf f")] == ["csrbf f1", "csrbf f10", "csrbf f20"]
    assert keys["csrbf"].mute and not obj.csrbf.live
    csrbf_blender.unregister()  # a file opened where csrbf is not installed
    for f in (1, 10, 20):
        scene.frame_set(f)
        assert np.abs(posed(obj) - exact[f]).max() <= 1e-6 * size, f
    # Between the keyed frames the keys blend linearly (as the bake said).
    scene.frame_set(15)
    blend = exact[10] + 0.5 * (exact[20] - exact[10])
    assert np.abs(posed(obj) - blend).max() <= 1e-6 * size
    csrbf_blender.register()
    # Every step: exact at every frame; a second bake replaces the first.
    obj.csrbf.bake_frames, obj.csrbf.bake_step = "EVERY", 1
    scene.frame_start, scene.frame_end = 10, 20
    assert bpy.ops.csrbf.bake() == {"FINISHED"}
    names = [k.name for k in obj.data.shape_keys.key_blocks if k.name.startswith("csrbf f")]
    assert names == [f"csrbf f{f}" for f in range(10, 21)]
    scene.frame_set(15)
    assert np.abs(posed(obj) - exact[15]).max() <= 1e-6 * size


def arm_with_handle(turn_deg=40.0):
    """The tube, its right end (x > 0.5) a handle about (0.5, 0, 0) turned
    about Z, its left end (x < -0.5) the anchor."""
    obj = tube()
    rest = core.rest_positions(obj)
    bpy.context.scene.cursor.location = (0.5, 0.0, 0.0)
    select_vertices(obj, rest[:, 0] > 0.5)
    assert bpy.ops.csrbf.add_handle(pivot="CURSOR") == {"FINISHED"}
    assert obj.mode == "EDIT"
    (h,) = core.handles(obj)
    select_vertices(obj, rest[:, 0] < -0.5)
    assert bpy.ops.csrbf.handle_anchor(handle=h.name) == {"FINISHED"}
    bpy.ops.object.mode_set(mode="OBJECT")
    h.rotation_axis_angle = (math.radians(turn_deg), 0.0, 0.0, 1.0)
    bpy.context.view_layer.update()
    obj.csrbf.radius = 0.8
    return obj, h, rest


def test_a_handle_made_in_the_panel_equals_the_same_handle_from_a_control_file(tmp_path):
    obj, h, rest = arm_with_handle()
    bpy.context.view_layer.objects.active = obj
    assert bpy.ops.csrbf.deform() == {"FINISHED"}
    got = core.shape_key_positions(obj, obj.csrbf.layer)
    spec = {"radius": 0.8, "handle": {
        "select": {"vertices": np.flatnonzero(rest[:, 0] > 0.5).tolist()},
        "rotate": {"axis": [0, 0, 1], "angle_deg": 40, "pivot": [0.5, 0, 0]}},
        "anchor": {"vertices": np.flatnonzero(rest[:, 0] < -0.5).tolist()}}
    want, _ = csrbf.deform_mesh(csrbf.Mesh(rest, core.triangles(obj)), spec)
    size = core.diagonal(rest)
    assert np.abs(got - want.vertices).max() <= 1e-6 * size
    # The exported file (groups by name) is the same handle.
    out = tmp_path / "arm.json"
    assert bpy.ops.csrbf.export_controls(filepath=str(out)) == {"FINISHED"}
    exported = json.loads(out.read_text())
    assert exported["handle"]["select"] == {"group": h.csrbf.handle_group}
    again, _ = csrbf.deform_mesh(csrbf.Mesh(rest, core.triangles(obj)), core.resolve_groups(exported, obj))
    assert np.abs(again.vertices - got).max() <= 1e-6 * size
    # Keyed, the handle turns with the frames (Live).
    h.rotation_axis_angle = (0.0, 0.0, 0.0, 1.0)
    h.keyframe_insert("rotation_axis_angle", frame=1)
    h.rotation_axis_angle = (math.radians(40), 0.0, 0.0, 1.0)
    h.keyframe_insert("rotation_axis_angle", frame=10)
    obj.csrbf.live = True
    bpy.context.scene.frame_set(10)
    assert np.abs(posed(obj) - want.vertices).max() <= 1e-6 * size
    bpy.context.scene.frame_set(1)
    assert np.abs(posed(obj) - rest).max() <= 1e-6 * size


def test_a_weighted_group_is_the_control_files_falloff():
    obj = tube()
    rest = core.rest_positions(obj)
    w = np.clip((rest[:, 0] + 0.2) / 0.8, 0.0, 1.0)  # 0 left of -0.2, rising to 1 at 0.6
    g = obj.vertex_groups.new(name="paint")
    for i in np.flatnonzero(w > 0):
        g.add([int(i)], float(w[i]), "REPLACE")
    tip = int(np.argmax(rest[:, 0]))
    add_pair(obj, rest[tip], rest[tip] + np.array([0.0, 0.3, 0.0]))
    s = obj.csrbf
    s.radius, s.region, s.vertex_group = 1.5, "GROUP", "paint"
    bpy.context.view_layer.update()
    bpy.context.view_layer.objects.active = obj
    assert bpy.ops.csrbf.deform() == {"FINISHED"}
    got = core.shape_key_positions(obj, s.layer)
    idx = np.flatnonzero(w > 0)
    weights = np.asarray([g.weight(int(i)) for i in idx])
    c = core.control_pairs(obj)
    spec = csrbf.control_file(c.starts, c.targets, 1.5, region={"weights": {"vertices": idx.tolist(), "weights": weights.tolist()}})
    want, _ = csrbf.deform_mesh(csrbf.Mesh(rest, core.triangles(obj)), spec)
    size = core.diagonal(rest)
    assert np.abs(got - want.vertices).max() <= 1e-6 * size
    moved = np.linalg.norm(got - rest, axis=1)
    assert moved[w == 0].max() == 0.0 and moved[tip] == pytest.approx(0.3, abs=1e-5)
    # Use Weights off: every vertex of the group moves fully.
    s.use_weights = False
    assert bpy.ops.csrbf.deform() == {"FINISHED"}
    flat, _ = csrbf.deform_mesh(csrbf.Mesh(rest, core.triangles(obj)), {**spec, "region": {"vertices": idx.tolist()}})
    assert np.abs(core.shape_key_positions(obj, s.layer) - flat.vertices).max() <= 1e-6 * size


@pytest.mark.parametrize("kind", ["SPHERE", "BOX", "SURFACE"])
def test_the_panels_regions_equal_the_control_files(kind):
    obj, h, rest = arm_with_handle(30.0)
    s = obj.csrbf
    s.region = kind
    if kind == "SPHERE":
        s.sphere_center, s.sphere_radius, s.falloff = (0.3, 0.0, 0.0), 0.9, 0.2
        region = {"sphere": {"center": [0.3, 0, 0], "radius": 0.9}, "falloff": 0.2}
    elif kind == "BOX":
        s.box_min, s.box_max, s.falloff = (-0.4, -1, -1), (1.2, 1, 1), 0.1
        region = {"box": {"min": [-0.4, -1, -1], "max": [1.2, 1, 1]}, "falloff": 0.1}
    else:
        s.surface_distance, s.surface_from = 0.9, "HANDLE"
        region = {"connected": {"distance": 0.9, "from": "handle"}}
    bpy.context.view_layer.objects.active = obj
    assert bpy.ops.csrbf.deform() == {"FINISHED"}
    got = core.shape_key_positions(obj, s.layer)
    spec = {"radius": 0.8, "region": region, "handle": {
        "select": {"vertices": np.flatnonzero(rest[:, 0] > 0.5).tolist()},
        "rotate": {"axis": [0, 0, 1], "angle_deg": 30, "pivot": [0.5, 0, 0]}},
        "anchor": {"vertices": np.flatnonzero(rest[:, 0] < -0.5).tolist()}}
    want, _ = csrbf.deform_mesh(csrbf.Mesh(rest, core.triangles(obj)), spec)
    assert np.abs(got - want.vertices).max() <= 1e-6 * core.diagonal(rest)
    assert np.abs(got - rest).max() > 0.05


def test_mirror_lands_every_start_on_the_surface():
    suzanne = csrbf.read_mesh(SUZANNE)
    obj = mesh_object(suzanne, "Suzanne")
    rest = core.rest_positions(obj)
    size = core.diagonal(rest)
    obj.csrbf.radius = 0.2 * size
    plane = csrbf.symmetry_plane(rest)
    right = np.flatnonzero(rest[:, 0] > plane + 0.1 * size)[::40][:5]
    for i in right:
        add_pair(obj, rest[i], rest[i] + np.array([0.02, 0.0, 0.03]) * size)
    on_plane = int(np.argmin(np.abs(rest[:, 0] - plane)))
    s0, _t0 = add_pair(obj, rest[on_plane], rest[on_plane] + 0.01 * size)
    s0.location.x = plane  # exactly on the plane: its own image
    bpy.context.view_layer.update()
    bpy.context.view_layer.objects.active = obj
    before = core.control_pairs(obj)
    assert bpy.ops.csrbf.mirror(axis="X", plane="FOUND") == {"FINISHED"}
    after = core.control_pairs(obj)
    assert len(after.starts) == len(before.starts) + len(right)
    from mathutils import Vector
    from mathutils.bvhtree import BVHTree

    tree = BVHTree.FromPolygons(rest.tolist(), core.triangles(obj).tolist())
    images = [n for n in after.names if n.endswith(".R")]
    assert len(images) == len(right) and all(bpy.data.objects[n[:-2] + ".L"] for n in images)
    for n in images:
        k = after.names.index(n)
        p = after.starts[k]
        assert tree.find_nearest(Vector(p))[3] <= 1e-4 * size, n  # on the surface
        src = after.starts[after.names.index(n[:-2] + ".L")]
        mirrored = np.array([2 * plane - src[0], src[1], src[2]])
        nearest = np.array(tree.find_nearest(Vector(mirrored))[0])
        assert np.linalg.norm(p - nearest) <= 1e-5 * size, n  # the surface's point nearest the image
        # The destination moved as the source's did, mirrored.
        d_src = after.targets[after.names.index(n[:-2] + ".L")] - src
        assert np.allclose(after.targets[k] - p, [-d_src[0], d_src[1], d_src[2]], atol=1e-5 * size)
    # Again: every image is there already; nothing added.
    bpy.ops.object.select_all(action="DESELECT")
    with pytest.raises(RuntimeError, match="nothing to mirror"):
        bpy.ops.csrbf.mirror(axis="X", plane="FOUND")
    assert len(core.control_pairs(obj).starts) == len(after.starts)


def test_mirror_finds_a_tilted_plane():
    """Issue 42 through Blender: a mesh symmetric about a plane turned 14
    and 11 degrees about two axes; Mirror (its plane of any orientation by
    default) puts each image on the surface, at the exact image."""
    suzanne = csrbf.read_mesh(SUZANNE)
    v = suzanne.vertices.astype(np.float64)
    both = np.vstack([v, v * [-1.0, 1.0, 1.0]])
    faces = np.vstack([suzanne.triangles, suzanne.triangles[:, ::-1] + len(v)])
    from mathutils import Matrix

    rot = np.array(Matrix.Rotation(math.radians(14), 3, "Y") @ Matrix.Rotation(math.radians(11), 3, "Z"))
    moved = both @ rot.T + [0.4, -0.3, 0.2]
    obj = mesh_object(csrbf.Mesh(moved.astype(np.float32), faces.astype(np.uint32)), "tilted")
    rest = core.rest_positions(obj)
    size = core.diagonal(rest)
    obj.csrbf.radius = 0.2 * size
    truth = rot @ [1.0, 0.0, 0.0]
    side = np.flatnonzero((rest - [0.4, -0.3, 0.2]) @ truth > 0.3)[::60][:4]
    for i in side:
        add_pair(obj, rest[i], rest[i] + truth * 0.05 * size)
    bpy.context.view_layer.update()
    bpy.context.view_layer.objects.active = obj
    assert bpy.ops.csrbf.mirror() == {"FINISHED"}
    after = core.control_pairs(obj)
    assert len(after.starts) == 2 * len(side)
    for k in range(len(side), 2 * len(side)):
        p = after.starts[k]
        src = after.starts[after.names.index(bpy.utils.flip_name(after.names[k]))]
        exact = src - 2 * ((src - [0.4, -0.3, 0.2]) @ truth) * truth
        assert np.linalg.norm(p - exact) < 2e-3 * size, after.names[k]
        d = after.targets[k] - p
        assert np.allclose(d, -truth * 0.05 * size, atol=1e-3 * size)


def test_add_control_keeps_edit_mode():
    head = csrbf.read_mesh(HEAD)
    obj = mesh_object(head)
    rest = core.rest_positions(obj)
    mask = np.zeros(len(rest), dtype=bool)
    mask[[3, 50]] = True
    select_vertices(obj, mask)
    assert bpy.ops.csrbf.add_control() == {"FINISHED"}
    assert obj.mode == "EDIT" and bpy.context.view_layer.objects.active == obj
    bpy.ops.object.mode_set(mode="OBJECT")
    assert np.allclose(core.control_pairs(obj).starts, rest[[3, 50]])


def state(obj):
    keys = obj.data.shape_keys
    names = [] if keys is None else [k.name for k in keys.key_blocks]
    return (names, [core.shape_key_positions(obj, n) for n in names], [g.name for g in obj.vertex_groups],
            sorted(o.name for o in bpy.data.objects))


def same(a, b):
    return a[0] == b[0] and all(np.array_equal(x, y) for x, y in zip(a[1], b[1])) and a[2:] == b[2:]


def test_bad_handles_and_groups_are_refused_and_change_nothing():
    obj = tube()
    rest = core.rest_positions(obj)
    # A handle with no vertices.
    select_vertices(obj, np.zeros(len(rest), dtype=bool))
    before = state(obj)
    with pytest.raises(RuntimeError, match="select the vertices the handle moves"):
        bpy.ops.csrbf.add_handle()
    # A pivot far outside.
    select_vertices(obj, rest[:, 0] > 0.5)
    bpy.context.scene.cursor.location = (1e4, 0.0, 0.0)
    with pytest.raises(RuntimeError, match="outside"):
        bpy.ops.csrbf.add_handle(pivot="CURSOR")
    bpy.ops.object.mode_set(mode="OBJECT")
    assert same(before, state(obj))
    # Add Handle in Object Mode.
    with pytest.raises(RuntimeError, match="Edit Mode"):
        bpy.ops.csrbf.add_handle()
    obj, h, rest = arm_with_handle()
    bpy.context.view_layer.objects.active = obj
    assert bpy.ops.csrbf.deform() == {"FINISHED"}
    before = state(obj)
    # A group with zero weights as the Region.
    g = obj.vertex_groups.new(name="zero")
    g.add(list(range(10)), 0.0, "REPLACE")
    obj.csrbf.region, obj.csrbf.vertex_group = "GROUP", "zero"
    with pytest.raises(RuntimeError, match="no vertex with a weight above 0"):
        bpy.ops.csrbf.deform()
    obj.csrbf.region = "ALL"
    # The handle's group emptied.
    hg = obj.vertex_groups[h.csrbf.handle_group]
    hg.remove(list(range(len(rest))))
    with pytest.raises(RuntimeError, match="no vertex with a weight above 0"):
        bpy.ops.csrbf.deform()
    hg.add(np.flatnonzero(rest[:, 0] > 0.5).tolist(), 1.0, "REPLACE")
    # Unevenly scaled, mirrored.
    for scale, words in (((1.0, 2.0, 1.0), "scaled unevenly"), ((-1.0, 1.0, 1.0), "mirrored")):
        h.scale = scale
        bpy.context.view_layer.update()
        with pytest.raises(RuntimeError, match=words):
            bpy.ops.csrbf.deform()
    h.scale = (1.0, 1.0, 1.0)
    # A rest moved far outside (Set Rest with the empty far away).
    h.location = (1e4, 0.0, 0.0)
    bpy.context.view_layer.update()
    assert bpy.ops.csrbf.handle_rest(handle=h.name) == {"FINISHED"}
    with pytest.raises(RuntimeError, match="outside"):
        bpy.ops.csrbf.deform()
    # Live shows the refusal and leaves the key as it was.
    obj.csrbf.live = True
    assert "outside" in obj.csrbf.warnings
    g_names = before[2] + ["zero"]
    after = state(obj)
    assert after[0] == before[0] and all(np.array_equal(x, y) for x, y in zip(after[1], before[1]))
    assert after[2] == g_names
    # Bake refuses as Deform does, and changes nothing.
    obj.csrbf.live = False
    with pytest.raises(RuntimeError, match="outside"):
        bpy.ops.csrbf.bake()
    after = state(obj)
    assert after[0] == before[0] and all(np.array_equal(x, y) for x, y in zip(after[1], before[1]))
    # Keys outside the scene's range only.
    h.location = (0.5, 0.0, 0.0)
    bpy.context.view_layer.update()
    bpy.ops.csrbf.handle_rest(handle=h.name)
    h.keyframe_insert("rotation_axis_angle", frame=500)
    with pytest.raises(RuntimeError, match="within frames 1-250"):
        bpy.ops.csrbf.bake()


def test_bake_with_only_the_phase_keyed_keeps_the_layers_key():
    """Static controls and a keyed phase (the key's value): the bake is the
    pose in the layer's own key, its value curve kept, playing without
    csrbf."""
    obj, h, rest = arm_with_handle()
    bpy.context.view_layer.objects.active = obj
    assert bpy.ops.csrbf.deform() == {"FINISHED"}
    key = obj.data.shape_keys.key_blocks[obj.csrbf.layer]
    key.value = 0.0
    key.keyframe_insert("value", frame=1)
    key.value = 1.0
    key.keyframe_insert("value", frame=11)
    full = core.shape_key_positions(obj, obj.csrbf.layer).copy()
    core.write_shape_key(obj, obj.csrbf.layer, rest, value=None)  # a stale key: the bake writes the pose
    assert bpy.ops.csrbf.bake() == {"FINISHED"}
    assert [k.name for k in obj.data.shape_keys.key_blocks] == ["Basis", obj.csrbf.layer]
    assert not key.mute and np.array_equal(core.shape_key_positions(obj, obj.csrbf.layer), full)
    csrbf_blender.unregister()
    bpy.context.scene.frame_set(6)
    assert np.abs(posed(obj) - (rest + 0.5 * (full - rest))).max() <= 1e-6 * core.diagonal(rest)
    csrbf_blender.register()


class FakeLayout:
    """Stands in for a panel's layout (headless Blender draws none): every
    property it is asked to show must exist on its data, every operator
    must be registered; it records what it was given."""

    def __init__(self, log):
        self.log = log
        self.enabled = True

    def _sub(self, *_, **__):
        return FakeLayout(self.log)

    row = column = box = _sub

    def label(self, text="", icon="NONE"):
        self.log.append(("label", text))

    def prop(self, data, name, **_):
        assert name in data.bl_rna.properties, (data, name)
        self.log.append(("prop", name))

    def prop_search(self, data, name, search_data, search_name, **_):
        assert name in data.bl_rna.properties and search_name in search_data.bl_rna.properties, (name, search_name)
        self.log.append(("prop_search", name))

    def operator(self, idname, **_):
        group, name = idname.split(".")
        assert hasattr(getattr(bpy.ops, group), name) and getattr(getattr(bpy.ops, group), name).idname(), idname
        self.log.append(("operator", idname))

        class Props:
            pass

        return Props()


@pytest.mark.parametrize("kind", ["ALL", "GROUP", "SPHERE", "BOX", "SURFACE"])
def test_the_panel_draws_every_region_and_handle(kind):
    from types import SimpleNamespace

    from csrbf_blender import ui

    obj, h, rest = arm_with_handle()
    obj.csrbf.region = kind
    obj.csrbf.bake_frames = "EVERY"
    bpy.context.view_layer.objects.active = h  # a handle's empty active: its mesh's panel
    log = []
    panel = SimpleNamespace(layout=FakeLayout(log), draw_region=ui.CSRBF_PT_panel.draw_region,
                            draw_handle=ui.CSRBF_PT_panel.draw_handle)
    ui.CSRBF_PT_panel.draw(panel, SimpleNamespace(active_object=h, region=SimpleNamespace(width=280)))
    shown = {name for what, name in log if what in ("prop", "prop_search", "operator")}
    assert {"csrbf.add_handle", "csrbf.handle_anchor", "csrbf.handle_rest", "csrbf.mirror", "csrbf.bake",
            "rotation_axis_angle", "handle_group", "anchor_group", "bake_step", "region"} <= shown
    want = {"GROUP": {"vertex_group", "use_weights"}, "SPHERE": {"sphere_center", "sphere_radius", "falloff"},
            "BOX": {"box_min", "box_max", "falloff"}, "SURFACE": {"surface_distance", "surface_from"}}.get(kind, set())
    assert want <= shown
    # Long lines wrap to the panel's width rather than run off its edge.
    obj.csrbf.advice = "to keep it from folding: " + "a radius 2.5x as large folds no face, " * 4
    log.clear()
    ui.CSRBF_PT_panel.draw(panel, SimpleNamespace(active_object=h, region=SimpleNamespace(width=280)))
    labels = [t for what, t in log if what == "label"]
    assert max(len(t) for t in labels) <= 40 and any("to keep it from folding" in t for t in labels)
