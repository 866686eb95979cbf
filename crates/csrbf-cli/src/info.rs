//! `info`: what a mesh, a control file or a deformation file holds.

use std::path::Path;

use anyhow::{Context, Result, bail};
use csrbf::{System, format};
use serde_json::{Value, json};

use crate::common::{Progress, read_controls};

pub fn info(
    mesh: Option<&Path>,
    controls: Option<&Path>,
    deformation: Option<&Path>,
    as_json: bool,
) -> Result<()> {
    let value = match (mesh, controls, deformation) {
        (Some(m), None, None) => mesh_info(m)?,
        (None, Some(c), None) => controls_info(c)?,
        (None, None, Some(d)) => deformation_info(d)?,
        _ => bail!("give one of --mesh, --controls or --deformation"),
    };
    if as_json {
        println!("{}", serde_json::to_string_pretty(&value)?);
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
                        println!("{pad}{k}:");
                        print_plain(v, indent + 2);
                    }
                    Value::Array(a) if a.iter().any(|x| x.is_object()) => {
                        for (i, x) in a.iter().enumerate() {
                            println!("{pad}{k}[{i}]:");
                            print_plain(x, indent + 2);
                        }
                    }
                    _ => println!("{pad}{k}: {v}"),
                }
            }
        }
        other => println!("{pad}{other}"),
    }
}

fn mesh_info(path: &Path) -> Result<Value> {
    let m = csrbf_mesh::read(path)?;
    let (lo, hi) = m.bounds().unwrap_or_default();
    let parts: Vec<Value> = m
        .parts
        .iter()
        .map(|p| json!({ "name": p.name, "kind": p.kind.name(), "faces": p.faces.len() }))
        .collect();
    Ok(json!({
        "file": path.display().to_string(),
        "vertices": m.positions.len(),
        "faces": m.faces.len(),
        "triangles": m.faces.triangle_count(),
        "bounds": { "min": lo.to_array(), "max": hi.to_array() },
        "diagonal": m.diagonal(),
        "uvs": m.uvs.is_some(),
        "colors": m.colors.is_some(),
        "normals": m.normals.is_some(),
        "materials": m.materials.len(),
        "parts": parts,
    }))
}

fn controls_info(path: &Path) -> Result<Value> {
    let specs = read_controls(path, &Progress::new(false))?;
    let mut stages = Vec::new();
    for (i, s) in specs.iter().enumerate() {
        let sys = System::new(&s.starts, s.options)
            .with_context(|| format!("{}: deformation {i}", path.display()))?;
        let st = sys.stats();
        let (lo, hi) = s
            .starts
            .iter()
            .fold((s.starts[0], s.starts[0]), |(a, b), p| {
                (a.min(*p), b.max(*p))
            });
        stages.push(json!({
            "controls": st.controls,
            "kernel": s.options.kernel.name(),
            "radius": s.options.radius,
            "polynomial": s.options.polynomial.name(),
            "bounds": { "min": lo.to_array(), "max": hi.to_array() },
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
        }));
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

fn deformation_info(path: &Path) -> Result<Value> {
    let bytes = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
    let stages = format::decode(&bytes).with_context(|| path.display().to_string())?;
    let list: Vec<Value> = stages
        .iter()
        .map(|(d, r)| {
            json!({
                "controls": d.starts().len(),
                "kernel": d.kernel().name(),
                "radius": d.radius(),
                "polynomial": d.polynomial().name(),
                "region": format!("{r:?}"),
            })
        })
        .collect();
    Ok(
        json!({ "file": path.display().to_string(), "bytes": bytes.len(), "version": format::VERSION, "deformations": list }),
    )
}
