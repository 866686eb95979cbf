//! What the commands share: reading inputs with their names in errors,
//! checking outputs before any work, progress messages.

use std::path::Path;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use csrbf_edit::{ControlFile, EditError, Note};
use csrbf_mesh::{Format, Mesh};

/// Progress lines on standard error, unless quiet.
pub struct Progress {
    on: bool,
    start: Instant,
}

impl Progress {
    pub fn new(on: bool) -> Progress {
        Progress {
            on,
            start: Instant::now(),
        }
    }

    /// A progress bar on one line of standard error.
    pub fn bar(&self, done: usize, total: usize) {
        if !self.on || total == 0 {
            return;
        }
        use std::io::IsTerminal;
        if !std::io::stderr().is_terminal() {
            // In a log, a line at every quarter.
            if done == total || (done * 4 / total) != ((done - 1) * 4 / total) {
                self.say(format_args!("{done}/{total}"));
            }
            return;
        }
        let width = 30;
        let filled = done * width / total;
        err_text!(
            "\r[{}{}] {done}/{total}",
            "#".repeat(filled),
            ".".repeat(width - filled)
        );
        if done == total {
            err_line!();
        }
    }

    pub fn say(&self, msg: impl std::fmt::Display) {
        if self.on {
            err_line!("[{:7.2} s] {msg}", self.start.elapsed().as_secs_f64());
        }
    }
}

/// Reads and checks a control file; warnings about unknown keys are printed.
pub fn read_controls(path: &Path, progress: &Progress) -> Result<ControlFile> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("cannot read control file {}", path.display()))?;
    let file = ControlFile::parse(&text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    for w in &file.warnings {
        err_line!("warning: {}: {w}", path.display());
    }
    let n: usize = file.deformations.iter().map(|d| d.starts.len()).sum();
    progress.say(format_args!(
        "{}: {} deformation(s), {n} control vectors",
        path.display(),
        file.deformations.len()
    ));
    Ok(file)
}

/// Resolves a control file on the mesh and fits every deformation (the
/// edit layer's road), its progress on standard error and its warnings as
/// `warning: ...`; errors name the file and the deformation.
pub fn fit_edit(
    file: &ControlFile,
    path: &Path,
    mesh: Option<&Mesh>,
    allow_large: bool,
    progress: &Progress,
) -> Result<csrbf_edit::Edit> {
    let source = path.display().to_string();
    let mut notes = |n: Note| match n {
        Note::Progress(t) => progress.say(t),
        Note::Warning(t) => err_line!("warning: {t}"),
        _ => {}
    };
    csrbf_edit::fit(file, &source, mesh, allow_large, &mut notes).map_err(|e| match e {
        // The library says "give the mesh"; here it is a flag.
        EditError::NeedsMesh { at, what } => {
            anyhow::anyhow!("{at}: {}", what.replace("give the mesh", "give --mesh"))
        }
        e => anyhow::Error::new(e),
    })
}

/// What `deform` and `apply` check of the result beyond moves and folds.
#[derive(clap::Args, Debug, Clone)]
pub struct CheckArgs {
    /// List (and warn of) faces stretched more than this factor: the largest singular value of a face's rest-to-deformed map, a finite number >= 1.
    #[arg(long, default_value_t = csrbf::STRETCH_LIMIT)]
    pub stretch_limit: f64,
    /// Look for faces that pass through each other in the result but not at rest: auto (meshes of at most 2M triangles), on or off.
    #[arg(long, default_value = "auto", value_parser = ["auto", "on", "off"])]
    pub self_intersections: String,
}

impl CheckArgs {
    /// The checks these flags ask for; a bad stretch limit names its flag.
    pub fn checks(&self) -> Result<csrbf_edit::Checks> {
        let checks = csrbf_edit::Checks::default()
            .with_stretch_limit(self.stretch_limit)
            .with_self_intersections(match self.self_intersections.as_str() {
                "on" => Some(true),
                "off" => Some(false),
                _ => None,
            });
        checks.diagnose.check().context("--stretch-limit")?;
        Ok(checks)
    }
}

/// Reads a mesh, with progress.
pub fn read_mesh(path: &Path, progress: &Progress) -> Result<Mesh> {
    let t = Instant::now();
    let loaded = csrbf_mesh::load(path)?;
    for w in &loaded.warnings {
        err_line!("warning: {w}");
    }
    let mesh = loaded.mesh;
    progress.say(format_args!(
        "read {}: {} vertices, {} faces ({:.0} ms)",
        path.display(),
        mesh.positions.len(),
        mesh.faces.len(),
        t.elapsed().as_secs_f64() * 1e3
    ));
    Ok(mesh)
}

/// Checks an output path before any work: a known extension (when `mesh`),
/// an existing directory, and not one of the inputs unless forced.
pub fn check_output(out: &Path, inputs: &[&Path], force: bool, mesh: bool) -> Result<()> {
    if mesh {
        Format::from_path(inputs[0])?;
        Format::from_path(out)?;
    }
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty())
        && !dir.is_dir()
    {
        if dir.exists() {
            bail!(
                "{}: {} is a file, not a folder",
                out.display(),
                dir.display()
            );
        }
        bail!(
            "{}: the output directory {} does not exist",
            out.display(),
            dir.display()
        );
    }
    if out.is_dir() {
        bail!("{}: is a directory; give a file name", out.display());
    }
    remove_stale_temps(out);
    if let Ok(o) = out.canonicalize() {
        for i in inputs {
            if (i.canonicalize().is_ok_and(|i| i == o) || same_file(i, out)) && !force {
                bail!(
                    "{}: the output is the same file as an input; refusing to overwrite it (pass --force to allow)",
                    out.display()
                );
            }
        }
    }
    Ok(())
}

/// Whether two paths name one file (a hard link too): the same device and
/// inode on Unix, volume and file index on Windows.
fn same_file(a: &Path, b: &Path) -> bool {
    same_file::is_same_file(a, b).unwrap_or(false)
}

/// Removes temporaries an earlier, killed run left beside `out`.
pub fn remove_stale_temps(out: &Path) {
    let dir = match out.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let n = csrbf_mesh::remove_stale_temps(dir);
    if n > 0 {
        err_line!(
            "note: removed {n} temporary file(s) an interrupted run left in {}",
            dir.display()
        );
    }
}

/// Checks a phase given on the command line.
pub fn check_phase(phase: f64) -> Result<()> {
    if !(0.0..=1.0).contains(&phase) {
        bail!("--phase must be within [0, 1], got {phase}");
    }
    Ok(())
}

/// The lower-case extension of `out` if it is one of `allowed`, else an
/// error listing them (`what` names the kind of file).
pub fn extension_in(out: &Path, allowed: &[&str], what: &str) -> Result<String> {
    let ext = out
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    if !allowed.contains(&ext.as_str()) {
        let list: Vec<String> = allowed.iter().map(|a| format!(".{a}")).collect();
        bail!(
            "{}: unknown {what} {ext:?}; supported: {}",
            out.display(),
            list.join(", ")
        );
    }
    Ok(ext)
}
