//! A region that follows the surface (issue 23) through every reader:
//! `deform`, `fit` + `apply`, scenes, and bad input named by its key.

use std::path::{Path, PathBuf};

use crate::support::*;

/// An "arm beside a torso": a strip bent into a hairpin, the torso leg at
/// x = 0 and the arm leg at x = 0.2, both 2 long down from y = 0, joined
/// over the top; over z in [0, 1]. Written as OBJ; returns the path and,
/// per vertex, whether it is on the torso leg.
pub fn hairpin(dir: &TempDir) -> (PathBuf, Vec<bool>) {
    let (gap, step, legs, rows) = (0.2f32, 0.05f32, 40usize, 10usize);
    let mut path = Vec::new();
    for k in (0..=legs).rev() {
        path.push((0.0, -(k as f32) * step));
    }
    let arc = 6;
    for k in 1..arc {
        let a = std::f32::consts::PI * (1.0 - k as f32 / arc as f32);
        path.push((gap / 2.0 * (1.0 + a.cos()), gap / 2.0 * a.sin()));
    }
    for k in 0..=legs {
        path.push((gap, -(k as f32) * step));
    }
    let mut obj = String::new();
    let mut torso = Vec::new();
    for &(x, y) in &path {
        for j in 0..=rows {
            obj.push_str(&format!("v {x} {y} {}\n", j as f32 / rows as f32));
            torso.push(x < gap / 2.0 && y < 0.0);
        }
    }
    let at = |i: usize, j: usize| i * (rows + 1) + j + 1;
    for i in 0..path.len() - 1 {
        for j in 0..rows {
            obj.push_str(&format!(
                "f {} {} {}\n",
                at(i, j),
                at(i + 1, j),
                at(i + 1, j + 1)
            ));
            obj.push_str(&format!(
                "f {} {} {}\n",
                at(i, j),
                at(i + 1, j + 1),
                at(i, j + 1)
            ));
        }
    }
    (dir.write("hairpin.obj", obj), torso)
}

/// The arm leg pulled outward near its bottom, R reaching across the gap.
fn pull(region: &str) -> String {
    format!(
        r#"{{"radius": 0.6, "kernel": "c2",
            "controls": [{{"from": [0.2, -1.5, 0.5], "to": [0.3, -1.5, 0.5]}},
                         {{"from": [0.2, -1.0, 0.5], "to": [0.2, -1.0, 0.5]}}],
            "region": {region}}}"#
    )
}

fn moves(rest: &Path, out: &Path) -> Vec<f32> {
    let a = csrbf_mesh::read(rest).expect("rest");
    let b = csrbf_mesh::read(out).expect("out");
    a.positions
        .iter()
        .zip(&b.positions)
        .map(|(p, q)| p.distance(*q))
        .collect()
}

fn torso_moved(m: &[f32], torso: &[bool]) -> usize {
    m.iter()
        .zip(torso)
        .filter(|(m, t)| **t && **m > 0.0)
        .count()
}

#[test]
fn a_connected_region_keeps_the_torso_still_in_every_reader() {
    let dir = TempDir::new("connected");
    let (mesh, torso) = hairpin(&dir);
    let deform = |name: &str, controls: &Path| {
        let out = dir.path(name);
        let json = deform_json(&mesh, controls, &out, &[]);
        (out, json)
    };
    let spatial = dir.write("spatial.json", pull("null"));
    let (out, _) = deform("spatial.obj", &spatial);
    assert!(
        torso_moved(&moves(&mesh, &out), &torso) > 50,
        "the space map reaches the torso"
    );

    let connected = dir.write(
        "connected.json",
        pull(r#"{"connected": {"distance": 0.5, "from": "starts"}, "falloff": 0.3}"#),
    );
    let (out, json) = deform("connected.obj", &connected);
    let m = moves(&mesh, &out);
    assert_eq!(torso_moved(&m, &torso), 0, "the torso moved");
    assert!(m.iter().any(|&x| x > 0.09), "the arm did not move");
    assert_eq!(json["inside_out_faces"], 0, "{json}");
    // A blended region is no seam.
    assert!(
        !json.to_string().contains("past the region's edge"),
        "{json}"
    );

    // fit (on the mesh) + apply gives the same positions.
    let fitted = dir.path("connected.csrbf");
    ok(&[
        "fit",
        "-q",
        "--mesh",
        arg(&mesh),
        "--controls",
        arg(&connected),
        "--out",
        arg(&fitted),
    ]);
    let applied = dir.path("applied.obj");
    ok(&[
        "apply",
        "-q",
        "--mesh",
        arg(&mesh),
        "--deformation",
        arg(&fitted),
        "--out",
        arg(&applied),
    ]);
    let a = csrbf_mesh::read(&out).expect("deformed");
    let b = csrbf_mesh::read(&applied).expect("applied");
    assert_eq!(a.positions, b.positions, "apply differs from deform");
    // The file's region lists this mesh's vertices: another mesh, or the
    // same count of vertices with other faces, is refused before any move;
    // the same faces in another order are the same mesh.
    let head = root().join("assets/models/cgal_head.off");
    let pin = csrbf_mesh::read(&mesh).expect("hairpin");
    let faces: Vec<Vec<u32>> = pin.faces.iter().map(<[u32]>::to_vec).collect();
    let with_faces = |name: &str, faces: &[Vec<u32>]| {
        let mut m = pin.clone();
        m.faces = csrbf_mesh::Faces::new();
        for f in faces {
            m.faces.push(f);
        }
        let path = dir.path(name);
        csrbf_mesh::write(&path, &m).expect("write");
        path
    };
    let reversed: Vec<Vec<u32>> = faces.iter().rev().cloned().collect();
    let reordered = with_faces("reordered.obj", &reversed);
    let mut flipped = faces.clone();
    flipped[0].reverse();
    let other = with_faces("other.obj", &flipped);
    ok(&[
        "apply",
        "-q",
        "--mesh",
        arg(&reordered),
        "--deformation",
        arg(&fitted),
        "--out",
        arg(&dir.path("reordered_out.obj")),
    ]);
    for (on, want) in [
        (&head, "it was fitted on a mesh of"),
        (&other, "with other faces"),
    ] {
        let out = dir.path("elsewhere.obj");
        fails(
            &[
                "apply",
                "--mesh",
                arg(on),
                "--deformation",
                arg(&fitted),
                "--out",
                arg(&out),
            ],
            &["connected.csrbf", want, "fit it again on this mesh"],
        );
        assert!(!out.exists());
    }
    let info = ok(&["info", "--deformation", arg(&fitted), "--json"]);
    assert!(info.contains("fitted_on_mesh"), "{info}");
    // Without the mesh the region cannot be measured.
    fails(
        &[
            "fit",
            "--controls",
            arg(&connected),
            "--out",
            arg(&dir.path("x.csrbf")),
        ],
        &["connected region", "give --mesh"],
    );

    // A scene plays the same deformation.
    let scene = dir.write(
        "s.scene.json",
        r#"{"duration": 1, "fps": 1, "camera": {"eye": [0, 0, 9], "target": [0, 0, 0]},
            "objects": [{"name": "pin", "mesh": "hairpin.obj",
              "parts": [{"name": "all", "select": "all",
                         "deformations": [{"controls": "connected.json"}]}]}]}"#,
    );
    let s = csrbf_anim::Scene::load(&scene).expect("scene");
    let frame = s.frame(0.0);
    let got = &frame.objects[0].positions;
    // The scene places the object by its trajectory (none here): compare
    // the shapes, not the places.
    let shift = got[0] - a.positions[0];
    for (g, d) in got.iter().zip(&a.positions) {
        assert!(
            (*g - shift - *d).length() < 1e-5,
            "the scene differs from deform"
        );
    }
}

#[test]
fn bad_connected_regions_are_named_by_key() {
    let dir = TempDir::new("connected-bad");
    let (mesh, _) = hairpin(&dir);
    for (region, want) in [
        (
            r#"{"connected": {"distance": -1}}"#,
            "region.connected.distance",
        ),
        (
            r#"{"connected": {"distance": 1, "from": "elbow"}}"#,
            "region.connected.from",
        ),
        (
            r#"{"connected": {"distance": 1, "from": "handle"}}"#,
            "no \"handle\"",
        ),
        (
            r#"{"connected": {"distance": null}}"#,
            "region.connected.distance",
        ),
    ] {
        let c = dir.write("bad.json", pull(region));
        fails(
            &[
                "deform",
                "--mesh",
                arg(&mesh),
                "--controls",
                arg(&c),
                "--out",
                arg(&dir.path("o.obj")),
            ],
            &[want],
        );
    }
    // A point cloud has no surface to follow.
    let cloud = dir.write("cloud.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n");
    let c = dir.write(
        "c.json",
        r#"{"radius": 1, "controls": [{"from": [0, 0, 0], "to": [0, 0, 0.1]}],
            "region": {"connected": {"distance": 1}}}"#,
    );
    fails(
        &[
            "deform",
            "--mesh",
            arg(&cloud),
            "--controls",
            arg(&c),
            "--out",
            arg(&dir.path("o.obj")),
        ],
        &["needs a mesh with faces"],
    );
}
