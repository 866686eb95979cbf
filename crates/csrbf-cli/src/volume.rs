//! Volume meshes (.vtk, .vtu, .msh) in `deform` and `info`: the edit
//! layer's morphs and cell checks, translated into flags and lines.

use std::path::Path;

use anyhow::{Context, Result, bail};
use csrbf_edit::Note;
use csrbf_edit::volume::{BoundaryMorph, VolumeMorph, VolumeReport, morph_boundary};
use csrbf_mesh::volume::{VolumeFormat, VolumeMesh};

use crate::common::{Progress, check_output, check_phase};
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
    let morph = read_morph(&a.controls)?;
    let mesh = read_volume(&a.mesh, progress)?;
    let mut notes = |n: Note| match n {
        Note::Progress(t) => progress.say(t),
        Note::Warning(t) => err_line!("warning: {t}"),
        _ => {}
    };
    let (moved, report) = morph
        .run(&mesh, a.phase, a.allow_large, &mut notes)
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

/// A control file or a boundary-driven morph by path, the reader's
/// warnings (a control file's unknown keys) printed.
fn read_morph(path: &Path) -> Result<VolumeMorph> {
    let morph = VolumeMorph::read(path)?;
    for w in morph.warnings() {
        err_line!("warning: {}: {w}", path.display());
    }
    Ok(morph)
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
pub fn picture(
    path: &Path,
    controls: Option<&Path>,
    phase: f64,
    allow_large: bool,
) -> Result<Picture> {
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
    let mut notes = |n: Note| {
        if let Note::Warning(t) = n {
            err_line!("warning: {t}");
        }
    };
    let (points, report) = read_morph(c)?
        .run(&mesh, phase, allow_large, &mut notes)
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

/// `bench --scene volume/N/K/S`: the box of N^3 cubes (6 tetrahedra each)
/// around K^3 cavities of S^3 cubes, every cavity moved by half a cube
/// (and a quarter sideways) and the box's sides held, R four cubes wide
/// (or R); every boundary node a control. Or a volume mesh and a morph
/// file.
pub fn bench(
    scene: Option<&str>,
    files: Option<(&Path, &Path)>,
    runs: usize,
    json: bool,
    export: Option<&Path>,
    progress: &Progress,
) -> Result<()> {
    let (name, mesh, morph) = match (scene, files) {
        (_, Some((m, c))) => {
            if export.is_some() {
                bail!(
                    "--export writes the synthetic volume scenes (--scene volume/N/K/S); {} is a file already",
                    m.display()
                );
            }
            let VolumeMorph::Boundary(morph) = read_morph(c)? else {
                bail!(
                    "{}: bench of a volume mesh times a boundary-driven morph (a document with \"boundary\")",
                    c.display()
                );
            };
            (m.display().to_string(), read_volume(m, progress)?, morph)
        }
        (Some(s), None) => {
            let dims: Vec<f64> = s
                .strip_prefix("volume/")
                .map(|r| r.split('/').map(str::parse).collect::<Result<_, _>>())
                .transpose()
                .ok()
                .flatten()
                .filter(|d: &Vec<f64>| {
                    (3..=4).contains(&d.len())
                        && d[..3].iter().all(|x| x.fract() == 0.0 && *x >= 0.0)
                        && (1.0..=400.0).contains(&d[0])
                        && d.get(3).is_none_or(|r| *r > 0.0 && r.is_finite())
                })
                .with_context(|| {
                    format!("--scene {s}: expected volume/N/K/S[/R] (N^3 cubes of 6 tetrahedra, 1 to 400; K^3 cavities of S^3 cubes; R in cubes, 4 by default): volume/56/1/20 has 1M cells")
                })?;
            let (n, k, c) = (dims[0] as usize, dims[1] as usize, dims[2] as usize);
            let h = 2.0 / n as f64;
            let cubes = dims.get(3).copied().unwrap_or(4.0);
            let mesh = csrbf_mesh::volume::shapes::box_with_cavities(n, k, c);
            let moved = if k > 0 && c > 0 { "inner" } else { "outer" };
            let hold: Vec<&str> = if moved == "inner" {
                vec!["outer"]
            } else {
                vec![]
            };
            let doc = serde_json::json!({"boundary": {"radius": cubes * h,
                "move": [{"zone": moved, "translate": [0.5 * h, 0.25 * h, 0.0]}], "hold": hold}});
            let morph = BoundaryMorph::from_value(&doc, Path::new(s))
                .map_err(|e| anyhow::anyhow!("{s}: {e}"))?;
            (format!("volume-{n}-{k}-{c}"), mesh, morph)
        }
        (None, None) => bail!("give --scene volume/N/K/S or --mesh and --controls"),
    };
    if let Some(dir) = export {
        let base = dir.join(&name);
        csrbf_mesh::volume::write(&base.with_extension("vtu"), &mesh)?;
        let doc = serde_json::json!({"boundary": {
            "radius": morph.options.radius,
            "kernel": morph.options.kernel.name(),
            "move": morph.moves.iter().map(|m| match &m.motion {
                csrbf_edit::volume::Motion::Rigid(h) => serde_json::json!({"zone": m.zone, "translate": h.translate.map(|t| t.to_array())}),
                _ => serde_json::json!({"zone": m.zone}),
            }).collect::<Vec<_>>(),
            "hold": morph.hold,
        }});
        csrbf_mesh::write_atomic(
            &base.with_extension("json"),
            serde_json::to_string_pretty(&doc)?.as_bytes(),
        )?;
        progress.say(format_args!("wrote {}.vtu and .json", base.display()));
        return Ok(());
    }
    progress.say(format_args!(
        "{name}: {} nodes, {} cells, R {}",
        mesh.points.len(),
        mesh.cells.len(),
        csrbf::plain_number(morph.options.radius)
    ));
    let mut figures = Vec::new();
    for _ in 0..runs.max(1) {
        let (_, r) = morph_boundary(&mesh, &morph, 1.0, &mut |_| {})?;
        figures.push(r);
    }
    let median = |f: &dyn Fn(&VolumeReport) -> f64| {
        let mut v: Vec<f64> = figures.iter().map(f).collect();
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let last = figures.last().context("no run")?;
    let (fit, morph_ms, check) = (
        median(&|r| r.fit_ms),
        median(&|r| r.morph_ms),
        median(&|r| r.check_ms),
    );
    let solid = last.cells.cells;
    let value = serde_json::json!({
        "scene": name,
        "nodes": mesh.points.len(),
        "cells": mesh.cells.len(),
        "solid_cells": solid,
        "controls": last.controls,
        "radius": morph.options.radius,
        "fit_ms": fit,
        "evaluate_ms": morph_ms - check,
        "check_ms": check,
        "total_ms": fit + morph_ms,
        "inverted_cells": last.cells.inverted.len(),
        "min_scaled_jacobian_after": last.cells.min_scaled_jacobian_after,
        "peak_rss_mb": crate::bench::peak_rss_mb(),
        "runs": runs,
    });
    if json {
        out_line!("{}", serde_json::to_string_pretty(&value)?);
    } else {
        out_line!(
            "{name}: {} nodes, {} cells, {} controls | fit {fit:.1} ms | evaluate {:.1} ms | cell check {check:.1} ms | {} inverted | peak {:.0} MB",
            mesh.points.len(),
            solid,
            last.controls,
            morph_ms - check,
            last.cells.inverted.len(),
            crate::bench::peak_rss_mb()
        );
    }
    Ok(())
}
