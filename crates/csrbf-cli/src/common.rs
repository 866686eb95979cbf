//! What the commands share: reading inputs with their names in errors,
//! checking outputs before any work, progress messages.

use std::path::Path;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use csrbf::controls::{ControlFile, ControlSpec};
use csrbf::{FittedStage, System};
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

/// Fits every deformation of a control file, naming the file and the
/// deformation in errors.
pub fn fit_all(
    specs: &[ControlSpec],
    path: &Path,
    mesh: Option<&Mesh>,
    allow_large: bool,
    progress: &Progress,
) -> Result<Vec<FittedStage>> {
    let mut specs = resolve_all(specs, path, mesh, progress)?;
    if let Some(m) = mesh {
        for (i, s) in specs.iter().enumerate() {
            csrbf_anim::apply::check_region(&s.region, m)
                .map_err(anyhow::Error::msg)
                .with_context(|| format!("{}: region", stage_name(path, i, specs.len())))?;
        }
    }
    if allow_large {
        for s in &mut specs {
            s.options = s.options.with_memory_limit(u64::MAX);
        }
    }
    let mut out = Vec::with_capacity(specs.len());
    for (i, s) in specs.iter().enumerate() {
        let at = stage_name(path, i, specs.len());
        warn_if_dense(s, &at);
        let t = Instant::now();
        if s.starts.is_empty() {
            // Work in progress (the reader warned): moves nothing, and the
            // deformations after it keep their numbers.
            out.extend(s.fit().with_context(|| at.clone())?);
            continue;
        }
        if let Some(options) = s.sweep {
            let sweep = csrbf::Sweep::fit(&s.starts, &s.targets, &s.paths, s.options, options)
                .with_context(|| at.clone())?;
            progress.say(format_args!(
                "swept {} controls ({}, R {}) in {} step(s), each step's |dD/dx| <= {:.3} (the single map's bound: {:.3}), {:.2} ms",
                s.starts.len(),
                s.options.kernel,
                csrbf::plain_number(s.options.radius),
                sweep.len(),
                sweep.bound(),
                sweep.plain_bound,
                t.elapsed().as_secs_f64() * 1e3
            ));
            if !sweep.certified() {
                err_line!(
                    "warning: {at}: a step of the sweep's {} has a gradient bound of {:.3} (>= 1), so it may fold: leave out \"steps\" and csrbf takes as many as it needs",
                    sweep.len(),
                    sweep.bound()
                );
            }
            out.extend(FittedStage::sweep(sweep, s.region.clone(), s.phase));
            continue;
        }
        let sys = System::new(&s.starts, s.options).with_context(|| at.clone())?;
        let def = sys.solve(&s.targets).with_context(|| at.clone())?;
        let st = sys.stats();
        progress.say(format_args!(
            "fitted {} controls ({}, R {}, {}): {} solver, band {} -> {}, {:.2} ms",
            st.controls,
            s.options.kernel,
            csrbf::plain_number(s.options.radius),
            s.options.polynomial,
            st.solver,
            st.bandwidth_before,
            st.bandwidth,
            t.elapsed().as_secs_f64() * 1e3
        ));
        out.push(
            FittedStage::new(def)
                .with_region(s.region.clone())
                .with_phase(s.phase),
        );
    }
    Ok(out)
}

fn stage_name(path: &Path, i: usize, count: usize) -> String {
    if count > 1 {
        format!("{}: deformations[{i}]", path.display())
    } else {
        path.display().to_string()
    }
}

/// Turns every handle into control vectors and every connected region into
/// vertex weights on the mesh (which they need); other deformations are
/// kept as they are.
pub fn resolve_all(
    specs: &[ControlSpec],
    path: &Path,
    mesh: Option<&Mesh>,
    progress: &Progress,
) -> Result<Vec<ControlSpec>> {
    let mut out = Vec::with_capacity(specs.len());
    for (i, s) in specs.iter().enumerate() {
        if !s.needs_mesh() {
            out.push(s.clone());
            continue;
        }
        let at = stage_name(path, i, specs.len());
        let Some(m) = mesh else {
            if s.handle.is_some() {
                bail!("{at}: handle: a handle is sampled on the mesh; give --mesh");
            }
            bail!("{at}: region: a connected region is measured along the mesh; give --mesh");
        };
        let t = Instant::now();
        let triangles = if s.region.needs_surface() {
            m.faces.triangles()
        } else {
            Vec::new()
        };
        let r = s
            .resolve_on(&m.positions, &triangles, &|n| m.part_vertices(n))
            .with_context(|| at.clone())?;
        let ms = t.elapsed().as_secs_f64() * 1e3;
        if s.handle.is_some() {
            progress.say(format_args!(
                "{at}: handle made {} control vectors",
                r.starts.len() - s.starts.len(),
            ));
        }
        if let csrbf::Region::Weights { vertices, weights } = &r.region
            && s.region.needs_surface()
        {
            progress.say(format_args!(
                "{at}: connected region: {} vertices ({} fully)",
                vertices.len(),
                weights.iter().filter(|&&w| w == 1.0).count()
            ));
        }
        progress.say(format_args!("{at}: resolved on the mesh ({ms:.1} ms)"));
        out.push(r);
    }
    Ok(out)
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
    pub fn checks(&self) -> Result<csrbf_anim::apply::Checks> {
        let checks = csrbf_anim::apply::Checks::default()
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

/// Warns before a long fit when R reaches most of the starts: the system is
/// then nearly dense (N^2 memory, N^3 work). The estimate is the engine's.
fn warn_if_dense(s: &ControlSpec, at: &str) {
    let e = csrbf::estimate(&s.starts, s.options.radius);
    if e.nearly_dense() {
        err_line!(
            "warning: {at}: R = {} reaches about {:.0} % of the {} starts, so the system is nearly dense and the fit will be slow and large; a smaller R keeps it sparse",
            csrbf::plain_number(s.options.radius),
            e.fraction * 100.0,
            e.starts
        );
    }
}
