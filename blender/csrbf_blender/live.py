"""Live posing: the shape key follows the controls, as they are moved, on
every frame change (playback, scrubbing, `frame_set`) and in renders (F12,
`blender -a`), keyframed or driven.

Each object keeps a `csrbf.Session` (the edit layer's live session, which
the studio's preview uses too): it keeps every layer's factored system and
the vertices' binding, so a moved destination or a turned handle costs one
solve and the kernel sums; a moved start, a new control or other settings
refit. Regions, handles and sweeps are the session's, as Deform's are
`deform_mesh`'s: the same positions and the same report, whose warnings
name a start that reaches no vertex (refused here as Deform refuses it).

A frame of a render is evaluated in the render's own depsgraph, whose
animated values the original objects do not hold: the controls are read
from the depsgraph the handler is given, and the pose written into the
mesh's shape key is evaluated again by Blender before the frame is drawn.

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
    """An object's live session: made again when the mesh may have changed
    (its vertex count, or a mode left: Edit Mode edits the rest shape,
    Weight Paint the groups)."""

    def __init__(self, obj):
        import csrbf

        self.vertices = len(obj.data.vertices)
        self.mode = obj.mode
        self.rest = core.rest_positions(obj)
        self.session = csrbf.Session(csrbf.Mesh(self.rest, core.triangles(obj)))
        self.groups = core.Groups(obj)
        self.spec = None  # the control file last posed
        self.shape = None  # its structure: all but where things move to

    def pose(self, obj, spec, controls) -> str:
        """Poses the shape key by `spec`: checked (a start that reaches no
        vertex refused) when its structure changed or the layer is a
        sweep, else a solve and the sums alone. Only a sweep's figures are
        shown live (they are checked each move); Deform shows the others."""
        s = obj.csrbf
        shape = _structure(spec)
        changed = shape != self.shape
        if changed or s.sweep:
            # No remedies while posing: Deform searches them.
            # Not the faces passing through each other (the costliest check,
            # 37 ms of 51 on 50k vertices): Deform looks for them.
            report = self.session.update(spec, remedies="off", self_intersections=False)
            far = [c for k, c in zip(report.warning_kinds, report.warning_controls) if k == "starts_far_from_mesh"]
            if far:  # what Deform refuses, refused alike (the key is left as it was)
                where = "onto the mesh" if s.region == "ALL" and not s.vertex_group else "onto the mesh, inside the Region,"
                names = ", ".join(repr(controls.names[k]) for k in (far[0] or []) if k < len(controls.names))
                raise ValueError(f"the start {names or '(a handle sample)'} lies farther than R = {s.radius:.4g} from every "
                                 f"vertex it acts on, so it moves nothing (move the start {where} or raise the radius)")
            self.shape = shape
            out = self.session.vertices
        else:
            report = None
            out = self.session.update_positions(spec)
        if report is not None and s.sweep:
            # A sweep's steps move with the destinations: checked each move,
            # so its figures are the pose's own (as Deform's are).
            _set(s, "moved", report.moved)
            _set(s, "inside_out", report.inside_out_faces)
            _set(s, "fold_phase", -1.0 if report.fold_phase is None else report.fold_phase)
            _set(s, "largest_move", report.largest_move)
            _set(s, "warnings", "\n".join(controls.problems + report.warnings))
        elif not s.sweep:
            # The last Deform's figures are not this pose's: cleared, not shown as current.
            _set(s, "moved", -1)
            _set(s, "advice", "")
            _set(s, "warnings", "\n".join(controls.problems))
        core.write_shape_key(obj, s.layer, out, value=None)
        self.spec = spec
        return "rebuilt" if changed else "solved"


def _structure(spec):
    """The control file without where its destinations and handles move to:
    equal for two files one solve apart."""
    if isinstance(spec, dict):
        return {k: _structure(v) for k, v in spec.items() if k not in ("to", "rotate", "scale", "translate")}
    if isinstance(spec, list):
        if spec and not isinstance(spec[0], (dict, list)):
            return spec  # numbers (a point, a vertex list): kept as they are
        return [_structure(v) for v in spec]
    return spec


def _set(settings, name, value) -> None:
    """Writes a setting only when it changes: a write tags the object, and an
    update from the handler must not start another one."""
    if getattr(settings, name) != value:
        setattr(settings, name, value)


def refresh(obj, depsgraph=None) -> str:
    """Brings the object's shape key up to date with its controls (as
    evaluated in `depsgraph` when given: a frame); returns what it did:
    "solved" (destinations or handles moved), "rebuilt" (starts or
    settings changed), "unchanged", "edit mode" (skipped: Blender would
    overwrite the key on leaving it) or an error message (the key is then
    left as it was and the message shown in the panel)."""
    if obj.mode == "EDIT":
        return "edit mode"
    uid = obj.session_uid
    st = _states.get(uid)
    if st is not None and (st.vertices != len(obj.data.vertices) or st.mode != obj.mode or obj.mode == "WEIGHT_PAINT"):
        st = None
    try:
        if st is None:
            st = _states[uid] = _State(obj)
        controls = core.control_pairs(obj, depsgraph)
        spec = core.control_file(obj, obj.csrbf, depsgraph, st.groups, controls)
        spec = core.resolve_groups(spec, obj, st.groups)
        if spec == st.spec:
            return "unchanged"
        return st.pose(obj, spec, controls)
    except Exception as e:  # the engine's refusal: shown, never raised into Blender's handler loop
        _states.pop(uid, None)
        _set(obj.csrbf, "warnings", f"live: {e}")
        return f"error: {e}"


def _live_objects(scene):
    return [o for o in scene.objects if o.type == "MESH" and o.csrbf.live]


@persistent
def _on_depsgraph(scene, depsgraph):
    for obj in _live_objects(scene):
        refresh(obj, depsgraph)


@persistent
def _on_frame(scene, depsgraph):
    # Playback, scrubbing, frame_set and each frame of a render: the
    # controls as this depsgraph evaluates them at the frame.
    for obj in _live_objects(scene):
        refresh(obj, depsgraph)


@persistent
def _on_render_done(scene, *_):
    # The key holds the last rendered frame's pose: back to the one the
    # viewport shows.
    try:
        depsgraph = bpy.context.evaluated_depsgraph_get()
    except Exception:  # no context to evaluate in: the next update poses it
        return
    for obj in _live_objects(scene):
        refresh(obj, depsgraph)


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


_HANDLERS = (
    ("depsgraph_update_post", _on_depsgraph),
    ("frame_change_post", _on_frame),
    ("render_complete", _on_render_done),
    ("render_cancel", _on_render_done),
    ("load_post", _on_load),
)


def register():
    for name, fn in _HANDLERS:
        handlers = getattr(bpy.app.handlers, name)
        if fn not in handlers:
            handlers.append(fn)


def unregister():
    for name, fn in _HANDLERS:
        handlers = getattr(bpy.app.handlers, name)
        if fn in handlers:
            handlers.remove(fn)
    _states.clear()
