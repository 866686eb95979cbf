//! The scene file (`*.scene.json`): plain data, read and written with serde.
//! Unknown keys are refused with their JSON path.

use csrbf::Kernel;
use serde::{Deserialize, Serialize};

pub use crate::rotation::Interpolation;
pub use crate::track::Easing;

/// A whole scene as written in its file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    /// Length of the animation in seconds (> 0).
    pub duration: f64,
    /// Frames per second for movies. Default 30.
    #[serde(default = "default_fps")]
    pub fps: f64,
    /// Picture size in pixels. Default 1024 x 768.
    #[serde(default = "default_size")]
    pub size: [u32; 2],
    /// Background colour, linear RGB in [0, 1].
    #[serde(default = "default_background")]
    pub background: [f32; 3],
    /// The camera.
    pub camera: CameraFile,
    /// Directional lights; one from the upper left when empty.
    #[serde(default)]
    pub lights: Vec<LightFile>,
    /// The animation objects.
    pub objects: Vec<ObjectFile>,
}

fn default_fps() -> f64 {
    30.0
}
fn default_size() -> [u32; 2] {
    [1024, 768]
}
fn default_background() -> [f32; 3] {
    [0.035, 0.04, 0.05]
}

/// A pinhole camera.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraFile {
    /// Where the eye is.
    pub eye: [f64; 3],
    /// What it looks at.
    pub target: [f64; 3],
    /// Up direction. Default +Y.
    #[serde(default = "default_up")]
    pub up: [f64; 3],
    /// Vertical field of view in degrees. Default 35.
    #[serde(default = "default_fov")]
    pub fov: f64,
}

fn default_up() -> [f64; 3] {
    [0.0, 1.0, 0.0]
}
fn default_fov() -> f64 {
    35.0
}

/// A directional light.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightFile {
    /// Direction the light travels.
    pub direction: [f64; 3],
    /// Colour, linear RGB. Default white.
    #[serde(default = "default_white")]
    pub color: [f32; 3],
    /// Intensity. Default 1.
    #[serde(default = "default_one")]
    pub intensity: f32,
}

fn default_white() -> [f32; 3] {
    [1.0, 1.0, 1.0]
}
fn default_one() -> f32 {
    1.0
}

/// An animation object: a mesh, its parts, its movement and turning.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectFile {
    /// Unique name.
    pub name: String,
    /// Mesh file, relative to the scene file.
    pub mesh: String,
    /// Uniform scale that places the mesh in the scene. Default 1. The
    /// object's control files and part regions stay in the mesh's own units.
    #[serde(default = "default_scale")]
    pub scale: f64,
    /// Base rotation that places the mesh in the scene (after `scale`, about
    /// the mesh's origin): stands up a model made with another up axis.
    /// Orientation keys turn the object from there. The object's control
    /// files and part regions stay in the mesh's own axes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rotation: Option<RotationFile>,
    /// Parts with their look and deformations; one part of the whole mesh when empty.
    #[serde(default)]
    pub parts: Vec<PartFile>,
    /// Position keys of the object's frame (Kochanek-Bartels); fixed at the origin when empty.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub trajectory: Vec<PositionKeyFile>,
    /// Orientation keys, about the object's centre of gravity; none when empty.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub orientation: Vec<OrientationKeyFile>,
    /// `squad` (smooth, default) or `slerp`.
    #[serde(default)]
    pub interpolation: Interpolation,
    /// Deformation by contact with another object, rebuilt every frame.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub contact: Option<ContactFile>,
}

fn default_scale() -> f64 {
    1.0
}

/// A part of an object.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PartFile {
    /// Name of the part.
    pub name: String,
    /// Which faces: `"all"`, `{"group": name}` (a group, object or material of
    /// the mesh), or a region `{"sphere": ...}`, `{"box": ...}` (faces whose
    /// every corner lies inside).
    #[serde(default = "default_all")]
    pub select: serde_json::Value,
    /// Colour, linear RGB or RGBA in [0, 1]. Default light grey.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub color: Option<Color>,
    /// Texture image (PNG or JPEG), relative to the scene file; uses the mesh's UVs.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub texture: Option<String>,
    /// Draw this part's edges. Default false.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub wireframe: bool,
    /// Deformations of this part, each with its phase track.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub deformations: Vec<DeformationFile>,
}

fn default_all() -> serde_json::Value {
    serde_json::Value::String("all".into())
}

/// A deformation of a part: a control file and its phase over time.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DeformationFile {
    /// Control file (JSON), relative to the scene file, in the mesh's units.
    pub controls: String,
    /// Phase keys; phase 1 throughout when empty.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub phase: Vec<PhaseKeyFile>,
    /// `smooth` (default) or `linear` between phase keys.
    #[serde(default)]
    pub easing: Easing,
}

/// A phase key.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PhaseKeyFile {
    /// Time in seconds.
    pub time: f64,
    /// Phase in [0, 1].
    pub phase: f64,
}

/// A position key with its Kochanek-Bartels parameters.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PositionKeyFile {
    /// Time in seconds (the timing mark).
    pub time: f64,
    /// Position of the object's frame.
    pub position: [f64; 3],
    /// Tension in [-1, 1]. Default 0.
    #[serde(default)]
    pub tension: f64,
    /// Continuity in [-1, 1]. Default 0.
    #[serde(default)]
    pub continuity: f64,
    /// Bias in [-1, 1]. Default 0.
    #[serde(default)]
    pub bias: f64,
}

/// A rotation: exactly one of a quaternion, an axis and angle, or Euler
/// angles (an orientation key without its time).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RotationFile {
    /// Quaternion `[x, y, z, w]`; normalised with a warning when not unit.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub quaternion: Option<[f64; 4]>,
    /// Rotation axis, with `angle`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axis: Option<[f64; 3]>,
    /// Angle in degrees, with `axis`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub angle: Option<f64>,
    /// Euler angles in degrees about X, Y, Z (applied in that order).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub euler: Option<[f64; 3]>,
}

impl RotationFile {
    /// The rotation as Euler angles in degrees about X, Y, Z (applied in
    /// that order), whichever way it is given; `None` unless exactly one
    /// usable way is (the loader names what is wrong).
    pub fn euler_degrees(&self) -> Option<[f64; 3]> {
        use crate::rotation::OrientationKey;
        let q = match (self.quaternion, self.axis, self.angle, self.euler) {
            (None, None, None, Some(e)) => return Some(e),
            (Some(q), None, None, None) => {
                let q = glam::DQuat::from_array(q);
                let len = q.length();
                if !(len > 1e-9 && len.is_finite()) {
                    return None;
                }
                q / len
            }
            (None, Some(axis), Some(angle), None)
                if glam::DVec3::from_array(axis).length() > 0.0 =>
            {
                OrientationKey::from_axis_angle(0.0, glam::DVec3::from_array(axis), angle).rotation
            }
            _ => return None,
        };
        let (z, y, x) = q.to_euler(glam::EulerRot::ZYX);
        Some([x.to_degrees(), y.to_degrees(), z.to_degrees()])
    }
}

/// An orientation key: exactly one of a quaternion, an axis and angle, or Euler angles.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OrientationKeyFile {
    /// Time in seconds.
    pub time: f64,
    /// Quaternion `[x, y, z, w]`; normalised with a warning when not unit.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub quaternion: Option<[f64; 4]>,
    /// Rotation axis, with `angle`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axis: Option<[f64; 3]>,
    /// Angle in degrees, with `axis`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub angle: Option<f64>,
    /// Euler angles in degrees about X, Y, Z (applied in that order).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub euler: Option<[f64; 3]>,
}

/// Contact with another object: where that object (a ball) penetrates this
/// one, the vertices inside it are pushed out to its surface by control
/// vectors, and the deformation is rebuilt and solved every frame (the
/// papers' ball in a deformable box).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ContactFile {
    /// Name of the object that pushes (its bounding sphere is used).
    pub with: String,
    /// Kernel. Default c2.
    #[serde(default)]
    pub kernel: Kernel,
    /// The radius of support is this many times the penetration depth plus
    /// the pusher's radius. Default 1.5.
    #[serde(default = "default_reach")]
    pub reach: f64,
}

fn default_reach() -> f64 {
    1.5
}

impl SceneFile {
    /// Parses a scene file; errors carry the JSON path of the problem.
    pub fn parse(text: &str) -> Result<SceneFile, ParseError> {
        let text = csrbf_edit::json::strip_bom(text);
        csrbf_edit::json::check_duplicate_keys(text).map_err(|e| ParseError {
            at: format!("line {}", e.second_line),
            message: e.to_string(),
        })?;
        let de = &mut serde_json::Deserializer::from_str(text);
        serde_path_to_error::deserialize(de).map_err(|e| {
            let path = e.path().to_string();
            let inner = e.into_inner();
            let place = format!("line {}, column {}", inner.line(), inner.column());
            let at = match (path.as_str(), inner.classify()) {
                // A field missing from the whole scene: its end is no place.
                (".", serde_json::error::Category::Data) => "the scene's top level".to_owned(),
                (_, serde_json::error::Category::Data) => path,
                // Broken JSON: the place first, and where in the scene.
                (".", _) => place,
                _ => format!("{place} (in {path})"),
            };
            // serde_json ends its message with the place, said above.
            ParseError {
                at,
                message: csrbf_edit::json::message_without_place(&inner),
            }
        })
    }

    /// The file's text, pretty-printed.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).unwrap_or_default()
    }
}

/// A scene file that does not parse: where (a JSON path such as
/// `objects[0].trajectory[2].time`, or a line and column) and why.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{at}: {message}")]
pub struct ParseError {
    /// JSON path, or line and column.
    pub at: String,
    /// What is wrong.
    pub message: String,
}

/// A colour: linear RGB or RGBA, each in [0, 1] (written as 3 or 4 numbers).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "Vec<f32>", into = "Vec<f32>")]
pub struct Color(pub [f32; 4]);

impl Color {
    /// An opaque colour.
    pub fn rgb(r: f32, g: f32, b: f32) -> Color {
        Color([r, g, b, 1.0])
    }
}

impl TryFrom<Vec<f32>> for Color {
    type Error = String;
    fn try_from(v: Vec<f32>) -> Result<Color, String> {
        if !(v.len() == 3 || v.len() == 4) || !v.iter().all(|c| (0.0..=1.0).contains(c)) {
            return Err(format!(
                "expected 3 or 4 numbers in [0, 1] (RGB or RGBA), got {v:?}"
            ));
        }
        Ok(Color([v[0], v[1], v[2], v.get(3).copied().unwrap_or(1.0)]))
    }
}

impl From<Color> for Vec<f32> {
    fn from(c: Color) -> Vec<f32> {
        if c.0[3] == 1.0 {
            c.0[..3].to_vec()
        } else {
            c.0.to_vec()
        }
    }
}
