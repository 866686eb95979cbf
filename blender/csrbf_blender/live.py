"""Live posing: while a destination empty moves, the shape key follows.

The factored system and the vertices' binding are kept per object (as the
studio keeps them): a moved destination costs one solve and the kernel
sums through the binding; a moved start, a new control or other settings rebuild them.

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

        s = obj.csrbf
        self.key = _settings_key(obj)
        self.starts, self.targets = controls.starts, controls.targets
        self.rest = core.rest_positions(obj)
        idx = None
        if s.vertex_group:
            idx = core.group_vertices(obj, s.vertex_group)
            if idx is None:
                raise ValueError(f"{obj.name!r} has no vertex group {s.vertex_group!r}")
        self.region = idx
        pts = self.rest if idx is None else self.rest[idx]
        self.system = csrbf.System(self.starts, s.radius, kernel=s.kernel, polynomial=s.polynomial)
        far = self.system.starts_out_of_reach(pts)
        if far:  # what Deform refuses, refused alike (the key is left as it was)
            where = "onto the mesh, inside the Region," if idx is not None else "onto the mesh"
            names = ", ".join(repr(controls.names[k]) for k in far)
            raise ValueError(f"the start {names} lies farther than R = {s.radius:.4g} from every vertex it acts on, "
                             f"so it moves nothing (move the start {where} or raise the radius)")
        self.binding = self.system.bind(pts)
        self.shown = None  # the targets last written

    def update(self, obj, targets, problems) -> None:
        s = obj.csrbf
        if s.sweep:
            # A sweep's steps move with the destinations: fitted anew each
            # move, so its figures are the pose's own (as Deform's are).
            import csrbf

            mesh = csrbf.Mesh(self.rest, core.triangles(obj))
            # No remedies while dragging: Deform searches them.
            out, report = csrbf.deform_mesh(mesh, core.resolve_groups(core.control_file(obj, s), obj),
                                            remedies="off")
            out = out.vertices
            _set(s, "moved", report.moved)
            _set(s, "inside_out", report.inside_out_faces)
            _set(s, "fold_phase", -1.0 if report.fold_phase is None else report.fold_phase)
            _set(s, "largest_move", report.largest_move)
            _set(s, "warnings", "\n".join(problems + report.warnings))
        else:
            d = self.system.solve(targets)
            disp = self.binding.displacements(d)
            out = self.rest.copy()
            if self.region is None:
                out += disp
            else:
                out[self.region] += disp
            # The last Deform's figures are not this pose's: cleared, not shown as current.
            _set(s, "moved", -1)
            _set(s, "warnings", "\n".join(problems))
        core.write_shape_key(obj, s.layer, out)
        self.shown = targets.copy()


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
        st.update(obj, targets, controls.problems)
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
