"""The Blender extension, headless (the bpy module): register it, build a
mesh, deform it from a control file and from empties, export the empties,
pose live, and refuse bad input without changing anything."""

from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path

import bpy
import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "blender"))
import csrbf  # noqa: E402
import csrbf_blender  # noqa: E402
from csrbf_blender import core, live  # noqa: E402

HEAD = ROOT / "assets" / "models" / "cgal_head.off"
SMILE = ROOT / "assets" / "controls" / "head_smile.json"


@pytest.fixture(autouse=True)
def fresh():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    csrbf_blender.register()
    yield
    csrbf_blender.unregister()


def mesh_object(mesh: csrbf.Mesh, name="head"):
    me = bpy.data.meshes.new(name)
    me.from_pydata(mesh.vertices.tolist(), [], [list(map(int, f)) for f in mesh.faces])
    me.update()
    obj = bpy.data.objects.new(name, me)
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.view_layer.objects.active = obj
    obj.select_set(True)
    return obj


def sphere():
    bpy.ops.mesh.primitive_uv_sphere_add(segments=48, ring_count=24, radius=1.0)
    return bpy.context.active_object


def state(obj):
    """Everything a refused operator must leave as it was."""
    keys = obj.data.shape_keys
    names = [] if keys is None else [k.name for k in keys.key_blocks]
    return names, core.rest_positions(obj).copy(), [core.shape_key_positions(obj, n) for n in names]


def same_state(a, b):
    return a[0] == b[0] and np.array_equal(a[1], b[1]) and all(np.array_equal(x, y) for x, y in zip(a[2], b[2]))


def test_deform_from_file_equals_deform_mesh():
    head = csrbf.read_mesh(HEAD)
    obj = mesh_object(head)
    assert bpy.ops.csrbf.deform_from_file(filepath=str(SMILE)) == {"FINISHED"}
    key = obj.data.shape_keys.key_blocks
    assert key[0].name == "Basis" and len(key) == 2 and key[1].value == 1.0
    want, report = csrbf.deform_mesh(csrbf.Mesh(head.vertices, head.triangles), str(SMILE))
    got = core.shape_key_positions(obj, key[1].name)
    assert np.abs(got - want.vertices).max() <= 1e-6 * head.diagonal
    assert obj.csrbf.moved == report.moved > 100
    assert obj.csrbf.inside_out == report.inside_out_faces
    # Run again: the same key is updated, not a new one, and from the rest shape.
    assert bpy.ops.csrbf.deform_from_file(filepath=str(SMILE)) == {"FINISHED"}
    assert len(obj.data.shape_keys.key_blocks) == 2
    assert np.array_equal(core.shape_key_positions(obj, key[1].name), got)


def test_regions_by_vertex_group_name():
    obj = sphere()
    top = [v.index for v in obj.data.vertices if v.co.z > 0.3]
    obj.vertex_groups.new(name="top").add(top, 1.0, "REPLACE")
    spec = {"radius": 0.8, "controls": [{"from": [0, 0, 1], "to": [0, 0, 1.3]}], "region": {"group": "top"},
            "name": "pull"}
    path = Path(bpy.app.tempdir or "/tmp") / "csrbf-top.json"
    path.write_text(json.dumps(spec))
    assert bpy.ops.csrbf.deform_from_file(filepath=str(path)) == {"FINISHED"}
    got = core.shape_key_positions(obj, "pull")
    rest = core.rest_positions(obj)
    moved = np.flatnonzero(np.linalg.norm(got - rest, axis=1) > 0)
    assert len(moved) > 0 and set(moved) <= set(top)
    want, _ = csrbf.deform_mesh(csrbf.Mesh(rest, core.triangles(obj)), {**spec, "region": {"vertices": top}})
    assert np.abs(got - want.vertices).max() <= 1e-6 * core.diagonal(rest)


def test_add_control_move_deform_and_export(tmp_path):
    obj = sphere()
    bpy.context.scene.cursor.location = (0.0, 0.0, 1.5)  # above the north pole
    assert bpy.ops.csrbf.add_control() == {"FINISHED"}
    s = obj.csrbf
    assert s.radius == pytest.approx(0.15 * core.diagonal(core.rest_positions(obj)))
    target = bpy.context.view_layer.objects.active
    assert target.get(core.ROLE) == "target"
    starts, targets = core.controls(obj)
    assert np.allclose(starts, [[0, 0, 1]], atol=1e-4)  # snapped to the surface
    target.location.z += 0.2  # what G does
    bpy.context.view_layer.update()
    bpy.context.view_layer.objects.active = obj
    s.radius = 0.6
    assert bpy.ops.csrbf.deform() == {"FINISHED"}
    got = core.shape_key_positions(obj, s.layer)
    starts, targets = core.controls(obj)
    rest = core.rest_positions(obj)
    want = csrbf.fit(starts, targets, 0.6).deform(rest)
    assert np.abs(got - want).max() <= 1e-6 * core.diagonal(rest)
    north = int(np.argmax(rest[:, 2]))
    assert got[north, 2] == pytest.approx(1.2, abs=1e-4)
    # The exported file is the CLI's: deform_mesh reads it to the same shape.
    out = tmp_path / "controls.json"
    assert bpy.ops.csrbf.export_controls(filepath=str(out)) == {"FINISHED"}
    again, _ = csrbf.deform_mesh(csrbf.Mesh(rest, core.triangles(obj)), str(out))
    assert np.abs(again.vertices - got).max() <= 1e-6 * core.diagonal(rest)
    assert json.loads(out.read_text())["radius"] == pytest.approx(0.6)


def test_live_follows_the_destination():
    obj = sphere()
    bpy.context.scene.cursor.location = (0.0, 0.0, 1.5)
    bpy.ops.csrbf.add_control()
    target = bpy.context.view_layer.objects.active
    obj.csrbf.radius = 0.6
    obj.csrbf.live = True
    rest = core.rest_positions(obj)
    north = int(np.argmax(rest[:, 2]))
    for dz in (0.1, 0.25):
        target.location.z = 1.0 + dz
        bpy.context.view_layer.update()  # runs the depsgraph handler
        got = core.shape_key_positions(obj, obj.csrbf.layer)
        assert got[north, 2] == pytest.approx(1.0 + dz, abs=1e-4)
    assert live.refresh(obj) == "unchanged"
    # What the handler does on each update, step by step (the handler off).
    bpy.app.handlers.depsgraph_update_post.remove(live._on_depsgraph)
    target.location.x = 0.05
    bpy.context.view_layer.update()
    assert live.refresh(obj) == "solved"  # a destination moved: one solve
    obj.csrbf.radius = 0.7
    assert live.refresh(obj) == "rebuilt"  # new settings: a new system


def test_bad_input_is_reported_and_changes_nothing(tmp_path):
    obj = sphere()
    before = state(obj)
    # No control vectors.
    with pytest.raises(RuntimeError, match="no control vectors"):
        bpy.ops.csrbf.deform()
    # A broken control file, a truncated one, one the engine refuses.
    for text, words in [("{\"radius\": 0.5, \"controls\": [", "line 1"),
                        ("{\"radius\": -1, \"controls\": [{\"from\": [0,0,1], \"to\": [0,0,2]}]}", "radius"),
                        ("{\"radius\": 0.5, \"controls\": [{\"from\": [0,0,1], \"to\": [0,0,2]}], \"region\": {\"group\": \"nope\"}}", "nope")]:
        bad = tmp_path / "bad.json"
        bad.write_text(text)
        with pytest.raises(RuntimeError, match=words):
            bpy.ops.csrbf.deform_from_file(filepath=str(bad))
        assert same_state(before, state(obj))
    with pytest.raises(RuntimeError, match="cannot read"):
        bpy.ops.csrbf.deform_from_file(filepath=str(tmp_path / "missing.json"))
    # A start far from the mesh.
    far = tmp_path / "far.json"
    far.write_text(json.dumps({"radius": 0.3, "controls": [{"from": [5, 5, 5], "to": [5, 5, 6]}]}))
    with pytest.raises(RuntimeError, match="farther than R"):
        bpy.ops.csrbf.deform_from_file(filepath=str(far))
    assert same_state(before, state(obj))
    # A radius <= 0 from the panel.
    bpy.context.scene.cursor.location = (0.0, 0.0, 1.5)
    bpy.ops.csrbf.add_control()
    bpy.context.view_layer.objects.active = obj
    before = state(obj)
    obj.csrbf.radius = 0.0
    with pytest.raises(RuntimeError, match="radius must be > 0"):
        bpy.ops.csrbf.deform()
    assert same_state(before, state(obj))
    # A non-mesh active object.
    empty = bpy.data.objects.new("lamp", None)
    bpy.context.scene.collection.objects.link(empty)
    bpy.context.view_layer.objects.active = empty
    for op in (bpy.ops.csrbf.deform, bpy.ops.csrbf.add_control):
        with pytest.raises(RuntimeError, match="must be a mesh"):
            op()
    assert same_state(before, state(obj))
    # A 3D cursor far from the mesh places no start.
    bpy.context.view_layer.objects.active = obj
    starts_before, _ = core.controls(obj)
    bpy.context.scene.cursor.location = (1e4, 1e4, 1e4)
    with pytest.raises(RuntimeError, match="place it on the surface"):
        bpy.ops.csrbf.add_control()
    assert len(core.controls(obj)[0]) == len(starts_before)


def test_a_folding_edit_says_so_in_the_panel():
    obj = sphere()
    bpy.context.scene.cursor.location = (0.0, 0.0, 1.5)
    bpy.ops.csrbf.add_control()
    target = bpy.context.view_layer.objects.active
    target.location.x = 0.5  # a long sideways drag: past the fold-free bound
    bpy.context.view_layer.update()
    bpy.context.view_layer.objects.active = obj
    obj.csrbf.radius = 0.6
    assert bpy.ops.csrbf.deform() == {"FINISHED"}  # a fold is reported, not refused
    assert obj.csrbf.inside_out > 0
    assert 0.0 < obj.csrbf.fold_phase <= 1.0
    assert "inside out" in obj.csrbf.warnings
    # The same edit as a fold-free sweep: nothing inside out, the pole on its
    # destination; live posing keeps it so.
    obj.csrbf.sweep = True
    assert bpy.ops.csrbf.deform() == {"FINISHED"}
    assert obj.csrbf.inside_out == 0 and obj.csrbf.fold_phase < 0
    rest = core.rest_positions(obj)
    north = int(np.argmax(rest[:, 2]))
    got = core.shape_key_positions(obj, obj.csrbf.layer)
    assert np.allclose(got[north], [0.5, 0.0, 1.0], atol=1e-4), got[north]
    obj.csrbf.live = True
    target.location.x = 0.6
    bpy.context.view_layer.update()
    got = core.shape_key_positions(obj, obj.csrbf.layer)
    assert np.allclose(got[north], [0.6, 0.0, 1.0], atol=1e-4), got[north]
    assert obj.csrbf.inside_out == 0


ROAD = sorted((ROOT / "assets" / "controls" / "road").glob("*.json"))


@pytest.mark.parametrize("controls", ROAD, ids=lambda p: p.name)
def test_the_road_files_deform_as_the_package_does(controls):
    """Issue 39: Deform from File gives csrbf.deform_mesh's positions bit for
    bit and its figures for every file of assets/controls/road (the package,
    in turn, gives `csrbf deform`'s: crates/csrbf-py/tests), the remedies'
    advice in the panel when the edit folds."""
    duck = controls.name.startswith("duck")
    model = csrbf.read_mesh(ROOT / "assets" / "models" / ("pybullet_duck.obj" if duck else "cgal_head.off"))
    obj = mesh_object(model, "duck" if duck else "head")
    if duck:  # the file's part, as a vertex group of the whole duck
        obj.vertex_groups.new(name="LOD3sp_LOD3spShape").add(list(range(len(model))), 1.0, "REPLACE")
    rest = core.rest_positions(obj)
    spec = core.resolve_groups(json.loads(controls.read_text()), obj)
    want, report = csrbf.deform_mesh(csrbf.Mesh(rest, core.triangles(obj)), spec)
    if "starts_far_from_mesh" in report.warning_kinds:
        # Deform refuses a start that reaches no vertex, naming it.
        with pytest.raises(RuntimeError, match="farther than R"):
            bpy.ops.csrbf.deform_from_file(filepath=str(controls))
        assert obj.data.shape_keys is None
        return
    assert bpy.ops.csrbf.deform_from_file(filepath=str(controls)) == {"FINISHED"}
    key = obj.data.shape_keys.key_blocks[1]
    assert np.array_equal(core.shape_key_positions(obj, key.name), want.vertices)
    assert obj.csrbf.moved == report.moved and obj.csrbf.inside_out == report.inside_out_faces
    for w in report.warnings:
        assert w in obj.csrbf.warnings
    if report.inside_out_faces:
        assert "to keep it from folding" in obj.csrbf.advice, obj.csrbf.advice
