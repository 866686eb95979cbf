//! A mesh file deformed by a control file, the way every front end does it
//! (the edit layer: regions, handles and sweeps resolved, the result checked):
//!
//! `cargo run --release -p csrbf-edit --example deform_file -- assets/models/cgal_head.off assets/controls/head_smile.json out/smile.obj`

use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<PathBuf> = std::env::args_os().skip(1).map(PathBuf::from).collect();
    let [mesh_path, controls_path, out_path] = &args[..] else {
        return Err("usage: deform_file MESH CONTROLS.json OUT".into());
    };
    let mut mesh = csrbf_mesh::read(mesh_path)?;
    let text = std::fs::read_to_string(controls_path)?;
    let file = csrbf_edit::controls::ControlFile::parse(&text)
        .map_err(|e| format!("{}: {e}", controls_path.display()))?;
    let report = csrbf_edit::apply::deform_mesh(&mut mesh, &file, 1.0)?;
    let d = &report.diagnostics;
    println!(
        "{} vertices; {} faces inside out; {} warnings",
        report.vertices,
        d.inside_out.len(),
        d.warnings.len()
    );
    for w in &d.warnings {
        println!("warning: {w}");
    }
    csrbf_mesh::write(out_path, &mesh)?;
    println!("wrote {}", out_path.display());
    Ok(())
}
