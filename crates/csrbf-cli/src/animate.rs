//! `animate`: a scene file as a movie (MP4, GIF) or PNG frames.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Result, bail};
use csrbf_anim::Scene;
use csrbf_render::movie::{MovieOptions, render_movie};

use crate::common::Progress;
use crate::look::{LookArgs, size_or};

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
        err_line!("warning: {}: {w}", path.display());
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
        err_line!("warning: {why}; wrote a GIF instead");
    }
    progress.say(format_args!(
        "rendered {} frames in {:.1} s",
        written.frames,
        t.elapsed().as_secs_f64()
    ));
    Ok(written.path)
}
