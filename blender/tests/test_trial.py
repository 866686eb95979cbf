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
