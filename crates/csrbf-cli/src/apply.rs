//! `apply`: a saved deformation (`.csrbf`) replayed on a mesh.

use std::path::Path;

use anyhow::{Context, Result};
use csrbf::format;

use crate::common::{CheckArgs, Progress, check_output, check_phase, read_mesh};
use crate::deform::write_deformed;

pub fn apply(
    mesh: &Path,
    deformation: &Path,
    phase: f64,
    out: &Path,
    force: bool,
    (json, check): (bool, &CheckArgs),
    progress: &Progress,
) -> Result<()> {
    check_phase(phase)?;
    let checks = check.checks()?;
    check_output(out, &[mesh, deformation], force, true)?;
    let bytes = std::fs::read(deformation)
        .with_context(|| format!("cannot read {}", deformation.display()))?;
    let replay = format::decode(&bytes).with_context(|| deformation.display().to_string())?;
    progress.say(format_args!(
        "{}: {} deformation(s), {}",
        deformation.display(),
        replay.stages.len(),
        replay.combine
    ));
    let mut m = read_mesh(mesh, progress)?;
    if let Some(stamp) = &replay.mesh {
        stamp
            .check(&csrbf_edit::apply::mesh_stamp(&m))
            .with_context(|| format!("{} on {}", deformation.display(), mesh.display()))?;
    }
    let (moved, report) =
        csrbf_edit::apply::compose_report(&m, &replay.stages, replay.combine, phase, &checks)
            .with_context(|| mesh.display().to_string())?;
    write_deformed(&mut m, moved, &report, (out, force, json), progress)
}
