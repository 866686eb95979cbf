//! What a press in the Composer's viewport lands on, as the Picker's
//! [`crate::pick_marker`] does for control markers: a position key's marker,
//! the scene camera's eye or target, an object. Plain functions of the
//! document, the loaded scene, a camera and a pixel, tested without a window.

use csrbf::glam::{DVec3, Vec2, Vec3};
use csrbf_anim::{Camera, CameraFile, Scene};

use super::{KeyRef, SceneDoc, Track, world_centre};

/// A position key's marker under the pointer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KeyHit {
    /// The object.
    pub object: usize,
    /// The key's index in its trajectory.
    pub index: usize,
    /// Where the marker is in the world.
    pub at: Vec3,
}

/// The position key marker nearest `px` within `tolerance` pixels (markers
/// are drawn at the key's position plus the object's centre); the
/// `selected` key wins where markers overlap (by 2 pixels). Objects marked
/// in `hidden` are skipped.
pub fn pick_key(
    doc: &SceneDoc,
    scene: &Scene,
    hidden: &[bool],
    selected: Option<KeyRef>,
    (cam, size): (&Camera, [u32; 2]),
    px: Vec2,
    tolerance: f32,
) -> Option<KeyHit> {
    let mut best: Option<(f32, KeyHit)> = None;
    for (o, of) in doc.file.objects.iter().enumerate() {
        if hidden.get(o).copied().unwrap_or(false) {
            continue;
        }
        let centre = scene.objects.get(o).map_or(DVec3::ZERO, |x| x.center);
        for (i, k) in of.trajectory.iter().enumerate() {
            let w = (DVec3::from_array(k.position) + centre).as_vec3();
            let Some((p, _)) = cam.project(w, size) else {
                continue;
            };
            let d = p.distance(px);
            let d = if selected == Some((o, Track::Position, i)) {
                d - 2.0
            } else {
                d
            };
            if d < tolerance && best.is_none_or(|b| d < b.0) {
                let hit = KeyHit {
                    object: o,
                    index: i,
                    at: w,
                };
                best = Some((d, hit));
            }
        }
    }
    best.map(|(_, hit)| hit)
}

/// The scene camera's eye (false) or target (true) nearest `px` within
/// `tolerance` pixels, with where it is.
pub fn pick_camera_end(
    camera: &CameraFile,
    (cam, size): (&Camera, [u32; 2]),
    px: Vec2,
    tolerance: f32,
) -> Option<(bool, DVec3)> {
    [(false, camera.eye), (true, camera.target)]
        .iter()
        .filter_map(|&(is_target, p)| {
            let w = DVec3::from_array(p);
            let (q, _) = cam.project(w.as_vec3(), size)?;
            let d = q.distance(px);
            (d < tolerance).then_some((d, is_target, w))
        })
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, is_target, w)| (is_target, w))
}

/// The nearest object whose bounding sphere at `time` the ray through `px`
/// meets (objects marked in `hidden` skipped).
pub fn pick_object(
    scene: &Scene,
    hidden: &[bool],
    time: f64,
    (cam, size): (&Camera, [u32; 2]),
    px: Vec2,
) -> Option<usize> {
    let ray = cam.ray(px, size);
    scene
        .objects
        .iter()
        .enumerate()
        .filter(|(k, _)| !hidden.get(*k).copied().unwrap_or(false))
        .filter_map(|(k, o)| {
            let centre = world_centre(scene, k, time)?;
            let oc = ray.origin - centre;
            let b = oc.dot(ray.dir);
            let disc = b * b - (oc.length_squared() - (o.radius as f32).powi(2));
            (disc >= 0.0).then(|| (k, -b - disc.sqrt()))
        })
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(k, _)| k)
}

/// A scene for the tests of the Composer's pointer (here and in the app's,
/// which turn on the `fixtures` feature).
#[cfg(any(test, feature = "fixtures"))]
pub mod fixture {
    use super::*;
    use crate::compose::{KeyValue, Loaded, SceneEdit};
    use std::path::Path;

    /// The face scene with position keys at 0 s (at the origin) and 2 s
    /// (2 up), the playhead at 0, looked at from the front.
    pub fn face() -> (SceneDoc, Loaded, Camera) {
        let path =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/scenes/face.scene.json");
        let mut doc = SceneDoc::open(&path).expect("face");
        for (t, y) in [(0.0, 0.0), (2.0, 2.0)] {
            doc.playhead = t;
            SceneEdit::AddKey {
                object: 0,
                track: Track::Position,
                value: KeyValue::Position([0.0, y, 0.0]),
            }
            .apply(&mut doc)
            .expect("a key");
        }
        doc.playhead = 0.0;
        let mut loaded = Loaded::new();
        let scene = loaded.prepare(&doc, &doc.file, false).expect("loads");
        loaded.install(scene, false, &mut 1);
        let c = loaded.scene.as_ref().expect("loaded").objects[0]
            .center
            .as_vec3();
        let cam = Camera::perspective(c + Vec3::new(0.0, 0.0, 60.0), c, Vec3::Y, 40.0);
        (doc, loaded, cam)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compose::fixture::face;

    const SIZE: [u32; 2] = [800, 600];

    #[test]
    fn a_key_marker_is_picked_near_its_pixel_and_the_selected_one_wins_a_tie() {
        let (doc, loaded, cam) = face();
        let scene = loaded.scene.as_ref().expect("loaded");
        let c = scene.objects[0].center.as_vec3();
        let (at_up, _) = cam.project(c + Vec3::Y * 2.0, SIZE).expect("in view");
        let hit = pick_key(
            &doc,
            scene,
            &[],
            None,
            (&cam, SIZE),
            at_up + Vec2::X * 3.0,
            9.0,
        );
        assert_eq!(hit.map(|h| (h.object, h.index)), Some((0, 1)));
        assert!(hit.is_some_and(|h| h.at.distance(c + Vec3::Y * 2.0) < 1e-4));
        // Too far, or hidden: nothing.
        assert!(
            pick_key(
                &doc,
                scene,
                &[],
                None,
                (&cam, SIZE),
                at_up + Vec2::X * 20.0,
                9.0
            )
            .is_none()
        );
        assert!(pick_key(&doc, scene, &[true], None, (&cam, SIZE), at_up, 9.0).is_none());
        // Halfway between the two markers the selected key wins.
        let (at_rest, _) = cam.project(c, SIZE).expect("in view");
        let mid = (at_up + at_rest) * 0.5;
        let tol = at_up.distance(at_rest);
        let pick = |sel| pick_key(&doc, scene, &[], sel, (&cam, SIZE), mid, tol).map(|h| h.index);
        assert_eq!(pick(Some((0, Track::Position, 0))), Some(0));
        assert_eq!(pick(Some((0, Track::Position, 1))), Some(1));
    }

    #[test]
    fn the_camera_ends_and_objects_are_picked_where_they_are_drawn() {
        let (doc, loaded, cam) = face();
        let scene = loaded.scene.as_ref().expect("loaded");
        let c = scene.objects[0].center;
        let (eye, target) = (c + DVec3::X * 5.0, c - DVec3::X * 5.0);
        let f = CameraFile {
            eye: eye.to_array(),
            target: target.to_array(),
            ..doc.file.camera.clone()
        };
        let (eye_px, _) = cam.project(eye.as_vec3(), SIZE).expect("in view");
        let picked = pick_camera_end(&f, (&cam, SIZE), eye_px, 9.0).expect("the eye");
        assert!(!picked.0 && picked.1.distance(eye) < 1e-9);
        let (target_px, _) = cam.project(target.as_vec3(), SIZE).expect("in view");
        assert_eq!(
            pick_camera_end(&f, (&cam, SIZE), target_px, 9.0).map(|e| e.0),
            Some(true)
        );
        assert!(pick_camera_end(&f, (&cam, SIZE), Vec2::ZERO, 9.0).is_none());
        // The head at the centre of the view; nothing in a corner.
        let centre = Camera::centre_pixel(SIZE);
        assert_eq!(pick_object(scene, &[], 0.0, (&cam, SIZE), centre), Some(0));
        assert_eq!(pick_object(scene, &[true], 0.0, (&cam, SIZE), centre), None);
        assert_eq!(pick_object(scene, &[], 0.0, (&cam, SIZE), Vec2::ZERO), None);
    }
}
