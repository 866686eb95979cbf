//! Issue 39, one road: every control file of `assets/controls/road` (single,
//! chain, add, sphere, box, vertex, group and connected regions, a handle
//! turning about a pivot with an anchor, a sweep, a layer without controls,
//! an edit that folds) deformed by `csrbf deform` and by the studio's core
//! (its `Live`, the edit layer's `Session`) gives the same positions bit for
//! bit and the same report, times aside. Python and Blender check
//! themselves against the same files (crates/csrbf-py/tests, blender/tests).

use std::path::PathBuf;

use serde_json::Value;

use crate::support::*;

/// The road's files, each with the bundled model it is written for.
pub fn road_cases() -> Vec<(PathBuf, PathBuf)> {
    let dir = root().join("assets/controls/road");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("assets/controls/road")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .collect();
    files.sort();
    assert!(files.len() >= 12, "{files:?}");
    files
        .into_iter()
        .map(|f| {
            let name = f.file_name().map(|n| n.to_string_lossy().into_owned());
            let mesh = if name.is_some_and(|n| n.starts_with("duck")) {
                root().join("assets/models/pybullet_duck.obj")
            } else {
                root().join("assets/models/cgal_head.off")
            };
            (mesh, f)
        })
        .collect()
}

/// A report's serialised form without what differs run to run: the times,
/// and the radius of a bounded remedies' search that stopped early.
pub fn untimed(v: &Value) -> Value {
    let mut v = v.clone();
    if let Some(o) = v.as_object_mut() {
        o.retain(|k, _| {
            !k.ends_with("_ms") && !["output", "files", "write_warnings"].contains(&k.as_str())
        });
        if let Some(Value::Object(r)) = o.get_mut("remedies") {
            let complete = r.get("complete") == Some(&Value::Bool(true));
            r.retain(|k, _| !k.ends_with("_ms") && k != "advice");
            if !complete {
                r.remove("radius_scale");
                r.remove("complete");
            }
        }
    }
    v
}

#[test]
fn every_front_end_deforms_the_road_files_alike() {
    use csrbf_studio_core::{Document, Live};
    let dir = TempDir::new("road");
    for (mesh_path, controls) in road_cases() {
        let name = controls
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let out = dir.path(&format!("{name}.ply"));
        let cli = deform_json(&mesh_path, &controls, &out, &["--phase", "0.7"]);
        let theirs = csrbf_mesh::read(&out).expect("the CLI's output");

        let mesh = csrbf_mesh::read(&mesh_path).expect("mesh");
        let mut doc = Document::new(mesh, mesh_path.clone(), 1.0);
        let text = std::fs::read_to_string(&controls).expect("controls");
        doc.controls = csrbf_edit::ControlFile::parse(&text).expect("parse");
        doc.phase = 0.7;
        let mut live = Live::without_picking(&doc);
        live.update(&doc).expect("the studio's core");
        assert!(
            live.positions() == &theirs.positions[..],
            "{name}: the studio's positions differ from csrbf deform's"
        );
        let studio = live.report().expect("report").to_json();
        assert_eq!(untimed(&studio), untimed(&cli), "{name}");
    }
}
