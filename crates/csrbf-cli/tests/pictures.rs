use crate::support::*;

fn head() -> std::path::PathBuf {
    root().join("assets/models/cgal_head.off")
}

fn smile() -> std::path::PathBuf {
    root().join("assets/controls/head_smile.json")
}

/// A copy of the face scene with its files, in `dir`.
fn face_scene(dir: &TempDir) -> std::path::PathBuf {
    std::fs::create_dir_all(dir.path("models")).expect("dir");
    std::fs::create_dir_all(dir.path("controls")).expect("dir");
    std::fs::copy(head(), dir.path("models/cgal_head.off")).expect("copy");
    std::fs::copy(smile(), dir.path("controls/head_smile.json")).expect("copy");
    let text =
        std::fs::read_to_string(root().join("assets/scenes/face.scene.json")).expect("scene");
    dir.write(
        "face.scene.json",
        text.replace("../models/", "models/")
            .replace("../controls/", "controls/"),
    )
}

#[test]
fn render_writes_a_picture_of_the_deformed_mesh() {
    let dir = TempDir::new("render");
    let out = dir.path("head.png");
    ok(&[
        "render",
        "-q",
        "--mesh",
        arg(&head()),
        "--controls",
        arg(&smile()),
        "--out",
        arg(&out),
        "--size",
        "160x120",
        "--overlay",
    ]);
    let bytes = std::fs::read(&out).expect("png");
    assert!(bytes.starts_with(b"\x89PNG"));
    fails(
        &[
            "render",
            "--mesh",
            arg(&head()),
            "--out",
            arg(&dir.path("x.png")),
            "--size",
            "0x100",
        ],
        &["--size", "1..8192"],
    );
    fails(
        &[
            "render",
            "--mesh",
            arg(&head()),
            "--out",
            arg(&dir.path("x.png")),
            "--size",
            "99999x100",
        ],
        &["--size"],
    );
    fails(
        &[
            "render",
            "--mesh",
            arg(&head()),
            "--out",
            arg(&dir.path("x.jpg")),
        ],
        &["PNG"],
    );
    fails(
        &[
            "render",
            "--mesh",
            arg(&head()),
            "--out",
            arg(&dir.path("no/x.png")),
        ],
        &["does not exist"],
    );
    assert_eq!(dir.files(), vec!["head.png"]);
}

#[test]
fn animate_writes_gif_frames_and_mp4_whole() {
    let dir = TempDir::new("animate");
    let scene = face_scene(&dir);
    let gif = dir.path("face.gif");
    ok(&[
        "animate",
        "-q",
        arg(&scene),
        "--out",
        arg(&gif),
        "--size",
        "96x72",
        "--fps",
        "10",
        "--to",
        "0.5",
    ]);
    assert!(std::fs::read(&gif).expect("gif").starts_with(b"GIF89a"));
    let frames = dir.path("frames");
    ok(&[
        "animate",
        "-q",
        arg(&scene),
        "--out",
        arg(&frames),
        "--size",
        "64x48",
        "--fps",
        "10",
        "--from",
        "1",
        "--to",
        "1.3",
    ]);
    let mut names: Vec<_> = std::fs::read_dir(&frames)
        .expect("frames")
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(
        names,
        vec![
            "frame_00000.png",
            "frame_00001.png",
            "frame_00002.png",
            "frame_00003.png"
        ]
    );
    let have_ffmpeg = std::process::Command::new("ffmpeg")
        .arg("-version")
        .output()
        .is_ok();
    if have_ffmpeg {
        let mp4 = dir.path("face.mp4");
        ok(&[
            "animate",
            "-q",
            arg(&scene),
            "--out",
            arg(&mp4),
            "--size",
            "96x72",
            "--to",
            "0.3",
        ]);
        let bytes = std::fs::read(&mp4).expect("mp4");
        assert_eq!(&bytes[4..8], b"ftyp");
    }
    // Without ffmpeg: a clear message suggesting GIF or frames, and no file.
    let out = command()
        .env("CSRBF_FFMPEG", "/nonexistent/ffmpeg")
        .args([
            "animate",
            arg(&scene),
            "--out",
            arg(&dir.path("none.mp4")),
            "--size",
            "64x48",
            "--to",
            "0.2",
        ])
        .output()
        .expect("run");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("ffmpeg was not found") && err.contains(".gif"),
        "{err}"
    );
    assert!(!dir.path("none.mp4").exists());
    // No temporary file left anywhere.
    assert!(
        dir.files().iter().all(|f| !f.contains(".tmp")),
        "{:?}",
        dir.files()
    );
}

#[test]
fn animate_refuses_bad_arguments_without_writing() {
    let dir = TempDir::new("animate-bad");
    let scene = face_scene(&dir);
    let before = dir.files();
    fails(
        &[
            "animate",
            arg(&scene),
            "--out",
            arg(&dir.path("no/such/m.gif")),
        ],
        &["does not exist"],
    );
    fails(
        &[
            "animate",
            arg(&scene),
            "--out",
            arg(&dir.path("m.gif")),
            "--size",
            "0x0",
        ],
        &["--size"],
    );
    fails(
        &[
            "animate",
            arg(&scene),
            "--out",
            arg(&dir.path("m.gif")),
            "--fps",
            "0",
        ],
        &["--fps"],
    );
    fails(
        &[
            "animate",
            arg(&scene),
            "--out",
            arg(&dir.path("m.gif")),
            "--from",
            "2",
            "--to",
            "1",
        ],
        &["--from"],
    );
    fails(
        &["animate", arg(&scene), "--out", arg(&dir.path("m.avi"))],
        &["m.avi", ".mp4"],
    );
    let bad = dir.write(
        "bad.scene.json",
        std::fs::read_to_string(&scene)
            .expect("s")
            .replace("\"fps\": 30", "\"fps\": 30, \"speed\": 2"),
    );
    fails(
        &["animate", arg(&bad), "--out", arg(&dir.path("m.gif"))],
        &["bad.scene.json", "speed"],
    );
    fails(
        &[
            "animate",
            arg(&dir.path("missing.scene.json")),
            "--out",
            arg(&dir.path("m.gif")),
        ],
        &["missing.scene.json"],
    );
    let mut after = before.clone();
    after.push("bad.scene.json".into());
    after.sort();
    assert_eq!(dir.files(), after);
}

/// Runs the Khronos glTF validator on a file; its report must have no error.
fn validate(file: &std::path::Path) {
    let script = root().join("scripts/validate_gltf.mjs");
    let out = std::process::Command::new("node")
        .arg(&script)
        .arg(file)
        .output();
    let out =
        out.expect("node is needed for the glTF validator: run scripts/test.sh, which installs it");
    let report = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "glTF validator: {report}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(report.contains(": 0 errors"), "{report}");
}

#[test]
fn exports_pass_the_khronos_validator() {
    let dir = TempDir::new("export");
    let scene = face_scene(&dir);
    for name in ["face.glb", "face.gltf"] {
        let out = dir.path(name);
        ok(&["export", "-q", arg(&scene), "--out", arg(&out)]);
        validate(&out);
    }
    fails(
        &["export", arg(&scene), "--out", arg(&dir.path("face.glb"))],
        &["exists", "--force"],
    );
    fails(
        &["export", arg(&scene), "--out", arg(&dir.path("face.fbx"))],
        &[".glb"],
    );
    // Every demo exports valid glTF (the ball keeps its motion; contact is per frame).
    for demo in ["fish", "ball", "brick"] {
        ok(&[
            "demo",
            "-q",
            demo,
            "--out",
            arg(&dir.path("demos")),
            "--size",
            "64x48",
            "--gif",
        ]);
        let scene = dir.path(&format!("demos/{demo}/{demo}.scene.json"));
        let out = dir.path(&format!("{demo}.glb"));
        ok(&["export", "-q", arg(&scene), "--out", arg(&out)]);
        validate(&out);
    }
    // A mesh written as glTF too.
    let glb = dir.path("head.glb");
    ok(&[
        "deform",
        "-q",
        "--mesh",
        arg(&head()),
        "--controls",
        arg(&smile()),
        "--out",
        arg(&glb),
    ]);
    validate(&glb);
}

/// Issue 24, item 1: a texture on the duck (UV seams: 2277 UVs for 2108
/// vertices) vanished from `export` without a word; it arrives, valid.
#[test]
fn export_keeps_a_texture_on_a_mesh_with_uv_seams() {
    let dir = TempDir::new("export-seams");
    ok(&[
        "demo",
        "-q",
        "fish",
        "--out",
        arg(&dir.path("d")),
        "--size",
        "32x24",
        "--gif",
    ]);
    let scene = dir.path("d/fish/fish.scene.json");
    let plain = dir.path("plain.glb");
    ok(&["export", "-q", arg(&scene), "--out", arg(&plain)]);
    // A 2x2 PNG, written by hand.
    let mut png = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut png, 2, 2);
        enc.set_color(png::ColorType::Rgba);
        let mut w = enc.write_header().expect("header");
        w.write_image_data(&[
            255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255, 255, 255, 255, 255,
        ])
        .expect("pixels");
    }
    std::fs::write(dir.path("d/fish/checker.png"), &png).expect("png");
    let text = std::fs::read_to_string(&scene).expect("scene");
    let textured = text.replacen(
        "\"name\": \"body\"",
        "\"name\": \"body\", \"texture\": \"checker.png\"",
        1,
    );
    assert_ne!(text, textured);
    std::fs::write(&scene, textured).expect("scene");
    let out = dir.path("duck.glb");
    ok(&["export", "-q", arg(&scene), "--out", arg(&out)]);
    validate(&out);
    let bytes = std::fs::read(&out).expect("glb");
    let json_len = u32::from_le_bytes(bytes[12..16].try_into().expect("len")) as usize;
    let doc: serde_json::Value = serde_json::from_slice(&bytes[20..20 + json_len]).expect("json");
    assert!(
        doc["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"].is_u64(),
        "no UVs"
    );
    assert_eq!(doc["images"].as_array().map(Vec::len), Some(1), "no image");
    assert!(
        bytes.windows(png.len()).any(|w| w == png),
        "the PNG is not embedded"
    );
    assert!(bytes.len() > std::fs::metadata(&plain).expect("plain").len() as usize);
}

#[test]
fn demo_writes_scene_poster_and_movie() {
    let dir = TempDir::new("demo");
    ok(&[
        "demo",
        "-q",
        "face",
        "--out",
        arg(&dir.path("d")),
        "--size",
        "80x60",
        "--gif",
    ]);
    for f in [
        "face.scene.json",
        "poster.png",
        "poster_controls.png",
        "movie.gif",
        "models/cgal_head.off",
        "controls/smile.json",
    ] {
        assert!(dir.path(&format!("d/face/{f}")).is_file(), "{f}");
    }
    fails(
        &["demo", "whale", "--out", arg(&dir.path("d"))],
        &["unknown demo", "face, fish, ball, brick"],
    );
    fails(
        &["demo", "face", "--out", arg(&dir.path("no/such"))],
        &["does not exist"],
    );
}

#[test]
fn render_shows_a_gltf_models_own_texture_upright() {
    let dir = TempDir::new("texture");
    let out = dir.path("box.png");
    ok(&[
        "render",
        "-q",
        "--mesh",
        arg(&model("assimp_BoxTextured.glb")),
        "--out",
        arg(&out),
        "--size",
        "200x150",
    ]);
    let img = image_rgba(&out);
    // The Khronos box's image: sky blue above, green below, on every face.
    let blue = |p: [u8; 4]| p[2] as i32 > p[0] as i32 + 50 && p[2] > p[1];
    let green = |p: [u8; 4]| p[1] as i32 > p[2] as i32 + 30 && p[1] > p[0];
    let (mut blue_y, mut green_y, mut nb, mut ng) = (0usize, 0usize, 0usize, 0usize);
    for y in 0..img.1 {
        for x in 0..img.0 {
            let p = img.2[(y * img.0 + x) as usize];
            if blue(p) {
                blue_y += y as usize;
                nb += 1;
            } else if green(p) {
                green_y += y as usize;
                ng += 1;
            }
        }
    }
    assert!(
        nb > 200 && ng > 200,
        "blue {nb}, green {ng}: the texture is missing"
    );
    assert!(blue_y / nb < green_y / ng, "the texture is upside down");
}

/// `render --folds` draws the faces a deformation turns inside out in red,
/// and only those: none in a picture of an edit that does not fold.
#[test]
fn render_shows_inside_out_faces_in_red() {
    let dir = TempDir::new("render-folds");
    // The mouth's corner pushed 1.5 R sideways: the cheek folds.
    let folding = dir.write(
        "fold.json",
        r#"{"radius": 2.0, "controls": [{"from": [-5.89911, 7.551, -1.42866], "to": [-5.89911, 7.551, 1.57134]}]}"#,
    );
    let head = head();
    let red = |controls: &std::path::Path, folds: bool, name: &str| {
        let out = dir.path(name);
        let mut args = vec![
            "render",
            "-q",
            "--mesh",
            arg(&head),
            "--controls",
            arg(controls),
            "--out",
            arg(&out),
            "--size",
            "320x240",
            "--view",
            "left",
            "--zoom",
            "2.5",
            "--target=-6,8,-0.5",
        ];
        if folds {
            args.push("--folds");
        }
        ok(&args);
        let (_, _, px) = image_rgba(&out);
        px.iter()
            .filter(|p| {
                let (r, g, b) = (u16::from(p[0]), u16::from(p[1]), u16::from(p[2]));
                r > 120 && g * 2 < r && b * 2 < r
            })
            .count()
    };
    let shown = red(&folding, true, "folds.png");
    assert!(shown > 10, "{shown} red pixels where the cheek folds");
    assert_eq!(
        red(&folding, false, "plain.png"),
        0,
        "red only with --folds"
    );
    assert_eq!(
        red(&smile(), true, "smile.png"),
        0,
        "the smile does not fold"
    );
    fails(
        &[
            "render",
            "--mesh",
            arg(&head),
            "--out",
            arg(&dir.path("x.png")),
            "--folds",
        ],
        &["--folds", "--controls"],
    );
}

/// Width, height and pixels of a PNG.
pub fn image_rgba(path: &std::path::Path) -> (u32, u32, Vec<[u8; 4]>) {
    let decoder = png::Decoder::new(std::io::BufReader::new(
        std::fs::File::open(path).expect("open"),
    ));
    let mut reader = decoder.read_info().expect("png");
    let mut buf = vec![0; reader.output_buffer_size().expect("size")];
    let info = reader.next_frame(&mut buf).expect("frame");
    let px = buf[..info.buffer_size()]
        .chunks_exact(4)
        .map(|c| [c[0], c[1], c[2], c[3]])
        .collect();
    (info.width, info.height, px)
}

/// Issue 9: a scene made with the Composer's edits and saved as the studio
/// saves it (paths relative to where it is written) is rendered by `csrbf
/// animate` frame for frame as the studio's scene renders.
#[test]
fn what_the_composer_saves_csrbf_animate_renders_as_the_studio_does() {
    use csrbf_studio_core::compose::{KeyValue, SceneDoc, SceneEdit, SceneHistory, Track};
    let dir = TempDir::new("composer");
    let mut doc = SceneDoc::empty();
    let mut h = SceneHistory::default();
    let object = |name: &str, mesh: &std::path::Path, doc: &SceneDoc| {
        let mut o = csrbf_anim::SceneFile::parse(&format!(
            r#"{{"duration": 1, "camera": {{"eye": [0, 0, 1], "target": [0, 0, 0]}},
                "objects": [{{"name": {name:?}, "mesh": "m", "parts": [{{"name": "all"}}]}}]}}"#
        ))
        .expect("object")
        .objects
        .remove(0);
        o.mesh = doc.name_of(mesh);
        o
    };
    let mut head_object = object("head", &head(), &doc);
    head_object.parts[0]
        .deformations
        .push(csrbf_anim::DeformationFile {
            controls: doc.name_of(&smile()),
            phase: Vec::new(),
            easing: Default::default(),
        });
    let duck = object(
        "duck",
        &root().join("assets/models/pybullet_duck.obj"),
        &doc,
    );
    for edit in [
        SceneEdit::AddObject(Box::new(head_object)),
        SceneEdit::AddObject(Box::new(duck)),
        SceneEdit::SetCamera(csrbf_anim::CameraFile {
            eye: [-40.0, 12.0, 20.0],
            target: [0.0, 9.0, 0.0],
            up: [0.0, 1.0, 0.0],
            fov: 40.0,
        }),
    ] {
        h.apply(&mut doc, &edit).expect("edit");
    }
    for (t, x, phase) in [(0.0, 0.0, 0.0), (1.5, 4.0, 1.0), (3.0, -2.0, 0.3)] {
        doc.playhead = t;
        for (object, track, value) in [
            (0, Track::Position, KeyValue::Position([x, 0.0, 0.0])),
            (1, Track::Position, KeyValue::Position([0.0, x, 5.0])),
            (
                0,
                Track::Phase {
                    part: 0,
                    deformation: 0,
                },
                KeyValue::Phase(phase),
            ),
        ] {
            h.apply(
                &mut doc,
                &SceneEdit::AddKey {
                    object,
                    track,
                    value,
                },
            )
            .expect("key");
        }
    }
    let saved = dir.path("studio.scene.json");
    std::fs::write(&saved, doc.text_for(&saved)).expect("save");
    let frames = dir.path("frames");
    ok(&[
        "animate",
        "-q",
        arg(&saved),
        "--out",
        arg(&frames),
        "--size",
        "120x90",
        "--fps",
        "2",
    ]);
    // The studio's scene (its document, its paths) through the same loop.
    let scene =
        csrbf_anim::Scene::from_file(doc.file.clone(), &doc.dir(), std::path::Path::new("studio"))
            .expect("the studio loads it");
    let mine = dir.path("mine");
    let mut options = csrbf_render::movie::MovieOptions::of(&scene);
    options.size = [120, 90];
    options.fps = 2.0;
    let written = csrbf_render::movie::render_movie(&scene, &mine, options, &mut |_, _| true)
        .expect("render");
    assert_eq!(written.frames, 9);
    for k in 0..written.frames {
        let name = format!("frame_{k:05}.png");
        let a = csrbf_anim::load_texture(&frames.join(&name)).expect("cli frame");
        let b = csrbf_anim::load_texture(&mine.join(&name)).expect("studio frame");
        assert_eq!((a.width, a.height), (b.width, b.height));
        let differ = a
            .rgba
            .iter()
            .zip(&b.rgba)
            .filter(|(x, y)| x.abs_diff(**y) > 2)
            .count();
        assert!(differ == 0, "frame {k}: {differ} channel values differ");
    }
    // And the scene moves: the first and fourth frames differ.
    let f0 = csrbf_anim::load_texture(&frames.join("frame_00000.png")).expect("frame");
    let f3 = csrbf_anim::load_texture(&frames.join("frame_00003.png")).expect("frame");
    let moved = f0
        .rgba
        .iter()
        .zip(&f3.rgba)
        .filter(|(x, y)| x.abs_diff(**y) > 30)
        .count();
    assert!(
        moved > 200,
        "only {moved} values changed between 0 s and 1.5 s"
    );
}
