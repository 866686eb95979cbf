//! `csrbf`: deform meshes by control vectors with compactly supported radial
//! basis functions. Glue only: the work is in the `csrbf` and `csrbf-mesh` crates.

/// A line on standard error that never panics: when standard error is
/// closed (`2>&-`, or a pipe to `head` that has exited) the message is
/// dropped and the work goes on, where `eprintln!` would panic (exit 101)
/// before the output is written. (`eprintln!` is refused by clippy.toml.)
macro_rules! err_line {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($arg)*);
    }};
}

/// [`err_line!`] without the newline (a progress bar's redraw).
macro_rules! err_text {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = write!(std::io::stderr(), $($arg)*);
    }};
}

/// A line on standard output that never panics: a reader that stops early
/// (`| head`) ends the listing, not the command.
macro_rules! out_line {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout(), $($arg)*);
    }};
}

mod animate;
mod apply;
mod bench;
mod common;
mod deform;
mod demo;
mod export;
mod fit;
mod info;
mod look;
mod pick;
mod render;
mod view;
mod volume;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// Real-time deformation of 3D models with compactly supported radial basis functions.
#[derive(Parser)]
#[command(name = "csrbf", version, about, long_about = None)]
struct Cli {
    /// Print no progress (warnings and errors still print).
    #[arg(long, short, global = true)]
    quiet: bool,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Deform a mesh by a control file and write the result.
    Deform(deform::DeformArgs),
    /// Fit the deformations of a control file and save them compactly (.csrbf, or .json for people).
    Fit {
        /// Control file (JSON).
        #[arg(long)]
        controls: PathBuf,
        /// The mesh, for control files with a handle (sampled on it).
        #[arg(long)]
        mesh: Option<PathBuf>,
        /// Fit even a system estimated past the memory limit (4 GiB).
        #[arg(long)]
        allow_large: bool,
        /// Output: .csrbf (binary, bit-exact) or .json.
        #[arg(long)]
        out: PathBuf,
        /// Allow the output to replace an input file.
        #[arg(long)]
        force: bool,
    },
    /// Apply a saved deformation (.csrbf) to a mesh.
    Apply {
        /// Input mesh.
        #[arg(long)]
        mesh: PathBuf,
        /// Deformation file from `csrbf fit`.
        #[arg(long)]
        deformation: PathBuf,
        /// Phase in [0, 1].
        #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
        phase: f64,
        /// Output mesh.
        #[arg(long)]
        out: PathBuf,
        /// Allow the output to replace an input file, and an OBJ output to replace side files (.mtl, textures) that csrbf did not write.
        #[arg(long)]
        force: bool,
        /// Print the figures (vertices moved, faces turned over, warnings) as JSON on standard output.
        #[arg(long)]
        json: bool,
        #[command(flatten)]
        check: common::CheckArgs,
    },
    /// Describe a mesh, a control file (system size, band, memory) or a deformation file.
    Info {
        /// A mesh: counts, bounds, centroid, up axis, and each part's vertices, bounds and centroid.
        #[arg(long)]
        mesh: Option<PathBuf>,
        /// A control file (with --mesh: the vectors its handles make, vertices within R, diagnostics).
        #[arg(long)]
        controls: Option<PathBuf>,
        /// A deformation file.
        #[arg(long)]
        deformation: Option<PathBuf>,
        /// Print one JSON object.
        #[arg(long)]
        json: bool,
    },
    /// Measure fit, bind, evaluate, refit and frame times (median of several runs).
    Bench(bench::BenchArgs),
    /// Render a picture of a mesh, optionally deformed, from a chosen view.
    Render(render::RenderArgs),
    /// What lies under a pixel of the picture `render` draws with the same flags: point, triangle, vertex, part.
    Pick(pick::PickArgs),
    /// Render a scene file as a movie (MP4, GIF) or PNG frames.
    Animate(animate::AnimateArgs),
    /// Write one of the papers' examples (face, fish, ball, brick, all): scene file, models, poster and movie.
    Demo(demo::DemoArgs),
    /// Export a scene as glTF 2.0 (.glb or .gltf): meshes, materials, motion, morph targets.
    Export {
        /// The scene file.
        scene: PathBuf,
        /// Output .glb or .gltf.
        #[arg(long)]
        out: PathBuf,
        /// Allow replacing an existing output file.
        #[arg(long)]
        force: bool,
    },
}

/// Mesa's Vulkan driver prints "error: XDG_RUNTIME_DIR is invalid or not set"
/// (twice, then works) when the variable is missing, as in containers and
/// cron jobs: give it a private folder before any thread starts.
fn runtime_dir() {
    if std::env::var_os("XDG_RUNTIME_DIR").is_some() {
        return;
    }
    let dir = std::env::temp_dir().join(format!(
        "csrbf-runtime-{}",
        std::env::var("USER").unwrap_or_else(|_| "user".into())
    ));
    let made = std::fs::create_dir_all(&dir).is_ok();
    #[cfg(unix)]
    let made = made && {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o700)).is_ok()
    };
    if made {
        // SAFETY: called first thing in `main`, before any other thread exists,
        // so nothing can read the environment while it changes.
        #[allow(unsafe_code)]
        unsafe {
            std::env::set_var("XDG_RUNTIME_DIR", &dir);
        }
    }
}

/// Leaves at once with `code`, from the interruption handler: without the
/// atexit handlers (`std::process::exit` runs them), which may tear down the
/// software Vulkan driver while a render thread still uses it and turn the
/// exit into a crash by signal.
fn leave(code: i32) -> ! {
    #[cfg(unix)]
    // SAFETY: `_exit` only ends the process; the files being written were
    // removed above and nothing else needs flushing (stderr is unbuffered).
    #[allow(unsafe_code)]
    unsafe {
        libc::_exit(code)
    }
    #[cfg(not(unix))]
    std::process::exit(code)
}

fn main() -> ExitCode {
    runtime_dir();
    // Ctrl-C or SIGTERM (Windows' console events too): stop ffmpeg, remove
    // what was being written, and leave with the shell's code for it.
    let _ = ctrlc::set_handler(|| {
        csrbf_render::movie::interrupt();
        err_line!("interrupted: partial files removed");
        leave(130);
    });
    let cli = Cli::parse();
    let progress = common::Progress::new(!cli.quiet);
    let result = match cli.command {
        Command::Deform(args) => deform::deform(&args, &progress),
        Command::Fit {
            controls,
            mesh,
            allow_large,
            out,
            force,
        } => fit::fit(
            &controls,
            mesh.as_deref(),
            &out,
            force,
            allow_large,
            &progress,
        ),
        Command::Apply {
            mesh,
            deformation,
            phase,
            out,
            force,
            json,
            check,
        } => apply::apply(
            &mesh,
            &deformation,
            phase,
            &out,
            force,
            (json, &check),
            &progress,
        ),
        Command::Info {
            mesh,
            controls,
            deformation,
            json,
        } => info::info(
            mesh.as_deref(),
            controls.as_deref(),
            deformation.as_deref(),
            json,
        ),
        Command::Bench(args) => bench::bench(&args, &progress),
        Command::Render(args) => render::render(&args, &progress),
        Command::Pick(args) => pick::pick(&args, &progress),
        Command::Animate(args) => animate::animate(&args, &progress),
        Command::Demo(args) => demo::demo(&args, &progress),
        Command::Export { scene, out, force } => export::export(&scene, &out, force, &progress),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            err_line!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
