//! `deform`: a mesh moved by a control file, with what moved and what to worry about.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result};
use csrbf::controls::ControlSpec;
use csrbf::{Combine, Diagnostics, FittedStage};
use csrbf_mesh::Mesh;

use crate::common::{
    CheckArgs, Progress, check_output, check_phase, fit_all, read_controls, read_mesh, resolve_all,
};

/// Options of `deform`.
#[derive(clap::Args, Debug)]
pub struct DeformArgs {
    /// Input mesh (.obj, .ply, .stl, .off, .gltf, .glb).
    #[arg(long)]
    pub mesh: PathBuf,
    /// Control file (JSON).
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
    #[command(flatten)]
    pub check: CheckArgs,
}

pub fn deform(a: &DeformArgs, progress: &Progress) -> Result<()> {
    let (mesh, controls, phase, out) = (&a.mesh, &a.controls, a.phase, &a.out);
    let (force, json, allow_large) = (a.force, a.json, a.allow_large);
    check_phase(phase)?;
    let checks = a.check.checks()?;
    check_output(out, &[mesh.as_path(), controls.as_path()], force, true)?;
    let file = read_controls(controls, progress)?;
    let mut m = read_mesh(mesh, progress)?;
    // Handles sampled once: the fit and, if the edit folds, the remedies use them.
    let specs = resolve_all(&file.deformations, controls, Some(&m), progress)?;
    let stages = fit_all(&specs, controls, Some(&m), allow_large, progress)?;
    move_and_write(
        &mut m,
        &stages,
        (Some(&specs), file.combine),
        phase,
        (mesh, out, force),
        (json, &checks),
        progress,
    )
}

/// When an edit folds: the smallest radius that would not and the sweep,
/// measured, as one line for people and a JSON object.
fn remedies_said(
    m: &Mesh,
    triangles: &[[u32; 3]],
    specs: &[ControlSpec],
    combine: Combine,
    phase: f64,
) -> (String, serde_json::Value) {
    let lookup = |name: &str| m.part_vertices(name);
    let Ok(r) = csrbf::remedies(&m.positions, triangles, specs, combine, phase, &lookup) else {
        return (String::new(), serde_json::Value::Null);
    };
    let mut ways = Vec::new();
    if let Some((scale, ms)) = r.radius_scale {
        let radii: Vec<String> = specs
            .iter()
            .filter(|s| s.sweep.is_none())
            .map(|s| format!("{:.4} -> {:.4}", s.options.radius, s.options.radius * scale))
            .collect();
        ways.push(format!(
            "a radius {scale:.2}x as large ({}) folds no face (fit + deform {ms:.2} ms)",
            radii.join(", ")
        ));
    }
    if let Some((steps, ms)) = r.sweep {
        ways.push(format!(
            "\"sweep\": true cannot fold ({steps} step(s), fit + deform {ms:.2} ms)"
        ));
    }
    let line = if ways.is_empty() {
        String::new()
    } else {
        format!(
            "to keep it from folding: {}; the edit as it is takes {:.2} ms",
            ways.join(", or "),
            r.plain_ms
        )
    };
    let value = serde_json::json!({
        "radius_scale": r.radius_scale.map(|x| x.0),
        "radius_ms": r.radius_scale.map(|x| x.1),
        "sweep_steps": r.sweep.map(|x| x.0),
        "sweep_ms": r.sweep.map(|x| x.1),
        "plain_ms": r.plain_ms,
    });
    (line, value)
}

/// Moves the vertices (each stage at its own phase times `phase`),
/// carries normals where the mesh had them (`Mesh::move_vertices`), writes
/// (with `force`, over an OBJ's side files that csrbf did not write).
#[allow(clippy::too_many_arguments)]
pub(crate) fn move_and_write(
    m: &mut Mesh,
    stages: &[FittedStage],
    (specs, combine): (Option<&[ControlSpec]>, Combine),
    phase: f64,
    (mesh_path, out, force): (&Path, &Path, bool),
    (json, checks): (bool, &csrbf_anim::apply::Checks),
    progress: &Progress,
) -> Result<()> {
    let t = Instant::now();
    let triangles = m.faces.triangles();
    let stages: Vec<FittedStage> = stages
        .iter()
        .map(|s| s.clone().with_phase(s.phase * phase))
        .collect();
    let (moved, report) = csrbf_anim::apply::compose_checked(m, &stages, combine, checks)
        .with_context(|| mesh_path.display().to_string())?;
    let deform_ms = t.elapsed().as_secs_f64() * 1e3;
    let (remedy, remedy_json) = match specs {
        Some(specs) if !report.inside_out.is_empty() => {
            remedies_said(m, &triangles, specs, combine, phase)
        }
        _ => (String::new(), serde_json::Value::Null),
    };
    if m.normals.is_some() {
        // Carried, not recomputed: a file's normals split at UV seams stay
        // equal on their copies, hard edges stay hard.
        m.move_vertices(moved);
    } else {
        m.positions = moved;
    }
    // The stages' phases were scaled by `phase`: the fold phase is a share of it.
    let fold_phase = report.fold_phase.map(|s| s * phase);
    progress.say(format_args!(
        "deformed and checked {} vertices in {deform_ms:.1} ms: {} moved (by more than 1e-6 of the diagonal), largest move {}{}, {} face(s) inside out{}, {}, {}",
        m.positions.len(),
        report.moved,
        csrbf::plain_number(report.largest_move),
        report
            .largest_move_vertex
            .map(|v| format!(" (vertex {v})"))
            .unwrap_or_default(),
        report.inside_out.len(),
        fold_phase
            .map(|p| format!(", folds from phase {p:.2} on"))
            .unwrap_or_default(),
        stretch_said(&report),
        intersections_said(&report),
    ));
    for w in &report.warnings {
        err_line!("warning: {w}");
    }
    if !remedy.is_empty() {
        err_line!("warning: {remedy}");
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
        let value = serde_json::json!({
            "output": out.display().to_string(),
            "files": written.files.iter().map(|f| f.display().to_string()).collect::<Vec<_>>(),
            "write_warnings": written.warnings,
            "vertices": m.positions.len(),
            "moved": report.moved,
            "largest_move": report.largest_move,
            "largest_move_vertex": report.largest_move_vertex,
            "inside_out_faces": report.inside_out.len(),
            "inside_out": report.inside_out.iter().take(1000).collect::<Vec<_>>(),
            "fold_phase": fold_phase,
            "flipped_faces": report.flipped.len(),
            "flipped": report.flipped.iter().take(1000).collect::<Vec<_>>(),
            "largest_stretch": report.largest_stretch,
            "largest_stretch_face": report.largest_stretch_face,
            "stretch_limit": report.stretch_limit,
            "stretched_faces": report.stretched.len(),
            "stretched": report.stretched.iter().take(1000).collect::<Vec<_>>(),
            "self_intersections": report.self_intersections.as_ref().map(Vec::len),
            "self_intersecting": report
                .self_intersections
                .as_ref()
                .map(|p| p.iter().take(1000).collect::<Vec<_>>()),

            "warnings": report.warnings.iter().map(|w| w.to_string()).collect::<Vec<_>>(),
            "deform_ms": deform_ms,
            "remedies": remedy_json,
        });
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

/// "largest stretch 1.32x (face 7), 0 face(s) over 4x".
fn stretch_said(r: &Diagnostics) -> String {
    format!(
        "largest stretch {}x{}, {} face(s) over {}x",
        csrbf::plain_number(r.largest_stretch),
        r.largest_stretch_face
            .map(|f| format!(" (face {f})"))
            .unwrap_or_default(),
        r.stretched.len(),
        r.stretch_limit
    )
}

/// "2 pair(s) of faces newly intersecting", or that it was not looked for.
fn intersections_said(r: &Diagnostics) -> String {
    match &r.self_intersections {
        Some(p) => format!("{} pair(s) of faces newly intersecting", p.len()),
        None => "self-intersections not checked".into(),
    }
}
