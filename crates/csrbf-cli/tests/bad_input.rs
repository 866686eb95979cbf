use crate::support::*;

const GOOD: &str = r#"{"kernel": "c2", "radius": 1.0, "polynomial": "linear", "controls": [
 {"from": [0,0,0], "to": [0,0,0.1]}, {"from": [1,0,0], "to": [1,0,0]},
 {"from": [0,1,0], "to": [0,1,0]}, {"from": [0,0,1], "to": [0,0,1]}, {"from": [1,1,1], "to": [1,1,1]}]}"#;

const TRI: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\n";

/// `deform --mesh MESH --controls CONTROLS --out OUT` fails saying `want`.
#[track_caller]
fn deform_to_fails(
    mesh: &std::path::Path,
    controls: &std::path::Path,
    out: &std::path::Path,
    want: &[&str],
) {
    fails(&deform_args(mesh, controls, out), want);
}

/// Runs `deform` and expects failure naming `file` and every `want`; the
/// existing output must be left untouched and nothing else written.
#[track_caller]
fn deform_fails(
    dir: &TempDir,
    mesh: &std::path::Path,
    controls: &std::path::Path,
    extra: &[&str],
    want: &[&str],
) {
    let out = dir.path("out.obj");
    std::fs::write(&out, "precious").expect("write");
    let before = dir.files();
    let mut args = deform_args(mesh, controls, &out);
    args.extend_from_slice(extra);
    fails(&args, want);
    assert_eq!(
        std::fs::read_to_string(&out).expect("out"),
        "precious",
        "output clobbered"
    );
    assert_eq!(dir.files(), before, "a file was left behind");
}

#[test]
fn malformed_meshes_of_every_format() {
    let dir = TempDir::new("badmesh");
    let c = dir.write("c.json", GOOD);
    let cases: &[(&str, &[u8], &[&str])] = &[
        ("a.obj", b"v 0 0 0\nv 1 0\n", &["a.obj:2", "3 coordinates"]),
        ("b.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n", &["b.obj:4", "vertex index 7 is out of range"]),
        ("c.obj", b"v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n", &["c.obj", "vertex 1", "not finite"]),
        ("d.obj", b"# empty\n", &["d.obj", "no vertices"]),
        ("e.off", b"OFF\n4 2 0\n0 0 0\n1 0 0\n", &["e.off", "truncated"]),
        ("f.off", b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 9\n", &["f.off:6", "vertex 9"]),
        ("g.ply", b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n1 0 0\n", &["g.ply", "truncated"]),
        ("h.ply", b"ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n\x00\x00", &["h.ply", "truncated"]),
        ("i.stl", b"solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n", &["i.stl", "truncated"]),
        ("j.stl", &[7u8; 200], &["j.stl", "not an STL"]),
        ("k.gltf", b"{\"asset\": {\"version\": \"2.0\"}, \"meshes\": [", &["k.gltf", "glTF"]),
        ("l.glb", b"glTF\x02\x00\x00\x00\x10\x00", &["l.glb", "GLB header is cut short"]),
        ("m.off", b"", &["m.off", "empty"]),
        ("n.off", b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n", &["n.off:6", "\"-1\" is negative"]),
        // A vertex count too large: face lines read as vertices.
        ("o.off", b"OFF\n4 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", &["o.off", "header's counts are wrong", "4 vertices"]),
    ];
    for (name, bytes, want) in cases {
        let m = dir.write(name, bytes);
        deform_fails(&dir, &m, &c, &[], want);
        std::fs::remove_file(&m).expect("rm");
    }
    // Truncated real files of each format.
    for name in [
        "cgal_head.off",
        "assimp_Suzanne_248.obj",
        "pyvista_airplane.ply",
        "assimp_sphereWithHole.stl",
        "assimp_BoxTextured.glb",
    ] {
        let bytes = std::fs::read(model(name)).expect("a bundled model");
        let m = dir.write(&format!("cut_{name}"), &bytes[..bytes.len() * 2 / 3 + 1]);
        if name.ends_with(".obj") {
            // OBJ has no counts or end marker: a cut can leave a valid file, so
            // the cut is warned about rather than refused.
            let out = dir.path("cut_out.obj");
            let r = csrbf(&[
                "deform",
                "--mesh",
                arg(&m),
                "--controls",
                arg(&c),
                "--out",
                arg(&out),
            ]);
            let err = String::from_utf8_lossy(&r.stderr);
            assert!(err.contains("may have been cut off"), "{err}");
            let _ = std::fs::remove_file(&out);
        } else {
            deform_fails(&dir, &m, &c, &[], &[&format!("cut_{name}")]);
        }
        std::fs::remove_file(&m).expect("rm");
    }
}

#[test]
fn bad_control_files() {
    let dir = TempDir::new("badcontrols");
    let m = dir.write("m.obj", TRI);
    let cases: &[(&str, &[&str])] = &[
        (
            "{\"radius\": 1, \"controls\": [",
            &["c.json", "line 1", "invalid JSON"],
        ),
        (
            r#"{"kernel": "c9", "radius": 1, "controls": [{"from": [0,0,0], "to": [0,0,0]}]}"#,
            &["c.json", "kernel", "c0, c2, c4, c6"],
        ),
        (
            r#"{"polynomial": "cubic", "radius": 1, "controls": [{"from": [0,0,0], "to": [0,0,0]}]}"#,
            &["polynomial", "none, linear"],
        ),
        (
            r#"{"radius": 0, "controls": [{"from": [0,0,0], "to": [0,0,0]}]}"#,
            &["radius", "> 0"],
        ),
        (
            r#"{"radius": -1, "controls": [{"from": [0,0,0], "to": [0,0,0]}]}"#,
            &["radius", "> 0"],
        ),
        (
            r#"{"radius": "big", "controls": [{"from": [0,0,0], "to": [0,0,0]}]}"#,
            &["radius", "expected a number"],
        ),
        (r#"{"radius": 1e999, "controls": []}"#, &["c.json"]),
        (
            r#"{"radius": 1, "polynomial": "none", "controls": [{"from": [0,0,0], "to": [0,0,0]}, {"from": [0,0], "to": [0,0,0]}]}"#,
            &["controls[1].from", "three numbers"],
        ),
        (
            r#"{"radius": 1, "polynomial": "none", "controls": [{"from": [0,0,0], "to": [0,"x",0]}]}"#,
            &["controls[0].to[1]", "number"],
        ),
        (
            r#"{"radius": 1, "polynomial": "none", "controls": [{"from": [0,0,0], "to": [0,0,0]}, {"from": [1,0,0], "to": [0,0,0]}, {"from": [0,0,0], "to": [1,0,0]}]}"#,
            &["controls 0 and 2", "same point"],
        ),
        (
            r#"{"radius": 1, "polynomial": "linear", "controls": [{"from": [0,0,0], "to": [0,0,0]}, {"from": [1,0,0], "to": [0,0,0]}]}"#,
            &["at least 4", "\"none\""],
        ),
        (
            r#"{"radius": 1, "polynomial": "linear", "controls": [{"from": [0,0,0], "to": [0,0,0]}, {"from": [1,0,0], "to": [0,0,0]}, {"from": [0,1,0], "to": [0,0,0]}, {"from": [1,1,0], "to": [0,0,0]}]}"#,
            &["one plane", "\"none\""],
        ),
        (
            r#"{"radius": 1, "polynomial": "none", "controls": [{"from": [0,0,0], "to": [0,0,0]}, {"from": [1e-14,0,0], "to": [0,0,0]}]}"#,
            &["controls 0 and 1", "too close"],
        ),
        (
            r#"{"radius": 1, "polynomial": "none", "region": {"group": "nose"}, "controls": [{"from": [0,0,0], "to": [0,0,0]}]}"#,
            &["c.json", "region", "\"nose\"", "no named parts"],
        ),
        (
            r#"{"radius": 1, "polynomial": "none", "region": {"vertices": [99]}, "controls": [{"from": [0,0,0], "to": [0,0,0]}]}"#,
            &[
                "c.json",
                "region",
                "vertex 99 is out of range",
                "4 vertices",
            ],
        ),
        (
            r#"{"deformations": [{"radius": 1, "polynomial": "none", "controls": [{"from": [0,0,0], "to": [0,0,0]}]}, {"radius": 1, "polynomial": "linear", "controls": [{"from": [0,0,0], "to": [0,0,0]}]}]}"#,
            &["deformations[1]", "at least 4"],
        ),
    ];
    for (text, want) in cases {
        let c = dir.write("c.json", text);
        deform_fails(&dir, &m, &c, &[], want);
        std::fs::remove_file(&c).expect("rm");
    }
    deform_fails(&dir, &m, &dir.path("missing.json"), &[], &["missing.json"]);
}

#[test]
fn bad_arguments_and_outputs() {
    let dir = TempDir::new("badargs");
    let m = dir.write("m.obj", TRI);
    let c = dir.write("c.json", GOOD);
    deform_fails(&dir, &m, &c, &["--phase", "1.5"], &["phase", "[0, 1]"]);
    deform_fails(&dir, &m, &c, &["--phase", "-0.1"], &["phase"]);
    // Unknown output extension: listed formats, nothing written.
    deform_to_fails(&m, &c, &dir.path("x.fbx"), &["x.fbx", ".obj", ".glb"]);
    deform_to_fails(
        &dir.path("m.3ds"),
        &c,
        &dir.path("o.obj"),
        &["m.3ds", "unknown mesh format"],
    );
    // An output that is a folder, or has no extension, is said to be one.
    let m = dir.write("m.obj", TRI);
    for (out, want) in [
        (dir.path(""), "is a folder"),
        (dir.path("noext"), "has no extension"),
    ] {
        deform_to_fails(&m, &c, &out, &[want, ".obj, .ply"]);
    }
    // Output into a missing directory.
    deform_to_fails(&m, &c, &dir.path("no/such/o.obj"), &["does not exist"]);
    // Output equal to the input: refused, input intact; allowed with --force.
    let before = std::fs::read(&m).expect("m");
    deform_to_fails(&m, &c, &m, &["same file as an input", "--force"]);
    assert_eq!(std::fs::read(&m).expect("m"), before);
    ok(&[
        "deform",
        "-q",
        "--mesh",
        arg(&m),
        "--controls",
        arg(&c),
        "--out",
        arg(&m),
        "--force",
    ]);
    assert_ne!(std::fs::read(&m).expect("m"), before);
    assert_eq!(dir.files(), vec!["c.json", "m.obj", "out.obj"]);
}

#[test]
fn corrupt_and_wrong_version_deformation_files() {
    let dir = TempDir::new("badcsrbf");
    let m = dir.write("m.obj", TRI);
    let c = dir.write("c.json", GOOD);
    let d = dir.path("d.csrbf");
    ok(&["fit", "-q", "--controls", arg(&c), "--out", arg(&d)]);
    let bytes = std::fs::read(&d).expect("d");
    let out = dir.path("o.obj");
    let apply_fails = |bad: &std::path::Path, want: &[&str]| {
        fails(
            &[
                "apply",
                "--mesh",
                arg(&m),
                "--deformation",
                arg(bad),
                "--out",
                arg(&out),
            ],
            want,
        );
    };
    let mut flipped = bytes.clone();
    flipped[40] ^= 1;
    let bad = dir.write("flip.csrbf", &flipped);
    apply_fails(&bad, &["flip.csrbf", "checksum"]);
    let bad = dir.write("cut.csrbf", &bytes[..bytes.len() / 2]);
    apply_fails(&bad, &["cut.csrbf"]);
    let mut v9 = bytes.clone();
    v9[6] = 9;
    let bad = dir.write("v9.csrbf", &v9);
    apply_fails(&bad, &["v9.csrbf", "version 9"]);
    let bad = dir.write("text.csrbf", "hello");
    apply_fails(&bad, &["text.csrbf", "magic"]);
    fails(
        &[
            "fit",
            "--controls",
            arg(&c),
            "--out",
            arg(&dir.path("d.bin")),
        ],
        &["d.bin", ".csrbf"],
    );
    assert!(!out.exists());
    fails(&["info"], &["--mesh"]);
}

/// Issue 7: a key given twice is refused with both lines; a byte-order mark
/// is accepted; a box with min > max is refused.
#[test]
fn duplicate_keys_boms_and_empty_boxes() {
    let dir = TempDir::new("dupkeys");
    let head = model("cgal_head.off");
    let out = dir.path("o.ply");
    let dup = dir.write("dup.json", "{\n  \"radius\": 3.5,\n  \"radius\": 0.1,\n  \"controls\": [{\"from\": [0, 0, 0], \"to\": [0, 0, 0]}]\n}\n");
    deform_to_fails(
        &head,
        &dup,
        &out,
        &["dup.json", "\"radius\" is given twice", "line 2", "line 3"],
    );
    let bom = dir.write("bom.json", "\u{feff}{\"radius\": 3.5, \"controls\": [{\"from\": [2.15, 10.18, 4.42], \"to\": [2.15, 10.5, 4.42]}]}");
    ok(&[
        "deform",
        "-q",
        "--mesh",
        arg(&head),
        "--controls",
        arg(&bom),
        "--out",
        arg(&out),
    ]);
    let empty = dir.write("box.json", r#"{"radius": 3.5, "region": {"box": {"min": [0, 5, 0], "max": [1, 1, 1]}}, "controls": [{"from": [0, 0, 0], "to": [0, 0, 0]}]}"#);
    deform_to_fails(
        &head,
        &empty,
        &dir.path("p.ply"),
        &["region.box.min[1]", "greater than max[1]"],
    );
    std::fs::copy(&head, dir.path("head.off")).expect("copy");
    let scene = dir.write("s.scene.json", "{\"duration\": 1, \"duration\": 2, \"camera\": {\"eye\": [0, 0, 9], \"target\": [0, 0, 0]}, \"objects\": []}");
    fails(
        &["export", arg(&scene), "--out", arg(&dir.path("s.glb"))],
        &["\"duration\" is given twice"],
    );
    assert!(!dir.path("p.ply").exists() && !dir.path("s.glb").exists());
}

/// Issue 7: an output under a file, a hard link to the input, a mesh whose
/// points coincide; OS errors printed once.
#[test]
fn odd_outputs_and_degenerate_meshes() {
    let dir = TempDir::new("oddout");
    let head = model("cgal_head.off");
    let c = root().join("assets/controls/head_smile.json");
    let file = dir.write("plain", "x");
    deform_to_fails(&head, &c, &file.join("o.ply"), &["is a file, not a folder"]);
    let copy = dir.path("head.off");
    std::fs::copy(&head, &copy).expect("copy");
    let link = dir.path("link.off");
    std::fs::hard_link(&copy, &link).expect("hard link");
    let before = std::fs::read(&copy).expect("read");
    deform_to_fails(&copy, &c, &link, &["same file as an input"]);
    assert_eq!(
        std::fs::read(&copy).expect("read"),
        before,
        "the input is untouched"
    );
    // Every point at one place: a picture all the same, not a camera error.
    let dot = dir.write("dot.obj", "v 1 1 1\nv 1 1 1\nv 1 1 1\nf 1 2 3\n");
    ok(&[
        "render",
        "-q",
        "--mesh",
        arg(&dot),
        "--out",
        arg(&dir.path("dot.png")),
        "--size",
        "32x24",
    ]);
    // A missing input: the system's message once (its words are the
    // system's: "No such file or directory" here, "The system cannot find
    // the file specified." from csrbf.exe, issue 22).
    let r = csrbf(&["info", "--mesh", arg(&dir.path("missing.obj"))]);
    let err = String::from_utf8_lossy(&r.stderr);
    assert_eq!(err.matches("(os error 2)").count(), 1, "{err}");
    assert!(
        err.contains("cannot read mesh") && err.contains("missing.obj"),
        "{err}"
    );
}
