//! Aiming: the camera flags `render` and `pick` share, and the scene they
//! look at with the camera those flags describe.

use std::path::Path;

use anyhow::{Context, Result, bail};
use csrbf_anim::camera::parse_axis;
use csrbf_anim::{Camera, CameraFile, Scene, ViewPreset};
use csrbf_mesh::Mesh;
use glam::Vec3;

use crate::look::mesh_scene;

/// Where the camera stands: a preset view or an explicit eye, the model's up
/// axis, the field of view and a zoom.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct CameraArgs {
    /// Look from: front, back, left, right, top, bottom or iso (default iso).
    #[arg(long)]
    pub view: Option<String>,
    /// The model's up axis: x, y, z, -x, -y, -z or a direction X,Y,Z (default: guessed from the model, and said).
    #[arg(long, allow_hyphen_values = true)]
    pub up: Option<String>,
    /// Eye position X,Y,Z (overrides --view).
    #[arg(long, allow_hyphen_values = true)]
    pub eye: Option<String>,
    /// Point looked at X,Y,Z (default: the centre of the deformed model).
    #[arg(long, allow_hyphen_values = true)]
    pub target: Option<String>,
    /// Vertical field of view in degrees.
    #[arg(long, default_value_t = 35.0)]
    pub fov: f32,
    /// Closer (> 1) or farther (< 1) than the framing of the whole model.
    #[arg(long, default_value_t = 1.0)]
    pub zoom: f32,
    /// Parallel projection (no perspective): sizes compare across the picture.
    #[arg(long)]
    pub ortho: bool,
}

/// Parses `X,Y,Z`.
fn parse_point(flag: &str, s: &str) -> Result<Vec3> {
    let v: Vec<f32> = s
        .split(',')
        .map(|x| x.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .ok()
        .filter(|v: &Vec<f32>| v.len() == 3 && v.iter().all(|x| x.is_finite()))
        .with_context(|| format!("{flag} {s:?}: expected three finite numbers X,Y,Z"))?;
    Ok(Vec3::new(v[0], v[1], v[2]))
}

impl CameraArgs {
    /// The camera for a picture of `size` of the box `lo`..`hi`, with `up`
    /// the model's up axis.
    pub fn camera(&self, lo: Vec3, hi: Vec3, up: Vec3, size: [u32; 2]) -> Result<Camera> {
        if !(self.fov > 1.0 && self.fov < 179.0) {
            bail!("--fov {}: must be within (1, 179) degrees", self.fov);
        }
        if !(self.zoom > 0.0 && self.zoom.is_finite()) {
            bail!("--zoom {}: must be a finite number > 0", self.zoom);
        }
        let preset: ViewPreset = self
            .view
            .as_deref()
            .unwrap_or("iso")
            .parse()
            .map_err(|e: String| anyhow::anyhow!("--view: {e}"))?;
        let aspect = size[0] as f32 / size[1] as f32;
        let dir = Camera::preset_direction(preset, up);
        let mut cam = Camera::framing(dir, up, lo, hi, self.fov, aspect, self.zoom);
        if self.ortho {
            cam = cam.orthographic_framing(lo, hi, aspect, self.zoom);
        }
        if let Some(t) = &self.target {
            let target = parse_point("--target", t)?;
            let shift = target - cam.target;
            cam.target = target;
            cam.eye += shift;
        }
        if let Some(e) = &self.eye {
            cam.eye = parse_point("--eye", e)?;
            if self.zoom != 1.0 {
                cam.eye = cam.target + (cam.eye - cam.target) / self.zoom;
            }
        }
        cam.check().map_err(|e| {
            anyhow::anyhow!("camera (--eye, --target, --up): {e}; eye and target must differ and up must not point along the view")
        })?;
        Ok(cam)
    }

    /// The up axis given, or guessed from the model (with the reason).
    pub fn up(&self, mesh: &Mesh, path: &Path) -> Result<(Vec3, String)> {
        match &self.up {
            Some(u) => Ok((
                parse_axis(u).map_err(|e| anyhow::anyhow!("--up: {e}"))?,
                "given".into(),
            )),
            None => {
                let (u, why) = csrbf_mesh::guess_up(mesh, path);
                Ok((u, format!("guessed: {why}; give --up to change")))
            }
        }
    }
}

/// A one-object scene of a mesh (deformed at `phase` when controls are
/// given) seen by the camera the flags describe: the picture `render` draws
/// and `pick` looks into.
pub struct Aimed {
    /// The scene, its camera set.
    pub scene: Scene,
    /// The camera.
    pub camera: Camera,
    /// The rest mesh.
    pub mesh: Mesh,
    /// The up axis and why.
    pub up: (Vec3, String),
    /// The model's positions in the picture (deformed at the phase).
    pub positions: Vec<Vec3>,
}

/// Loads the mesh and controls and aims the camera at the deformed model.
pub fn aim(
    mesh_path: &Path,
    controls: Option<&Path>,
    phase: f64,
    size: [u32; 2],
    args: &CameraArgs,
    with_rest: bool,
) -> Result<Aimed> {
    let (mut scene, mesh) = mesh_scene(mesh_path, controls, phase, size)?;
    let up = args.up(&mesh, mesh_path)?;
    // Frame the deformed model, so a large edit stays in the picture (and
    // the rest one too when both are shown).
    let positions = scene.frame(0.0).objects.swap_remove(0).positions;
    let rest: &[Vec3] = if with_rest { &mesh.positions } else { &[] };
    let (lo, hi) = positions
        .iter()
        .chain(rest)
        .filter(|p| p.is_finite())
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(*p), hi.max(*p))
        });
    if !lo.is_finite() || !hi.is_finite() {
        bail!(
            "{}: the mesh has no finite vertex to look at",
            mesh_path.display()
        );
    }
    // A model whose points all coincide still gets a picture.
    let pad = ((hi - lo).length() * 1e-3).max(1e-3 * lo.abs().max(hi.abs()).max_element().max(1.0));
    let (lo, hi) = (lo - Vec3::splat(pad), hi + Vec3::splat(pad));
    let camera = args.camera(lo, hi, up.0, size)?;
    let Camera {
        eye,
        target,
        up: cam_up,
        ..
    } = camera;
    let fov = match camera.projection {
        csrbf_anim::Projection::Perspective { fov } => fov as f64,
        csrbf_anim::Projection::Orthographic { .. } => args.fov as f64,
    };
    scene.file.camera = CameraFile {
        eye: eye.as_dvec3().to_array(),
        target: target.as_dvec3().to_array(),
        up: cam_up.as_dvec3().to_array(),
        fov,
    };
    Ok(Aimed {
        scene,
        camera,
        mesh,
        up,
        positions,
    })
}
