//! `deform`, `fit` and `apply`.

use std::path::Path;
use std::time::Instant;

use anyhow::{Context, Result};
use csrbf::{Deformation, Region, compose, format};
use csrbf_mesh::Mesh;

use crate::common::{Progress, check_output, check_phase, fit_all, read_controls, read_mesh};

pub fn deform(
    mesh: &Path,
    controls: &Path,
    phase: f64,
    out: &Path,
    force: bool,
    progress: &Progress,
) -> Result<()> {
    check_phase(phase)?;
    check_output(out, &[mesh, controls], force, true)?;
    let specs = read_controls(controls, progress)?;
    let stages = fit_all(&specs, controls, progress)?;
    let mut m = read_mesh(mesh, progress)?;
    // The file's phase of each deformation, scaled by the command's.
    let stages: Vec<_> = stages
        .into_iter()
        .map(|(d, r, p)| (d, r, p * phase))
        .collect();
    move_and_write(&mut m, &stages, mesh, out, progress)
}

pub fn fit(controls: &Path, out: &Path, force: bool, progress: &Progress) -> Result<()> {
    check_output(out, &[controls], force, false)?;
    let ext = crate::common::extension_in(out, &["csrbf", "json"], "deformation format")?;
    let specs = read_controls(controls, progress)?;
    let stages: Vec<(Deformation, Region)> = fit_all(&specs, controls, progress)?
        .into_iter()
        .map(|(d, r, _)| (d, r))
        .collect();
    let bytes = if ext == "json" {
        serde_json::to_vec_pretty(&format::to_json(&stages))?
    } else {
        format::encode(&stages)
    };
    csrbf_mesh::write_atomic(out, &bytes)?;
    progress.say(format_args!(
        "wrote {} ({} bytes)",
        out.display(),
        bytes.len()
    ));
    Ok(())
}

pub fn apply(
    mesh: &Path,
    deformation: &Path,
    phase: f64,
    out: &Path,
    force: bool,
    progress: &Progress,
) -> Result<()> {
    check_phase(phase)?;
    check_output(out, &[mesh, deformation], force, true)?;
    let bytes = std::fs::read(deformation)
        .with_context(|| format!("cannot read {}", deformation.display()))?;
    let stages = format::decode(&bytes).with_context(|| deformation.display().to_string())?;
    progress.say(format_args!(
        "{}: {} deformation(s)",
        deformation.display(),
        stages.len()
    ));
    let mut m = read_mesh(mesh, progress)?;
    let stages: Vec<_> = stages.into_iter().map(|(d, r)| (d, r, phase)).collect();
    move_and_write(&mut m, &stages, mesh, out, progress)
}

/// Moves the vertices, recomputes normals where the mesh had them, writes.
fn move_and_write(
    m: &mut Mesh,
    stages: &[(Deformation, Region, f64)],
    mesh_path: &Path,
    out: &Path,
    progress: &Progress,
) -> Result<()> {
    let t = Instant::now();
    let lookup = |name: &str| m.part_vertices(name);
    let moved =
        compose(&m.positions, stages, &lookup).with_context(|| mesh_path.display().to_string())?;
    let max_move = moved
        .iter()
        .zip(&m.positions)
        .map(|(a, b)| a.distance(*b))
        .fold(0.0f32, f32::max);
    m.positions = moved;
    if m.normals.is_some() {
        m.recompute_normals();
    }
    progress.say(format_args!(
        "deformed {} vertices in {:.1} ms (largest move {max_move})",
        m.positions.len(),
        t.elapsed().as_secs_f64() * 1e3
    ));
    csrbf_mesh::write(out, m)?;
    progress.say(format_args!("wrote {}", out.display()));
    Ok(())
}
