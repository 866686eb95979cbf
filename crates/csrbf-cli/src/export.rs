//! `export`: a scene as glTF 2.0 with morph targets and sampled motion.

use std::path::Path;

use anyhow::{Result, bail};

use crate::animate::load_scene;
use crate::common::{Progress, check_output};

pub fn export(scene: &Path, out: &Path, force: bool, progress: &Progress) -> Result<()> {
    let ext = crate::common::extension_in(out, &["glb", "gltf"], "export format")?;
    if out.exists() && !force {
        bail!("{}: exists; pass --force to replace it", out.display());
    }
    check_output(out, &[scene], force, false)?;
    let s = load_scene(scene)?;
    for note in csrbf_anim::export_notes(&s) {
        err_line!("note: {}: {note}", scene.display());
    }
    let bytes = csrbf_anim::export_gltf(&s, ext == "glb");
    csrbf_mesh::write_atomic(out, &bytes)?;
    progress.say(format_args!(
        "wrote {} ({} bytes)",
        out.display(),
        bytes.len()
    ));
    Ok(())
}
