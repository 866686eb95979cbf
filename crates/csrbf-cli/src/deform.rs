//! `deform`: a mesh moved by a control file, with what moved and what to worry about.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use csrbf_edit::{RemedySearch, Report};
use csrbf_mesh::Mesh;

use crate::common::{
    CheckArgs, Progress, check_output, check_phase, fit_edit, read_controls, read_mesh,
};

/// Options of `deform`.
#[derive(clap::Args, Debug)]
pub struct DeformArgs {
    /// Input mesh: a surface (.obj, .ply, .stl, .off, .gltf, .glb) or a volume mesh (.vtk, .vtu, .msh: every node moved, every cell checked).
    #[arg(long)]
    pub mesh: PathBuf,
    /// Control file (JSON); for a volume mesh, also a boundary-driven morph (a document with "boundary": zones moved and held).
    #[arg(long)]
    pub controls: PathBuf,
    /// Phase in [0, 1]: 0 is the rest shape, 1 the full deformation.
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    pub phase: f64,
    /// Output mesh; the format comes from the extension.
    #[arg(long)]
    pub out: PathBuf,
    /// Allow the output to replace an input file, and an OBJ output to replace side files (.mtl, textures) that csrbf did not write.
    #[arg(long)]
    pub force: bool,
    /// Print the figures (vertices moved, faces turned over, warnings) as JSON on standard output.
    #[arg(long)]
    pub json: bool,
    /// Fit even a system estimated past the memory limit (4 GiB).
    #[arg(long)]
    pub allow_large: bool,
    /// When an edit folds, search for a radius and a sweep that would not: bounded (at most the edit's own fit and deform time, or 0.2 s), full (to the smallest radius), or off.
    #[arg(long, default_value = "bounded", value_parser = ["bounded", "full", "off"])]
    pub remedies: String,
    #[command(flatten)]
    pub check: CheckArgs,
}

pub fn deform(a: &DeformArgs, progress: &Progress) -> Result<()> {
    if crate::volume::is_volume(&a.mesh) {
        return crate::volume::deform_volume(a, progress);
    }
    let (mesh, controls, phase, out) = (&a.mesh, &a.controls, a.phase, &a.out);
    check_phase(phase)?;
    let checks = a.check.checks()?;
    let search = RemedySearch::parse(&a.remedies).context("--remedies")?;
    check_output(out, &[mesh.as_path(), controls.as_path()], a.force, true)?;
    let file = read_controls(controls, progress)?;
    let mut m = read_mesh(mesh, progress)?;
    let edit = fit_edit(&file, controls, Some(&m), a.allow_large, progress)?;
    if search == RemedySearch::Full {
        progress.say("deforming; if a face folds, the remedies are searched to the end");
    }
    let (moved, report) = edit
        .deform(&m, phase, &checks, search)
        .with_context(|| mesh.display().to_string())?;
    write_deformed(&mut m, moved, &report, (out, a.force, a.json), progress)
}

/// Moves the vertices to `moved`, carrying normals where the mesh had them
/// (`Mesh::move_vertices`), says what the report says, and writes (with
/// `force`, over an OBJ's side files that csrbf did not write); `--json`
/// prints the files and the report's serialised form.
pub(crate) fn write_deformed(
    m: &mut Mesh,
    moved: Vec<glam::Vec3>,
    report: &Report,
    (out, force, json): (&Path, bool, bool),
    progress: &Progress,
) -> Result<()> {
    if m.normals.is_some() {
        // Carried, not recomputed: a file's normals split at UV seams stay
        // equal on their copies, hard edges stay hard.
        m.move_vertices(moved);
    } else {
        m.positions = moved;
    }
    progress.say(format_args!(
        "deformed and checked {} vertices in {:.1} ms: {}",
        report.vertices,
        report.deform_ms,
        report.summary()
    ));
    for w in report.warnings() {
        err_line!("warning: {w}");
    }
    let advice = report.advice();
    if !advice.is_empty() {
        err_line!("warning: {advice}");
    }
    if let Some(lost) = csrbf_mesh::Format::from_path(out)?.loses(m) {
        err_line!("warning: {}: {lost}", out.display());
    }
    let options = csrbf_mesh::WriteOptions::default().with_force(force);
    let written = csrbf_mesh::write_with(out, m, &options)?;
    for w in &written.warnings {
        err_line!("warning: {w}");
    }
    progress.say(format_args!("wrote {}", files_said(&written.files)));
    if json {
        let mut value = serde_json::json!({
            "output": out.display().to_string(),
            "files": written.files.iter().map(|f| f.display().to_string()).collect::<Vec<_>>(),
            "write_warnings": written.warnings,
        });
        if let (Some(o), serde_json::Value::Object(r)) = (value.as_object_mut(), report.to_json()) {
            o.extend(r);
        }
        out_line!("{}", serde_json::to_string_pretty(&value)?);
    }
    Ok(())
}

/// "out/b.obj, b.mtl, b_0.png": the first file as given, the side files
/// beside it by name.
fn files_said(files: &[PathBuf]) -> String {
    let mut said: Vec<String> = Vec::new();
    for (k, f) in files.iter().enumerate() {
        let name = match f.file_name() {
            Some(n) if k > 0 => n.to_string_lossy().into_owned(),
            _ => f.display().to_string(),
        };
        said.push(name);
    }
    said.join(", ")
}
