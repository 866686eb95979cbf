"""Live posing: while a destination empty moves, the shape key follows.

Each object keeps a `csrbf.Session` (the edit layer's live session, which
the studio's preview uses too): it keeps every layer's factored system and
the vertices' binding, so a moved destination costs one solve and the kernel
sums; a moved start, a new control or other settings refit. Regions and
sweeps are the session's, as Deform's are `deform_mesh`'s: the same
positions and the same report, whose warnings name a start that reaches no
vertex (refused here as Deform refuses it).

The handlers are persistent: Blender keeps them through File > Open and
File > New, so the Live toggle, which is saved in the .blend, means what it
shows: a file saved with Live on is live again once opened.
"""

from __future__ import annotations

import bpy
import numpy as np
from bpy.app.handlers import persistent

from . import core

# Object (its session_uid) -> _State. Runtime only (not saved in the .blend).
_states: dict[int, "_State"] = {}


class _State:
    def __init__(self, obj, controls):
        import csrbf

        self.key = _settings_key(obj)
        self.starts = controls.starts
        self.rest = core.rest_positions(obj)
        self.session = csrbf.Session(csrbf.Mesh(self.rest, core.triangles(obj)))
        self.shown = None  # the targets last written
        self.checked = False  # whether the session's last update was checked

    def update(self, obj, controls, problems) -> None:
        """Poses the shape key from the controls: checked (a start that
        reaches no vertex refused) when the session was just made or the
        layer is a sweep, else a solve and the sums alone. Only a sweep's
        figures are shown live (they are checked each move); Deform shows
        the others."""
        s = obj.csrbf
        spec = core.resolve_groups(core.control_file(obj, s), obj)
        if not self.checked or s.sweep:
            # No remedies while posing: Deform searches them.
            report = self.session.update(spec, remedies="off")
            far = [c for k, c in zip(report.warning_kinds, report.warning_controls) if k == "starts_far_from_mesh"]
            if far:  # what Deform refuses, refused alike (the key is left as it was)
                where = "onto the mesh, inside the Region," if s.vertex_group else "onto the mesh"
                names = ", ".join(repr(controls.names[k]) for k in (far[0] or []) if k < len(controls.names))
                raise ValueError(f"the start {names} lies farther than R = {s.radius:.4g} from every vertex it acts on, "
                                 f"so it moves nothing (move the start {where} or raise the radius)")
            self.checked = True
            out = self.session.vertices
        else:
            out = self.session.update_positions(spec)
        if s.sweep:
            # A sweep's steps move with the destinations: checked each move,
            # so its figures are the pose's own (as Deform's are).
            _set(s, "moved", report.moved)
            _set(s, "inside_out", report.inside_out_faces)
            _set(s, "fold_phase", -1.0 if report.fold_phase is None else report.fold_phase)
            _set(s, "largest_move", report.largest_move)
            _set(s, "warnings", "\n".join(problems + report.warnings))
        else:
            # The last Deform's figures are not this pose's: cleared, not shown as current.
            _set(s, "moved", -1)
            _set(s, "warnings", "\n".join(problems))
        core.write_shape_key(obj, s.layer, out)
        self.shown = controls.targets.copy()


def _set(settings, name, value) -> None:
    """Writes a setting only when it changes: a write tags the object, and an
    update from the handler must not start another one."""
    if getattr(settings, name) != value:
        setattr(settings, name, value)


def _settings_key(obj):
    s = obj.csrbf
    return (s.radius, s.kernel, s.polynomial, s.sweep, s.vertex_group, s.layer, len(obj.data.vertices))


def refresh(obj) -> str:
    """Brings the object's shape key up to date with its empties; returns
    what it did: "solved" (destinations moved), "rebuilt" (starts or
    settings changed), "unchanged", "edit mode" (skipped: Blender would
    overwrite the key on leaving it) or an error message (the key is then
    left as it was and the message shown in the panel)."""
    if obj.mode == "EDIT":
        return "edit mode"
    controls = core.control_pairs(obj)
    starts, targets = controls.starts, controls.targets
    if len(starts) == 0:
        _set(obj.csrbf, "warnings", "\n".join(["live: no control vectors"] + controls.problems))
        return "no control vectors"
    uid = obj.session_uid
    st = _states.get(uid)
    did = "solved"
    try:
        if st is None or st.key != _settings_key(obj) or not np.array_equal(st.starts, starts):
            st = _states[uid] = _State(obj, controls)
            did = "rebuilt"
        elif st.shown is not None and np.array_equal(st.shown, targets):
            return "unchanged"
        st.update(obj, controls, controls.problems)
    except Exception as e:  # the engine's refusal: shown, never raised into Blender's handler loop
        _states.pop(uid, None)
        _set(obj.csrbf, "warnings", f"live: {e}")
        return f"error: {e}"
    return did


@persistent
def _on_depsgraph(scene, depsgraph):
    for obj in scene.objects:
        if obj.type == "MESH" and obj.csrbf.live:
            refresh(obj)


@persistent
def _on_load(_filepath):
    # Another file's objects: nothing kept is theirs. Controls saved by
    # earlier versions are brought up to date (owner pointers).
    _states.clear()
    core.migrate()


def set_enabled(obj, on: bool) -> None:
    if obj is None or obj.type != "MESH":
        return
    if on:
        refresh(obj)
    else:
        _states.pop(obj.session_uid, None)


def register():
    if _on_depsgraph not in bpy.app.handlers.depsgraph_update_post:
        bpy.app.handlers.depsgraph_update_post.append(_on_depsgraph)
    if _on_load not in bpy.app.handlers.load_post:
        bpy.app.handlers.load_post.append(_on_load)


def unregister():
    if _on_depsgraph in bpy.app.handlers.depsgraph_update_post:
        bpy.app.handlers.depsgraph_update_post.remove(_on_depsgraph)
    if _on_load in bpy.app.handlers.load_post:
        bpy.app.handlers.load_post.remove(_on_load)
    _states.clear()
