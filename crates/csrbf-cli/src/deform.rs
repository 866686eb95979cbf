//! `deform`: a mesh moved by a control file, with what moved and what to worry about.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result};
use csrbf::{Combine, FittedStage, compose_diagnosed};
use csrbf_mesh::Mesh;

use crate::common::{Progress, check_output, check_phase, fit_all, read_controls, read_mesh};

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
    /// Allow the output to replace an input file.
    #[arg(long)]
    pub force: bool,
    /// Print the figures (vertices moved, faces turned over, warnings) as JSON on standard output.
    #[arg(long)]
    pub json: bool,
    /// Fit even a system estimated past the memory limit (4 GB).
    #[arg(long)]
    pub allow_large: bool,
}

pub fn deform(a: &DeformArgs, progress: &Progress) -> Result<()> {
    let (mesh, controls, phase, out) = (&a.mesh, &a.controls, a.phase, &a.out);
    let (force, json, allow_large) = (a.force, a.json, a.allow_large);
    check_phase(phase)?;
    check_output(out, &[mesh.as_path(), controls.as_path()], force, true)?;
    let file = read_controls(controls, progress)?;
    let mut m = read_mesh(mesh, progress)?;
    let stages = fit_all(
        &file.deformations,
        controls,
        Some(&m),
        allow_large,
        progress,
    )?;
    move_and_write(
        &mut m,
        &stages,
        file.combine,
        phase,
        mesh,
        out,
        json,
        progress,
    )
}

/// Moves the vertices (each stage at its own phase times `phase`),
/// recomputes normals where the mesh had them, writes.
#[allow(clippy::too_many_arguments)]
pub(crate) fn move_and_write(
    m: &mut Mesh,
    stages: &[FittedStage],
    combine: Combine,
    phase: f64,
    mesh_path: &Path,
    out: &Path,
    json: bool,
    progress: &Progress,
) -> Result<()> {
    let t = Instant::now();
    let lookup = |name: &str| m.part_vertices(name);
    let triangles = m.faces.triangles();
    let stages: Vec<FittedStage> = stages
        .iter()
        .map(|s| s.clone().with_phase(s.phase * phase))
        .collect();
    let (moved, report) = compose_diagnosed(&m.positions, &stages, combine, &triangles, &lookup)
        .with_context(|| mesh_path.display().to_string())?;
    let deform_ms = t.elapsed().as_secs_f64() * 1e3;
    m.positions = moved;
    if m.normals.is_some() {
        m.recompute_normals();
    }
    // The stages' phases were scaled by `phase`: the fold phase is a share of it.
    let fold_phase = report.fold_phase.map(|s| s * phase);
    progress.say(format_args!(
        "deformed and checked {} vertices in {deform_ms:.1} ms: {} moved, largest move {:.6}{}, {} face(s) inside out{}",
        m.positions.len(),
        report.moved,
        report.largest_move,
        report
            .largest_move_vertex
            .map(|v| format!(" (vertex {v})"))
            .unwrap_or_default(),
        report.inside_out.len(),
        fold_phase
            .map(|p| format!(", folds from phase {p:.2} on"))
            .unwrap_or_default(),
    ));
    for w in &report.warnings {
        eprintln!("warning: {w}");
    }
    if let Some(lost) = csrbf_mesh::Format::from_path(out)?.loses(m) {
        eprintln!("warning: {}: {lost}", out.display());
    }
    csrbf_mesh::write(out, m)?;
    progress.say(format_args!("wrote {}", out.display()));
    if json {
        let value = serde_json::json!({
            "output": out.display().to_string(),
            "vertices": m.positions.len(),
            "moved": report.moved,
            "largest_move": report.largest_move,
            "largest_move_vertex": report.largest_move_vertex,
            "inside_out_faces": report.inside_out.len(),
            "inside_out": report.inside_out.iter().take(1000).collect::<Vec<_>>(),
            "fold_phase": fold_phase,
            "flipped_faces": report.flipped.len(),
            "flipped": report.flipped.iter().take(1000).collect::<Vec<_>>(),
            "warnings": report.warnings.iter().map(|w| w.to_string()).collect::<Vec<_>>(),
            "deform_ms": deform_ms,
        });
        println!("{}", serde_json::to_string_pretty(&value)?);
    }
    Ok(())
}
