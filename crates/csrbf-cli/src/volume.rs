//! Volume meshes (.vtk, .vtu, .msh) in `deform` and `info`: the edit
//! layer's morphs and cell checks, translated into flags and lines.

use std::path::Path;

use anyhow::{Context, Result, bail};
use csrbf_edit::Note;
use csrbf_edit::volume::{BoundaryMorph, VolumeReport, morph_boundary, morph_volume};
use csrbf_mesh::volume::{VolumeFormat, VolumeMesh};

use crate::common::{Progress, check_output, check_phase, read_controls};
use crate::deform::DeformArgs;

/// Whether a path names a volume mesh by its extension.
pub fn is_volume(path: &Path) -> bool {
    VolumeFormat::is_volume_path(path)
}

/// Reads a volume mesh, saying how much it holds.
pub fn read_volume(path: &Path, progress: &Progress) -> Result<VolumeMesh> {
    let t = std::time::Instant::now();
    let mesh = csrbf_mesh::volume::read(path)?;
    progress.say(format_args!(
        "{}: {} nodes, {} cells ({}), {} zone(s), read in {:.1} ms",
        path.display(),
        mesh.points.len(),
        mesh.cells.len(),
        mesh.cells
            .counts()
            .iter()
            .map(|(k, n)| format!("{n} {}", k.name()))
            .collect::<Vec<_>>()
            .join(", "),
        mesh.zones.len(),
        t.elapsed().as_secs_f64() * 1e3
    ));
    Ok(mesh)
}

/// `deform` of a volume mesh: a control file moves every node, or a
/// boundary-driven morph (a document with `boundary`) moves named zones and
/// holds others; every cell is checked and the morphed mesh written in any
/// volume format.
pub fn deform_volume(a: &DeformArgs, progress: &Progress) -> Result<()> {
    check_phase(a.phase)?;
    if !is_volume(&a.out) {
        bail!(
            "{}: the input is a volume mesh; write it as one of {} (its boundary surface: `csrbf render`)",
            a.out.display(),
            VolumeFormat::EXTENSIONS
        );
    }
    check_output(
        &a.out,
        &[a.mesh.as_path(), a.controls.as_path()],
        a.force,
        false,
    )?;
    let text = std::fs::read_to_string(&a.controls)
        .with_context(|| format!("cannot read control file {}", a.controls.display()))?;
    let root: Option<serde_json::Value> =
        serde_json::from_str(csrbf_edit::json::strip_bom(&text)).ok();
    let boundary = root.as_ref().is_some_and(BoundaryMorph::is_boundary);
    let mesh = read_volume(&a.mesh, progress)?;
    let mut notes = |n: Note| match n {
        Note::Progress(t) => progress.say(t),
        Note::Warning(t) => err_line!("warning: {t}"),
        _ => {}
    };
    let (moved, report) = if boundary {
        let morph = BoundaryMorph::read(&a.controls)?;
        morph_boundary(&mesh, &morph, a.phase, &mut notes)
    } else {
        let file = read_controls(&a.controls, progress)?;
        let source = a.controls.display().to_string();
        morph_volume(&mesh, &file, &source, a.phase, a.allow_large, &mut notes)
    }
    .with_context(|| a.mesh.display().to_string())?;
    say_report(&report, progress);
    let mut out = mesh;
    out.points = moved;
    csrbf_mesh::volume::write(&a.out, &out)?;
    progress.say(format_args!("wrote {}", a.out.display()));
    if a.json {
        let mut value = serde_json::json!({ "output": a.out.display().to_string() });
        if let (Some(o), serde_json::Value::Object(r)) = (value.as_object_mut(), report.to_json()) {
            o.extend(r);
        }
        out_line!("{}", serde_json::to_string_pretty(&value)?);
    }
    Ok(())
}

/// The report's lines: the summary, per zone, and the advice as a warning.
fn say_report(report: &VolumeReport, progress: &Progress) {
    progress.say(format_args!(
        "morphed {} nodes in {:.1} ms (fit {:.1} ms): {}",
        report.nodes,
        report.morph_ms,
        report.fit_ms,
        report.summary()
    ));
    for z in &report.cells.zones {
        progress.say(format_args!(
            "  zone {}: {} cells, {} inside out, least scaled Jacobian {:.3}",
            z.name, z.cells, z.inverted, z.min_scaled_jacobian_after
        ));
    }
    if !report.advice.is_empty() {
        err_line!("warning: {}", report.advice);
    }
}

/// `info --mesh` of a volume mesh.
pub fn volume_info(path: &Path) -> Result<serde_json::Value> {
    let mesh = csrbf_mesh::volume::read(path)?;
    let mut value = serde_json::json!({ "file": path.display().to_string() });
    if let (Some(o), serde_json::Value::Object(r)) =
        (value.as_object_mut(), csrbf_edit::volume::describe(&mesh))
    {
        o.extend(r);
    }
    Ok(value)
}

/// What `render` draws of a volume mesh: its boundary surface at rest
/// (vertex i is node i) with, after the boundary's faces, every face of
/// the cells the morph turns inside out; the surface's positions after the
/// morph (the rest ones without controls); and those appended faces.
pub struct Picture {
    /// The rest surface.
    pub rest: csrbf_mesh::Mesh,
    /// Its positions after the morph.
    pub moved: Vec<glam::Vec3>,
    /// The faces of the inverted cells (indices into `rest.faces`).
    pub inverted_faces: Vec<u32>,
}

/// The surface of a volume mesh to draw, morphed by `controls` (a control
/// file or a boundary-driven morph) at `phase` when given.
pub fn picture(path: &Path, controls: Option<&Path>, phase: f64) -> Result<Picture> {
    let quiet = Progress::new(false);
    let mesh = read_volume(path, &quiet)?;
    let mut rest = mesh.surface();
    let Some(c) = controls else {
        let moved = rest.positions.clone();
        return Ok(Picture {
            rest,
            moved,
            inverted_faces: Vec::new(),
        });
    };
    let text = std::fs::read_to_string(c)
        .with_context(|| format!("cannot read control file {}", c.display()))?;
    let root: Option<serde_json::Value> =
        serde_json::from_str(csrbf_edit::json::strip_bom(&text)).ok();
    let mut notes = |n: Note| {
        if let Note::Warning(t) = n {
            err_line!("warning: {t}");
        }
    };
    let (points, report) = if root.as_ref().is_some_and(BoundaryMorph::is_boundary) {
        morph_boundary(&mesh, &BoundaryMorph::read(c)?, phase, &mut notes)
    } else {
        let file = read_controls(c, &quiet)?;
        morph_volume(
            &mesh,
            &file,
            &c.display().to_string(),
            phase,
            false,
            &mut notes,
        )
    }
    .with_context(|| path.display().to_string())?;
    let mut inverted_faces = Vec::new();
    for &cell in &report.cells.inverted {
        let nodes = mesh.cells.cell(cell as usize);
        for f in mesh.cells.kinds[cell as usize].faces() {
            let face: Vec<u32> = f.iter().map(|&l| nodes[l]).collect();
            inverted_faces.push(rest.faces.len() as u32);
            rest.faces.push(&face);
        }
    }
    let moved = points.iter().map(|p| p.as_vec3()).collect();
    Ok(Picture {
        rest,
        moved,
        inverted_faces,
    })
}
