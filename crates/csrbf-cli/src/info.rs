//! `info`: what a mesh, a control file or a deformation file holds.

use std::path::Path;

use anyhow::{Context, Result, bail};
use csrbf::format;
use serde_json::{Value, json};

use glam::Vec3;

use crate::common::{Progress, read_controls, read_mesh};

pub fn info(
    mesh: Option<&Path>,
    controls: Option<&Path>,
    deformation: Option<&Path>,
    as_json: bool,
) -> Result<()> {
    let value = match (mesh, controls, deformation) {
        (Some(m), None, None) if crate::volume::is_volume(m) => crate::volume::volume_info(m)?,
        (Some(m), None, None) => mesh_info(m)?,
        (m, Some(c), None) => controls_info(c, m)?,
        (None, None, Some(d)) => deformation_info(d)?,
        _ => bail!("give --mesh, --controls (with --mesh for handles and reach), or --deformation"),
    };
    if as_json {
        out_line!("{}", serde_json::to_string_pretty(&value)?);
    } else {
        print_plain(&value, 0);
    }
    Ok(())
}

fn print_plain(v: &Value, indent: usize) {
    let pad = " ".repeat(indent);
    match v {
        Value::Object(o) => {
            for (k, v) in o {
                match v {
                    Value::Object(_) => {
                        out_line!("{pad}{k}:");
                        print_plain(v, indent + 2);
                    }
                    Value::Array(a) if a.iter().any(|x| x.is_object()) => {
                        for (i, x) in a.iter().enumerate() {
                            out_line!("{pad}{k}[{i}]:");
                            print_plain(x, indent + 2);
                        }
                    }
                    _ => out_line!("{pad}{k}: {v}"),
                }
            }
        }
        other => out_line!("{pad}{other}"),
    }
}

fn mesh_info(path: &Path) -> Result<Value> {
    // Warnings (an OBJ's missing library or texture) go to standard error.
    let m = read_mesh(path, &Progress::new(false))?;
    let (lo, hi) = m.bounds().unwrap_or_default();
    let parts: Vec<Value> = m
        .parts
        .iter()
        .map(|p| {
            let verts = m.part_vertices(&p.name).unwrap_or_default();
            let pts: Vec<Vec3> = verts.iter().map(|&v| m.positions[v as usize]).collect();
            let (lo, hi) = pts.iter().fold(
                (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
                |(lo, hi), q| (lo.min(*q), hi.max(*q)),
            );
            let centroid = pts.iter().copied().sum::<Vec3>() / pts.len().max(1) as f32;
            json!({
                "name": p.name,
                "kind": p.kind.name(),
                "faces": p.faces.len(),
                "vertices": verts.len(),
                "bounds": if pts.is_empty() { Value::Null } else { json!({ "min": lo.to_array(), "max": hi.to_array() }) },
                "centroid": if pts.is_empty() { Value::Null } else { json!(centroid.to_array()) },
            })
        })
        .collect();
    let centroid = m.positions.iter().copied().sum::<Vec3>() / m.positions.len().max(1) as f32;
    let (up, why) = csrbf_mesh::guess_up(&m, path);
    Ok(json!({
        "file": path.display().to_string(),
        "vertices": m.positions.len(),
        "faces": m.faces.len(),
        "triangles": m.faces.triangle_count(),
        "bounds": { "min": lo.to_array(), "max": hi.to_array() },
        "diagonal": m.diagonal(),
        "centroid": centroid.to_array(),
        "up": format!("{} ({why})", csrbf_anim::camera::axis_name(up)),
        "uvs": m.uvs.is_some(),
        "colors": m.colors.is_some(),
        "normals": m.normals.is_some(),
        "materials": m.materials.len(),
        "textures": m.materials.iter().filter(|t| t.texture.is_some()).count(),
        "parts": parts,
    }))
}

fn controls_info(path: &Path, mesh_path: Option<&Path>) -> Result<Value> {
    let quiet = Progress::new(false);
    let file = read_controls(path, &quiet)?;
    let mesh = mesh_path.map(|m| read_mesh(m, &quiet)).transpose()?;
    let generated: Vec<usize> = file.deformations.iter().map(|s| s.starts.len()).collect();
    let source = path.display().to_string();
    let specs =
        csrbf_edit::resolve(&file, &source, mesh.as_ref(), &mut |_| {}).map_err(|e| match e {
            csrbf_edit::EditError::NeedsMesh { at, what } => {
                anyhow::anyhow!("{at}: {}", what.replace("give the mesh", "give --mesh"))
            }
            e => anyhow::Error::new(e),
        })?;
    let mut stages = Vec::new();
    for (i, s) in specs.iter().enumerate() {
        if s.starts.is_empty() {
            // Work in progress: nothing to fit (the reader warned).
            stages.push(json!({
                "controls": 0,
                "kernel": s.options.kernel.name(),
                "radius": s.options.radius,
                "polynomial": s.options.polynomial.name(),
            }));
            continue;
        }
        // The edit layer's one fit: the single map (with its system's
        // figures) or the sweep.
        let fitted = csrbf_edit::fit_spec(s)
            .with_context(|| format!("{}: deformation {i}", path.display()))?;
        let (lo, hi) = s
            .starts
            .iter()
            .fold((s.starts[0], s.starts[0]), |(a, b), p| {
                (a.min(*p), b.max(*p))
            });
        let mut stage = json!({
            "controls": s.starts.len(),
            "kernel": s.options.kernel.name(),
            "radius": s.options.radius,
            "polynomial": s.options.polynomial.name(),
            "bounds": { "min": lo.to_array(), "max": hi.to_array() },
        });
        let sys = match &fitted.stats {
            Some(st) => st.clone(),
            // A sweep: the figures of the system of its starts.
            None => csrbf::System::new(&s.starts, s.options)
                .with_context(|| format!("{}: deformation {i}", path.display()))?
                .stats()
                .clone(),
        };
        if let Some(o) = stage.as_object_mut() {
            o.extend(system_json(&sys));
        }
        let stage_obj = stage.as_object_mut().context("stage")?;
        if s.starts.len() > generated[i] {
            // The vectors a handle made, after the file's own.
            let made: Vec<Value> = (generated[i]..s.starts.len())
                .map(|j| json!({ "from": s.starts[j].to_array(), "to": s.targets[j].to_array() }))
                .collect();
            stage_obj.insert("handle_vectors".into(), json!(made));
        }
        // The fold-free certificate: the single map's bound of |dD/dx| (below
        // 1: it cannot fold), and a sweep's steps and their bound.
        stage_obj.insert("gradient_bound".into(), json!(fitted.gradient_bound()));
        if let Some(sw) = &fitted.sweep {
            stage_obj.insert(
                "sweep".into(),
                json!({ "steps": sw.steps, "step_bound": sw.bound, "certified": sw.certified }),
            );
        }
        let stages1 = fitted.stages;
        if let Some(m) = &mesh {
            // Per control: the vertices within R of its start.
            let within = csrbf::vertices_within(&m.positions, &s.starts, s.options.radius);
            stage_obj.insert("vertices_within_r".into(), json!(within));
            let lookup = |n: &str| m.part_vertices(n);
            let moved =
                csrbf::compose_with_groups(&m.positions, &stages1, csrbf::Combine::Chain, &lookup)?;
            let report = csrbf::diagnose(
                &m.positions,
                &moved,
                &m.faces.triangles(),
                &stages1,
                csrbf::Combine::Chain,
                &lookup,
            )?;
            stage_obj.insert(
                "diagnostics".into(),
                json!({
                    "moved": report.moved,
                    "largest_move": report.largest_move,
                    "flipped_faces": report.flipped.len(),
                    "inside_out_faces": report.inside_out.len(),
                    "fold_phase": report.fold_phase,
                    "warnings": report.warnings.iter().map(|w| w.to_string()).collect::<Vec<_>>(),
                }),
            );
        }
        stages.push(stage);
    }
    // The first deformation's figures at the top level; every one under "deformations".
    let mut top = json!({ "file": path.display().to_string(), "deformations_count": stages.len() });
    if let (Some(t), Some(first)) = (top.as_object_mut(), stages[0].as_object()) {
        t.extend(first.clone());
    }
    if stages.len() > 1 {
        top["deformations"] = json!(stages);
    }
    Ok(top)
}

/// A system's figures as `info` prints them.
fn system_json(st: &csrbf::SystemStats) -> serde_json::Map<String, Value> {
    let v = json!({
        "neighbours": { "min": st.neighbours_min, "mean": st.neighbours_mean, "max": st.neighbours_max },
        "nonzeros": st.nonzeros,
        "bandwidth_before": st.bandwidth_before,
        "envelope_before": st.envelope_before,
        "bandwidth": st.bandwidth,
        "envelope": st.envelope,
        "ordering": st.ordering,
        "orderings": st.orderings.iter().map(|o| json!({ "ordering": o.ordering, "bandwidth": o.bandwidth, "envelope": o.envelope })).collect::<Vec<_>>(),
        "profile_bytes": st.profile_bytes,
        "dense_bytes": st.dense_bytes,
        "factor_bytes": st.factor_bytes,
        "solver": st.solver,
    });
    match v {
        Value::Object(o) => o,
        _ => serde_json::Map::new(),
    }
}

fn deformation_info(path: &Path) -> Result<Value> {
    let bytes = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
    let replay = format::decode(&bytes).with_context(|| path.display().to_string())?;
    let list: Vec<Value> = replay
        .stages
        .iter()
        .map(|s| {
            let (d, r, phase) = (&s.deformation, &s.region, s.phase);
            let mut v = json!({
                "controls": d.starts().len(),
                "kernel": d.kernel().name(),
                "radius": d.radius(),
                "polynomial": d.polynomial().name(),
                "phase": phase,
                "region": r.to_string(),
                "gradient_bound": d.gradient_bound(),
            });
            if let Some(step) = s.sweep {
                v["sweep_step"] = json!({ "step": step.index, "steps": step.count });
            }
            v
        })
        .collect();
    Ok(json!({
        "file": path.display().to_string(),
        "bytes": bytes.len(),
        "version": u16::from_le_bytes([bytes[6], bytes[7]]),
        "combine": replay.combine.name(),
        "deformations": list,
        // The mesh its regions' vertex indices refer to (apply refuses another).
        "fitted_on_mesh": replay.mesh.map(|m| json!({ "vertices": m.vertices, "faces_hash": m.faces })),
    }))
}
