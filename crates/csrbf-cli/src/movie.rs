//! `render` and `animate`: pictures and movies of meshes and scenes.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use csrbf_anim::Scene;
use csrbf_render::movie::{MovieOptions, render_movie};
use csrbf_render::{Overlay, SceneOptions, SceneRenderer};

use crate::common::{Progress, check_output};

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
    let m = csrbf_mesh::read(mesh)?;
    let quiet = Progress::new(false);
    let controls = controls
        .map(|c| crate::common::read_controls(c, &quiet).map(|f| (c, f)))
        .transpose()?;
    let scene = csrbf_anim::still::mesh_scene(mesh, m.clone(), controls, phase, size)?;
    Ok((scene, m))
}

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
    let scene = aimed.scene;
    progress.say(format_args!(
        "up {} ({})",
        csrbf_anim::camera::axis_name(aimed.up.0),
        aimed.up.1
    ));
    let mut r = SceneRenderer::new(&scene, panel[0], panel[1])?;
    progress.say(format_args!("rendering on {}", r.renderer().adapter()));
    let t = Instant::now();
    let frame = scene.frame(0.0);
    let mut img = r.render(&scene, &frame, a.look.options())?;
    if a.before_after {
        let mut rest = frame.clone();
        let obj = &mut rest.objects[0];
        obj.positions.clone_from(&aimed.mesh.positions);
        csrbf_mesh::triangle_vertex_normals_into(
            &obj.positions,
            &aimed.mesh.faces.triangles(),
            &mut obj.normals,
        );
        let before = r.render(&scene, &rest, a.look.options())?;
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

/// Options of `animate`.
#[derive(clap::Args, Debug)]
pub struct AnimateArgs {
    /// The scene file (*.scene.json).
    pub scene: PathBuf,
    /// movie.mp4 (ffmpeg), movie.gif, or a folder for PNG frames.
    #[arg(long)]
    pub out: PathBuf,
    /// Frames per second (default: the scene's).
    #[arg(long)]
    pub fps: Option<f64>,
    /// Picture size WIDTHxHEIGHT (default: the scene's).
    #[arg(long)]
    pub size: Option<String>,
    /// Start time in seconds (default 0).
    #[arg(long)]
    pub from: Option<f64>,
    /// End time in seconds (default: the scene's duration).
    #[arg(long)]
    pub to: Option<f64>,
    #[command(flatten)]
    pub look: LookArgs,
    /// Allow replacing an existing output file.
    #[arg(long)]
    pub force: bool,
}

pub fn load_scene(path: &Path) -> Result<Scene> {
    let scene = Scene::load(path)?;
    for w in &scene.warnings {
        eprintln!("warning: {}: {w}", path.display());
    }
    Ok(scene)
}

pub fn animate(a: &AnimateArgs, progress: &Progress) -> Result<()> {
    if a.out.exists() && !a.out.is_dir() && !a.force {
        bail!("{}: exists; pass --force to replace it", a.out.display());
    }
    crate::common::remove_stale_temps(&a.out);
    let scene = load_scene(&a.scene)?;
    let size = size_or(a.size.as_deref(), scene.file.size)?;
    let fps = a.fps.unwrap_or(scene.file.fps);
    if !(fps > 0.0 && fps <= csrbf_anim::MAX_FPS) {
        bail!(
            "--fps must be within (0, {}], got {fps}",
            csrbf_anim::MAX_FPS
        );
    }
    let (from, to) = (a.from.unwrap_or(0.0), a.to.unwrap_or(scene.file.duration));
    if !(from >= 0.0 && to > from && to.is_finite()) {
        bail!("--from {from} --to {to}: need 0 <= from < to");
    }
    let mut options = MovieOptions::of(&scene);
    (options.size, options.fps, options.from, options.to) = (size, fps, from, to);
    options.look = a.look.options();
    let written = write_movie(&scene, &a.out, options, progress)?;
    progress.say(format_args!("wrote {}", written.display()));
    Ok(())
}

/// Renders a scene into a movie through the library's frame loop, with a
/// progress bar; returns where it went.
pub fn write_movie(
    scene: &Scene,
    out: &Path,
    options: MovieOptions,
    progress: &Progress,
) -> Result<PathBuf> {
    let t = Instant::now();
    progress.say(format_args!(
        "{} frames of {}x{} at {} fps",
        options.frames(),
        options.size[0],
        options.size[1],
        options.fps
    ));
    let written = render_movie(scene, out, options, &mut |done, total| {
        progress.bar(done, total);
        true
    })?;
    if let Some(why) = &written.fell_back {
        eprintln!("warning: {why}; wrote a GIF instead");
    }
    progress.say(format_args!(
        "rendered {} frames in {:.1} s",
        written.frames,
        t.elapsed().as_secs_f64()
    ));
    Ok(written.path)
}

pub fn export(scene: &Path, out: &Path, force: bool, progress: &Progress) -> Result<()> {
    let ext = crate::common::extension_in(out, &["glb", "gltf"], "export format")?;
    if out.exists() && !force {
        bail!("{}: exists; pass --force to replace it", out.display());
    }
    check_output(out, &[scene], force, false)?;
    let s = load_scene(scene)?;
    for note in csrbf_anim::export_notes(&s) {
        eprintln!("note: {}: {note}", scene.display());
    }
    let bytes = csrbf_anim::export_gltf(&s, ext == "glb");
    csrbf_mesh::write_atomic(out, &bytes)?;
    progress.say(format_args!(
        "wrote {} ({} bytes)",
        out.display(),
        bytes.len()
    ));
    Ok(())
}

/// Options of `demo`.
#[derive(clap::Args, Debug)]
pub struct DemoArgs {
    /// face, fish, ball, brick, or all.
    pub name: String,
    /// Folder to write into (made if missing; its parent must exist).
    #[arg(long)]
    pub out: PathBuf,
    /// Write an animated GIF instead of an MP4.
    #[arg(long)]
    pub gif: bool,
    /// Picture size WIDTHxHEIGHT (default: the scene's, 1024x768).
    #[arg(long)]
    pub size: Option<String>,
}

pub fn demo(a: &DemoArgs, progress: &Progress) -> Result<()> {
    let names: Vec<&str> = if a.name == "all" {
        csrbf_anim::demos::DEMOS.to_vec()
    } else {
        vec![a.name.as_str()]
    };
    for name in &names {
        if csrbf_anim::demos::demo(name).is_none() {
            bail!(
                "unknown demo {name:?}: expected one of {}, or all",
                csrbf_anim::demos::DEMOS.join(", ")
            );
        }
    }
    if !a.out.is_dir() {
        match a.out.parent() {
            Some(p) if !p.as_os_str().is_empty() && !p.is_dir() => {
                bail!(
                    "{}: the parent folder {} does not exist",
                    a.out.display(),
                    p.display()
                )
            }
            _ => std::fs::create_dir(&a.out)
                .with_context(|| format!("cannot make {}", a.out.display()))?,
        }
    }
    for name in names {
        let Some(d) = csrbf_anim::demos::demo(name) else {
            continue;
        };
        let dir = a.out.join(name);
        let scene_path = d.write(&dir, name)?;
        let scene = load_scene(&scene_path)?;
        let size = size_or(a.size.as_deref(), scene.file.size)?;
        let mut r = SceneRenderer::new(&scene, size[0], size[1])?;
        let mut opts = SceneOptions::default();
        r.render(&scene, &scene.frame(d.poster), opts)?
            .save_png(&dir.join("poster.png"))?;
        opts.overlay = Overlay::Full;
        r.render(&scene, &scene.frame(d.poster), opts)?
            .save_png(&dir.join("poster_controls.png"))?;
        let movie = dir.join(if a.gif { "movie.gif" } else { "movie.mp4" });
        let mut options = MovieOptions::of(&scene);
        options.size = size;
        options.gif_fallback = true;
        let movie = write_movie(&scene, &movie, options, progress)?;
        progress.say(format_args!(
            "{name}: {} (scene {}, poster {})",
            movie.display(),
            scene_path.display(),
            dir.join("poster.png").display()
        ));
    }
    Ok(())
}
