//! What `render`, `pick`, `animate` and `demo` share: the look flags, picture
//! sizes, and the one-object scene of a mesh.

use std::path::Path;

use anyhow::{Context, Result, bail};
use csrbf_anim::Scene;
use csrbf_render::{Overlay, SceneOptions};

use crate::common::Progress;

/// Look options shared by `render` and `animate`.
#[derive(clap::Args, Clone, Copy, Debug)]
pub struct LookArgs {
    /// Flat shading (one normal per face).
    #[arg(long)]
    pub flat: bool,
    /// Draw the mesh's edges.
    #[arg(long)]
    pub wireframe: bool,
    /// Draw the control vectors: `full` (starts, arrows, support spheres; the default
    /// when the flag has no value) or `arrows` (starts and arrows, for many vectors).
    #[arg(long, num_args = 0..=1, default_missing_value = "full", value_parser = parse_overlay)]
    pub overlay: Option<Overlay>,
    /// Draw an axis gizmo (X red, Y green, Z blue) in the lower left corner.
    #[arg(long)]
    pub gizmo: bool,
}

fn parse_overlay(s: &str) -> Result<Overlay, String> {
    s.parse()
}

impl LookArgs {
    pub fn options(&self) -> SceneOptions {
        let mut o = SceneOptions::default();
        o.draw.flat = self.flat;
        o.draw.wireframe = self.wireframe;
        o.overlay = self.overlay.unwrap_or_default();
        o.gizmo = self.gizmo;
        o
    }
}

/// Parses `WxH`.
pub fn parse_size(s: &str) -> Result<[u32; 2]> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .with_context(|| format!("--size {s:?}: expected WIDTHxHEIGHT, e.g. 1024x768"))?;
    let w: u32 = w
        .trim()
        .parse()
        .with_context(|| format!("--size {s:?}: width is not a whole number"))?;
    let h: u32 = h
        .trim()
        .parse()
        .with_context(|| format!("--size {s:?}: height is not a whole number"))?;
    if w == 0 || h == 0 || w > csrbf_anim::MAX_SIDE || h > csrbf_anim::MAX_SIDE {
        bail!(
            "--size {s:?}: each side must be within 1..{} pixels",
            csrbf_anim::MAX_SIDE
        );
    }
    Ok([w, h])
}

/// The picture size of `render` and `pick` unless `--size` says otherwise.
pub const DEFAULT_SIZE: [u32; 2] = [1024, 768];

/// The `--size` given, or `default`.
pub fn size_or(size: Option<&str>, default: [u32; 2]) -> Result<[u32; 2]> {
    Ok(size.map(parse_size).transpose()?.unwrap_or(default))
}

/// A one-object scene of a mesh, deformed at `phase` by a control file when
/// given (`csrbf_anim::still::mesh_scene`; `view::aim` sets the camera the
/// flags ask for); also gives the mesh as read.
pub fn mesh_scene(
    mesh: &Path,
    controls: Option<&Path>,
    phase: f64,
    size: [u32; 2],
) -> Result<(Scene, csrbf_mesh::Mesh)> {
    if crate::volume::is_volume(mesh) {
        // The boundary surface, morphed by the volume road; the scene shows
        // it as it is (no controls of its own).
        let p = crate::volume::picture(mesh, controls, phase, false)?;
        let mut moved = p.rest.clone();
        moved.positions = p.moved;
        // The scene names its mesh by the path made whole (`..` resolved),
        // and finds the surface given under that name.
        let key = mesh.canonicalize().unwrap_or_else(|_| mesh.to_owned());
        let scene = csrbf_anim::still::mesh_scene(&key, moved, None, 0.0, size)?;
        return Ok((scene, p.rest));
    }
    let m = csrbf_mesh::read(mesh)?;
    let quiet = Progress::new(false);
    let controls = controls
        .map(|c| crate::common::read_controls(c, &quiet).map(|f| (c, f)))
        .transpose()?;
    let scene = csrbf_anim::still::mesh_scene(mesh, m.clone(), controls, phase, size)?;
    Ok((scene, m))
}
