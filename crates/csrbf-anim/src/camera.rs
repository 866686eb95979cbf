//! The one camera of csrbf: pictures (`csrbf render`, movies), scenes, picking
//! (`csrbf pick`) and the studio's viewport all go through [`Camera`], so a
//! pixel picked is the pixel drawn.
//!
//! Pixels: `(0, 0)` is the top-left corner of the picture, `x` grows to the
//! right and `y` down; the centre of pixel `(i, j)` is `(i + 0.5, j + 0.5)`.
//! Clip space is wgpu's (depth in [0, 1], right-handed view).

use csrbf_mesh::Ray;
use glam::camera::rh::proj::directx;
use glam::{Mat4, Vec2, Vec3, Vec4Swizzles};

/// How the camera projects.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// A pinhole with this vertical field of view, in degrees, within (0, 180).
    Perspective {
        /// Vertical field of view in degrees.
        fov: f32,
    },
    /// Parallel rays; `height` world units fill the picture's height.
    Orthographic {
        /// World units from the bottom to the top of the picture.
        height: f32,
    },
}

/// A camera looking from `eye` at `target`, with `up` pointing up in the picture.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Eye position.
    pub eye: Vec3,
    /// Point looked at (the centre of the picture).
    pub target: Vec3,
    /// Up direction (need not be orthogonal to the view, only not parallel).
    pub up: Vec3,
    /// Perspective or orthographic.
    pub projection: Projection,
}

/// Why a camera cannot be used.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum CameraError {
    /// Eye or target is not finite, or they coincide.
    #[error("eye {eye:?} and target {target:?} must be finite and distinct")]
    EyeAtTarget {
        /// Eye.
        eye: Vec3,
        /// Target.
        target: Vec3,
    },
    /// Up is zero, not finite, or parallel to the direction of view.
    #[error("up {up:?} must be finite and not parallel to the view direction {view:?}")]
    BadUp {
        /// Up.
        up: Vec3,
        /// Direction of view.
        view: Vec3,
    },
    /// A field of view outside (0, 180) degrees or an orthographic height <= 0.
    #[error("{0}")]
    BadProjection(String),
}

/// Directions to look from, for framing a model (`--view`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ViewPreset {
    /// Looking along -forward (from the front).
    Front,
    /// From behind.
    Back,
    /// From the model's left.
    Left,
    /// From the model's right.
    Right,
    /// From above.
    Top,
    /// From below.
    Bottom,
    /// A three-quarter view from the front, right and above.
    Iso,
}

impl std::str::FromStr for ViewPreset {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Ok(match s.to_ascii_lowercase().as_str() {
            "front" => ViewPreset::Front,
            "back" => ViewPreset::Back,
            "left" => ViewPreset::Left,
            "right" => ViewPreset::Right,
            "top" => ViewPreset::Top,
            "bottom" => ViewPreset::Bottom,
            "iso" => ViewPreset::Iso,
            _ => {
                return Err(format!(
                    "unknown view {s:?}: expected front, back, left, right, top, bottom or iso"
                ));
            }
        })
    }
}

/// Parses an axis: `x`, `y`, `z`, `-x`, `-y`, `-z` (also `+x`), or any
/// direction as three numbers `X,Y,Z` (a scan that stands tilted in its
/// frame), returned unit length.
pub fn parse_axis(s: &str) -> Result<Vec3, String> {
    Ok(
        match s.trim().to_ascii_lowercase().trim_start_matches('+') {
            "x" => Vec3::X,
            "y" => Vec3::Y,
            "z" => Vec3::Z,
            "-x" => Vec3::NEG_X,
            "-y" => Vec3::NEG_Y,
            "-z" => Vec3::NEG_Z,
            t if t.contains(',') => {
                let v: Vec<f32> = t
                    .split(',')
                    .map(|x| x.trim().parse::<f32>())
                    .collect::<Result<_, _>>()
                    .map_err(|_| format!("axis {s:?}: expected three numbers X,Y,Z"))?;
                let [x, y, z] = v[..] else {
                    return Err(format!(
                        "axis {s:?}: expected three numbers X,Y,Z, got {}",
                        v.len()
                    ));
                };
                let d = Vec3::new(x, y, z);
                if !d.is_finite() || d.length() < 1e-6 {
                    return Err(format!(
                        "axis {s:?}: a direction must be finite and not zero"
                    ));
                }
                d.normalize()
            }
            _ => {
                return Err(format!(
                    "unknown axis {s:?}: expected x, y, z, -x, -y, -z or a direction X,Y,Z"
                ));
            }
        },
    )
}

/// Names an axis-aligned unit vector (`+Y`), or prints it.
pub fn axis_name(v: Vec3) -> String {
    for (a, n) in [
        (Vec3::X, "+X"),
        (Vec3::Y, "+Y"),
        (Vec3::Z, "+Z"),
        (Vec3::NEG_X, "-X"),
        (Vec3::NEG_Y, "-Y"),
        (Vec3::NEG_Z, "-Z"),
    ] {
        if v == a {
            return n.to_owned();
        }
    }
    format!("({:.3}, {:.3}, {:.3})", v.x, v.y, v.z)
}

/// The lights of a scene that lists none, as (direction travelled, grey
/// level): a key light from the camera's upper left and a weaker fill from
/// its right. What `csrbf animate` draws and `csrbf export` writes.
pub fn default_lights(camera: &Camera) -> [(Vec3, f32); 2] {
    let fwd = (camera.target - camera.eye).normalize_or(Vec3::NEG_Z);
    let right = fwd.cross(camera.up).normalize_or(Vec3::X);
    let up = right.cross(fwd);
    [
        ((fwd - up * 0.8 + right * 0.6).normalize(), 0.85),
        ((fwd + up * 0.2 - right * 0.9).normalize(), 0.3),
    ]
}

impl Camera {
    /// A perspective camera.
    pub fn perspective(eye: Vec3, target: Vec3, up: Vec3, fov: f32) -> Camera {
        Camera {
            eye,
            target,
            up,
            projection: Projection::Perspective { fov },
        }
    }

    /// Checks that the camera defines a view.
    pub fn check(&self) -> Result<(), CameraError> {
        let view = self.target - self.eye;
        if !self.eye.is_finite() || !self.target.is_finite() || !(view.length() > 0.0) {
            return Err(CameraError::EyeAtTarget {
                eye: self.eye,
                target: self.target,
            });
        }
        let side = view.normalize().cross(self.up.normalize_or_zero());
        if !self.up.is_finite() || !(side.length() > 1e-4) {
            return Err(CameraError::BadUp { up: self.up, view });
        }
        match self.projection {
            Projection::Perspective { fov } if !(fov > 0.0 && fov < 180.0) => {
                Err(CameraError::BadProjection(format!(
                    "field of view {fov} must be within (0, 180) degrees"
                )))
            }
            Projection::Orthographic { height } if !(height > 0.0 && height.is_finite()) => Err(
                CameraError::BadProjection(format!("orthographic height {height} must be > 0")),
            ),
            _ => Ok(()),
        }
    }

    /// The orthonormal frame of the view: right, up, forward (towards the target).
    pub fn basis(&self) -> (Vec3, Vec3, Vec3) {
        let fwd = (self.target - self.eye).normalize_or(Vec3::NEG_Z);
        let right = fwd.cross(self.up).normalize_or(Vec3::X);
        let up = right.cross(fwd);
        (right, up, fwd)
    }

    /// The world-to-view matrix.
    pub fn view(&self) -> Mat4 {
        glam::camera::rh::view::look_at_mat4(self.eye, self.target, self.up)
    }

    /// The projection for a picture of this aspect (width / height) between
    /// the near and far planes (distances along the view direction).
    pub fn proj(&self, aspect: f32, near: f32, far: f32) -> Mat4 {
        match self.projection {
            Projection::Perspective { fov } => {
                directx::perspective(fov.to_radians(), aspect, near, far)
            }
            Projection::Orthographic { height } => {
                let (hw, hh) = (height * 0.5 * aspect, height * 0.5);
                directx::orthographic(-hw, hw, -hh, hh, near, far)
            }
        }
    }

    /// World to clip space.
    pub fn view_proj(&self, aspect: f32, near: f32, far: f32) -> Mat4 {
        self.proj(aspect, near, far) * self.view()
    }

    /// Half the picture's height at unit distance (perspective) or in world
    /// units (orthographic).
    fn half_height(&self) -> f32 {
        match self.projection {
            Projection::Perspective { fov } => (fov.to_radians() * 0.5).tan(),
            Projection::Orthographic { height } => height * 0.5,
        }
    }

    /// The ray through a point of the picture (pixel coordinates, see the
    /// module docs) of a picture `size` pixels wide and high.
    pub fn ray(&self, pixel: Vec2, size: [u32; 2]) -> Ray {
        let (w, h) = (size[0].max(1) as f32, size[1].max(1) as f32);
        let (right, up, fwd) = self.basis();
        // Normalised device coordinates, y up.
        let nx = pixel.x / w * 2.0 - 1.0;
        let ny = 1.0 - pixel.y / h * 2.0;
        let hh = self.half_height();
        let hw = hh * w / h;
        match self.projection {
            Projection::Perspective { .. } => Ray::new(
                self.eye,
                (fwd + right * (nx * hw) + up * (ny * hh)).normalize(),
            ),
            Projection::Orthographic { .. } => {
                Ray::new(self.eye + right * (nx * hw) + up * (ny * hh), fwd)
            }
        }
    }

    /// Where a world point lands in a picture `size` pixels wide and high
    /// (pixel coordinates, possibly outside the picture), with its distance
    /// along the view direction; None when it lies behind a perspective eye.
    pub fn project(&self, point: Vec3, size: [u32; 2]) -> Option<(Vec2, f32)> {
        let (w, h) = (size[0].max(1) as f32, size[1].max(1) as f32);
        let (right, up, fwd) = self.basis();
        let d = point - self.eye;
        let depth = d.dot(fwd);
        let hh = self.half_height();
        let hw = hh * w / h;
        let (x, y) = match self.projection {
            Projection::Perspective { .. } => {
                if !(depth > 0.0) {
                    return None;
                }
                (d.dot(right) / depth / hw, d.dot(up) / depth / hh)
            }
            Projection::Orthographic { .. } => (d.dot(right) / hw, d.dot(up) / hh),
        };
        Some((Vec2::new((x + 1.0) * 0.5 * w, (1.0 - y) * 0.5 * h), depth))
    }

    /// A camera looking along `direction` (from the eye towards the model)
    /// that frames the box `lo`..`hi` in a picture of this aspect, with `fov`
    /// degrees vertically; `zoom` > 1 moves closer.
    pub fn framing(
        direction: Vec3,
        up: Vec3,
        lo: Vec3,
        hi: Vec3,
        fov: f32,
        aspect: f32,
        zoom: f32,
    ) -> Camera {
        let centre = (lo + hi) * 0.5;
        let radius = ((hi - lo).length() * 0.5).max(1e-6);
        // The narrower of the two fields of view must hold the bounding sphere.
        let half_v = (fov.to_radians() * 0.5).max(1e-3);
        let half_h = (half_v.tan() * aspect).atan();
        let half = half_v.min(half_h);
        let dist = radius / half.sin() * 1.02 / zoom.max(1e-3);
        let dir = direction.normalize_or(Vec3::NEG_Z);
        // Up must not be parallel to the direction of view.
        let up = if dir.cross(up).length() < 1e-3 {
            dir.any_orthonormal_vector()
        } else {
            up
        };
        Camera::perspective(centre - dir * dist, centre, up, fov)
    }

    /// The same view made orthographic, framing the box `lo`..`hi` as
    /// [`Camera::framing`] does: its bounding sphere fits the narrower side
    /// of a picture of this aspect; `zoom` > 1 shows less.
    pub fn orthographic_framing(self, lo: Vec3, hi: Vec3, aspect: f32, zoom: f32) -> Camera {
        let diameter = (hi - lo).length().max(1e-6) * 1.02;
        Camera {
            projection: Projection::Orthographic {
                height: diameter / zoom.max(1e-3) * (1.0 / aspect).max(1.0),
            },
            ..self
        }
    }

    /// The direction of view for a preset, given the model's up axis.
    /// Forward (the model's front) is taken as +Z when up is Y, -Y when up is
    /// Z, and so on: the right-handed convention of the tools that wrote it.
    pub fn preset_direction(preset: ViewPreset, up: Vec3) -> Vec3 {
        let up = up.normalize_or(Vec3::Y);
        // The model's front: +Z for Y-up, -Y for Z-up (Blender), +Z for
        // X-up; for a tilted up, the nearest axis's front made square to it.
        let a = up.abs();
        let front = if a.z > a.y && a.z >= a.x {
            Vec3::NEG_Y * up.z.signum()
        } else {
            Vec3::Z
        };
        let front = (front - up * front.dot(up)).normalize_or(Vec3::X);
        let right = up.cross(front);
        // The direction travelled by the eye's gaze (towards the model).
        match preset {
            ViewPreset::Front => -front,
            ViewPreset::Back => front,
            ViewPreset::Left => right,
            ViewPreset::Right => -right,
            ViewPreset::Top => -up,
            ViewPreset::Bottom => up,
            ViewPreset::Iso => (-front * 1.0 - right * 0.55 - up * 0.35).normalize(),
        }
    }

    /// The pixel of the picture's point at the view's centre, for tests.
    pub fn centre_pixel(size: [u32; 2]) -> Vec2 {
        Vec2::new(size[0] as f32 * 0.5, size[1] as f32 * 0.5)
    }

    /// Clip-space position of a world point (for checks against the GPU's).
    pub fn clip(&self, point: Vec3, aspect: f32, near: f32, far: f32) -> Vec3 {
        let c = self.view_proj(aspect, near, far) * point.extend(1.0);
        c.xyz() / c.w
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cams() -> Vec<Camera> {
        vec![
            Camera::perspective(
                Vec3::new(3.0, 2.0, 5.0),
                Vec3::new(0.5, 0.2, -0.1),
                Vec3::Y,
                40.0,
            ),
            Camera {
                eye: Vec3::new(-1.0, 4.0, 0.5),
                target: Vec3::ZERO,
                up: Vec3::Z,
                projection: Projection::Orthographic { height: 3.0 },
            },
        ]
    }

    #[test]
    fn axes_are_named_or_typed_as_directions() {
        assert_eq!(parse_axis("-Z"), Ok(Vec3::NEG_Z));
        assert_eq!(parse_axis("+y"), Ok(Vec3::Y));
        let d = parse_axis(" 0, 3, 4 ").expect("a direction");
        assert!((d - Vec3::new(0.0, 0.6, 0.8)).length() < 1e-6);
        assert_eq!(axis_name(d), "(0.000, 0.600, 0.800)");
        for bad in [
            "up", "1,2", "1,2,3,4", "0,0,0", "1,nan,0", "a,b,c", "1e40,0,0",
        ] {
            let e = parse_axis(bad).expect_err(bad);
            assert!(e.contains(bad), "{bad}: {e}");
        }
        // The views of any up are square to it: front and right across it.
        for up in [Vec3::Y, Vec3::NEG_Z, Vec3::new(0.3, 0.2, -0.93).normalize()] {
            let front = Camera::preset_direction(ViewPreset::Front, up);
            let right = Camera::preset_direction(ViewPreset::Left, up);
            assert!(
                front.dot(up).abs() < 1e-6 && right.dot(up).abs() < 1e-6,
                "{up}"
            );
            assert!((front.length() - 1.0).abs() < 1e-6 && (right.length() - 1.0).abs() < 1e-6);
            assert!(front.dot(right).abs() < 1e-6);
            assert_eq!(Camera::preset_direction(ViewPreset::Top, up), -up);
        }
    }

    #[test]
    fn ray_and_project_are_inverse() {
        let size = [640, 480];
        for cam in cams() {
            cam.check().expect("camera");
            for px in [
                Vec2::new(0.5, 0.5),
                Vec2::new(320.0, 240.0),
                Vec2::new(611.3, 17.9),
            ] {
                let ray = cam.ray(px, size);
                let p = ray.at(7.0);
                let (back, depth) = cam.project(p, size).expect("in front");
                assert!(back.distance(px) < 1e-3, "{px} -> {back}");
                assert!(depth > 0.0);
            }
        }
    }

    #[test]
    fn project_agrees_with_the_matrix_the_gpu_uses() {
        let size = [800u32, 600u32];
        let aspect = 800.0 / 600.0;
        for cam in cams() {
            for p in [Vec3::new(0.3, 0.1, 0.2), Vec3::new(-0.4, 0.5, 0.1)] {
                let (px, _) = cam.project(p, size).expect("in front");
                let ndc = cam.clip(p, aspect, 0.01, 100.0);
                let gpu = Vec2::new((ndc.x + 1.0) * 400.0, (1.0 - ndc.y) * 300.0);
                assert!(px.distance(gpu) < 1e-2, "{px} vs {gpu}");
            }
        }
    }

    #[test]
    fn framing_keeps_the_box_in_the_picture() {
        let (lo, hi) = (Vec3::new(-1.0, 0.0, -3.0), Vec3::new(2.0, 9.0, 1.0));
        for preset in [
            ViewPreset::Front,
            ViewPreset::Top,
            ViewPreset::Iso,
            ViewPreset::Left,
        ] {
            for up in [Vec3::Y, Vec3::Z, Vec3::NEG_Y] {
                for size in [[640u32, 480u32], [300, 900]] {
                    let dir = Camera::preset_direction(preset, up);
                    let aspect = size[0] as f32 / size[1] as f32;
                    let persp = Camera::framing(dir, up, lo, hi, 35.0, aspect, 1.0);
                    let ortho = persp.orthographic_framing(lo, hi, aspect, 1.0);
                    for (cam, k) in [persp, ortho]
                        .into_iter()
                        .flat_map(|c| (0..8).map(move |k| (c, k)))
                    {
                        cam.check().expect("camera");
                        let c = Vec3::new(
                            if k & 1 == 0 { lo.x } else { hi.x },
                            if k & 2 == 0 { lo.y } else { hi.y },
                            if k & 4 == 0 { lo.z } else { hi.z },
                        );
                        let (px, _) = cam.project(c, size).expect("in front");
                        assert!(
                            px.x >= 0.0
                                && px.y >= 0.0
                                && px.x <= size[0] as f32
                                && px.y <= size[1] as f32,
                            "{preset:?} up {up}: corner {c} at {px}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn presets_look_the_way_they_say() {
        // Z-up: the top view looks down -Z, the front view along +Y.
        assert_eq!(
            Camera::preset_direction(ViewPreset::Top, Vec3::Z),
            Vec3::NEG_Z
        );
        assert_eq!(
            Camera::preset_direction(ViewPreset::Front, Vec3::Z),
            Vec3::Y
        );
        assert_eq!(
            Camera::preset_direction(ViewPreset::Front, Vec3::Y),
            Vec3::NEG_Z
        );
        assert_eq!(
            Camera::preset_direction(ViewPreset::Bottom, Vec3::NEG_Y),
            Vec3::NEG_Y
        );
    }

    #[test]
    fn bad_cameras_are_named() {
        let mut c = Camera::perspective(Vec3::ONE, Vec3::ONE, Vec3::Y, 40.0);
        assert!(matches!(c.check(), Err(CameraError::EyeAtTarget { .. })));
        c.target = Vec3::new(1.0, 0.0, 1.0);
        assert!(matches!(c.check(), Err(CameraError::BadUp { .. })));
        c.up = Vec3::X;
        c.projection = Projection::Perspective { fov: f32::NAN };
        assert!(matches!(c.check(), Err(CameraError::BadProjection(_))));
        c.projection = Projection::Perspective { fov: 40.0 };
        assert!(c.check().is_ok());
    }
}
