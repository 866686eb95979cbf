use crate::support::*;

#[test]
fn deform_every_real_model_into_every_format() {
    let dir = TempDir::new("every");
    let models = all_models();
    assert!(models.len() >= 7);
    let outs = ["obj", "ply", "stl", "off", "gltf", "glb"];
    for (i, model) in models.iter().enumerate() {
        let controls = dir.write(&format!("c{i}.json"), controls_for(model, "c2", "linear"));
        let ext = outs[i % outs.len()];
        let out = dir.path(&format!("m{i}.{ext}"));
        ok(&[
            "deform",
            "--quiet",
            "--mesh",
            arg(model),
            "--controls",
            arg(&controls),
            "--out",
            arg(&out),
        ]);
        let a = csrbf_mesh::read(model).expect("in");
        let b = csrbf_mesh::read(&out).expect("out");
        if ext != "stl" {
            assert_eq!(
                a.positions.len(),
                b.positions.len(),
                "{} -> {ext}: vertex count",
                model.display()
            );
        }
        // Somewhere moved, and the starts went to their destinations.
        assert_ne!(
            a.positions,
            b.positions,
            "{}: nothing moved",
            model.display()
        );
    }
}

#[test]
fn deform_moves_starts_to_destinations_and_phase_scales() {
    let dir = TempDir::new("phase");
    let mesh = root().join("assets/models/cgal_head.off");
    let controls = root().join("assets/controls/head_smile.json");
    let full = dir.path("full.ply");
    let half = dir.path("half.ply");
    ok(&[
        "deform",
        "-q",
        "--mesh",
        arg(&mesh),
        "--controls",
        arg(&controls),
        "--out",
        arg(&full),
    ]);
    ok(&[
        "deform",
        "-q",
        "--mesh",
        arg(&mesh),
        "--controls",
        arg(&controls),
        "--phase",
        "0.5",
        "--out",
        arg(&half),
    ]);
    let rest = csrbf_mesh::read(&mesh).expect("rest");
    let f = csrbf_mesh::read(&full).expect("full");
    let h = csrbf_mesh::read(&half).expect("half");
    let spec: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&controls).expect("c")).expect("json");
    for c in spec["controls"].as_array().expect("controls") {
        let from: Vec<f32> = c["from"]
            .as_array()
            .expect("from")
            .iter()
            .map(|x| x.as_f64().expect("num") as f32)
            .collect();
        let to: Vec<f32> = c["to"]
            .as_array()
            .expect("to")
            .iter()
            .map(|x| x.as_f64().expect("num") as f32)
            .collect();
        let i = rest
            .positions
            .iter()
            .position(|p| p.to_array() == [from[0], from[1], from[2]])
            .expect("start on a vertex");
        let got = f.positions[i].to_array();
        for k in 0..3 {
            assert!(
                (got[k] - to[k]).abs() < 1e-4,
                "vertex {i}: {got:?} vs {to:?}"
            );
        }
    }
    for ((r, f), h) in rest.positions.iter().zip(&f.positions).zip(&h.positions) {
        assert!((*r + (*f - *r) * 0.5 - *h).length() < 1e-4);
    }
}

#[test]
fn fit_then_apply_equals_deform_and_json_is_readable() {
    let dir = TempDir::new("fit");
    let mesh = root().join("assets/models/cgal_head.off");
    let controls = root().join("assets/controls/head_smile.json");
    let d = dir.path("smile.csrbf");
    ok(&["fit", "-q", "--controls", arg(&controls), "--out", arg(&d)]);
    let a = dir.path("a.obj");
    let b = dir.path("b.obj");
    ok(&[
        "apply",
        "-q",
        "--mesh",
        arg(&mesh),
        "--deformation",
        arg(&d),
        "--phase",
        "0.7",
        "--out",
        arg(&a),
    ]);
    ok(&[
        "deform",
        "-q",
        "--mesh",
        arg(&mesh),
        "--controls",
        arg(&controls),
        "--phase",
        "0.7",
        "--out",
        arg(&b),
    ]);
    assert_eq!(std::fs::read(&a).expect("a"), std::fs::read(&b).expect("b"));
    let j = dir.path("smile.json");
    ok(&["fit", "-q", "--controls", arg(&controls), "--out", arg(&j)]);
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&j).expect("json")).expect("valid");
    assert_eq!(v["deformations"][0]["kernel"], "c2");
    assert_eq!(
        v["deformations"][0]["starts"].as_array().map(Vec::len),
        Some(34)
    );
    let info = ok(&["info", "--deformation", arg(&d), "--json"]);
    assert!(info.contains("\"controls\": 34"), "{info}");
    // The JSON form is for reading: apply and info say so, and what to do.
    for args in [
        vec!["apply", "--mesh", arg(&mesh), "--deformation", arg(&j)],
        vec!["info", "--deformation", arg(&j)],
    ] {
        let mut args = args;
        if args[0] == "apply" {
            args.extend(["--out", arg(&a)]);
        }
        fails(
            &args,
            &["smile.json", "it is JSON", "csrbf fit --out D.csrbf"],
        );
    }
}

#[test]
fn composition_with_regions_and_groups() {
    let dir = TempDir::new("compose");
    let mesh = dir.write(
        "quad.obj",
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\nv 2 1 0\ng left\nf 1 2 3 4\ng right\nf 2 5 6 3\n",
    );
    let controls = dir.write(
        "c.json",
        r#"{"deformations": [
            {"radius": 5, "polynomial": "none", "region": {"group": "right"},
             "controls": [{"from": [2, 0, 0], "to": [2, 0, 1]}]},
            {"radius": 5, "polynomial": "none", "region": {"vertices": [0]},
             "controls": [{"from": [0, 0, 0], "to": [0, 0, -1]}]}]}"#,
    );
    let out = dir.path("out.obj");
    ok(&[
        "deform",
        "-q",
        "--mesh",
        arg(&mesh),
        "--controls",
        arg(&controls),
        "--out",
        arg(&out),
    ]);
    let m = csrbf_mesh::read(&out).expect("out");
    assert_eq!(m.positions[0].z, -1.0); // only vertex 0 in stage 2
    assert!(m.positions[4].z > 0.99); // the start of stage 1
    assert_eq!(m.positions[3].z, 0.0); // in neither region
    assert_eq!(m.part_vertices("right"), Some(vec![1, 2, 4, 5]));
}

#[test]
fn info_reports_the_system_figures() {
    let controls = root().join("assets/controls/head_smile.json");
    let v: serde_json::Value =
        serde_json::from_str(&ok(&["info", "--controls", arg(&controls), "--json"])).expect("json");
    for key in [
        "controls",
        "nonzeros",
        "bandwidth",
        "envelope",
        "profile_bytes",
        "dense_bytes",
        "solver",
        "neighbours",
    ] {
        assert!(v.get(key).is_some(), "missing {key}: {v}");
    }
    assert_eq!(v["dense_bytes"], 34 * 34 * 4);
    let mesh = root().join("assets/models/cgal_head.off");
    let m: serde_json::Value =
        serde_json::from_str(&ok(&["info", "--mesh", arg(&mesh), "--json"])).expect("json");
    assert_eq!(m["vertices"], 1487);
    assert_eq!(m["faces"], 2918);
    let plain = ok(&["info", "--mesh", arg(&mesh)]);
    assert!(plain.contains("vertices: 1487"));
}

#[test]
fn bench_prints_every_phase() {
    let v: serde_json::Value = serde_json::from_str(&ok(&[
        "bench", "-q", "--scene", "fish", "--runs", "1", "--json",
    ]))
    .expect("json");
    for key in [
        "fit_ms",
        "bind_ms",
        "evaluate_ms",
        "refit_ms",
        "frame_ms",
        "peak_rss_mb",
    ] {
        assert!(v[key].as_f64().is_some(), "missing {key}: {v}");
    }
    // The roofline measured in the same run: the evaluation's time over
    // its bound, both there.
    let r = &v["roofline"];
    let (bound, ratio) = (r["bound_ms"].as_f64(), r["evaluate_over_bound"].as_f64());
    let evaluate = v["evaluate_ms"].as_f64().unwrap_or(0.0);
    match (bound, ratio) {
        (Some(b), Some(q)) => assert!(b > 0.0 && (q - evaluate / b).abs() <= 1e-9 * q, "{r}"),
        _ => panic!("no roofline: {v}"),
    }
    let mesh = root().join("assets/models/cgal_head.off");
    let controls = root().join("assets/controls/head_smile.json");
    let v: serde_json::Value = serde_json::from_str(&ok(&[
        "bench",
        "-q",
        "--mesh",
        arg(&mesh),
        "--controls",
        arg(&controls),
        "--runs",
        "1",
        "--json",
        "--solver",
        "supernodal",
    ]))
    .expect("json");
    assert_eq!(v["solver"], "supernodal");
    // The factorisation's multiply-adds and its time against the
    // machine's f64 rate.
    let f = &v["factor"];
    let (madds, bound) = (f["multiply_adds"].as_f64(), f["bound_ms"].as_f64());
    assert!(
        madds.is_some_and(|m| m > 0.0) && bound.is_some_and(|b| b > 0.0),
        "{f}"
    );
    // A scan-like scene: starts spread over a real mesh, R a share of it.
    let duck = root().join("assets/models/pybullet_duck.obj");
    let v: serde_json::Value = serde_json::from_str(&ok(&[
        "bench",
        "-q",
        "--scene",
        "scan",
        "--mesh",
        arg(&duck),
        "--starts",
        "300",
        "--share",
        "0.1",
        "--runs",
        "1",
        "--json",
    ]))
    .expect("json");
    assert_eq!(v["controls"], 300);
    assert_eq!(v["scene"], "scan-pybullet_duck");
    let bounds = csrbf_mesh::read(&duck).expect("duck").diagonal() as f64;
    let r = v["radius"].as_f64().unwrap_or(0.0);
    assert!((r - 0.1 * bounds).abs() < 1e-4 * bounds, "{r} vs {bounds}");
    fails(&["bench", "--scene", "scan"], &["--scene scan", "--mesh"]);
    fails(
        &[
            "bench",
            "--scene",
            "scan",
            "--mesh",
            arg(&duck),
            "--share",
            "0",
        ],
        &["--share 0", "(0, 1]"],
    );
}

#[test]
fn bench_exports_its_scene_as_a_closed_mesh_the_cli_deforms() {
    let dir = TempDir::new("bench-export");
    ok(&[
        "bench",
        "-q",
        "--scene",
        "fish",
        "--runs",
        "1",
        "--export",
        arg(dir.path("").as_path()),
    ]);
    let mesh = csrbf_mesh::read(&dir.path("fish.ply")).expect("the exported mesh");
    // 975 points on a sphere: a closed triangulation has 2V - 4 faces.
    assert_eq!(mesh.positions.len(), 975);
    assert_eq!(mesh.faces.len(), 2 * 975 - 4);
    let out = dir.path("deformed.ply");
    ok(&[
        "deform",
        "-q",
        "--mesh",
        arg(&dir.path("fish.ply")),
        "--controls",
        arg(&dir.path("fish.json")),
        "--out",
        arg(&out),
    ]);
    assert!(out.exists());
}

/// A scene's name is made a file name in the export folder: a V/N scene's
/// slash does not ask for a folder. A mesh and control file are not
/// exported again: refused, the mesh left as it was.
#[test]
fn bench_exports_into_its_folder_whatever_the_scenes_name() {
    let dir = TempDir::new("bench-export-names");
    ok(&[
        "bench",
        "-q",
        "--scene",
        "3000/300",
        "--export",
        arg(dir.path("").as_path()),
    ]);
    let mesh = csrbf_mesh::read(&dir.path("3000-300.ply")).expect("the exported mesh");
    assert_eq!(mesh.positions.len(), 3000);
    assert!(dir.path("3000-300.json").exists());
    let before = std::fs::read(dir.path("3000-300.ply")).expect("the mesh");
    fails(
        &[
            "bench",
            "-q",
            "--mesh",
            arg(&dir.path("3000-300.ply")),
            "--controls",
            arg(&dir.path("3000-300.json")),
            "--export",
            arg(dir.path("").as_path()),
        ],
        &[
            "--export writes the synthetic scenes",
            "3000-300.ply",
            "are files already",
        ],
    );
    assert_eq!(
        std::fs::read(dir.path("3000-300.ply")).expect("the mesh"),
        before
    );
}

#[test]
fn help_on_every_command() {
    for cmd in ["deform", "fit", "apply", "info", "bench"] {
        let out = ok(&[cmd, "--help"]);
        assert!(out.contains("Usage"), "{cmd}: {out}");
    }
}

/// Issue 6: STL cannot keep what the others keep, and says so.
#[test]
fn writing_stl_warns_what_it_loses() {
    let dir = TempDir::new("stlwarn");
    let duck = model("pybullet_duck.obj");
    let c = dir.write("c.json", controls_for(&duck, "c2", "none"));
    // Deforms the duck into `name`; the run must succeed; its standard error.
    let deform_to = |name: &str| {
        let r = csrbf(&[
            "deform",
            "--mesh",
            arg(&duck),
            "--controls",
            arg(&c),
            "--out",
            arg(&dir.path(name)),
        ]);
        let err = String::from_utf8_lossy(&r.stderr).into_owned();
        assert!(r.status.success(), "{name}: {err}");
        err
    };
    let err = deform_to("d.stl");
    assert!(
        err.contains("STL stores triangles, not vertices") && err.contains("UVs"),
        "{err}"
    );
    let err = deform_to("d.ply");
    assert!(!err.contains("STL stores"));
    // Issue 24, item 2: the duck's seam UVs do not fit PLY or OFF either,
    // and that is said too; PLY keeps its parts as face properties that
    // other programs do not read (said); OBJ keeps both and says nothing.
    assert!(
        err.contains("PLY keeps one UV per vertex")
            && err.contains("seams")
            && err.contains("face properties"),
        "{err}"
    );
    for (name, said) in [("d.off", true), ("d.obj", false)] {
        let err = deform_to(name);
        assert_eq!(
            err.contains("keeps one UV per vertex"),
            said,
            "{name}: {err}"
        );
    }
}

#[test]
fn what_the_studio_saves_csrbf_deform_turns_into_the_mesh_the_studio_shows() {
    use csrbf::glam::DVec3;
    use csrbf_studio_core::{Command, Document, History, Live};
    let path = root().join("assets/models/cgal_head.off");
    let mesh = csrbf_mesh::read(&path).expect("the bundled head");
    let diag = mesh.diagonal() as f64;
    let tip = mesh
        .positions
        .iter()
        .copied()
        .min_by(|a, b| a.x.total_cmp(&b.x))
        .expect("vertices")
        .as_dvec3();
    // Edits as the studio makes them: a pull at the nose, a pin on the
    // chin side, a second layer with another kernel and a region.
    let mut doc = Document::new(mesh, path.clone(), diag * 0.15);
    let mut h = History::default();
    h.apply(
        &mut doc,
        Command::add(0, tip, tip + DVec3::new(-2.0, 0.5, 0.0)),
    )
    .expect("pull");
    h.apply(
        &mut doc,
        Command::add(
            0,
            tip + DVec3::new(0.5, -3.0, 0.0),
            tip + DVec3::new(0.5, -3.0, 0.0),
        ),
    )
    .expect("pin");
    let mut second = doc.controls.deformations[0].clone();
    second.starts = vec![tip + DVec3::new(1.0, 2.0, 0.0)];
    second.targets = vec![tip + DVec3::new(1.0, 2.6, 0.3)];
    second.options.kernel = csrbf::Kernel::C4;
    second.name = Some("brow".into());
    h.apply(
        &mut doc,
        Command::InsertLayer {
            layer: 1,
            spec: Box::new(second),
        },
    )
    .expect("layer");
    let mut live = Live::new(&doc);
    live.update(&doc).expect("the studio's preview");

    let dir = TempDir::new("studio-saves");
    let controls = dir.write("edit.json", doc.to_text());
    let out = dir.path("out.ply");
    ok(&[
        "deform",
        "-q",
        "--mesh",
        arg(&path),
        "--controls",
        arg(&controls),
        "--out",
        arg(&out),
    ]);
    let deformed = csrbf_mesh::read(&out).expect("the CLI's output");
    assert_eq!(deformed.positions.len(), live.positions().len());
    let worst = deformed
        .positions
        .iter()
        .zip(live.positions())
        .map(|(a, b)| (*a - *b).length() as f64)
        .fold(0.0, f64::max);
    assert!(
        worst <= 1e-6 * diag,
        "largest difference {worst} (diagonal {diag})"
    );
    assert!(
        live.positions()
            .iter()
            .zip(&doc.mesh.positions)
            .any(|(a, b)| (*a - *b).length() > 0.1),
        "the edit moved the head"
    );
}

/// Issue 23, bug 1: a layer with no control vectors yet (the studio saves
/// one before its first vector) is read, moves nothing and is said; the
/// deformations after it keep their numbers in messages.
#[test]
fn a_layer_with_no_vectors_yet_is_read_and_said() {
    let dir = TempDir::new("wip");
    let head = model("cgal_head.off");
    let wip = dir.write(
        "wip.json",
        r#"{"deformations": [{"radius": 2, "controls": []},
            {"radius": 3, "controls": [{"from": [0, 12, 3], "to": [0, 12.3, 3]}]}]}"#,
    );
    let out = dir.path("w.ply");
    let r = csrbf(&[
        "deform",
        "--mesh",
        arg(&head),
        "--controls",
        arg(&wip),
        "--out",
        arg(&out),
    ]);
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(r.status.success(), "{err}");
    assert!(
        err.contains("deformations[0].controls: no control vectors yet"),
        "{err}"
    );
    let only = dir.write(
        "only.json",
        r#"{"radius": 3, "controls": [{"from": [0, 12, 3], "to": [0, 12.3, 3]}]}"#,
    );
    let out2 = dir.path("o.ply");
    ok(&[
        "deform",
        "-q",
        "--mesh",
        arg(&head),
        "--controls",
        arg(&only),
        "--out",
        arg(&out2),
    ]);
    assert_eq!(
        std::fs::read(&out).expect("w"),
        std::fs::read(&out2).expect("o")
    );
    // An error in the layer after it names that layer by its number in the file.
    let bad = dir.write(
        "bad.json",
        r#"{"deformations": [{"radius": 2, "controls": []},
            {"radius": 3, "controls": [{"from": [0, 12, 3], "to": [0, 12.3, 3]}, {"from": [0, 12, 3], "to": [0, 12, 3]}]}]}"#,
    );
    fails(
        &[
            "deform",
            "--mesh",
            arg(&head),
            "--controls",
            arg(&bad),
            "--out",
            arg(&dir.path("b.ply")),
        ],
        &["deformations[1]", "controls 0 and 1"],
    );
}

/// Standard output and error closed (a pipe to `head` that has exited,
/// `2>&-`): the command still writes its mesh and exits 0. (Printing used
/// to panic there, exit 101, before the output was written.)
#[test]
fn closed_streams_do_not_stop_a_command() {
    let dir = TempDir::new("closed");
    let out = dir.path("smile.obj");
    let head = model("cgal_head.off");
    let c = root().join("assets/controls/head_smile.json");
    let mut child = command()
        .args(["deform", "--mesh", arg(&head), "--controls", arg(&c)])
        .args(["--out", arg(&out), "--json"])
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("run csrbf");
    drop(child.stdout.take());
    drop(child.stderr.take());
    let status = child.wait().expect("wait");
    assert!(status.success(), "{status}");
    let text = std::fs::read_to_string(&out).expect("the mesh is written");
    assert!(text.lines().filter(|l| l.starts_with("v ")).count() > 1000);
}

/// Absurd numbers (a move of 1e30, R = 1e300) are computed without an
/// overflow (a sweep's cell keys overflowed i64) and said as numbers a
/// person reads: no figure of thirty digits.
#[test]
fn absurd_numbers_are_said_plainly() {
    let dir = TempDir::new("absurd");
    let head = model("cgal_head.off");
    for (i, (radius, to)) in [(0.3, "1e30"), (1e300, "0.1")].into_iter().enumerate() {
        let c = dir.write(
            &format!("c{i}.json"),
            format!(
                r#"{{"radius": {radius}, "controls": [{{"from": [0, 0, 0], "to": [0, {to}, 0]}}]}}"#
            ),
        );
        let out = dir.path(&format!("o{i}.off"));
        let run = csrbf(&[
            "deform",
            "--mesh",
            arg(&head),
            "--controls",
            arg(&c),
            "--out",
            arg(&out),
        ]);
        let said = String::from_utf8_lossy(&run.stderr);
        assert!(run.status.success(), "{said}");
        let longest = said
            .split(|ch: char| !ch.is_ascii_digit())
            .map(str::len)
            .max()
            .unwrap_or(0);
        assert!(longest < 12, "a {longest}-digit figure: {said}");
    }
}
