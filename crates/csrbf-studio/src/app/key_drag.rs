//! The Composer's pointer in its viewport as a small state machine: a press
//! picks what it lands on (the selected orientation key's gizmo ring, a
//! position key's marker, the scene camera's eye or target, else an object)
//! and may begin a [`KeyDrag`]; each move gives what the drag shows (a
//! retimed file, a moved camera); the release gives the one edit it makes.
//! Window-free: plain values in, plain values out, tested here.

use csrbf::glam::{DQuat, DVec3, Vec2, Vec3};
use csrbf_anim::{Camera, CameraFile, OrientationKeyFile, Scene, SceneFile};

use crate::DragTool;
use crate::compose::{
    KeyRef, KeyValue, SceneDoc, SceneEdit, Track, key_value, pick_camera_end, pick_key,
    pick_object, world_centre,
};
use crate::gizmo::{RING_PIXELS, ring_under, turned};

/// How near a marker (camera end, key) a press must be, in points.
const MARKER_POINTS: f32 = 9.0;
/// How near a gizmo ring a press must be, in pixels.
const RING_TOLERANCE: f32 = 6.0;

/// A drag in the Composer's viewport.
#[derive(Clone, Debug)]
pub(super) enum KeyDrag {
    Position {
        object: usize,
        index: usize,
        /// The key's marker moved on the plane facing the camera, or along
        /// the held axis (the Picker's tool).
        tool: DragTool,
        /// The key's position when the drag began.
        start: [f64; 3],
        /// The pointer's pixel at the press.
        pressed: Vec2,
    },
    Turn {
        object: usize,
        index: usize,
        axis: Vec3,
        centre: Vec3,
        start: DQuat,
        pressed: Vec2,
    },
    /// The scene camera's eye (or its target) moved on the plane facing
    /// the view, or along the held axis.
    Camera {
        target: bool,
        tool: DragTool,
        start: CameraFile,
        pressed: Vec2,
    },
    Orbit,
    Pan,
}

/// The view the pointer is in: its camera, size in pixels, pixels per point.
#[derive(Clone, Copy)]
pub(super) struct View<'a> {
    pub cam: &'a Camera,
    pub size: [u32; 2],
    pub ppp: f32,
}

/// What the Composer holds that a press looks at.
pub(super) struct Scope<'a> {
    pub doc: &'a SceneDoc,
    pub scene: &'a Scene,
    pub hidden: &'a [bool],
    /// The selected key.
    pub key: Option<KeyRef>,
    /// Looking through the scene camera (its ends are not shown).
    pub through_camera: bool,
    /// The held axis, if any.
    pub axis: Option<DVec3>,
}

/// What a press did.
#[derive(Debug)]
pub(super) enum Press {
    /// A drag begins; the selection stays.
    Drag(KeyDrag),
    /// A position key's marker: it is selected, the playhead goes to its
    /// time, and it is dragged.
    Key {
        key: KeyRef,
        time: f64,
        drag: KeyDrag,
    },
    /// The object under the pointer is selected (None: nothing there).
    Object(Option<usize>),
}

/// A press at `px` with Alt (orbit, or pan with Shift) or not.
pub(super) fn press(s: &Scope<'_>, v: View<'_>, px: Vec2, alt: bool, shift: bool) -> Press {
    if alt {
        return Press::Drag(if shift { KeyDrag::Pan } else { KeyDrag::Orbit });
    }
    if let Some(turn) = press_ring(s, v, px) {
        return Press::Drag(turn);
    }
    let view = (v.cam, v.size);
    let near = MARKER_POINTS * v.ppp;
    if let Some(hit) = pick_key(s.doc, s.scene, s.hidden, s.key, view, px, near) {
        let key = &s.doc.file.objects[hit.object].trajectory[hit.index];
        return Press::Key {
            key: (hit.object, Track::Position, hit.index),
            time: key.time,
            drag: KeyDrag::Position {
                object: hit.object,
                index: hit.index,
                tool: DragTool::begin(v.cam, v.size, px, hit.at.as_dvec3(), s.axis),
                start: key.position,
                pressed: px,
            },
        };
    }
    if !s.through_camera
        && let Some((target, w)) = pick_camera_end(&s.doc.file.camera, view, px, near)
    {
        return Press::Drag(KeyDrag::Camera {
            target,
            tool: DragTool::begin(v.cam, v.size, px, w, s.axis),
            start: s.doc.file.camera.clone(),
            pressed: px,
        });
    }
    Press::Object(pick_object(s.scene, s.hidden, s.doc.playhead, view, px))
}

/// A ring of the selected orientation key's gizmo under the pointer.
fn press_ring(s: &Scope<'_>, v: View<'_>, px: Vec2) -> Option<KeyDrag> {
    let Some((o, Track::Orientation, i)) = s.key else {
        return None;
    };
    let t = *s.doc.key_times(o, Track::Orientation).get(i)?;
    let centre = world_centre(s.scene, o, t)?;
    let axis = ring_under(
        centre,
        v.cam,
        v.size,
        RING_PIXELS * v.ppp,
        px,
        RING_TOLERANCE,
    )?;
    let Some(KeyValue::Orientation(q)) = key_value(&s.doc.file.objects[o], Track::Orientation, i)
    else {
        return None;
    };
    Some(KeyDrag::Turn {
        object: o,
        index: i,
        axis,
        centre,
        start: DQuat::from_array(q),
        pressed: px,
    })
}

/// What a drag shows while the button is down.
#[derive(Debug)]
pub(super) enum Shown {
    /// The scene retimed to this file (the document unchanged until the
    /// release).
    File(SceneFile),
    /// The scene camera as it would be.
    Camera(CameraFile),
}

/// What `drag` shows with the pointer at `px` (None: nothing to show, or a
/// view drag, which the caller does).
pub(super) fn moved(drag: &KeyDrag, doc: &SceneDoc, v: View<'_>, px: Vec2) -> Option<Shown> {
    if let KeyDrag::Camera { .. } = drag {
        return drag.camera_at(v, px).map(Shown::Camera);
    }
    let mut file = doc.file.clone();
    // (The key may be gone: an undo by key during the drag.)
    if let Some((object, index, p)) = drag.key_position(v, px) {
        let k = file.objects.get_mut(object)?.trajectory.get_mut(index)?;
        k.position = p;
    } else if let Some((object, index, q)) = drag.key_turn(v, px) {
        let k = file.objects.get_mut(object)?.orientation.get_mut(index)?;
        *k = quaternion_key(k.time, q);
    } else {
        return None;
    }
    Some(Shown::File(file))
}

/// What the release of a drag does.
#[derive(Debug)]
pub(super) enum Released {
    /// The edit the drag makes.
    Edit(SceneEdit),
    /// Refused, and why.
    Refused(&'static str),
    /// A click without a move: the drag's preview is undone.
    Revert,
    /// Nothing.
    Nothing,
}

/// The release of `drag` at `px`: a move of more than a pixel makes its
/// edit, a click on a key undoes its preview.
pub(super) fn release(drag: KeyDrag, v: View<'_>, px: Vec2) -> Released {
    let moved = drag.pressed().is_some_and(|p| px.distance(p) > 1.0);
    if let Some(camera) = drag.camera_at(v, px).filter(|_| moved) {
        return if DVec3::from_array(camera.eye) == DVec3::from_array(camera.target) {
            Released::Refused("Not done: the camera's eye and target would meet")
        } else {
            Released::Edit(SceneEdit::SetCamera(camera))
        };
    }
    let set = |object, track, index, value| {
        Released::Edit(SceneEdit::SetKey {
            object,
            track,
            index,
            value,
        })
    };
    if let Some((object, index, p)) = drag.key_position(v, px).filter(|_| moved) {
        return set(object, Track::Position, index, KeyValue::Position(p));
    }
    if let Some((object, index, q)) = drag.key_turn(v, px).filter(|_| moved) {
        return set(
            object,
            Track::Orientation,
            index,
            KeyValue::Orientation(q.to_array()),
        );
    }
    match drag {
        KeyDrag::Position { .. } | KeyDrag::Turn { .. } => Released::Revert,
        _ => Released::Nothing,
    }
}

impl KeyDrag {
    /// The pointer's pixel at the press (None for a view drag).
    fn pressed(&self) -> Option<Vec2> {
        match self {
            KeyDrag::Position { pressed, .. }
            | KeyDrag::Turn { pressed, .. }
            | KeyDrag::Camera { pressed, .. } => Some(*pressed),
            KeyDrag::Orbit | KeyDrag::Pan => None,
        }
    }

    /// A position key's drag: the key and where it is with the pointer at
    /// `px` (None when the drag is not one, or the point is off the view).
    fn key_position(&self, v: View<'_>, px: Vec2) -> Option<(usize, usize, [f64; 3])> {
        let KeyDrag::Position {
            object,
            index,
            tool,
            start,
            ..
        } = self
        else {
            return None;
        };
        let to = tool.moved_to(v.cam, v.size, px)?;
        let p = DVec3::from_array(*start) + to - tool.origin;
        Some((*object, *index, p.to_array()))
    }

    /// An orientation key's turn: the key and its rotation with the pointer
    /// at `px`.
    fn key_turn(&self, v: View<'_>, px: Vec2) -> Option<(usize, usize, DQuat)> {
        let KeyDrag::Turn {
            object,
            index,
            axis,
            centre,
            start,
            pressed,
        } = self
        else {
            return None;
        };
        let q = turned(v.cam, v.size, *centre, *axis, *start, *pressed, px);
        Some((*object, *index, q))
    }

    /// The scene camera with its eye (or target) where the pointer has it.
    fn camera_at(&self, v: View<'_>, px: Vec2) -> Option<CameraFile> {
        let KeyDrag::Camera {
            target,
            tool,
            start,
            ..
        } = self
        else {
            return None;
        };
        let to = tool.moved_to(v.cam, v.size, px)?;
        Some(camera_moved(start, *target, to - tool.origin))
    }
}

/// An orientation key at `time` holding the quaternion `q`.
fn quaternion_key(time: f64, q: DQuat) -> OrientationKeyFile {
    OrientationKeyFile {
        time,
        quaternion: Some(q.to_array()),
        axis: None,
        angle: None,
        euler: None,
    }
}

/// `camera` with its eye (or its target) moved by `by`.
pub(super) fn camera_moved(camera: &CameraFile, target: bool, by: DVec3) -> CameraFile {
    let mut out = camera.clone();
    let end = if target {
        &mut out.target
    } else {
        &mut out.eye
    };
    *end = (DVec3::from_array(*end) + by).to_array();
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compose::fixture::face;

    const SIZE: [u32; 2] = [800, 600];

    fn view(cam: &Camera) -> View<'_> {
        View {
            cam,
            size: SIZE,
            ppp: 1.0,
        }
    }

    fn scope<'a>(doc: &'a SceneDoc, scene: &'a Scene, key: Option<KeyRef>) -> Scope<'a> {
        Scope {
            doc,
            scene,
            hidden: &[],
            key,
            through_camera: true,
            axis: None,
        }
    }

    #[test]
    fn a_key_pressed_dragged_and_released_is_one_set_key_and_a_click_reverts() {
        let (doc, loaded, cam) = face();
        let scene = loaded.scene.as_ref().expect("loaded");
        let v = view(&cam);
        let c = scene.objects[0].center.as_vec3();
        let (at, _) = cam.project(c, SIZE).expect("in view");
        let Press::Key { key, time, drag } = press(&scope(&doc, scene, None), v, at, false, false)
        else {
            panic!("the key's marker");
        };
        assert_eq!((key, time), ((0, Track::Position, 0), 0.0));
        // Moved right: the shown file has the key moved right, the document not.
        let to = at + Vec2::new(40.0, 0.0);
        let Some(Shown::File(file)) = moved(&drag, &doc, v, to) else {
            panic!("a preview");
        };
        let x = file.objects[0].trajectory[0].position[0];
        assert!(x > 0.1, "{x}");
        assert_eq!(doc.file.objects[0].trajectory[0].position, [0.0; 3]);
        let Released::Edit(SceneEdit::SetKey {
            value: KeyValue::Position(p),
            ..
        }) = release(drag.clone(), v, to)
        else {
            panic!("one edit");
        };
        assert!((p[0] - x).abs() < 1e-9 && p[1].abs() < 1e-6);
        assert!(matches!(release(drag, v, at), Released::Revert));
    }

    #[test]
    fn alt_orbits_a_ring_turns_and_elsewhere_an_object_is_selected() {
        let (doc, loaded, cam) = face();
        let scene = loaded.scene.as_ref().expect("loaded");
        let v = view(&cam);
        let s = scope(&doc, scene, None);
        assert!(matches!(
            press(&s, v, Vec2::ZERO, true, false),
            Press::Drag(KeyDrag::Orbit)
        ));
        assert!(matches!(
            press(&s, v, Vec2::ZERO, true, true),
            Press::Drag(KeyDrag::Pan)
        ));
        // Off the key marker but on the head: the object.
        let (at, _) = cam
            .project(scene.objects[0].center.as_vec3(), SIZE)
            .expect("in view");
        assert!(matches!(
            press(&s, v, at + Vec2::new(0.0, 30.0), false, false),
            Press::Object(Some(0))
        ));
        assert!(matches!(
            press(&s, v, Vec2::ZERO, false, false),
            Press::Object(None)
        ));
        // The selected orientation key (at 2 s): its Z ring faces the view.
        let s = scope(&doc, scene, Some((0, Track::Orientation, 1)));
        let centre = world_centre(scene, 0, 2.0).expect("centre");
        let (c, _) = cam.project(centre, SIZE).expect("in view");
        let on_ring = c + Vec2::new(RING_PIXELS, 0.0).rotate(Vec2::from_angle(0.7));
        let Press::Drag(turn @ KeyDrag::Turn { axis, .. }) = press(&s, v, on_ring, false, false)
        else {
            panic!("a turn");
        };
        assert_eq!(axis, Vec3::Z);
        let to = c + Vec2::new(RING_PIXELS, 0.0).rotate(Vec2::from_angle(0.7 + 0.5));
        assert!(matches!(
            release(turn, v, to),
            Released::Edit(SceneEdit::SetKey {
                track: Track::Orientation,
                ..
            })
        ));
    }

    #[test]
    fn moving_a_camera_end_moves_that_end_only() {
        let start = CameraFile {
            eye: [0.0, 0.0, 5.0],
            target: [0.0; 3],
            ..SceneDoc::empty().file.camera
        };
        let moved = camera_moved(&start, false, DVec3::new(0.0, 0.0, -5.0));
        assert_eq!(moved.eye, [0.0; 3]);
        assert_eq!(moved.target, start.target);
    }
}
