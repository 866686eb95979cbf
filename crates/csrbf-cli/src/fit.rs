//! `fit`: the deformations of a control file, fitted and saved compactly.

use std::path::Path;

use anyhow::Result;
use csrbf::format;

use crate::common::{Progress, check_output, fit_edit, read_controls, read_mesh};

pub fn fit(
    controls: &Path,
    mesh: Option<&Path>,
    out: &Path,
    force: bool,
    allow_large: bool,
    progress: &Progress,
) -> Result<()> {
    let inputs: Vec<&Path> = std::iter::once(controls).chain(mesh).collect();
    check_output(out, &inputs, force, false)?;
    let ext = crate::common::extension_in(out, &["csrbf", "json"], "deformation format")?;
    let file = read_controls(controls, progress)?;
    let m = mesh.map(|p| read_mesh(p, progress)).transpose()?;
    let stages = fit_edit(&file, controls, m.as_ref(), allow_large, progress)?.stages();
    // Regions that list vertices (resolved on the mesh) hold for that mesh
    // alone: the file names it, and `apply` refuses another.
    let stamp = m
        .as_ref()
        .filter(|_| format::Replay::lists_vertices(&stages))
        .map(csrbf_edit::apply::mesh_stamp);
    let bytes = if ext == "json" {
        let mut value = format::to_json(&stages, file.combine);
        if let Some(s) = stamp {
            value["mesh"] = serde_json::json!({ "vertices": s.vertices, "faces_hash": s.faces });
        }
        serde_json::to_vec_pretty(&value)?
    } else {
        format::encode_for(&stages, file.combine, stamp)
    };
    csrbf_mesh::write_atomic(out, &bytes)?;
    progress.say(format_args!(
        "wrote {} ({} bytes)",
        out.display(),
        bytes.len()
    ));
    Ok(())
}
