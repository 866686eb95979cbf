//! A one-object scene of a mesh, for still pictures and picking: what
//! `csrbf render` and `csrbf pick` look at, and what the studio's viewport
//! shows of the document it edits.

use std::path::Path;

use csrbf_edit::controls::ControlFile;
use csrbf_mesh::Mesh;
use glam::Vec3;

use crate::camera::{Camera, ViewPreset};
use crate::file::{
    CameraFile, Color, DeformationFile, ObjectFile, PartFile, PhaseKeyFile, SceneFile,
};
use crate::scene::{Assets, Scene};
use crate::{AnimError, Result};

/// Clay, for meshes without a texture of their own.
pub const CLAY: [f32; 3] = [0.78, 0.62, 0.45];
/// The background of stills.
pub const BACKGROUND: [f32; 3] = [0.035, 0.04, 0.05];

/// A scene of `mesh` (read from `mesh_path`, given as a value so it is not
/// read again), deformed at `phase` by `controls` (a control file and its
/// path) when given, seen from a three-quarter view about the model's
/// guessed up axis that frames its rest shape in a picture of `size`. A
/// textured model shows its own image; others are clay.
pub fn mesh_scene(
    mesh_path: &Path,
    mesh: Mesh,
    controls: Option<(&Path, ControlFile)>,
    phase: f64,
    size: [u32; 2],
) -> Result<Scene> {
    let (lo, hi) = mesh.bounds().ok_or_else(|| AnimError::Scene {
        path: mesh_path.to_owned(),
        at: "mesh".into(),
        message: "the mesh has no vertices".into(),
    })?;
    let (up, _) = csrbf_mesh::guess_up(&mesh, mesh_path);
    let aspect = size[0] as f32 / size[1].max(1) as f32;
    let dir = Camera::preset_direction(ViewPreset::Iso, up);
    let cam = Camera::framing(dir, up, lo, hi, 35.0, aspect, 1.0);
    let textured = mesh.materials.iter().any(|m| m.texture.is_some());
    let mut assets = Assets::new();
    let deformations = match controls {
        Some((path, file)) => {
            // Keyed as the scene's loader resolves the name (`a/../b` as
            // `b`), or it would read the file again.
            assets.set_controls(
                crate::path::resolve(Path::new(""), &path.display().to_string()),
                file,
            );
            vec![DeformationFile {
                controls: path.display().to_string(),
                phase: vec![PhaseKeyFile { time: 0.0, phase }],
                easing: crate::Easing::Linear,
            }]
        }
        None => Vec::new(),
    };
    assets.set_mesh(
        crate::path::resolve(Path::new(""), &mesh_path.display().to_string()),
        mesh,
    );
    let v = |v: Vec3| v.as_dvec3().to_array();
    let file = SceneFile {
        duration: 1.0,
        fps: 30.0,
        size,
        background: BACKGROUND,
        camera: CameraFile {
            eye: v(cam.eye),
            target: v(cam.target),
            up: v(cam.up),
            fov: 35.0,
        },
        lights: vec![],
        objects: vec![ObjectFile {
            name: "mesh".into(),
            mesh: mesh_path.display().to_string(),
            scale: 1.0,
            rotation: None,
            parts: vec![PartFile {
                name: "all".into(),
                select: "all".into(),
                color: Some(if textured {
                    Color([1.0; 4])
                } else {
                    Color([CLAY[0], CLAY[1], CLAY[2], 1.0])
                }),
                texture: None,
                wireframe: false,
                deformations,
            }],
            trajectory: vec![],
            orientation: vec![],
            interpolation: crate::Interpolation::Squad,
            contact: None,
        }],
    };
    Scene::from_file_with(file, Path::new(""), mesh_path, &assets)
}
