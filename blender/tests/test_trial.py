"""Defects a new user's trial of the extension found, one test each (named
by the defect): live through File > Open and New, duplicated and lone
empties, a renamed mesh, Deform in Edit Mode, the panel's figures while
live, a control empty active, and the minor ones (a missing vertex group,
the user's radius, a start far from the mesh while live)."""

from __future__ import annotations

import json

import bpy
import csrbf
import numpy as np
import pytest
from test_blender import fresh, sphere  # noqa: F401 (fresh: the autouse fixture)

from csrbf_blender import core, ui


def add_control(z=1.5):
    """Add Control Vector above the north pole; returns (start, destination)."""
    bpy.context.scene.cursor.location = (0.0, 0.0, z)
    assert bpy.ops.csrbf.add_control() == {"FINISHED"}
    target = bpy.context.view_layer.objects.active
    k = target[core.PAIR]
    return bpy.data.objects[target.name.replace(f" to {k}", f" start {k}")], target


def north_z(obj):
    rest = core.rest_positions(obj)
    return float(core.shape_key_positions(obj, obj.csrbf.layer)[int(np.argmax(rest[:, 2])), 2])


def select_only(*objs):
    for o in bpy.context.view_layer.objects:
        o.select_set(False)
    for o in objs:
        o.select_set(True)
    bpy.context.view_layer.objects.active = objs[-1]


def test_defect1_live_survives_file_new_and_open(tmp_path):
    # File > New after the extension is enabled: Live still follows.
    bpy.ops.wm.read_homefile(use_empty=True)
    obj = sphere()
    _, target = add_control()
    obj.csrbf.radius = 0.6
    obj.csrbf.live = True
    target.location.z = 1.2
    bpy.context.view_layer.update()
    assert north_z(obj) == pytest.approx(1.2, abs=1e-4)
    # Saved with Live on and opened (File > Open): live again, as the toggle shows.
    path = tmp_path / "live.blend"
    names = obj.name, target.name
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    bpy.ops.wm.open_mainfile(filepath=str(path))
    obj, target = (bpy.data.objects[n] for n in names)
    assert obj.csrbf.live
    target.location.z = 1.3
    bpy.context.view_layer.update()
    assert north_z(obj) == pytest.approx(1.3, abs=1e-4)


def test_defect2_duplicated_pairs_are_new_controls_lone_empties_reported(tmp_path):
    obj = sphere()
    start, target = add_control()
    # Shift+D on both empties: a second control vector, the first kept.
    select_only(start, target)
    assert bpy.ops.object.duplicate() == {"FINISHED"}
    copy_start, copy_target = sorted(bpy.context.selected_objects, key=lambda e: e[core.ROLE])
    copy_target.location.x += 0.3
    copy_start.location.x += 0.3
    bpy.context.view_layer.update()
    starts, _ = core.controls(obj)
    assert len(starts) == 2
    bpy.context.view_layer.objects.active = obj
    out = tmp_path / "c.json"
    assert bpy.ops.csrbf.export_controls(filepath=str(out)) == {"FINISHED"}
    assert len(json.loads(out.read_text())["controls"]) == 2
    # A start copied alone: reported by name, the original start kept.
    select_only(start)
    assert bpy.ops.object.duplicate() == {"FINISHED"}
    lone = bpy.context.active_object
    lone.location.x -= 0.3
    bpy.context.view_layer.update()
    bpy.context.view_layer.objects.active = obj
    obj.csrbf.radius = 0.6
    assert bpy.ops.csrbf.deform() == {"FINISHED"}
    assert f"start {lone.name!r} has no destination" in obj.csrbf.warnings
    assert np.allclose(np.sort(core.controls(obj)[0][:, 0]), [0.0, 0.3], atol=1e-4)
    # A start deleted: its destination is named, not silently ignored.
    bpy.data.objects.remove(copy_start)
    assert bpy.ops.csrbf.deform() == {"FINISHED"}
    assert f"destination {copy_target.name!r} has no start" in obj.csrbf.warnings
    assert len(core.controls(obj)[0]) == 1


def test_defect2_orphans_of_one_number_are_not_paired_up():
    obj = sphere()
    start, target = add_control()
    select_only(start, target)
    assert bpy.ops.object.duplicate() == {"FINISHED"}
    copy_start, copy_target = sorted(bpy.context.selected_objects, key=lambda e: e[core.ROLE])
    # The original's start and the copy's destination deleted: what is left
    # shares the pair number, but each lost its own partner.
    bpy.data.objects.remove(start)
    bpy.data.objects.remove(copy_target)
    bpy.context.view_layer.objects.active = obj
    with pytest.raises(RuntimeError, match=f"no control vectors.*start {copy_start.name!r} has no destination"):
        bpy.ops.csrbf.deform()  # (which also brings old files' empties up to date)
    c = core.control_pairs(obj)
    assert len(c.starts) == 0
    assert len(c.problems) == 2 and any(repr(copy_start.name) in p for p in c.problems)


def test_defect3_renaming_the_mesh_keeps_its_controls():
    obj = sphere()
    _, target = add_control()
    obj.csrbf.radius = 0.6
    target.location.z = 1.2
    old = obj.name
    obj.name = "Ball"
    bpy.context.view_layer.update()
    bpy.context.view_layer.objects.active = obj
    assert bpy.ops.csrbf.deform() == {"FINISHED"}
    assert north_z(obj) == pytest.approx(1.2, abs=1e-4)
    # The collection and the empties follow the new name.
    assert obj.csrbf.collection.name == "csrbf Ball"
    assert bpy.data.collections.get(f"csrbf {old}") is None
    assert sorted(e.name for e in core.control_empties(obj)) == ["Ball start 0", "Ball to 0"]
    obj.csrbf.live = True
    target.location.z = 1.3
    bpy.context.view_layer.update()
    assert north_z(obj) == pytest.approx(1.3, abs=1e-4)


def test_defect3_files_naming_the_owner_by_string_are_migrated(tmp_path):
    # The empties as earlier versions saved them: the owner by name, no partners.
    obj = sphere()
    col = bpy.data.collections.new(f"csrbf {obj.name}")
    bpy.context.scene.collection.children.link(col)
    for role, z in (("start", 1.0), ("target", 1.2)):
        e = bpy.data.objects.new(f"{obj.name} {role} 0", None)
        col.objects.link(e)
        e.parent = obj
        e.location = (0.0, 0.0, z)
        e[core.ROLE], e[core.PAIR], e[core.OWNER] = role, 0, obj.name
    obj.csrbf.radius = 0.6
    path = tmp_path / "old.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    bpy.ops.wm.open_mainfile(filepath=str(path))
    obj = bpy.data.objects["Sphere"]
    obj.name = "Ball"
    bpy.context.view_layer.objects.active = obj
    assert bpy.ops.csrbf.deform() == {"FINISHED"}
    assert north_z(obj) == pytest.approx(1.2, abs=1e-4)


def test_defect4_deform_in_edit_mode_is_kept():
    import bmesh  # only after bpy

    obj = sphere()
    _, target = add_control()
    target.location.z = 1.2
    bpy.context.view_layer.update()
    bpy.context.view_layer.objects.active = obj
    obj.csrbf.radius = 0.6
    bpy.ops.object.mode_set(mode="EDIT")
    bm = bmesh.from_edit_mesh(obj.data)  # an edit not yet written to the mesh
    min(bm.verts, key=lambda v: v.co.z).co.z -= 0.1
    bmesh.update_edit_mesh(obj.data)
    assert bpy.ops.csrbf.deform() == {"FINISHED"}
    assert obj.mode == "EDIT"
    bpy.ops.object.mode_set(mode="OBJECT")
    rest = core.rest_positions(obj)
    assert rest[:, 2].min() == pytest.approx(-1.1, abs=1e-5)  # the edit kept
    got = core.shape_key_positions(obj, obj.csrbf.layer)
    starts, targets = core.controls(obj)
    want = csrbf.fit(starts, targets, 0.6).deform(rest)
    assert np.abs(got - want).max() <= 1e-6 * core.diagonal(rest)
    assert north_z(obj) == pytest.approx(1.2, abs=1e-4)


def test_defect5_live_does_not_show_a_past_deforms_figures():
    obj = sphere()
    _, target = add_control()
    obj.csrbf.radius = 0.6
    target.location.z = 1.1
    bpy.context.view_layer.update()
    bpy.context.view_layer.objects.active = obj
    assert bpy.ops.csrbf.deform() == {"FINISHED"}
    assert ("0 face(s) inside out", "CHECKMARK") in ui.status_lines(obj)
    obj.csrbf.live = True
    target.location.x = 0.5  # folds: Deform would say so
    bpy.context.view_layer.update()
    lines = [text for text, _ in ui.status_lines(obj)]
    assert not any("inside out" in t or "vertices moved" in t for t in lines), lines
    assert any("Live pose" in t for t in lines), lines


def test_defect6_mesh_operators_accept_an_active_control_empty(tmp_path):
    obj = sphere()
    _, target = add_control()
    obj.csrbf.radius = 0.6
    target.location.z = 1.2
    bpy.context.view_layer.update()
    assert bpy.context.view_layer.objects.active == target
    assert bpy.ops.csrbf.deform() == {"FINISHED"}
    assert north_z(obj) == pytest.approx(1.2, abs=1e-4)
    assert bpy.ops.csrbf.export_controls(filepath=str(tmp_path / "c.json")) == {"FINISHED"}
    assert bpy.ops.csrbf.add_control() == {"FINISHED"}  # on the same mesh
    assert len(core.controls(obj)[0]) == 2


def test_defect7_a_missing_vertex_group_is_named(tmp_path):
    obj = sphere()
    obj.vertex_groups.new(name="top")
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"radius": 0.5, "controls": [{"from": [0, 0, 1], "to": [0, 0, 2]}],
                               "region": {"group": "nope"}}))
    with pytest.raises(RuntimeError, match="'Sphere' has no vertex group 'nope' \\(its vertex groups: 'top'\\)"):
        bpy.ops.csrbf.deform_from_file(filepath=str(bad))


def test_defect7_add_control_keeps_the_users_radius():
    obj = sphere()
    obj.csrbf.radius = 0.3
    add_control()
    assert obj.csrbf.radius == pytest.approx(0.3)


def test_defect7_live_reports_a_start_far_from_the_mesh():
    obj = sphere()
    start, target = add_control()
    obj.csrbf.radius = 0.3
    obj.csrbf.live = True
    target.location.z = 1.2
    bpy.context.view_layer.update()
    before = core.shape_key_positions(obj, obj.csrbf.layer).copy()
    start.location = (5.0, 5.0, 5.0)
    target.location = (5.0, 5.0, 6.0)
    bpy.context.view_layer.update()  # the handler reports, never raises
    assert f"start {start.name!r} lies farther than R" in obj.csrbf.warnings
    assert np.array_equal(core.shape_key_positions(obj, obj.csrbf.layer), before)  # left as it was


