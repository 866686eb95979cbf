//! The Composer driven as a person would, headless (egui_kittest): a scene
//! built by clicks, saved and read back by the CLI's loader, playback at
//! the scene's rate, export (glTF through the Khronos validator, a movie
//! cancelled), recovery, and every bad scene file of issue 9.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use csrbf_anim::{Scene, SceneFile};
use csrbf_studio::app::{Args, Mode, StudioApp};
use csrbf_studio::compose::Track;
use eframe::egui;
use egui::accesskit::Role;
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;

use crate::support;

fn assets() -> PathBuf {
    csrbf_testkit::root().join("assets")
}

/// A private folder per test.
fn temp(test: &str) -> PathBuf {
    // Named by the checkout too: a target directory shared with another
    // checkout must not hand this test the other's saved scene (issue 19).
    csrbf_testkit::scratch(
        env!("CARGO_TARGET_TMPDIR"),
        &format!("studio-compose-{test}"),
    )
}

fn app(args: Args, state: PathBuf) -> Harness<'static, StudioApp> {
    // Tall enough for an object's whole panel (what is scrolled out of
    // view cannot be clicked).
    app_sized(args, state, [1280.0, 1200.0])
}

/// The app in a window of `size` (a tall one shows the whole side panel:
/// what is scrolled out of view cannot be clicked).
fn app_sized(args: Args, state: PathBuf, size: [f32; 2]) -> Harness<'static, StudioApp> {
    let mut h = Harness::builder()
        .with_size(size)
        .with_max_steps(64)
        .build_eframe(move |cc| StudioApp::with_state_dir(cc, args, Some(state)));
    h.run_steps(3);
    h
}

fn face(test: &str) -> Harness<'static, StudioApp> {
    app(
        Args {
            mesh: Some(assets().join("scenes/face.scene.json")),
            controls: None,
        },
        temp(test),
    )
}

/// The app on the papers' ball-in-a-box demo scene (written from
/// `csrbf_anim::demos`): two objects, the box pushed by the ball.
fn ball(test: &str) -> Harness<'static, StudioApp> {
    let dir = temp(test);
    let scene = csrbf_anim::demos::demo("ball")
        .expect("the ball demo")
        .write(&dir, "ball")
        .expect("written");
    app(
        Args {
            mesh: Some(scene),
            controls: None,
        },
        dir.join("state"),
    )
}

/// Clicks the timeline's ruler at `time`.
fn scrub(h: &mut Harness<'_, StudioApp>, time: f64) {
    let r = h.state().timeline_ruler().expect("the timeline is drawn");
    let d = h.state().scene_doc().expect("a scene").file.duration;
    let at = egui::pos2(r.left() + (time / d) as f32 * r.width(), r.center().y);
    click_at(h, at);
    let t = h.state().scene_doc().expect("a scene").playhead;
    assert!(
        (t - time).abs() < 0.02,
        "the playhead went to {t}, not {time}"
    );
}

fn click_at(h: &mut Harness<'_, StudioApp>, at: egui::Pos2) {
    for pressed in [true, false] {
        support::button(h, at, pressed);
        h.step();
    }
    h.run_steps(2);
}

/// The `k`-th Key button of the timeline (tracks in order: each object's
/// position, orientation, then its deformations' phases).
fn key_button(h: &mut Harness<'_, StudioApp>, k: usize) {
    let nodes: Vec<_> = h.get_all_by_label("Key").collect();
    assert!(nodes.len() > k, "only {} Key buttons", nodes.len());
    nodes[k].click();
    h.run_steps(3);
}

/// A left-button drag from `from` to `to` in eight steps.
fn drag(h: &mut Harness<'_, StudioApp>, from: egui::Pos2, to: egui::Pos2) {
    support::button(h, from, true);
    h.step();
    for k in 1..=8 {
        h.event(egui::Event::PointerMoved(
            from + (to - from) * (k as f32 / 8.0),
        ));
        h.step();
    }
    support::button(h, to, false);
    h.run_steps(3);
}

/// The screen position of a viewport point, and the viewport's pixels per
/// point.
fn on_screen(h: &Harness<'_, StudioApp>, p: csrbf::glam::Vec3) -> egui::Pos2 {
    let (cam, size, gate) = h.state().compose_camera().expect("a scene");
    let (px, _) = cam.project(p, size).expect("in view");
    let ppp = size[0] as f32 / gate.width();
    egui::pos2(gate.min.x + px.x / ppp, gate.min.y + px.y / ppp)
}

#[test]
fn a_two_object_scene_built_by_clicks_saves_what_the_cli_loads_frame_for_frame() {
    let dir = temp("build");
    let mut h = app(Args::default(), dir.join("state"));
    // The Composer, a new scene, two meshes added through the dialog.
    h.get_by_label("Composer").click();
    h.run_steps(2);
    assert_eq!(h.state().mode(), Mode::Compose);
    for mesh in ["models/cgal_head.off", "models/pybullet_duck.obj"] {
        h.get_by_label("Add object…").click();
        support::choose(&mut h, &assets().join(mesh), "Open");
    }
    let doc = h.state().scene_doc().expect("a scene");
    assert_eq!(doc.file.objects.len(), 2, "{:?}", h.state().message());
    assert_eq!(doc.file.objects[0].name, "cgal_head");
    // The head: a deformation, then keys at 0 and 2 s; the key at 2 s is
    // dragged in the viewport; a key at 1 s; a phase key.
    h.get_all_by_label("cgal_head")
        .next()
        .expect("listed")
        .click();
    h.run_steps(2);
    h.get_by_label("Add deformation…").click();
    support::choose(&mut h, &assets().join("controls/head_smile.json"), "Open");
    scrub(&mut h, 0.0);
    key_button(&mut h, 0);
    scrub(&mut h, 2.0);
    key_button(&mut h, 0);
    assert_eq!(
        h.state()
            .scene_doc()
            .expect("scene")
            .key_times(0, Track::Position),
        vec![0.0, 2.0]
    );
    let scene = h.state().loaded_scene().expect("loaded");
    let centre = scene.objects[0].center.as_vec3();
    let key = csrbf::glam::DVec3::from_array(
        h.state().scene_doc().expect("scene").file.objects[0].trajectory[1].position,
    )
    .as_vec3();
    let from = on_screen(&h, key + centre);
    let to = from + egui::vec2(96.0, -32.0);
    drag(&mut h, from, to);
    let moved = h.state().scene_doc().expect("scene").file.objects[0].trajectory[1].position;
    let dragged = csrbf::glam::DVec3::from_array(moved).as_vec3();
    assert!(
        (dragged - key).length() > 0.1 * scene_radius(&h),
        "the key moved: {key} -> {dragged}"
    );
    // The marker is where the pointer let go (on the plane facing the camera).
    let landed = on_screen(&h, dragged + centre);
    assert!(landed.distance(to) < 1.5, "{landed:?} vs {to:?}");
    // With X held, a drag moves the key along X only.
    h.key_press(egui::Key::X);
    h.run_steps(1);
    let before = h.state().scene_doc().expect("scene").file.objects[0].trajectory[1].position;
    let from = on_screen(&h, dragged + centre);
    drag(&mut h, from, from + egui::vec2(60.0, 50.0));
    h.key_press(egui::Key::X);
    h.run_steps(1);
    let after = h.state().scene_doc().expect("scene").file.objects[0].trajectory[1].position;
    assert!(
        (after[0] - before[0]).abs() > 1e-3,
        "moved along X: {before:?} -> {after:?}"
    );
    assert_eq!((after[1], after[2]), (before[1], before[2]));
    let steps = h.state().scene_undo_steps();
    scrub(&mut h, 1.0);
    key_button(&mut h, 0);
    assert_eq!(
        h.state()
            .scene_doc()
            .expect("scene")
            .key_times(0, Track::Position),
        vec![0.0, 1.0, 2.0]
    );
    // Phase: a key at 0 s set to 0 (the deformation then phases in).
    scrub(&mut h, 0.0);
    key_button(&mut h, 2);
    h.get_by_role(Role::Slider).set_value_accesskit(0.0);
    h.run_steps(3);
    let phase = Track::Phase {
        part: 0,
        deformation: 0,
    };
    let doc = h.state().scene_doc().expect("scene").clone();
    assert_eq!(doc.key_times(0, phase), vec![0.0]);
    assert_eq!(
        doc.file.objects[0].parts[0].deformations[0].phase[0].phase,
        0.0
    );
    assert_eq!(h.state().scene_undo_steps(), steps + 3);
    // Save with Ctrl+S: the dialog, a path, Save.
    let saved = dir.join("out").join("built.scene.json");
    std::fs::create_dir_all(saved.parent().expect("folder")).expect("folder");
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::S);
    h.run_steps(2);
    support::choose(&mut h, &saved, "Save");
    assert!(
        !h.state().scene_doc().expect("scene").dirty,
        "{:?}",
        h.state().message()
    );
    let text = std::fs::read_to_string(&saved).expect("saved");
    let file = SceneFile::parse(&text).expect("the CLI's parser reads it");
    // Paths are relative to where the scene was saved.
    let mesh = Path::new(&file.objects[0].mesh);
    assert!(mesh.is_relative(), "{}", mesh.display());
    assert_eq!(
        std::fs::canonicalize(saved.parent().expect("folder").join(mesh)).expect("found"),
        std::fs::canonicalize(assets().join("models/cgal_head.off")).expect("head")
    );
    // What `csrbf animate` loads from the file moves every vertex where
    // the studio shows it, at every frame time tried.
    let cli = Scene::load(&saved).expect("the CLI's loader takes it");
    let studio = h.state().loaded_scene().expect("loaded").clone();
    for t in [0.0, 0.5, 1.0, 1.3, 2.0, 3.5] {
        let (a, b) = (cli.frame(t), studio.frame(t));
        for (oa, ob) in a.objects.iter().zip(&b.objects) {
            assert_eq!(oa.positions, ob.positions, "t = {t}");
        }
    }
    // The head moves between its keys and deforms as the phase rises.
    let f0 = cli.frame(0.0);
    let f1 = cli.frame(1.0);
    assert_ne!(f0.objects[0].positions, f1.objects[0].positions);
}

fn scene_radius(h: &Harness<'_, StudioApp>) -> f32 {
    h.state()
        .loaded_scene()
        .expect("loaded")
        .objects
        .iter()
        .map(|o| o.radius as f32)
        .fold(0.0, f32::max)
}

#[test]
fn play_moves_the_playhead_by_the_scenes_frame_rate() {
    let mut h = face("play");
    h.get_by_label("Play").click();
    let started = Instant::now();
    let mut frames = 0;
    while started.elapsed() < Duration::from_millis(700) {
        h.step();
        frames += 1;
        std::thread::sleep(Duration::from_millis(5));
    }
    let elapsed = started.elapsed().as_secs_f64();
    let app = h.state();
    let t = app.scene_doc().expect("scene").playhead;
    let fps = app.scene_doc().expect("scene").file.fps;
    // Whole frames of 1/30 s, as many as the wall clock allows: at most one
    // frame behind (the first tick starts the clock) and never ahead.
    let frame = (t * fps).round();
    assert!((t * fps - frame).abs() < 1e-6, "on a frame: {t}");
    assert!(
        t <= elapsed + 1e-9 && t >= elapsed - 0.25,
        "played {t} s in {elapsed} s ({frames} draws)"
    );
    assert!(app.playback().expect("scene").playing);
    // Space pauses; the playhead stays.
    h.key_press(egui::Key::Space);
    h.run_steps(2);
    let paused = h.state().scene_doc().expect("scene").playhead;
    std::thread::sleep(Duration::from_millis(100));
    h.run_steps(2);
    assert_eq!(h.state().scene_doc().expect("scene").playhead, paused);
    // Every frame: one frame a draw, none dropped, whatever the clock.
    h.get_by_label("Every frame").click();
    h.get_by_label("Start").click();
    h.run_steps(1);
    h.key_press(egui::Key::Space);
    for _ in 0..10 {
        h.step();
    }
    let app = h.state();
    let t = app.scene_doc().expect("scene").playhead;
    let n = (t * fps).round() as i64;
    assert!((9..=11).contains(&n), "{n} frames in 10 draws");
    assert_eq!(app.playback().expect("scene").dropped, 0);
    // Next and Back step one frame.
    h.key_press(egui::Key::Space);
    h.run_steps(1);
    let at = h.state().scene_doc().expect("scene").playhead;
    h.get_by_label("Next").click();
    h.run_steps(1);
    let next = h.state().scene_doc().expect("scene").playhead;
    assert!((next - at - 1.0 / fps).abs() < 1e-9, "{at} -> {next}");
}

/// Runs the Khronos glTF validator on a file; its report must have no error.
fn validate(file: &Path) {
    let script = csrbf_testkit::root().join("scripts/validate_gltf.mjs");
    let out = std::process::Command::new("node")
        .arg(&script)
        .arg(file)
        .output()
        .expect("node is needed for the glTF validator: run scripts/test.sh, which installs it");
    let report = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success() && report.contains(": 0 errors"),
        "glTF validator: {report}{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn the_export_menu_writes_a_glb_the_khronos_validator_passes_and_a_cancelled_movie_leaves_nothing()
{
    let mut h = face("export");
    let dir = temp("export-out");
    let glb = dir.join("face.glb");
    h.get_by_label("File").click();
    h.run_steps(3);
    h.get_by_label("Export glTF…  Ctrl+Shift+E").click();
    support::choose(&mut h, &glb, "Save");
    assert!(h.state_mut().finish_export(Duration::from_secs(120)));
    h.run_steps(2);
    assert!(
        glb.exists(),
        "{} / {:?}",
        h.state().status(),
        h.state().message()
    );
    validate(&glb);
    assert!(
        h.state().status().contains("face.glb"),
        "{}",
        h.state().status()
    );
    // The same bytes as `csrbf export` makes (one library call).
    let cli = csrbf_anim::export_gltf(
        &Scene::load(&assets().join("scenes/face.scene.json")).expect("face"),
        true,
    );
    assert_eq!(std::fs::read(&glb).expect("glb"), cli);
    // A movie cancelled at once: nothing is left where it was going.
    let gif = dir.join("face.gif");
    h.state_mut().export_movie(&gif);
    // A few frames: a new modal is laid out unseen in its first (egui's
    // sizing pass), so its Cancel shows from the next one on.
    h.run_steps(3);
    assert!(
        h.state().exporting(),
        "{} / {:?}",
        h.state().status(),
        h.state().message()
    );
    h.get_by_label("Cancel").click();
    h.run_steps(2);
    assert!(h.state_mut().finish_export(Duration::from_secs(120)));
    h.run_steps(2);
    assert!(!gif.exists(), "{}", h.state().status());
    assert!(
        h.state().status().contains("cancelled"),
        "{}",
        h.state().status()
    );
}

#[test]
fn bad_scene_files_are_refused_with_the_cli_message_and_the_open_scene_kept() {
    let mut h = face("bad");
    let kept = h.state().scene_doc().expect("face").file.clone();
    let dir = temp("bad-files");
    std::fs::copy(assets().join("models/cgal_head.off"), dir.join("head.off")).expect("copy");
    let good = r#"{"duration": 2, "camera": {"eye": [0, 0, 50], "target": [0, 0, 0]},
      "objects": [{"name": "head", "mesh": "head.off",
        "trajectory": [{"time": 0, "position": [0, 0, 0]}, {"time": 1, "position": [1, 0, 0]}]}]}"#;
    let cases = [
        ("unknown", good.replace("\"duration\"", "\"speed\": 1, \"duration\""), "speed"),
        ("missing-mesh", good.replace("head.off", "gone.off"), "objects[0].mesh"),
        (
            "missing-texture",
            good.replace(
                "\"mesh\": \"head.off\",",
                "\"mesh\": \"head.off\", \"parts\": [{\"name\": \"a\", \"texture\": \"gone.png\"}],",
            ),
            "gone.png",
        ),
        (
            "order",
            good.replace("\"time\": 1,", "\"time\": 0,"),
            "objects[0].trajectory[1].time",
        ),
        ("zero", good.replace("\"duration\": 2", "\"duration\": 0"), "duration"),
        // Issue 42: a deformation `csrbf deform` refuses (two controls with
        // one start) is refused by the scene too.
        (
            "twice",
            good.replace(
                "\"mesh\": \"head.off\",",
                "\"mesh\": \"head.off\", \"parts\": [{\"name\": \"a\", \"deformations\": [{\"controls\": \"twice.json\"}]}],",
            ),
            "controls 0 and 1",
        ),
    ];
    std::fs::write(
        dir.join("twice.json"),
        r#"{"radius": 20, "controls": [{"from": [0, 0, 0], "to": [0, 0, 1]}, {"from": [0, 0, 0], "to": [0, 1, 0]}]}"#,
    )
    .expect("write");
    for (name, text, names) in cases {
        let path = dir.join(format!("{name}.scene.json"));
        std::fs::write(&path, text).expect("write");
        h.state_mut().open_scene(&path);
        h.run_steps(2);
        let (title, message) = h.state().message().cloned().expect("a dialog");
        assert!(
            title.contains("scene")
                && message.contains(&format!("{name}.scene.json"))
                && message.contains(names),
            "{name}: {title}: {message}"
        );
        // The CLI says the same.
        let cli = Scene::load(&path)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(message.contains(&cli), "{name}: {message} vs {cli}");
        assert_eq!(h.state().scene_doc().expect("kept").file, kept, "{name}");
        h.get_by_label("OK").click();
        h.run_steps(1);
    }
    // The good one opens.
    let path = dir.join("good.scene.json");
    std::fs::write(&path, good).expect("write");
    h.state_mut().open_scene(&path);
    h.run_steps(2);
    assert!(h.state().message().is_none(), "{:?}", h.state().message());
    assert_eq!(
        h.state().scene_doc().expect("open").file.objects[0].name,
        "head"
    );
    // Dragging a key past another reorders; onto another is refused.
    h.state_mut()
        .scene_edit(csrbf_studio::compose::SceneEdit::MoveKey {
            object: 0,
            track: Track::Position,
            index: 0,
            time: 1.5,
        });
    let doc = h.state().scene_doc().expect("open").clone();
    assert_eq!(doc.key_times(0, Track::Position), vec![1.0, 1.5]);
    assert!(
        !h.state_mut()
            .scene_edit(csrbf_studio::compose::SceneEdit::MoveKey {
                object: 0,
                track: Track::Position,
                index: 0,
                time: 1.5,
            })
    );
    assert_eq!(h.state().scene_doc().expect("open").file, doc.file);
    assert!(SceneFile::parse(&doc.to_text()).is_ok());
}

#[test]
fn an_unsaved_scene_comes_back_from_the_recovery_file() {
    let state = temp("recovery-state");
    let mut h = app(
        Args {
            mesh: Some(assets().join("scenes/face.scene.json")),
            controls: None,
        },
        state.clone(),
    );
    scrub(&mut h, 1.0);
    key_button(&mut h, 0);
    let edited = h.state().scene_doc().expect("scene").file.clone();
    assert!(h.state().scene_doc().expect("scene").dirty);
    // The recovery file is written within a second of the change.
    let until = Instant::now() + Duration::from_secs(5);
    while Instant::now() < until && !state.join("recovery.scene.json").exists() {
        h.step();
        std::thread::sleep(Duration::from_millis(100));
    }
    drop(h);
    let mut h = app(Args::default(), state);
    h.get_by_label("Restore").click();
    h.run_steps(3);
    let doc = h.state().scene_doc().expect("restored");
    assert_eq!(doc.file, edited);
    assert!(doc.dirty);
    assert_eq!(h.state().mode(), Mode::Compose);
}

#[test]
fn a_deformation_opens_in_the_picker_and_the_composer_comes_back() {
    let mut h = face("picker");
    h.get_all_by_label("head").next().expect("listed").click();
    h.run_steps(2);
    h.get_by_label("Edit in Picker").click();
    h.run_steps(3);
    assert_eq!(h.state().mode(), Mode::Pick);
    let doc = h.state().document().expect("the head in the Picker");
    assert!(
        doc.mesh_path.ends_with("cgal_head.off"),
        "{}",
        doc.mesh_path.display()
    );
    assert!(!doc.controls.deformations.is_empty());
    assert!(
        h.state()
            .controls_path()
            .is_some_and(|p| p.ends_with("head_smile.json")),
        "{:?}",
        h.state().controls_path()
    );
    // Back: the scene is as it was, loaded again from its files.
    h.get_by_label("File").click();
    h.run_steps(3);
    h.get_by_label("Back to the Composer").click();
    h.run_steps(3);
    assert_eq!(h.state().mode(), Mode::Compose);
    assert!(h.state().loaded_scene().is_some());
    assert!(!h.state().scene_doc().expect("scene").dirty);
}

#[test]
fn a_key_dragged_along_its_row_moves_in_time_and_reorders_past_another() {
    let mut h = face("timeline");
    let phase = Track::Phase {
        part: 0,
        deformation: 0,
    };
    let before = h.state().scene_doc().expect("face").key_times(0, phase);
    assert_eq!(before, vec![0.0, 1.2, 2.6, 3.8]);
    let row = h.state().timeline_row(0, phase).expect("the phase row");
    let d = h.state().scene_doc().expect("face").file.duration;
    let x = |t: f64| row.left() + (t / d) as f32 * row.width();
    // The key at 1.2 s dragged to 3.0 s: past the one at 2.6 s.
    drag(
        &mut h,
        egui::pos2(x(1.2), row.center().y),
        egui::pos2(x(3.0), row.center().y),
    );
    let after = h.state().scene_doc().expect("face").key_times(0, phase);
    assert_eq!(after, vec![0.0, 2.6, 3.0, 3.8], "{}", h.state().status());
    // The dragged key stays selected at its new place; one undo step.
    assert_eq!(h.state().selected_key(), Some((0, phase, 2)));
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    h.run_steps(2);
    assert_eq!(
        h.state().scene_doc().expect("face").key_times(0, phase),
        before
    );
    // Onto another key: refused, the track as it was.
    let row = h.state().timeline_row(0, phase).expect("the phase row");
    let x = |t: f64| row.left() + (t / d) as f32 * row.width();
    drag(
        &mut h,
        egui::pos2(x(1.2), row.center().y),
        egui::pos2(x(2.6), row.center().y),
    );
    assert_eq!(
        h.state().scene_doc().expect("face").key_times(0, phase),
        before
    );
    assert!(
        h.state().status().contains("Not done"),
        "{}",
        h.state().status()
    );
}

#[test]
fn an_orientation_key_turns_by_a_ring_of_its_gizmo() {
    use csrbf::glam::{DQuat, DVec3};
    let mut h = face("gizmo");
    // The key at 2 s: 12 degrees about Y.
    h.state_mut().select_key((0, Track::Orientation, 1));
    h.run_steps(2);
    let q = |h: &Harness<'_, StudioApp>| {
        let k = h.state().scene_doc().expect("face").file.objects[0].orientation[1];
        DQuat::from_array(csrbf_studio::compose::orientation_quaternion(&k).expect("a rotation"))
    };
    let before = q(&h);
    let rings = h.state().gizmo_rings();
    assert_eq!(rings.len(), 3);
    // A drag along the Y ring, an eighth of the way round (its points go
    // round in 64 steps).
    let (axis, pts) = rings
        .iter()
        .find(|(a, _)| *a == csrbf::glam::Vec3::Y)
        .expect("the Y ring");
    assert_eq!(*axis, csrbf::glam::Vec3::Y);
    // Where the ring is seen most face-on: where points 8 apart are farthest apart.
    let start = (0..56)
        .max_by(|&a, &b| {
            pts[a]
                .distance(pts[a + 8])
                .total_cmp(&pts[b].distance(pts[b + 8]))
        })
        .expect("points");
    drag(&mut h, pts[start], pts[start + 8]);
    let after = q(&h);
    let turn = after * before.inverse();
    let (turn_axis, angle) = turn.to_axis_angle();
    // The turn follows the ring under the pointer: an eighth of a turn.
    assert!(
        (angle.to_degrees() - 45.0).abs() < 2.0,
        "turned {} degrees",
        angle.to_degrees()
    );
    assert!(
        turn_axis.dot(DVec3::Y).abs() > 0.999,
        "about Y: {turn_axis}"
    );
    // One undo step brings the key back.
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    h.run_steps(2);
    assert!(q(&h).angle_between(before) < 1e-9);
}

#[test]
fn contact_is_set_up_from_the_panel_and_plays() {
    let mut h = ball("contact");
    // The box is pushed by the ball: the walls bulge somewhere in the scene.
    let moved = |h: &Harness<'_, StudioApp>| {
        let s = h.state().loaded_scene().expect("loaded");
        let rest = &s.objects[1].mesh.positions;
        (0..=48)
            .map(|k| {
                let f = s.frame(k as f64 * 0.1);
                let (rot, shift) = s.objects[1].transform(k as f64 * 0.1);
                f.objects[1]
                    .positions
                    .iter()
                    .zip(rest)
                    .map(|(p, r)| {
                        let world = rot.as_quat() * *r + shift.as_vec3();
                        p.distance(world)
                    })
                    .fold(0.0f32, f32::max)
            })
            .fold(0.0f32, f32::max)
    };
    assert!(moved(&h) > 1e-3, "the walls bulge");
    // "Pushed by: nothing" on the box: no contact, the walls stay.
    h.get_all_by_label("box").next().expect("listed").click();
    h.run_steps(2);
    contact_box(&h).click();
    h.run_steps(2);
    h.get_by_label("nothing").click();
    h.run_steps(3);
    assert!(
        h.state().scene_doc().expect("scene").file.objects[1]
            .contact
            .is_none()
    );
    assert_eq!(moved(&h), 0.0);
    // And back: pushed by the ball again.
    contact_box(&h).click();
    h.run_steps(2);
    h.get_all_by_label("ball")
        .last()
        .expect("the menu's ball")
        .click();
    h.run_steps(3);
    let c = h.state().scene_doc().expect("scene").file.objects[1]
        .contact
        .clone();
    assert_eq!(c.map(|c| c.with), Some("ball".to_string()));
    assert!(moved(&h) > 1e-3);
}

/// Issue 42: an object's base orientation is set in the panel; it turns
/// the mesh and its deformations together, is saved in the scene, and
/// "None" takes it away.
#[test]
fn a_base_rotation_stands_a_model_up_with_its_deformations() {
    let mut h = face("base-rotation");
    let rest = |h: &Harness<'_, StudioApp>| {
        h.state().loaded_scene().expect("loaded").objects[0]
            .mesh
            .positions
            .clone()
    };
    let before = rest(&h);
    let smile = |h: &Harness<'_, StudioApp>| {
        let s = h.state().loaded_scene().expect("loaded");
        // At 2 s the smile is full; what it moves, in the object's own frame.
        let f = s.frame(2.0);
        let (rot, shift) = s.objects[0].transform(2.0);
        let inverse = rot.as_quat().inverse();
        f.objects[0]
            .positions
            .iter()
            .map(|p| inverse * (*p - shift.as_vec3()))
            .collect::<Vec<_>>()
    };
    let smiled = smile(&h);
    h.get_all_by_label("head").next().expect("listed").click();
    h.run_steps(2);
    h.get_by_label("Z-up to Y-up").click();
    h.run_steps(3);
    let file = h.state().scene_doc().expect("scene").file.clone();
    assert_eq!(
        file.objects[0].rotation.and_then(|r| r.euler),
        Some([-90.0, 0.0, 0.0])
    );
    let turn = csrbf::glam::Mat3::from_rotation_x(-90f32.to_radians());
    for (p, q) in before.iter().zip(rest(&h)) {
        assert!((turn * *p).distance(q) < 1e-4, "{p} -> {q}");
    }
    // The smile turned with the head (its control file is in the mesh's axes).
    for (p, q) in smiled.iter().zip(smile(&h)) {
        assert!((turn * *p).distance(q) < 1e-3, "{p} -> {q}");
    }
    h.get_by_label("None").click();
    h.run_steps(3);
    assert_eq!(
        h.state().scene_doc().expect("scene").file.objects[0].rotation,
        None
    );
    assert_eq!(rest(&h), before);
}

/// The "Pushed by" combo box of the selected object (the other is its
/// turning's).
fn contact_box<'a>(h: &'a Harness<'_, StudioApp>) -> egui_kittest::Node<'a> {
    let boxes: Vec<_> = h.get_all_by_role(Role::ComboBox).collect();
    let values: Vec<_> = boxes.iter().map(|b| b.value()).collect();
    boxes
        .into_iter()
        .find(|b| b.value().is_some_and(|v| v != "squad" && v != "slerp"))
        .unwrap_or_else(|| panic!("no contact combo box among {values:?}"))
}

#[test]
fn saving_over_a_file_that_exists_asks_first() {
    let mut h = face("replace");
    let dir = temp("replace-out");
    let path = dir.join("taken.scene.json");
    std::fs::write(&path, "kept").expect("write");
    h.key_press_modifiers(
        egui::Modifiers::COMMAND | egui::Modifiers::SHIFT,
        egui::Key::S,
    );
    support::choose(&mut h, &path, "Save");
    // Not yet: the dialog asks.
    assert_eq!(std::fs::read_to_string(&path).expect("read"), "kept");
    h.get_by_label_contains("exists. Replace it?");
    h.get_by_label("Keep it").click();
    // The dialog's window takes a few frames to settle to its new size.
    h.run_steps(4);
    assert_eq!(std::fs::read_to_string(&path).expect("read"), "kept");
    // Asked again, and replaced.
    h.get_by_label("Save").click();
    h.run_steps(4);
    h.get_by_label_contains("exists. Replace it?");
    h.get_by_label("Replace").click();
    h.run_steps(3);
    let text = std::fs::read_to_string(&path).expect("read");
    assert!(SceneFile::parse(&text).is_ok(), "{text}");
    assert!(!h.state().scene_doc().expect("scene").dirty);
}

#[test]
fn a_scene_save_that_fails_says_why_and_writes_nothing() {
    let mut h = face("save-fails");
    scrub(&mut h, 1.0);
    key_button(&mut h, 0);
    let before = h.state().scene_doc().expect("scene").file.clone();
    let bad = temp("save-fails-out")
        .join("no such folder")
        .join("s.scene.json");
    h.state_mut().save_scene_to(&bad);
    h.run_steps(2);
    let (title, text) = h.state().message().cloned().expect("a dialog says why");
    assert!(
        title.contains("Cannot save") && text.contains("no such folder"),
        "{title}: {text}"
    );
    assert!(!bad.exists());
    let doc = h.state().scene_doc().expect("kept");
    assert!(doc.dirty, "still unsaved");
    assert_eq!(doc.file, before);
    // An empty scene is not written either: the CLI would refuse it.
    let mut h = app(Args::default(), temp("save-empty-state"));
    h.state_mut().new_scene();
    let empty = temp("save-empty").join("empty.scene.json");
    h.state_mut().save_scene_to(&empty);
    h.run_steps(2);
    let (_, text) = h.state().message().cloned().expect("a dialog says why");
    assert!(text.contains("objects"), "{text}");
    assert!(!empty.exists());
}

/// The scene's lights from the side panel. Add writes out the renderer's
/// default two as placed from the scene camera (what a movie of the scene
/// without lights shows), Remove takes one away, undo brings it back, the
/// scene shown has what the document has, and a save writes them in the
/// CLI's format.
#[test]
fn lights_are_added_removed_undone_and_saved() {
    let dir = temp("lights-out");
    let mut h = face("lights");
    let doc_lights =
        |h: &Harness<'_, StudioApp>| h.state().scene_doc().expect("face").file.lights.clone();
    assert!(doc_lights(&h).is_empty());
    h.get_by_label("Add light").click();
    h.run_steps(3);
    let lights = doc_lights(&h);
    assert_eq!(lights.len(), 2, "{}", h.state().status());
    let f = &h.state().scene_doc().expect("face").file.camera;
    let v = |a: [f64; 3]| csrbf::glam::DVec3::from_array(a).as_vec3();
    let cam = csrbf_anim::Camera::perspective(v(f.eye), v(f.target), v(f.up), f.fov as f32);
    for (l, d) in lights.iter().zip(csrbf_render::default_lights(cam)) {
        let dir = csrbf::glam::DVec3::from_array(l.direction).as_vec3();
        assert!(
            (dir - d.direction).length() < 1e-6,
            "{dir} vs {}",
            d.direction
        );
        let color = csrbf::glam::Vec3::from_array(l.color) * l.intensity;
        assert!((color - d.color).length() < 1e-6, "{color} vs {}", d.color);
    }
    assert_eq!(
        h.state().loaded_scene().expect("loaded").file.lights,
        lights,
        "the scene shown is lit as the document says"
    );
    // Lights come before the objects in the panel: the first Remove is the
    // first light's.
    h.get_all_by_label("Remove")
        .next()
        .expect("a light's Remove")
        .click();
    h.run_steps(3);
    assert_eq!(doc_lights(&h), lights[1..].to_vec());
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    h.run_steps(2);
    assert_eq!(doc_lights(&h), lights);
    assert_eq!(
        h.state().loaded_scene().expect("loaded").file.lights,
        lights
    );

    let saved = dir.join("lit.scene.json");
    h.key_press_modifiers(
        egui::Modifiers::COMMAND | egui::Modifiers::SHIFT,
        egui::Key::S,
    );
    h.run_steps(2);
    support::choose(&mut h, &saved, "Save");
    let file = SceneFile::parse(&std::fs::read_to_string(&saved).expect("saved"))
        .expect("the CLI's parser reads it");
    assert_eq!(file.lights, lights);
}

/// The scene camera aimed in the viewport: its eye dragged lands under the
/// pointer (on the plane facing the view) with the target kept, one undo
/// brings it back, and a drag of the target moves the target alone. What
/// the camera sees follows: `csrbf animate` renders through the file's
/// camera, and the document holds the moved one.
#[test]
fn the_scene_camera_is_aimed_by_dragging_its_eye_and_target() {
    let mut h = face("camera-drag");
    let v = |a: [f64; 3]| csrbf::glam::DVec3::from_array(a).as_vec3();
    let camera =
        |h: &Harness<'_, StudioApp>| h.state().scene_doc().expect("face").file.camera.clone();
    let before = camera(&h);
    // Opening frames the objects (the eye is out of view here); F frames
    // everything, the scene camera too.
    let gate = h.state().compose_camera().expect("a scene").2;
    assert!(!gate.contains(on_screen(&h, v(before.eye))));
    h.key_press(egui::Key::F);
    h.run_steps(3);
    let from = on_screen(&h, v(before.eye));
    assert!(
        gate.shrink(60.0).contains(from),
        "the eye is at {from:?}, out of {gate:?}"
    );
    let to = from + egui::vec2(40.0, -25.0);
    drag(&mut h, from, to);
    let moved = camera(&h);
    assert_eq!(moved.target, before.target, "{}", h.state().status());
    assert_ne!(moved.eye, before.eye, "{}", h.state().status());
    let landed = on_screen(&h, v(moved.eye));
    assert!(
        landed.distance(to) < 1.5,
        "the eye went to {landed:?}, not {to:?}"
    );
    assert!(h.state().scene_doc().expect("face").dirty);
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    h.run_steps(2);
    assert_eq!(camera(&h), before);

    let from = on_screen(&h, v(before.target));
    let to = from + egui::vec2(-30.0, 20.0);
    drag(&mut h, from, to);
    let aimed = camera(&h);
    assert_eq!(aimed.eye, before.eye);
    let landed = on_screen(&h, v(aimed.target));
    assert!(
        landed.distance(to) < 1.5,
        "the target went to {landed:?}, not {to:?}"
    );
    // Looking through it, the new target is the picture's centre.
    h.key_press(egui::Key::C);
    h.run_steps(2);
    let (cam, size, _) = h.state().compose_camera().expect("a scene");
    let (centre, _) = cam.project(v(aimed.target), size).expect("in front");
    let mid = csrbf::glam::Vec2::new(size[0] as f32, size[1] as f32) / 2.0;
    assert!(centre.distance(mid) < 1.0, "{centre} vs {mid}");
}

/// A key copied from one object and pasted onto another at the playhead,
/// as a window sends Ctrl+C and Ctrl+V (Copy and Paste events): the other
/// object's track gets the value and the tension, continuity and bias, the
/// source keeps its key, and one undo removes the pasted one.
#[test]
fn a_key_is_copied_from_one_object_and_pasted_onto_another() {
    let mut h = ball("paste");
    let file = |h: &Harness<'_, StudioApp>| h.state().scene_doc().expect("ball").file.clone();
    let names: Vec<String> = file(&h).objects.iter().map(|o| o.name.clone()).collect();
    let from = file(&h).objects[0].trajectory.len() - 1;
    let source = file(&h).objects[0].trajectory[from];
    h.state_mut().select_key((0, Track::Position, from));
    h.run_steps(2);
    h.event(egui::Event::Copy);
    h.run_steps(2);
    assert!(
        h.state().status().contains("Copied"),
        "{}",
        h.state().status()
    );
    // The other object, at a time where it has no key.
    // (Named in the objects list and on the timeline; either selects it.)
    h.get_all_by_label(names[1].as_str())
        .next()
        .expect("the other object")
        .click();
    h.run_steps(2);
    let before = file(&h).objects[1].trajectory.clone();
    let time = 1.7;
    scrub(&mut h, time);
    let time = h.state().scene_doc().expect("ball").playhead;
    assert!(before.iter().all(|k| k.time != time));
    h.event(egui::Event::Paste("anything".into()));
    h.run_steps(2);
    let after = file(&h).objects[1].trajectory.clone();
    assert_eq!(after.len(), before.len() + 1, "{}", h.state().status());
    let k = after
        .iter()
        .find(|k| k.time == time)
        .expect("pasted at the playhead");
    assert_eq!(k.position, source.position);
    assert_eq!(
        [k.tension, k.continuity, k.bias],
        [source.tension, source.continuity, source.bias]
    );
    assert_eq!(
        file(&h).objects[0].trajectory.len(),
        from + 1,
        "the source is kept"
    );
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    h.run_steps(2);
    assert_eq!(file(&h).objects[1].trajectory, before);
}

/// A part added from the panel is carved out of the whole-mesh part (a
/// sphere about the surface point nearest the mesh's middle to start): the
/// loaded scene has every
/// face in exactly one part, the sphere's in the new one. Removing it gives
/// the faces back, undo brings it again, and what is saved `Scene::load`
/// (the loader `csrbf animate` uses) parts the same way.
#[test]
fn a_part_is_added_carved_out_removed_and_saved() {
    let dir = temp("parts-out");
    let mut h = app_sized(
        Args {
            mesh: Some(assets().join("scenes/face.scene.json")),
            controls: None,
        },
        temp("parts"),
        [1280.0, 1500.0],
    );
    h.get_all_by_label("head")
        .next()
        .expect("the head in the objects list")
        .click();
    h.run_steps(3);
    h.get_by_label("Add part").click();
    h.run_steps(3);
    let faces = |h: &Harness<'_, StudioApp>| -> Vec<usize> {
        let s = h.state().loaded_scene().expect("loaded");
        s.objects[0].parts.iter().map(|p| p.faces.len()).collect()
    };
    let total = h.state().loaded_scene().expect("loaded").objects[0]
        .mesh
        .faces
        .len();
    let split = faces(&h);
    assert_eq!(split.len(), 2, "{}", h.state().status());
    assert!(split[1] > 0 && split[1] < total, "{split:?} of {total}");
    assert_eq!(split[0] + split[1], total);
    let file = h.state().scene_doc().expect("face").file.clone();
    assert!(file.objects[0].parts[1].select.get("sphere").is_some());

    // The second part's Remove (both parts have one now).
    h.get_all_by_label("Remove part")
        .last()
        .expect("the new part's Remove")
        .click();
    h.run_steps(3);
    assert_eq!(faces(&h), vec![total]);
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    h.run_steps(2);
    assert_eq!(faces(&h), split);

    let saved = dir.join("parts.scene.json");
    h.key_press_modifiers(
        egui::Modifiers::COMMAND | egui::Modifiers::SHIFT,
        egui::Key::S,
    );
    h.run_steps(2);
    support::choose(&mut h, &saved, "Save");
    let cli = Scene::load(&saved).expect("the CLI's loader reads it");
    let parts: Vec<usize> = cli.objects[0].parts.iter().map(|p| p.faces.len()).collect();
    assert_eq!(parts, split);
}

/// Issue 23, bug 4: a number typed into a field is applied on Enter (not
/// at each keystroke, which applied 6 on the way to 60); a value the scene
/// refuses leaves the one before and says why.
#[test]
fn a_typed_number_applies_on_enter_and_a_refused_one_keeps_the_value_before() {
    let mut h = face("typed-fps");
    let fps = |h: &Harness<'_, StudioApp>| h.state().scene_doc().expect("scene").file.fps;
    let before = fps(&h);
    let type_fps = |h: &mut Harness<'_, StudioApp>, text: &str| {
        h.get_by_role_and_label(Role::SpinButton, "fps").focus();
        h.run_steps(2);
        for c in text.chars() {
            h.event(egui::Event::Text(c.to_string()));
            h.run_steps(1);
        }
    };
    type_fps(&mut h, "60");
    assert_eq!(fps(&h), before, "nothing applied while typing");
    h.key_press(egui::Key::Enter);
    h.run_steps(2);
    assert_eq!(fps(&h), 60.0, "{}", h.state().status());
    // The issue's case: an hour at 20 fps; 60 fps would be more frames than
    // a scene may have: refused, the field goes back to 20 and says why.
    assert!(
        h.state_mut()
            .scene_edit(csrbf_studio::compose::SceneEdit::SetTiming {
                fps: 20.0,
                duration: 3600.0
            })
    );
    h.run_steps(2);
    type_fps(&mut h, "60");
    assert_eq!(fps(&h), 20.0, "6 is not applied on the way to 60");
    h.key_press(egui::Key::Enter);
    h.run_steps(2);
    assert_eq!(fps(&h), 20.0);
    assert!(
        h.state().status().contains("Not done"),
        "{}",
        h.state().status()
    );
    let shown = h.get_by_role_and_label(Role::SpinButton, "fps").value();
    assert_eq!(
        shown.as_deref(),
        Some("20.0 fps"),
        "the field shows the value kept"
    );
    // Issue 42: once a value is taken, the refusal of the one before is
    // not shown as if it still held.
    assert!(
        h.state_mut()
            .scene_edit(csrbf_studio::compose::SceneEdit::SetTiming {
                fps: 24.0,
                duration: 4.0
            })
    );
    h.run_steps(2);
    assert!(
        !h.state().status().contains("Not done"),
        "{}",
        h.state().status()
    );
}

/// Issue 23, bug 5: closing the window during an export asks what to do
/// with it; cancelling leaves neither the movie nor a temporary file, and
/// finishing writes the movie whole.
#[test]
fn closing_during_an_export_asks_and_never_leaves_a_temporary_file() {
    let mut h = face("close-export");
    let dir = temp("close-export-out");
    let close = |h: &mut Harness<'_, StudioApp>| {
        h.input_mut()
            .viewports
            .entry(egui::ViewportId::ROOT)
            .or_default()
            .events
            .push(egui::ViewportEvent::Close);
        h.run_steps(2);
    };
    let leftovers = |dir: &Path| {
        std::fs::read_dir(dir)
            .expect("the folder")
            .filter_map(|e| e.ok())
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect::<Vec<_>>()
    };
    // Few frames: a short movie.
    let duration = h.state().scene_doc().expect("scene").file.duration;
    assert!(
        h.state_mut()
            .scene_edit(csrbf_studio::compose::SceneEdit::SetTiming { fps: 6.0, duration }),
        "{}",
        h.state().status()
    );
    let gif = dir.join("face.gif");
    h.state_mut().export_movie(&gif);
    h.run_steps(1);
    assert!(h.state().exporting());
    close(&mut h);
    h.get_by_label("Quit during the export?");
    assert!(
        h.state().exporting(),
        "still running while the question waits"
    );
    h.get_by_label("Cancel it and quit").click();
    h.run_steps(2);
    assert!(!h.state().exporting());
    assert_eq!(leftovers(&dir), Vec::<String>::new(), "nothing left behind");
    // Finish, then quit: the movie is written whole.
    h.state_mut().export_movie(&gif);
    h.run_steps(1);
    close(&mut h);
    h.get_by_label("Finish, then quit").click();
    h.run_steps(1);
    assert!(h.state_mut().finish_export(Duration::from_secs(120)));
    h.run_steps(2);
    assert_eq!(leftovers(&dir), vec!["face.gif".to_string()]);
}
