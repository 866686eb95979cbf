//! `render`: a picture of a mesh, deformed or not, from a chosen view.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Result, bail};
use csrbf_render::{Overlay, SceneRenderer};

use crate::common::{Progress, check_output};
use crate::look::{DEFAULT_SIZE, LookArgs, size_or};

/// Options of `render`.
#[derive(clap::Args, Debug)]
pub struct RenderArgs {
    /// The mesh.
    #[arg(long)]
    pub mesh: PathBuf,
    /// A control file to deform it by.
    #[arg(long)]
    pub controls: Option<PathBuf>,
    /// Phase in [0, 1].
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    pub phase: f64,
    /// Output picture (.png).
    #[arg(long)]
    pub out: PathBuf,
    /// Picture size WIDTHxHEIGHT (default 1024x768).
    #[arg(long)]
    pub size: Option<String>,
    #[command(flatten)]
    pub look: LookArgs,
    #[command(flatten)]
    pub camera: crate::view::CameraArgs,
    /// Rest (left) and deformed (right) side by side, seen by one camera.
    #[arg(long)]
    pub before_after: bool,
    /// Draw the faces the deformation turns inside out in red, through the
    /// rest of the surface made see-through (the exact check `deform`
    /// reports; needs --controls).
    #[arg(long)]
    pub folds: bool,
    /// Allow the output to replace an input file.
    #[arg(long)]
    pub force: bool,
}

pub fn render(a: &RenderArgs, progress: &Progress) -> Result<()> {
    crate::common::check_phase(a.phase)?;
    let inputs: Vec<&Path> = std::iter::once(a.mesh.as_path())
        .chain(a.controls.as_deref())
        .collect();
    check_output(&a.out, &inputs, a.force, false)?;
    if a.out.extension().map(|e| e.to_ascii_lowercase()) != Some("png".into()) {
        bail!(
            "{}: pictures are written as PNG; give a .png file",
            a.out.display()
        );
    }
    if a.look.overlay.is_some_and(|o| o != Overlay::Off) && a.controls.is_none() {
        bail!("--overlay draws control vectors: give --controls too");
    }
    let size = size_or(a.size.as_deref(), DEFAULT_SIZE)?;
    if a.before_after && a.controls.is_none() {
        bail!("--before-after shows a deformation: give --controls too");
    }
    if a.folds && a.controls.is_none() {
        bail!("--folds shows where a deformation turns faces inside out: give --controls too");
    }
    if a.before_after && size[0] < 2 {
        bail!("--before-after needs a picture at least 2 pixels wide");
    }
    // Side by side, each half of the picture.
    let panel = if a.before_after {
        [size[0] / 2, size[1]]
    } else {
        size
    };
    let aimed = crate::view::aim(
        &a.mesh,
        a.controls.as_deref(),
        a.phase,
        panel,
        &a.camera,
        a.before_after,
    )?;
    let mut scene = aimed.scene;
    progress.say(format_args!(
        "up {} ({})",
        csrbf_anim::camera::axis_name(aimed.up.0),
        aimed.up.1
    ));
    let volume = crate::volume::is_volume(&a.mesh);
    if volume && !a.folds {
        // A volume mesh's boundary see-through: what is inside it (a
        // cavity's surface, the object the mesh is around) shows.
        for part in &mut scene.objects[0].parts {
            part.color[3] *= SEE_THROUGH;
        }
    }
    if a.folds
        && let Some(c) = &a.controls
    {
        let faces = if volume {
            crate::volume::picture(&a.mesh, Some(c), a.phase, false)?.inverted_faces
        } else {
            let file = crate::common::read_controls(c, progress)?;
            inside_out_faces(&aimed.mesh, &file, a.phase)?
        };
        progress.say(format_args!(
            "{} faces inside out{}",
            faces.len(),
            if faces.is_empty() { "" } else { ", drawn red" }
        ));
        paint(&mut scene.objects[0], &aimed.mesh, faces);
    }
    // Through the exact camera the flags made (orthographic too); `pick` uses it.
    let mut look = a.look.options();
    look.camera = Some(aimed.camera);
    let mut r = SceneRenderer::new(&scene, panel[0], panel[1])?;
    progress.say(format_args!("rendering on {}", r.renderer().adapter()));
    let t = Instant::now();
    let frame = scene.frame(0.0);
    let mut img = r.render(&scene, &frame, look)?;
    if a.before_after {
        let mut rest = frame.clone();
        let obj = &mut rest.objects[0];
        obj.positions.clone_from(&aimed.mesh.positions);
        csrbf_mesh::triangle_vertex_normals_into(
            &obj.positions,
            &aimed.mesh.faces.triangles(),
            &mut obj.normals,
        );
        let before = r.render(&scene, &rest, look)?;
        img = side_by_side(&before, &img, size[0]);
    }
    img.save_png(&a.out)?;
    progress.say(format_args!(
        "wrote {} ({}x{}, {:.0} ms)",
        a.out.display(),
        size[0],
        size[1],
        t.elapsed().as_secs_f64() * 1e3
    ));
    Ok(())
}

/// The red of faces turned inside out.
const FOLD_RED: [f32; 4] = [0.86, 0.08, 0.06, 1.0];

/// The faces of `mesh` that `file` at `phase` turns inside out, as
/// `csrbf deform` finds them (ascending).
fn inside_out_faces(
    mesh: &csrbf_mesh::Mesh,
    file: &csrbf_edit::ControlFile,
    phase: f64,
) -> Result<Vec<u32>> {
    let mut moved = mesh.clone();
    let checks = csrbf_edit::Checks::default().with_self_intersections(Some(false));
    let report = csrbf_edit::apply::deform_mesh_checked(
        &mut moved,
        file,
        phase,
        &checks,
        csrbf_edit::RemedySearch::Off,
    )?;
    // Triangles to the faces they were cut from.
    let mut face_of = Vec::with_capacity(mesh.faces.triangle_count());
    for (f, corners) in mesh.faces.iter().enumerate() {
        face_of.extend(std::iter::repeat_n(
            f as u32,
            corners.len().saturating_sub(2),
        ));
    }
    let mut faces: Vec<u32> = report
        .diagnostics
        .inside_out
        .iter()
        .filter_map(|&t| face_of.get(t as usize).copied())
        .collect();
    faces.dedup();
    Ok(faces)
}

/// The opacity of the rest of the surface when faces are shown inside out:
/// a fold's turned faces lie between two layers of surface, seen through it.
const SEE_THROUGH: f32 = 0.35;

/// Moves `faces` out of the object's parts into a red part of their own
/// (the first part, opaque), and makes the rest see-through.
fn paint(object: &mut csrbf_anim::Object, mesh: &csrbf_mesh::Mesh, faces: Vec<u32>) {
    if faces.is_empty() {
        return;
    }
    for part in &mut object.parts {
        part.faces.retain(|f| faces.binary_search(f).is_err());
        part.color[3] *= SEE_THROUGH;
    }
    let mut vertices: Vec<u32> = faces
        .iter()
        .flat_map(|&f| mesh.faces.face(f as usize).iter().copied())
        .collect();
    vertices.sort_unstable();
    vertices.dedup();
    // Drawn first: the see-through parts blend over it (drawn after them,
    // a fold inside the volume would fail their depth test).
    object.parts.insert(
        0,
        csrbf_anim::Part {
            name: "inside out".into(),
            faces,
            vertices,
            color: FOLD_RED,
            texture: None,
            wireframe: false,
        },
    );
}

/// Two pictures of one height next to each other in a picture `width` wide
/// (a last odd column is left background).
fn side_by_side(
    left: &csrbf_render::Image,
    right: &csrbf_render::Image,
    width: u32,
) -> csrbf_render::Image {
    let h = left.height;
    let mut rgba = Vec::with_capacity(4 * width as usize * h as usize);
    for y in 0..h {
        for img in [left, right] {
            let row = 4 * (y * img.width) as usize;
            rgba.extend_from_slice(&img.rgba[row..row + 4 * img.width as usize]);
        }
        let last = 4 * (y * right.width + right.width - 1) as usize;
        for _ in (left.width + right.width)..width {
            rgba.extend_from_slice(&right.rgba[last..last + 4]);
        }
    }
    csrbf_render::Image {
        width,
        height: h,
        rgba,
    }
}
