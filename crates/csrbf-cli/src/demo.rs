//! `demo`: the papers' examples, written as scenes with a poster and a movie.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use csrbf_render::movie::MovieOptions;
use csrbf_render::{Overlay, SceneOptions, SceneRenderer};

use crate::animate::{load_scene, write_movie};
use crate::common::Progress;
use crate::look::size_or;

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
