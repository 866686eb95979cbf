//! Scenes from files: round trips, frames, and every bad input.

use std::path::{Path, PathBuf};

use glam::Vec3;

use crate::*;

fn assets() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets")
}

/// A temporary folder with the bundled head, its smile and a scene file.
struct Dir(PathBuf);

impl Dir {
    fn new(name: &str) -> Dir {
        let d = std::env::temp_dir().join(format!("csrbf-anim-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).expect("dir");
        std::fs::copy(assets().join("models/cgal_head.off"), d.join("head.off")).expect("copy");
        std::fs::copy(
            assets().join("controls/head_smile.json"),
            d.join("smile.json"),
        )
        .expect("copy");
        Dir(d)
    }
    fn scene(&self, text: &str) -> PathBuf {
        let p = self.0.join("s.scene.json");
        std::fs::write(&p, text).expect("write");
        p
    }
}

impl Drop for Dir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

const GOOD: &str = r#"{
  "duration": 2.0,
  "camera": {"eye": [-30, 10, 10], "target": [0, 9, 0]},
  "objects": [{
    "name": "head", "mesh": "head.off",
    "parts": [{"name": "skin", "color": [0.8, 0.5, 0.4],
      "deformations": [{"controls": "smile.json", "phase": [{"time": 0, "phase": 0}, {"time": 1, "phase": 1}]}]}],
    "trajectory": [{"time": 0, "position": [0, 0, 0]}, {"time": 2, "position": [1, 0, 0], "tension": 0.5}],
    "orientation": [{"time": 0, "axis": [0, 1, 0], "angle": 0}, {"time": 2, "euler": [0, 30, 0]}]
  }]
}"#;

#[test]
fn a_scene_round_trips_through_its_file() {
    let f = SceneFile::parse(GOOD).expect("parse");
    let back = SceneFile::parse(&f.to_json()).expect("reparse");
    assert_eq!(f, back);
    for name in demos::DEMOS {
        let d = demos::demo(name).expect("demo");
        assert_eq!(
            SceneFile::parse(&d.scene.to_json()).expect("demo parses"),
            d.scene,
            "{name}"
        );
    }
}

/// A scene's mistakes are placed once: a field missing from the whole
/// scene at its top level, a wrong value by its path, broken JSON by line
/// and column and the path it was in (serde's own "at line ... column ..."
/// is not repeated).
#[test]
fn scene_mistakes_are_placed_once() {
    let cases = [
        (
            r#"{"duration": 1, "objects": []}"#,
            "the scene's top level: missing field `camera`",
        ),
        (
            r#"{"duration": "x", "camera": {}, "objects": []}"#,
            "duration: invalid type",
        ),
        (
            r#"{"duration": 1, "objects": ["#,
            "line 1, column 28 (in objects): EOF",
        ),
    ];
    for (text, want) in cases {
        let e = SceneFile::parse(text).expect_err(text).to_string();
        assert!(e.contains(want) && !e.contains(" at line "), "{e}");
    }
}

/// Issue 22: a scene written on Windows (backslashes, files in other
/// folders) opens here, and frames the same as the one written with `/`.
#[test]
fn a_scene_written_on_windows_opens_here() {
    let d = Dir::new("windows-paths");
    std::fs::create_dir_all(d.0.join("models")).expect("dir");
    std::fs::create_dir_all(d.0.join("scenes")).expect("dir");
    std::fs::rename(d.0.join("head.off"), d.0.join("models/head.off")).expect("move");
    let scene = |sep: &str| {
        let text = GOOD
            .replace("\"head.off\"", &format!("\"..{sep}models{sep}head.off\""))
            .replace("\"smile.json\"", &format!("\"..{sep}smile.json\""))
            .replace('\\', "\\\\");
        let p = d.0.join("scenes/s.scene.json");
        std::fs::write(&p, text).expect("write");
        Scene::load(&p).expect("load")
    };
    let (windows, unix) = (scene("\\"), scene("/"));
    assert_eq!(
        windows.frame(0.7).objects[0].positions,
        unix.frame(0.7).objects[0].positions
    );
}

#[test]
fn frames_move_deform_and_turn() {
    let d = Dir::new("frames");
    let s = Scene::load(&d.scene(GOOD)).expect("load");
    assert_eq!(s.frame_count(), 61);
    let rest = &s.objects[0].mesh.positions;
    let f0 = s.frame(0.0);
    // At t = 0: phase 0, no move, no turn.
    for (a, b) in f0.objects[0].positions.iter().zip(rest) {
        assert!((*a - *b).length() < 1e-4);
    }
    // At t = 1: the smile is full, so each start is at its destination (then moved and turned).
    let f1 = s.frame(1.0);
    let obj = &s.objects[0];
    let (rot, shift) = obj.transform(1.0);
    let st = &obj.deformations[0].stages[0];
    for (start, goal) in st.deformation.starts().iter().zip(&st.targets) {
        let i = rest
            .iter()
            .position(|p| p.as_dvec3().distance(*start) < 1e-5)
            .expect("start on a vertex");
        let want = (rot * *goal + shift).as_vec3();
        assert!(
            (f1.objects[0].positions[i] - want).length() < 1e-3,
            "vertex {i}"
        );
    }
    // Turning about the centre of gravity keeps it on the trajectory.
    let c = obj.center;
    let moved = rot * c + shift;
    assert!((moved - (c + obj.trajectory.position(1.0))).length() < 1e-9);
    // Normals stay unit.
    assert!(
        f1.objects[0]
            .normals
            .iter()
            .all(|n| (n.length() - 1.0).abs() < 1e-3)
    );
    assert_eq!(f1.objects[0].controls.len(), 34);
}

#[test]
fn contact_pushes_walls_out_and_rebuilds_each_frame() {
    let d = demos::demo("ball").expect("ball");
    let dir = std::env::temp_dir().join(format!("csrbf-anim-ball-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("models")).expect("dir");
    for (rel, bytes) in &d.files {
        std::fs::write(dir.join(rel), bytes).expect("write");
    }
    let s = Scene::from_file(d.scene.clone(), &dir, Path::new("ball")).expect("scene");
    assert_eq!(s.objects[1].mesh.positions.len(), 386);
    // At an impact the wall moves outward, and only near the ball.
    let f = s.frame(0.8);
    let rest = &s.objects[1].mesh.positions;
    let moved: Vec<(Vec3, Vec3)> = f.objects[1]
        .positions
        .iter()
        .zip(rest)
        .filter(|(a, b)| (**a - **b).length() > 1e-6)
        .map(|(a, b)| (*a, *b))
        .collect();
    assert!(!moved.is_empty());
    // The wall it hits (x = 1) goes outward where it hits.
    let (a, b) = moved
        .iter()
        .max_by(|p, q| (p.0 - p.1).length().total_cmp(&(q.0 - q.1).length()))
        .copied()
        .expect("moved");
    assert!((b.x - 1.0).abs() < 1e-5 && a.x > b.x + 0.05, "{b} -> {a}");
    assert!(moved.iter().map(|(a, b)| a.x - b.x).sum::<f32>() > 0.0);
    assert!(moved.len() < 120, "{} vertices moved", moved.len());
    // Half way between impacts nothing touches.
    let f = s.frame(0.0);
    assert!(
        f.objects[1]
            .positions
            .iter()
            .zip(rest)
            .all(|(a, b)| (*a - *b).length() < 1e-6)
    );
    std::fs::remove_dir_all(&dir).ok();
}

fn load_err(d: &Dir, text: &str) -> String {
    match Scene::load(&d.scene(text)) {
        Ok(_) => panic!("accepted: {text}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn bad_scenes_are_named_by_path() {
    let d = Dir::new("bad");
    let cases: Vec<(String, &[&str])> = vec![
        (
            GOOD.replace("\"duration\": 2.0", "\"duration\": 2.0, \"colour\": 1"),
            &["unknown field `colour`"],
        ),
        (
            GOOD.replace("\"name\": \"skin\"", "\"name\": \"skin\", \"colr\": 1"),
            &["objects[0].parts[0]", "colr"],
        ),
        (
            GOOD.replace("head.off", "missing.off"),
            &["objects[0].mesh", "missing.off"],
        ),
        (
            GOOD.replace("smile.json", "nothere.json"),
            &[
                "objects[0].parts[0].deformations[0].controls",
                "nothere.json",
            ],
        ),
        (
            GOOD.replace("\"duration\": 2.0", "\"duration\": 0"),
            &["duration", "> 0"],
        ),
        (
            GOOD.replace("{\"time\": 2, \"position\"", "{\"time\": -1, \"position\""),
            &["objects[0].trajectory[1].time", "time order"],
        ),
        (
            GOOD.replace("{\"time\": 1, \"phase\": 1}", "{\"time\": 0, \"phase\": 1}"),
            &["phase[1].time", "time order"],
        ),
        (
            GOOD.replace("{\"time\": 1, \"phase\": 1}", "{\"time\": 1, \"phase\": 2}"),
            &["phase[1].phase", "[0, 1]"],
        ),
        (
            GOOD.replace(
                "\"euler\": [0, 30, 0]",
                "\"euler\": [0, 30, 0], \"angle\": 3",
            ),
            &["orientation[1]", "exactly one"],
        ),
        (
            GOOD.replace("\"tension\": 0.5", "\"tension\": 5"),
            &["trajectory[1].tension", "[-1, 1]"],
        ),
        (
            GOOD.replace("\"camera\"", "\"size\": [0, 100], \"camera\""),
            &["size", "1..8192"],
        ),
        (
            GOOD.replace("\"camera\"", "\"size\": [100000, 100], \"camera\""),
            &["size", "1..8192"],
        ),
        (
            GOOD.replace(
                "\"color\": [0.8, 0.5, 0.4]",
                "\"color\": [0.8, 0.5, 0.4], \"texture\": \"nope.png\"",
            ),
            &["parts[0].texture", "nope.png"],
        ),
        (
            GOOD.replace(
                "\"color\": [0.8, 0.5, 0.4]",
                "\"color\": [0.8, 0.5, 0.4], \"texture\": \"head.off\"",
            ),
            &["parts[0].texture", "head.off"],
        ),
        (
            GOOD.replace(
                "\"name\": \"skin\"",
                "\"name\": \"skin\", \"select\": {\"group\": \"lips\"}",
            ),
            &["select.group", "lips"],
        ),
        (
            GOOD.replace("\"camera\"", "\"lights\": [{\"direction\": [0, 0, 0]}], \"camera\""),
            &["lights[0].direction", "non-zero"],
        ),
        (
            GOOD.replace(
                "\"camera\"",
                "\"lights\": [{\"direction\": [0, -1, 0]}, {\"direction\": [1, 0, 0], \"color\": [1, -0.5, 0]}], \"camera\"",
            ),
            &["lights[1].color", ">= 0"],
        ),
        (
            GOOD.replace(
                "\"camera\"",
                "\"lights\": [{\"direction\": [0, -1, 0], \"intensity\": -2}], \"camera\"",
            ),
            &["lights[0].intensity", ">= 0"],
        ),
        ("{\"duration\": ".to_string(), &["line 1"]),
    ];
    for (text, want) in cases {
        let e = load_err(&d, &text);
        assert!(e.contains("s.scene.json"), "{e}");
        for w in want {
            assert!(e.contains(w), "{e:?} does not contain {w:?}");
        }
    }
}

#[test]
fn a_non_unit_quaternion_is_normalised_with_a_warning() {
    let d = Dir::new("quat");
    let text = GOOD.replace("\"euler\": [0, 30, 0]", "\"quaternion\": [0, 0.5, 0, 1.5]");
    let s = Scene::load(&d.scene(&text)).expect("load");
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert!(
        s.warnings[0].contains("orientation[1].quaternion") && s.warnings[0].contains("normalised")
    );
    let q = s.objects[0].orientation.rotation(2.0);
    assert!((q.length() - 1.0).abs() < 1e-12);
    let zero = GOOD.replace("\"euler\": [0, 30, 0]", "\"quaternion\": [0, 0, 0, 0]");
    assert!(load_err(&d, &zero).contains("zero quaternion"));
}

#[test]
fn part_textures_load_from_png() {
    let d = Dir::new("tex");
    let img = image::RgbaImage::from_fn(4, 2, |x, _| image::Rgba([x as u8 * 60, 0, 0, 255]));
    img.save(d.0.join("t.png")).expect("png");
    let text = GOOD.replace(
        "\"color\": [0.8, 0.5, 0.4]",
        "\"color\": [0.8, 0.5, 0.4], \"texture\": \"t.png\"",
    );
    let s = Scene::load(&d.scene(&text)).expect("load");
    let t = s.objects[0].parts[0].texture.as_ref().expect("texture");
    assert_eq!((t.width, t.height, t.mime.as_str()), (4, 2, "image/png"));
    assert_eq!(&t.rgba[4..8], &[60, 0, 0, 255]);
}

/// Issue 6: a control file of several deformations means the same in a scene
/// as in `csrbf deform` (`csrbf::compose`), chained or added, at any phase.
#[test]
fn scenes_combine_deformations_as_compose_does() {
    let d = Dir::new("combine");
    let two = |combine: &str| {
        format!(
            r#"{{"combine": "{combine}", "deformations": [
              {{"radius": 4, "controls": [{{"from": [2.15, 10.18, 4.42], "to": [2.15, 11.5, 5.0]}}]}},
              {{"radius": 3, "phase": 0.6, "region": {{"box": {{"min": [-9, 11, -9], "max": [9, 20, 9]}}, "falloff": 1.5}},
               "controls": [{{"from": [2.3, 11.2, 4.6], "to": [3.2, 11.2, 4.6]}}]}}]}}"#
        )
    };
    let mesh = csrbf_mesh::read(&d.0.join("head.off")).expect("head");
    let mut checked = 0;
    for combine in ["chain", "add"] {
        std::fs::write(d.0.join("two.json"), two(combine)).expect("write");
        let text = GOOD
            .replace("smile.json", "two.json")
            .replace(r#""trajectory": [{"time": 0, "position": [0, 0, 0]}, {"time": 2, "position": [1, 0, 0], "tension": 0.5}],"#, "")
            .replace(r#""orientation": [{"time": 0, "axis": [0, 1, 0], "angle": 0}, {"time": 2, "euler": [0, 30, 0]}]"#, r#""orientation": []"#);
        let scene = Scene::load(&d.scene(&text)).expect("scene");
        let file = csrbf_edit::controls::ControlFile::parse(&two(combine)).expect("controls");
        for (time, track) in [(1.0, 1.0f64), (0.5, 0.5)] {
            let stages: Vec<_> = file
                .deformations
                .iter()
                .map(|s| {
                    let def =
                        csrbf::Deformation::fit(&s.starts, &s.targets, s.options).expect("fit");
                    csrbf::FittedStage::new(def)
                        .with_region(s.region.clone())
                        .with_phase(s.phase * track)
                })
                .collect();
            let want = csrbf::compose_with_groups(&mesh.positions, &stages, file.combine, &|n| {
                mesh.part_vertices(n)
            })
            .expect("compose");
            // The scene eases its phase track: compare where it is linear.
            let phase = scene.objects[0].deformations[0].track.phase(time);
            if (phase - track).abs() > 1e-9 {
                continue;
            }
            let got = &scene.frame(time).objects[0].positions;
            let worst = got
                .iter()
                .zip(&want)
                .map(|(a, b)| a.distance(*b))
                .fold(0.0f32, f32::max);
            assert!(worst < 1e-4, "{combine} at {time}: off by {worst}");
            checked += 1;
        }
    }
    assert_eq!(checked, 4, "every time compared");
}

/// Issue 6: scenes built and changed from memory, for the Composer.
#[test]
fn scenes_take_meshes_and_controls_as_values_and_update_one_object() {
    let d = Dir::new("assets");
    let mut file = SceneFile::parse(GOOD).expect("parse");
    // Values under the paths the scene names: the files need not exist.
    let mut head = csrbf_mesh::read(&d.0.join("head.off")).expect("head");
    for p in &mut head.positions {
        p.y += 100.0;
    }
    let smile = csrbf_edit::controls::ControlFile::parse(
        &std::fs::read_to_string(d.0.join("smile.json")).expect("smile"),
    )
    .expect("controls");
    let mut assets = Assets::new();
    assets.set_mesh(d.0.join("virtual.off"), head);
    assets.set_controls(d.0.join("virtual.json"), smile);
    file.objects[0].mesh = "virtual.off".into();
    file.objects[0].parts[0].deformations[0].controls = "virtual.json".into();
    let mut scene =
        Scene::from_file_with(file.clone(), &d.0, Path::new("mem"), &assets).expect("from memory");
    assert!(scene.objects[0].mesh.positions[0].y > 90.0);
    // Without the values, the same file fails naming what is missing.
    let e = Scene::from_file(file.clone(), &d.0, Path::new("mem"))
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(
        e.contains("objects[0].mesh") && e.contains("virtual.off"),
        "{e}"
    );
    // One object changed: only it is prepared again; a bad change leaves the scene as it was.
    let before = scene.frame(1.0).objects[0].positions.clone();
    let mut moved = file.objects[0].clone();
    moved.scale = 2.0;
    scene
        .update_object(0, moved.clone(), &assets)
        .expect("update");
    let after = scene.frame(1.0).objects[0].positions.clone();
    assert_ne!(before, after);
    assert_eq!(scene.file.objects[0].scale, 2.0);
    let mut bad = moved;
    bad.scale = -1.0;
    let e = scene
        .update_object(0, bad, &assets)
        .expect_err("negative scale");
    assert!(e.to_string().contains("objects[0].scale"), "{e}");
    assert_eq!(scene.file.objects[0].scale, 2.0);
    assert!(
        scene
            .update_object(3, file.objects[0].clone(), &assets)
            .is_err()
    );
}

/// An object's scale and base rotation place its mesh and its
/// deformations together: control files and part regions stay in the
/// mesh's own units and axes (the Picker edits them there).
#[test]
fn scale_and_base_rotation_place_the_mesh_with_its_deformations() {
    let d = Dir::new("placed");
    let object = |placing: &str| {
        format!(
            r#"{{"duration": 1, "camera": {{"eye": [-30, 10, 10], "target": [0, 9, 0]}},
              "objects": [{{"name": "head", "mesh": "head.off"{placing},
                "parts": [{{"name": "skin", "select": {{"sphere": {{"center": [-6, 8, -1], "radius": 5}}}},
                  "deformations": [{{"controls": "smile.json"}}]}}]}}]}}"#
        )
    };
    let plain = Scene::load(&d.scene(&object(""))).expect("plain");
    let (scale, axis, angle) = (2.5f32, Vec3::new(1.0, 0.3, 0.0).normalize(), -90.0f32);
    let placed = Scene::load(&d.scene(&object(
        r#", "scale": 2.5, "rotation": {"axis": [1, 0.3, 0], "angle": -90}"#,
    )))
    .expect("placed");
    let place = glam::Mat3::from_axis_angle(axis, angle.to_radians()) * scale;
    let (a, b) = (plain.frame(1.0), placed.frame(1.0));
    let (lo, hi) = plain.objects[0].mesh.bounds().expect("bounds");
    let tol = 1e-5 * scale * lo.distance(hi);
    let mut moved = 0;
    for (i, (p, q)) in a.objects[0]
        .positions
        .iter()
        .zip(&b.objects[0].positions)
        .enumerate()
    {
        assert!(
            (place * *p).distance(*q) < tol,
            "vertex {i}: {} vs {q}",
            place * *p
        );
        moved += usize::from(p.distance(plain.objects[0].mesh.positions[i]) > 1e-3);
    }
    assert!(moved > 100, "the smile moves the head ({moved} vertices)");
    // The controls drawn are placed too.
    for (c, e) in a.objects[0].controls.iter().zip(&b.objects[0].controls) {
        assert!((place * c.2).distance(e.2) < tol);
    }
    // A bad rotation is named by its place.
    for (bad, want) in [
        (
            r#", "rotation": {"axis": [0, 0, 0], "angle": 5}"#,
            "objects[0].rotation.axis",
        ),
        (
            r#", "rotation": {"axis": [1, 0, 0], "angle": 5, "euler": [0, 0, 1]}"#,
            "exactly one",
        ),
        (
            r#", "rotation": {"quaternion": [0, 0, 0, 0]}"#,
            "objects[0].rotation.quaternion",
        ),
        (r#", "rotation": {"turn": 5}"#, "turn"),
    ] {
        let e = Scene::load(&d.scene(&object(bad)))
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(e.contains(want), "{bad}: {e}");
    }
    // Every way of giving it reads back as the Euler angles the Composer shows.
    let given = placed.file.objects[0].rotation.expect("rotation");
    let e = given.euler_degrees().expect("euler");
    let as_euler = crate::file::RotationFile {
        euler: Some(e),
        ..Default::default()
    };
    let again = Scene::load(&d.scene(&object(&format!(
        r#", "scale": 2.5, "rotation": {}"#,
        serde_json::to_string(&as_euler).expect("json")
    ))))
    .expect("euler");
    for (p, q) in b.objects[0]
        .positions
        .iter()
        .zip(&again.frame(1.0).objects[0].positions)
    {
        assert!(p.distance(*q) < tol, "{p} vs {q}");
    }
    let round = SceneFile::parse(&placed.file.to_json()).expect("reparse");
    assert_eq!(round, placed.file);
}

/// The Composer's cheap path: new keys on a loaded scene give the frames a
/// fresh load of the same file gives; a change of anything else is left to a
/// load, and a bad key leaves the scene as it was.
#[test]
fn retiming_a_scene_equals_loading_it_again() {
    let d = Dir::new("retime");
    let path = d.scene(GOOD);
    let mut scene = Scene::load(&path).expect("load");
    let mut file = scene.file.clone();
    let o = &mut file.objects[0];
    o.trajectory[1].position = [3.0, -1.0, 2.0];
    o.trajectory.push(PositionKeyFile {
        time: 1.5,
        position: [0.0, 2.0, 0.0],
        tension: -0.3,
        continuity: 0.2,
        bias: 0.4,
    });
    o.trajectory.swap(1, 2);
    o.orientation[1].euler = Some([10.0, 70.0, -5.0]);
    o.interpolation = Interpolation::Slerp;
    o.parts[0].deformations[0].phase[1].phase = 0.4;
    o.parts[0].deformations[0].easing = Easing::Linear;
    file.fps = 24.0;
    assert!(scene.retime(file.clone()).expect("retime"));
    let fresh = Scene::from_file(file.clone(), &d.0, &path).expect("fresh");
    for t in [0.0, 0.3, 0.9, 1.5, 1.77, 2.0] {
        let (a, b) = (scene.frame(t), fresh.frame(t));
        assert_eq!(a.objects[0].positions, b.objects[0].positions, "t = {t}");
    }
    // Keys out of order: refused with their path, the scene kept.
    let mut bad = file.clone();
    bad.objects[0].trajectory.swap(0, 1);
    let e = scene.retime(bad).expect_err("out of order").to_string();
    assert!(e.contains("objects[0].trajectory[1].time"), "{e}");
    assert_eq!(scene.file, file);
    // Another mesh scale is not a retime.
    let mut other = file.clone();
    other.objects[0].scale = 2.0;
    assert!(!scene.retime(other).expect("no error"));
    assert_eq!(scene.file, file);
}

/// Issue 7: a scene asking for more frames than any movie or export may
/// have is refused before anything is sampled.
#[test]
fn endless_scenes_are_refused_by_their_frame_count() {
    let d = Dir::new("endless");
    for (duration, fps) in ["1e9", "1e6"].iter().zip([30.0, 30.0]) {
        let text = GOOD.replace(
            "\"duration\": 2.0",
            &format!("\"duration\": {duration}, \"fps\": {fps}"),
        );
        let e = Scene::load(&d.scene(&text))
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(
            e.contains("duration") && e.contains("more than the limit of 100000"),
            "{e}"
        );
    }
    assert_eq!(frame_count(2.0, 30.0), 61);
    assert_eq!(frame_count(f64::NAN, 30.0), 1);
}

/// Whether `p` lies inside the closed triangle mesh, by the parity of the
/// crossings of a ray (a direction no edge of a box is parallel to).
fn inside(p: Vec3, positions: &[Vec3], triangles: &[[u32; 3]]) -> bool {
    let dir = Vec3::new(0.5773, 0.5801, 0.5745).normalize();
    let mut crossings = 0;
    for t in triangles {
        let (a, b, c) = (
            positions[t[0] as usize],
            positions[t[1] as usize],
            positions[t[2] as usize],
        );
        let (e1, e2) = (b - a, c - a);
        let h = dir.cross(e2);
        let det = e1.dot(h);
        if det.abs() < 1e-12 {
            continue;
        }
        let s = p - a;
        let u = s.dot(h) / det;
        let q = s.cross(e1);
        let v = dir.dot(q) / det;
        let t = e2.dot(q) / det;
        if u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > 0.0 {
            crossings += 1;
        }
    }
    crossings % 2 == 1
}

/// Issue 6: the ball never shows through the wall: at every frame of the
/// demo, every vertex of the ball lies inside the deformed box.
#[test]
fn the_ball_stays_inside_the_bulging_box() {
    let d = Dir::new("ball");
    let demo = demos::demo("ball").expect("demo");
    let path = demo.write(&d.0, "ball").expect("write");
    let scene = Scene::load(&path).expect("scene");
    let ball = scene
        .objects
        .iter()
        .position(|o| o.name == "ball")
        .expect("ball");
    let walls = scene
        .objects
        .iter()
        .position(|o| o.name == "box")
        .expect("box");
    let tris = &scene.objects[walls].triangles;
    let mut worst = (0, 0.0f64);
    for k in 0..scene.frame_count() {
        let f = scene.frame(k as f64 / scene.file.fps);
        let out = f.objects[ball]
            .positions
            .iter()
            .filter(|p| !inside(**p, &f.objects[walls].positions, tris))
            .count();
        if out > 0 && (out as f64) > worst.1 {
            worst = (k, out as f64);
        }
    }
    assert_eq!(
        worst.1, 0.0,
        "frame {}: {} ball vertices outside the box",
        worst.0, worst.1
    );
}

/// Issue 7: seeded mutations of scene files give an error or a scene, never a panic.
#[test]
fn the_scene_reader_survives_thousands_of_mutations() {
    use csrbf::fuzz::mutate;
    use csrbf::synthetic::Rng;
    let seeds: Vec<Vec<u8>> = demos::DEMOS
        .iter()
        .map(|n| demos::demo(n).expect("demo").scene.to_json().into_bytes())
        .chain(std::iter::once(GOOD.as_bytes().to_vec()))
        .collect();
    let all: Vec<&[u8]> = seeds.iter().map(Vec::as_slice).collect();
    let mut rng = Rng::new(99);
    let (mut read, mut refused) = (0, 0);
    for case in 0..4000 {
        let input = mutate(all[case % all.len()], &mut rng, &all);
        let text = String::from_utf8_lossy(&input).into_owned();
        match std::panic::catch_unwind(|| SceneFile::parse(&text).is_ok()) {
            Ok(true) => read += 1,
            Ok(false) => refused += 1,
            Err(_) => panic!("case {case} panicked"),
        }
    }
    assert!(read > 0 && refused > 0, "{read} read, {refused} refused");
}

/// A face belongs to the last part that selects it: a sphere carved out of
/// a whole-mesh part takes its faces, the whole part keeps the rest, every
/// face is in exactly one part, and each part's vertices are its faces'.
#[test]
fn a_later_part_takes_its_faces_from_an_earlier_one() {
    let d = Dir::new("own");
    let one = Scene::load(&d.scene(GOOD)).expect("load");
    let (centre, radius) = (one.objects[0].center, one.objects[0].radius);
    let nose = format!(
        r#""parts": [{{"name": "skin", "color": [0.8, 0.5, 0.4],
      "deformations": [{{"controls": "smile.json", "phase": [{{"time": 0, "phase": 0}}, {{"time": 1, "phase": 1}}]}}]}},
      {{"name": "piece", "select": {{"sphere": {{"center": [{}, {}, {}], "radius": {}}}}}, "color": [0.2, 0.2, 0.9]}}],"#,
        centre.x,
        centre.y,
        centre.z,
        radius * 0.6
    );
    let start = GOOD.find("\"parts\"").expect("parts");
    let end = GOOD.find("\"trajectory\"").expect("trajectory");
    let text = format!("{}{}\n    {}", &GOOD[..start], nose, &GOOD[end..]);
    let s = Scene::load(&d.scene(&text)).expect("load");
    let o = &s.objects[0];
    let nf = o.mesh.faces.len();
    let (skin, piece) = (&o.parts[0], &o.parts[1]);
    assert!(!piece.faces.is_empty() && piece.faces.len() < nf);
    assert_eq!(skin.faces.len() + piece.faces.len(), nf, "every face once");
    let mut all: Vec<u32> = skin.faces.iter().chain(&piece.faces).copied().collect();
    all.sort_unstable();
    assert_eq!(all, (0..nf as u32).collect::<Vec<_>>());
    for p in [skin, piece] {
        let mut v: Vec<u32> = p
            .faces
            .iter()
            .flat_map(|&f| o.mesh.faces.face(f as usize).to_vec())
            .collect();
        v.sort_unstable();
        v.dedup();
        assert_eq!(p.vertices, v, "{}", p.name);
    }
    // What the skin alone would have had: every face.
    assert_eq!(one.objects[0].parts[0].faces.len(), nf);
}
