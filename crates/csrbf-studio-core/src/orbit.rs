//! The viewport's camera as a person moves it: orbit about a target, pan,
//! zoom towards the point under the pointer, frame a box, and the view
//! presets in the model's own up axis (a Z-up or -Y-up model is not shown
//! lying on its side).

use csrbf::glam::Vec3;
use csrbf_anim::{Camera, Projection, ViewPreset};

/// The up axes a model may have, named as the View menu and the CLI's
/// `--up` name them.
pub const UP_AXES: [(&str, Vec3); 6] = [
    ("+Y", Vec3::Y),
    ("+Z", Vec3::Z),
    ("+X", Vec3::X),
    ("-Y", Vec3::NEG_Y),
    ("-Z", Vec3::NEG_Z),
    ("-X", Vec3::NEG_X),
];

/// An orbiting camera: a target, a distance, and two angles about the
/// model's up axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Orbit {
    /// The point looked at and turned about.
    pub target: Vec3,
    /// From the eye to the target.
    pub distance: f32,
    /// Turn about the up axis, radians; 0 looks at the model's front.
    pub yaw: f32,
    /// Height above the model's horizon, radians, within +-89.5 degrees.
    pub pitch: f32,
    /// The model's up axis (unit).
    pub up: Vec3,
    /// Vertical field of view, degrees.
    pub fov: f32,
    /// Orthographic instead of perspective (same framing at the target).
    pub orthographic: bool,
}

const PITCH_LIMIT: f32 = 89.5 * std::f32::consts::PI / 180.0;

impl Orbit {
    /// A front view of the box `lo`..`hi` for a model whose up axis is `up`.
    pub fn new(up: Vec3, lo: Vec3, hi: Vec3, aspect: f32) -> Orbit {
        let mut o = Orbit {
            target: (lo + hi) * 0.5,
            distance: 1.0,
            yaw: 0.0,
            pitch: 0.0,
            up: up.normalize_or(Vec3::Y),
            fov: 35.0,
            orthographic: false,
        };
        o.frame(lo, hi, aspect);
        o
    }

    /// The model's front and right, given its up axis (as
    /// [`Camera::preset_direction`] takes them).
    fn axes(&self) -> (Vec3, Vec3) {
        let front = -Camera::preset_direction(ViewPreset::Front, self.up);
        let right = self.up.cross(front);
        (front, right)
    }

    /// From the target towards the eye (unit).
    pub fn eye_direction(&self) -> Vec3 {
        let (front, right) = self.axes();
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        (front * cy + right * sy) * cp + self.up * sp
    }

    /// The camera the renderer and the picking rays use.
    pub fn camera(&self) -> Camera {
        let eye = self.target + self.eye_direction() * self.distance;
        let cam = Camera::perspective(eye, self.target, self.up, self.fov);
        if self.orthographic {
            let height = 2.0 * self.distance * (self.fov.to_radians() * 0.5).tan();
            Camera {
                projection: Projection::Orthographic { height },
                ..cam
            }
        } else {
            cam
        }
    }

    /// Looks from `direction` (from the target towards the eye), keeping the
    /// target and distance; the pitch stays within its limits.
    pub fn look_from(&mut self, direction: Vec3) {
        let d = direction.normalize_or(self.eye_direction());
        let (front, right) = self.axes();
        self.pitch = d
            .dot(self.up)
            .clamp(-1.0, 1.0)
            .asin()
            .clamp(-PITCH_LIMIT, PITCH_LIMIT);
        self.yaw = d.dot(right).atan2(d.dot(front));
    }

    /// Turns the view by a pointer drag of `dx`, `dy` pixels (a 100-pixel
    /// drag is one radian).
    pub fn orbit(&mut self, dx: f32, dy: f32) {
        self.yaw -= dx * 0.01;
        self.pitch = (self.pitch + dy * 0.01).clamp(-PITCH_LIMIT, PITCH_LIMIT);
    }

    /// [`Orbit::orbit`] about the point `p` instead of the target: `p` stays
    /// where it is in the picture (orbit about the selection).
    pub fn orbit_about(&mut self, dx: f32, dy: f32, p: Vec3) {
        let (r0, u0, f0) = self.camera().basis();
        let d = self.target - p;
        let local = Vec3::new(d.dot(r0), d.dot(u0), d.dot(f0));
        self.orbit(dx, dy);
        let (r1, u1, f1) = self.camera().basis();
        self.target = p + r1 * local.x + u1 * local.y + f1 * local.z;
    }

    /// Slides the view so the point at the target's depth follows a pointer
    /// drag of `dx`, `dy` pixels in a viewport `height` pixels high.
    pub fn pan(&mut self, dx: f32, dy: f32, height: f32) {
        let per_pixel = 2.0 * self.distance * (self.fov.to_radians() * 0.5).tan() / height.max(1.0);
        let (right, up, _) = self.camera().basis();
        self.target += (-right * dx + up * dy) * per_pixel;
    }

    /// Moves the eye and the target towards `point` by `factor` (< 1 closer):
    /// `point` stays under the pointer, as in modelling tools.
    pub fn zoom_about(&mut self, factor: f32, point: Vec3) {
        let factor = factor.clamp(1e-3, 1e3);
        let distance = self.distance * factor;
        if !(distance > 1e-6 && distance < 1e9) {
            return;
        }
        self.target = point + (self.target - point) * factor;
        self.distance = distance;
    }

    /// The point of the plane through the target facing the camera under
    /// `pixel` (what a zoom goes towards when the pointer is off the model).
    pub fn point_on_target_plane(&self, pixel: csrbf::glam::Vec2, size: [u32; 2]) -> Vec3 {
        let cam = self.camera();
        let ray = cam.ray(pixel, size);
        let forward = cam.basis().2;
        let denom = ray.dir.dot(forward);
        if denom.abs() < 1e-6 {
            return self.target;
        }
        ray.at((self.target - ray.origin).dot(forward) / denom)
    }

    /// Keeps the direction of view and fits the box `lo`..`hi` in a picture
    /// of this aspect.
    pub fn frame(&mut self, lo: Vec3, hi: Vec3, aspect: f32) {
        let framed = Camera::framing(
            -self.eye_direction(),
            self.up,
            lo,
            hi,
            self.fov,
            aspect,
            1.0,
        );
        self.target = framed.target;
        self.distance = (framed.eye - framed.target).length().max(1e-6);
    }

    /// Looks from a preset direction of the model (front, side, top...),
    /// keeping the target and distance.
    pub fn preset(&mut self, preset: ViewPreset) {
        let eye = -Camera::preset_direction(preset, self.up);
        let (front, right) = self.axes();
        self.pitch = eye
            .dot(self.up)
            .clamp(-1.0, 1.0)
            .asin()
            .clamp(-PITCH_LIMIT, PITCH_LIMIT);
        self.yaw = eye.dot(right).atan2(eye.dot(front));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn looking_from_a_direction_puts_the_eye_there() {
        for up in [Vec3::Y, Vec3::Z, Vec3::NEG_Y] {
            let mut o = Orbit::new(up, Vec3::splat(-1.0), Vec3::ONE, 1.5);
            for d in [Vec3::new(1.0, 2.0, 3.0), Vec3::new(-2.0, 0.5, -1.0)] {
                o.look_from(d);
                assert!(
                    (o.eye_direction() - d.normalize()).length() < 1e-5,
                    "{up} {d}"
                );
            }
        }
    }
    use csrbf::glam::Vec2;

    const SIZE: [u32; 2] = [640, 400];

    fn orbit(up: Vec3) -> Orbit {
        Orbit::new(up, Vec3::splat(-1.0), Vec3::splat(1.0), 1.6)
    }

    #[test]
    fn presets_look_where_the_cli_looks_and_keep_the_model_upright() {
        // Every up axis the View menu offers, -Z and -X included (a horse
        // scanned with -Z up stood on its head).
        assert_eq!(UP_AXES.len(), 6);
        // And a typed direction: a scan standing tilted in its frame.
        let tilted = [
            Vec3::new(0.2, 0.95, -0.3).normalize(),
            Vec3::new(-0.1, 0.35, 0.93).normalize(),
            Vec3::new(0.7, -0.7, 0.1).normalize(),
        ];
        for up in UP_AXES.map(|(_, up)| up).into_iter().chain(tilted) {
            let mut o = orbit(up);
            for p in [
                ViewPreset::Front,
                ViewPreset::Back,
                ViewPreset::Left,
                ViewPreset::Right,
                ViewPreset::Iso,
            ] {
                o.preset(p);
                let cam = o.camera();
                let gaze = (cam.target - cam.eye).normalize();
                let want = Camera::preset_direction(p, up);
                assert!(gaze.dot(want) > 0.9999, "{up} {p:?}: {gaze} vs {want}");
                // The picture's up is the model's up.
                let (_, screen_up, _) = cam.basis();
                assert!(screen_up.dot(up) > 0.8, "{up} {p:?}: {screen_up}");
            }
            o.preset(ViewPreset::Top);
            let cam = o.camera();
            assert!((cam.target - cam.eye).normalize().dot(-up) > 0.9999);
        }
    }

    #[test]
    fn zoom_keeps_the_point_under_the_pointer() {
        let mut o = orbit(Vec3::Y);
        o.orbit(37.0, -21.0);
        let pixel = Vec2::new(500.0, 120.0);
        let p = o.point_on_target_plane(pixel, SIZE);
        let before = o.distance;
        o.zoom_about(0.5, p);
        let (at, _) = o.camera().project(p, SIZE).expect("in front");
        assert!(at.distance(pixel) < 1e-2, "{at} vs {pixel}");
        assert!((o.distance - before * 0.5).abs() < 1e-5);
        // Degenerate factors are refused, not applied.
        o.zoom_about(f32::NAN, p);
        assert!(o.distance.is_finite());
    }

    #[test]
    fn pan_moves_the_target_with_the_pointer() {
        let mut o = orbit(Vec3::Z);
        let before = o.camera();
        let mark = o.target;
        let (p0, _) = before.project(mark, SIZE).expect("in front");
        o.pan(30.0, -12.0, SIZE[1] as f32);
        let (p1, _) = o.camera().project(mark, SIZE).expect("in front");
        assert!(
            (p1 - p0 - Vec2::new(30.0, -12.0)).length() < 1e-2,
            "{p0} {p1}"
        );
    }

    #[test]
    fn framing_holds_the_whole_box() {
        let mut o = orbit(Vec3::Y);
        o.orbit(80.0, 40.0);
        o.frame(Vec3::new(10.0, 0.0, 0.0), Vec3::new(14.0, 1.0, 2.0), 1.6);
        let cam = o.camera();
        for c in 0..8 {
            let p = Vec3::new(
                if c & 1 == 0 { 10.0 } else { 14.0 },
                if c & 2 == 0 { 0.0 } else { 1.0 },
                if c & 4 == 0 { 0.0 } else { 2.0 },
            );
            let (at, _) = cam.project(p, SIZE).expect("in front");
            assert!(
                at.x >= 0.0 && at.y >= 0.0 && at.x <= 640.0 && at.y <= 400.0,
                "{p}: {at}"
            );
        }
        o.orthographic = true;
        let (at, _) = o.camera().project(o.target, SIZE).expect("in front");
        assert!(at.distance(Camera::centre_pixel(SIZE)) < 1e-3);
    }

    #[test]
    fn orbiting_about_a_point_keeps_it_where_it_is_in_the_picture() {
        for up in [Vec3::Y, Vec3::Z] {
            let mut o = orbit(up);
            o.orbit(20.0, -10.0);
            let p = o.target + Vec3::new(0.3, -0.2, 0.25);
            let size = [640, 480];
            let before = o.camera().project(p, size).expect("in view").0;
            let target = o.target;
            o.orbit_about(35.0, 12.0, p);
            let after = o.camera().project(p, size).expect("in view").0;
            assert!(before.distance(after) < 1e-2, "{up}: {before} -> {after}");
            assert!(o.target.distance(target) > 1e-3, "the view turned about p");
        }
    }
}
