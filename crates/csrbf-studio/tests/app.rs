//! The app driven as a person would, headless (egui_kittest): clicks and
//! drags in the viewport, the side panel's widgets, keyboard shortcuts,
//! files. No display and no GPU are needed (the viewport's picture is
//! tested in `snapshots.rs`).

use std::path::{Path, PathBuf};
use std::time::Duration;

use csrbf::glam::{Vec2, Vec3};
use csrbf_edit::controls::ControlFile;
use csrbf_studio::app::{Args, StudioApp};
use csrbf_studio::{Live, vertices_in_box};
use eframe::egui;
use egui::accesskit::Role;
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;

use crate::support;

use csrbf_testkit::{all_models, model};

/// A private state folder, so tests neither see nor leave recovery files.
fn state_dir(test: &str) -> PathBuf {
    csrbf_testkit::scratch(env!("CARGO_TARGET_TMPDIR"), &format!("studio-app-{test}"))
}

fn open(args: Args, test: &str) -> Harness<'static, StudioApp> {
    open_sized(args, test, [1280.0, 800.0])
}

fn open_sized(args: Args, test: &str, size: [f32; 2]) -> Harness<'static, StudioApp> {
    // SAFETY of set_var: each test process sets the same value before any
    // thread reads it... the tests run in threads, so the folder is per test
    // through the app's own override instead.
    let dir = state_dir(test);
    let mut h = Harness::builder()
        .with_size(size)
        .with_max_steps(64)
        .build_eframe(move |cc| StudioApp::with_state_dir(cc, args, Some(dir)));
    settle(&mut h);
    h
}

fn settle(h: &mut Harness<'_, StudioApp>) {
    h.run_steps(2);
    assert!(
        h.state_mut().settle(Duration::from_secs(60)),
        "the preview answers"
    );
    h.run_steps(2);
}

fn head(test: &str) -> Harness<'static, StudioApp> {
    open(
        Args {
            mesh: Some(model("cgal_head.off")),
            controls: None,
        },
        test,
    )
}

/// Screen position (points) of a viewport pixel.
fn screen(h: &Harness<'_, StudioApp>, pixel: Vec2) -> egui::Pos2 {
    let (_, _, corner, ppp) = h.state().viewport_camera().expect("a mesh is open");
    egui::pos2(corner.x + pixel.x / ppp, corner.y + pixel.y / ppp)
}

fn press(h: &mut Harness<'_, StudioApp>, pixel: Vec2, pressed: bool) {
    let at = screen(h, pixel);
    support::button(h, at, pressed);
    h.step();
}

fn move_to(h: &mut Harness<'_, StudioApp>, pixel: Vec2) {
    let at = screen(h, pixel);
    h.event(egui::Event::PointerMoved(at));
    h.step();
}

/// The nose of the bundled head: the vertex farthest along -X (the head
/// looks along -X), nudged one pixel into the face so the ray meets skin.
fn nose_pixel(h: &Harness<'_, StudioApp>) -> (Vec2, Vec3) {
    let doc = h.state().document().expect("open");
    let tip = doc
        .mesh
        .positions
        .iter()
        .copied()
        .min_by(|a, b| a.x.total_cmp(&b.x))
        .expect("vertices");
    let (cam, size, _, _) = h.state().viewport_camera().expect("open");
    let (px, _) = cam.project(tip, size).expect("in view");
    // Round to a pixel a pointer can reach exactly.
    (Vec2::new(px.x.round() + 2.0, px.y.round()), tip)
}

#[test]
fn a_click_on_the_nose_puts_a_start_exactly_on_the_surface_under_the_pointer() {
    let mut h = head("click");
    let (px, _) = nose_pixel(&h);
    // The camera and viewport the click is aimed through (the side panel
    // may change the viewport's shape after the click).
    let (cam, size, corner, ppp) = h.state().viewport_camera().expect("open");
    let at = screen(&h, px);
    press(&mut h, px, true);
    press(&mut h, px, false);
    settle(&mut h);

    let app = h.state();
    let doc = app.document().expect("open");
    let spec = &doc.controls.deformations[0];
    assert_eq!(
        spec.starts.len(),
        1,
        "one click, one control: {}",
        app.status()
    );
    assert_eq!(
        spec.starts[0], spec.targets[0],
        "a click without a drag is a pin"
    );

    // The ray through the pixel the event landed on, cast by brute force.
    let landed = Vec2::new((at.x - corner.x) * ppp, (at.y - corner.y) * ppp);
    let triangles = doc.mesh.faces.triangles();
    let hit =
        csrbf_mesh::bvh::cast_brute_force(&doc.mesh.positions, &triangles, &cam.ray(landed, size))
            .expect("the ray meets the head");
    let diag = doc.diagonal();
    let err = (spec.starts[0] - hit.point.as_dvec3()).length();
    assert!(
        err <= 1e-4 * diag,
        "start {} vs hit {}: {err}",
        spec.starts[0],
        hit.point
    );
    assert!(app.undo_steps() == 1);
}

#[test]
fn dragging_from_the_nose_pulls_it_then_undo_restores_the_exact_state() {
    let mut h = head("drag");
    let rest = h.state().shown_positions().expect("open").to_vec();
    let before = h.state().document().expect("open").controls.clone();
    let (px, tip) = nose_pixel(&h);
    press(&mut h, px, true);
    for k in 1..=8 {
        move_to(&mut h, px - Vec2::new(10.0 * k as f32, 0.0));
    }
    press(&mut h, px - Vec2::new(80.0, 0.0), false);
    settle(&mut h);

    let app = h.state();
    let doc = app.document().expect("open");
    let spec = &doc.controls.deformations[0];
    assert_eq!(spec.starts.len(), 1);
    let pull = spec.targets[0] - spec.starts[0];
    assert!(
        pull.x < -0.05 * doc.diagonal(),
        "the destination went left (-X): {pull}"
    );
    let shown = app.shown_positions().expect("open");
    let k = rest.iter().position(|p| *p == tip).expect("tip");
    assert!(
        shown[k].x < rest[k].x - 0.05 * doc.diagonal() as f32,
        "the nose moved: {} -> {}",
        rest[k],
        shown[k]
    );
    // The preview is the engine's result for the document as it stands.
    let mut live = Live::new(doc);
    live.update(doc).expect("update");
    assert_eq!(shown, live.positions());
    let frame = app.preview_frame().expect("a frame");
    assert_eq!(
        frame.factorisations, 1,
        "the drag solved again without refactoring"
    );
    // Placing a control and dragging out its destination is one step (it
    // was two: the insert, then the drag; a new user's trial).
    assert_eq!(app.undo_steps(), 1, "the add and its drag as one step");
    let pulled = doc.controls.clone();

    // Ctrl+Z: the document and the picture are as before, exactly.
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    settle(&mut h);
    let app = h.state();
    assert_eq!(app.document().expect("open").controls, before);
    assert_eq!(app.shown_positions().expect("open"), &rest[..]);
    // And redo brings the edit back.
    h.key_press_modifiers(
        egui::Modifiers::COMMAND | egui::Modifiers::SHIFT,
        egui::Key::Z,
    );
    settle(&mut h);
    assert_eq!(
        h.state().document().expect("open").controls,
        pulled,
        "the control and its destination"
    );
}

/// Places a control at the nose and drags it 60 pixels left.
fn pull_nose(h: &mut Harness<'_, StudioApp>) {
    let (px, _) = nose_pixel(h);
    press(h, px, true);
    for k in 1..=6 {
        move_to(h, px - Vec2::new(10.0 * k as f32, 0.0));
    }
    press(h, px - Vec2::new(60.0, 0.0), false);
    settle(h);
}

/// Issue 23, bug 8: a file's radius far outside the slider's usual range
/// is shown as it is (and used and saved as it is), not clamped.
#[test]
fn a_radius_beyond_the_sliders_range_is_shown_as_it_is() {
    let dir = state_dir("far-radius-files");
    let controls = dir.join("far.json");
    std::fs::write(
        &controls,
        r#"{"radius": 3000, "controls": [{"from": [0, 0, 0], "to": [0, 0, 0]}]}"#,
    )
    .expect("write");
    let mut h = open(
        Args {
            mesh: Some(model("cgal_head.off")),
            controls: Some(controls),
        },
        "far-radius",
    );
    h.run_steps(2);
    let shown = h.query_by_label_contains("R = 3000.0000 = ");
    assert!(shown.is_some(), "the label shows the radius in use");
    let doc = h.state().document().expect("open");
    assert_eq!(doc.controls.deformations[0].options.radius, 3000.0);
}

#[test]
fn the_radius_slider_refits_and_shows_its_share_of_the_diagonal() {
    let mut h = head("radius");
    pull_nose(&mut h);
    let before = h.state().shown_positions().expect("open").to_vec();
    let fits = h.state().preview_frame().expect("frame").factorisations;
    let diag = h.state().document().expect("open").diagonal();
    let want = (diag * 0.3 * 1e4).round() / 1e4;
    h.get_by_role_and_label(Role::SpinButton, "radius R")
        .set_value_accesskit(want);
    settle(&mut h);
    let app = h.state();
    let r = app.document().expect("open").controls.deformations[0]
        .options
        .radius;
    assert!((r - want).abs() < 1e-9, "R {r} vs {want}");
    assert!(
        app.preview_frame().expect("frame").factorisations > fits,
        "a refit"
    );
    assert_ne!(app.shown_positions().expect("open"), &before[..]);
    h.get_by_label_contains("% of the diagonal");
    // A radius of zero or less cannot be entered: the slider stops above 0.
    h.get_by_role_and_label(Role::SpinButton, "radius R")
        .set_value_accesskit(-1.0);
    settle(&mut h);
    let r = h.state().document().expect("open").controls.deformations[0]
        .options
        .radius;
    assert!(r > 0.0, "{r}");
}

#[test]
fn what_the_studio_saves_the_cli_reads_back_to_the_same_document() {
    let mut h = head("save");
    pull_nose(&mut h);
    let dir = state_dir("save-out");
    let path = dir.join("nose.json");
    h.state_mut().save_to(&path);
    h.run_steps(2);
    let app = h.state();
    assert_eq!(app.controls_path(), Some(path.as_path()));
    let doc = app.document().expect("open");
    assert!(!doc.dirty);
    let text = std::fs::read_to_string(&path).expect("saved");
    let file = ControlFile::parse(&text).expect("the CLI's parser reads it");
    assert_eq!(file.deformations, doc.controls.deformations);
    // What `csrbf deform` computes from it (its library path) is what the
    // studio shows (the CLI binary itself is checked in csrbf-cli's tests).
    let mut mesh = (*doc.mesh).clone();
    csrbf_edit::apply::deform_mesh(&mut mesh, &file, 1.0).expect("deform");
    let diag = doc.diagonal() as f32;
    for (a, b) in mesh
        .positions
        .iter()
        .zip(app.shown_positions().expect("open"))
    {
        assert!((*a - *b).length() <= 1e-6 * diag, "{a} vs {b}");
    }

    // A save into a folder that does not exist fails, says so, and the
    // document stays unsaved; nothing is left behind.
    let mut h = head("save-fail");
    pull_nose(&mut h);
    let bad = dir.join("no such folder").join("x.json");
    h.state_mut().save_to(&bad);
    h.run_steps(2);
    let app = h.state();
    assert!(app.document().expect("open").dirty);
    let (title, text) = app.message().expect("a dialog says why");
    assert!(
        title.contains("Cannot save") && text.contains("no such folder"),
        "{title}: {text}"
    );
    // Why, not only the path (issue 23, bug 7).
    assert!(
        text.contains("does not exist") || text.contains("os error"),
        "{text}"
    );
    assert!(!bad.exists());
}

#[test]
fn a_broken_file_is_refused_with_the_cli_message_and_the_document_kept() {
    let mut h = head("broken");
    pull_nose(&mut h);
    let kept = h.state().document().expect("open").controls.clone();
    let dir = state_dir("broken-files");
    let broken = dir.join("broken.json");
    std::fs::write(
        &broken,
        "{\"radius\": 0.5,\n \"controls\": [{\"from\": [0, 0], \"to\": [0, 0, 1]}]}\n",
    )
    .expect("write");
    h.state_mut().open_controls(&broken);
    h.run_steps(2);
    let (title, text) = h.state().message().expect("a dialog").clone();
    assert!(title.contains("control file"), "{title}");
    assert!(
        text.contains("broken.json") && text.contains("controls[0].from"),
        "{text}"
    );
    assert_eq!(h.state().document().expect("open").controls, kept);
    // Issue 42: a file that parses but that `csrbf deform` refuses on this
    // mesh (two controls with one start) is refused alike, in its words,
    // and the document stays as it was (so Save cannot write it).
    h.get_by_label("OK").click();
    h.run_steps(1);
    let twice = dir.join("twice.json");
    std::fs::write(
        &twice,
        "{\"radius\": 20, \"controls\": [{\"from\": [0, 0, 0], \"to\": [0, 0, 1]}, {\"from\": [0, 0, 0], \"to\": [0, 1, 0]}]}",
    )
    .expect("write");
    h.state_mut().open_controls(&twice);
    h.run_steps(2);
    let (title, text) = h.state().message().expect("a dialog").clone();
    assert!(title.contains("control file"), "{title}");
    assert!(
        text.contains("twice.json") && text.contains("controls 0 and 1"),
        "{text}"
    );
    assert_eq!(h.state().document().expect("open").controls, kept);

    let mesh = dir.join("broken.off");
    std::fs::write(&mesh, "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4 0 1 2 3\n").expect("write");
    let ctx = h.ctx.clone();
    h.state_mut().open_mesh(&ctx, &mesh);
    h.run_steps(2);
    // The document has unsaved changes: the studio asks first.
    h.get_by_label("Discard").click();
    h.run_steps(3);
    let (title, text) = h.state().message().expect("a dialog").clone();
    assert!(title.contains("mesh"), "{title}");
    assert!(text.contains("broken.off"), "{text}");
    let doc = h.state().document().expect("still open");
    assert!(doc.mesh_path.ends_with("cgal_head.off"));
    // A mesh of one point (zero extent) is refused, saying why: there is
    // no surface to place on and no size to take a radius from.
    let point = dir.join("point.off");
    std::fs::write(&point, "OFF\n3 1 0\n1 1 1\n1 1 1\n1 1 1\n3 0 1 2\n").expect("write");
    h.state_mut().open_mesh(&ctx, &point);
    h.run_steps(2);
    let (_, text) = h.state().message().expect("a dialog").clone();
    assert!(
        text.contains("point.off") && text.contains("no extent"),
        "{text}"
    );
    assert!(
        h.state()
            .document()
            .expect("kept")
            .mesh_path
            .ends_with("cgal_head.off")
    );
    // A mesh that is not there: the system's reason, not only the name.
    h.state_mut().open_mesh(&ctx, &dir.join("nonexist.obj"));
    h.run_steps(2);
    let (_, text) = h.state().message().expect("a dialog").clone();
    assert!(
        text.contains("nonexist.obj") && text.contains("os error"),
        "{text}"
    );

    // A scene file goes to the Composer, which says what is wrong with it
    // (the CLI's message); the Picker's document is kept.
    let scene = dir.join("face.scene.json");
    std::fs::write(&scene, "{}").expect("write");
    h.state_mut().open_controls(&scene);
    h.run_steps(2);
    let (title, text) = h.state().message().expect("a dialog").clone();
    assert!(
        title.contains("scene") && text.contains("face.scene.json") && text.contains("duration"),
        "{title}: {text}"
    );
    assert!(
        h.state()
            .document()
            .expect("open")
            .mesh_path
            .ends_with("cgal_head.off")
    );
}

#[test]
fn the_recovery_file_brings_back_an_unsaved_session() {
    let dir = state_dir("recovery-shared");
    let mut h = Harness::builder()
        .with_size([1280.0, 800.0])
        .with_max_steps(64)
        .build_eframe({
            let dir = dir.clone();
            move |cc| {
                StudioApp::with_state_dir(
                    cc,
                    Args {
                        mesh: Some(model("cgal_head.off")),
                        controls: None,
                    },
                    Some(dir),
                )
            }
        });
    settle(&mut h);
    pull_nose(&mut h);
    let lost = h.state().document().expect("open").controls.clone();
    // The file is written in the background within a frame of the edit.
    // Written in the background, at most once a second.
    let file = dir.join("recovery.json");
    let stored = |lost: &ControlFile| {
        let text = std::fs::read_to_string(&file).ok()?;
        let v: serde_json::Value = serde_json::from_str(&text).ok()?;
        let f = ControlFile::parse(v.get("controls")?.as_str()?).ok()?;
        (f == *lost).then_some(())
    };
    for _ in 0..200 {
        h.step();
        if stored(&lost).is_some() {
            break;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    assert!(
        stored(&lost).is_some(),
        "the recovery file holds the last edit"
    );
    // The app "crashes": it is dropped without saving.
    drop(h);
    let mut h = Harness::builder()
        .with_size([1280.0, 800.0])
        .with_max_steps(64)
        .build_eframe(move |cc| StudioApp::with_state_dir(cc, Args::default(), Some(dir)));
    h.run_steps(2);
    h.get_by_label("Restore").click();
    h.run_steps(2);
    settle(&mut h);
    let doc = h.state().document().expect("restored");
    assert_eq!(doc.controls, lost);
    assert!(doc.dirty, "a restored session is still unsaved");
}

#[test]
fn a_handle_turns_a_chosen_part_as_a_rotation() {
    // The wing of the bundled airplane... a long thin part; the head's
    // nose is too short. Use Suzanne's left ear.
    let mut h = suzanne_tall("handle");
    let doc = h.state().document().expect("open").clone();
    let (lo, hi) = doc.mesh.bounds().expect("bounds");
    // The ear: vertices beyond 75 % of the half-width on +X.
    let centre = (lo + hi) * 0.5;
    let reach = (hi.x - centre.x) * 0.75;
    let ear: Vec<u32> = doc
        .mesh
        .positions
        .iter()
        .enumerate()
        .filter(|(_, p)| p.x - centre.x > reach)
        .map(|(i, _)| i as u32)
        .collect();
    assert!(ear.len() > 5, "Suzanne has an ear on +X");
    // Box-select the ear with the Vertices tool, from the front view.
    h.get_by_label("Vertices").click();
    h.run_steps(1);
    let (cam, size, _, _) = h.state().viewport_camera().expect("open");
    let corners: Vec<Vec2> = ear
        .iter()
        .filter_map(|&i| {
            cam.project(doc.mesh.positions[i as usize], size)
                .map(|p| p.0)
        })
        .collect();
    let a = corners.iter().copied().fold(Vec2::INFINITY, Vec2::min) - Vec2::splat(3.0);
    let b = corners.iter().copied().fold(Vec2::NEG_INFINITY, Vec2::max) + Vec2::splat(3.0);
    press(&mut h, a, true);
    move_to(&mut h, (a + b) * 0.5);
    press(&mut h, b, false);
    h.run_steps(1);
    h.get_by_label("Apply the chosen vertices").click();
    h.run_steps(2);
    settle(&mut h);
    // Turn it by typing an angle, as a person would for an exact value.
    h.get_by_role_and_label(Role::SpinButton, "angle")
        .set_value_accesskit(30.0);
    settle(&mut h);

    let app = h.state();
    let doc = app.document().expect("open");
    let layer = doc.controls.deformations.last().expect("a handle layer");
    let handle = layer.handle.as_ref().expect("handle");
    let rot = handle.rotate.expect("a rotation");
    assert!((rot.angle_deg - 30.0).abs() < 1e-9, "{}", rot.angle_deg);
    let frame = app.preview_frame().expect("frame");
    assert!(frame.error.is_none(), "{:?}", frame.error);
    // The tip turned by 30 degrees about the axis through the pivot.
    let lookup = |n: &str| doc.mesh.part_vertices(n);
    let sel = handle
        .select
        .select(&doc.mesh.positions, &lookup)
        .expect("selection");
    let pivot = sel
        .iter()
        .map(|&i| doc.mesh.positions[i as usize].as_dvec3())
        .sum::<csrbf::glam::DVec3>()
        / sel.len() as f64;
    let axis = rot.axis.normalize();
    let flat = |p: csrbf::glam::DVec3| {
        let d = p - pivot;
        d - axis * d.dot(axis)
    };
    // The tip: the chosen vertex farthest from the axis.
    let tip = *sel
        .iter()
        .max_by(|&&a, &&b| {
            let d = |i: u32| flat(doc.mesh.positions[i as usize].as_dvec3()).length();
            d(a).total_cmp(&d(b))
        })
        .expect("a selection");
    let before = flat(doc.mesh.positions[tip as usize].as_dvec3());
    let after = flat(app.shown_positions().expect("open")[tip as usize].as_dvec3());
    let turned = before.angle_between(after).to_degrees();
    assert!(
        (turned - 30.0).abs() < 2.0,
        "the tip turned {turned} degrees"
    );
    assert!(
        (after.length() / before.length() - 1.0).abs() < 0.05,
        "a rotation keeps the tip's distance to the axis"
    );

    // The gizmo: a drag from beside the pivot a quarter turn around it
    // turns the handle by about 90 degrees more (or less: the sign follows
    // the axis against the view).
    let (cam, size, _, _) = h.state().viewport_camera().expect("open");
    let (p, _) = cam.project(pivot.as_vec3(), size).expect("pivot in view");
    // Off the axis rings (40 px; X and Y are edge-on lines in this view):
    // on a diagonal, 30 px out, from 45 to 135 degrees.
    let at = |deg: f32| {
        let a = deg.to_radians();
        p + Vec2::new(30.0 * a.cos(), -30.0 * a.sin())
    };
    press(&mut h, at(45.0), true);
    for k in 1..=9 {
        move_to(&mut h, at(45.0 + 10.0 * k as f32));
    }
    press(&mut h, at(135.0), false);
    settle(&mut h);
    let doc = h.state().document().expect("open");
    let rot = doc
        .controls
        .deformations
        .last()
        .expect("layer")
        .handle
        .as_ref()
        .expect("handle")
        .rotate
        .expect("rotation");
    let turned = (rot.angle_deg - 30.0).abs();
    assert!(
        (turned - 90.0).abs() < 1.0,
        "the gizmo turned it by {turned} degrees"
    );
    assert_eq!(
        h.state().undo_steps(),
        3,
        "apply, angle, and the gizmo drag as one step"
    );
}

/// Issue 23, bug 3: in View > Rest, a box of the vertex tool takes the
/// vertices where they are drawn (at rest), not where the edit moved them;
/// with X-ray it takes those facing away too.
#[test]
fn a_box_in_the_rest_view_chooses_the_vertices_drawn_at_rest() {
    let mut h = head("rest-box");
    pull_nose(&mut h);
    h.get_by_label("View").click();
    h.run_steps(3);
    h.get_by_label("Rest").click();
    h.run_steps(1);
    h.key_press(egui::Key::Escape);
    h.run_steps(1);
    h.get_by_label("Vertices").click();
    h.run_steps(1);
    let (px, _) = nose_pixel(&h);
    let (a, b) = (px - Vec2::new(25.0, 25.0), px + Vec2::new(25.0, 25.0));
    let drag_box = |h: &mut Harness<'_, StudioApp>| {
        press(h, a, true);
        move_to(h, (a + b) / 2.0);
        move_to(h, b);
        press(h, b, false);
    };
    drag_box(&mut h);
    let app = h.state();
    let doc = app.document().expect("open");
    let (cam, size, _, _) = app.viewport_camera().expect("open");
    let triangles = doc.mesh.faces.triangles();
    let in_box = |positions: &[Vec3], through: bool| {
        let normals = csrbf_mesh::triangle_vertex_normals(positions, &triangles);
        vertices_in_box(&cam, size, (a, b), (positions, &normals), through)
    };
    let at_rest = in_box(&doc.mesh.positions, false);
    let deformed = in_box(app.shown_positions().expect("shown"), false);
    assert!(at_rest.len() > 5, "{}", app.status());
    assert_ne!(at_rest, deformed, "the edit moved the nose out of the box");
    assert_eq!(app.chosen_vertices(), &at_rest[..], "{}", app.status());
    // X-ray: every vertex in the box, the far side of the head too.
    h.get_by_label("select through the model (X-ray)").click();
    h.run_steps(1);
    drag_box(&mut h);
    let through = in_box(&h.state().document().expect("open").mesh.positions, true);
    assert!(through.len() > at_rest.len());
    assert_eq!(h.state().chosen_vertices(), &through[..]);
}

#[test]
fn the_vertex_brush_paints_vertices_near_the_pointer() {
    let mut h = head("brush");
    h.get_by_label("Vertices").click();
    h.run_steps(1);
    let (px, tip) = nose_pixel(&h);
    let at = |h: &Harness<'_, StudioApp>, pixel: Vec2| screen(h, pixel);
    let pos = at(&h, px);
    // Ctrl held through the stroke.
    h.event(egui::Event::ModifiersChanged(egui::Modifiers::COMMAND));
    h.event(egui::Event::PointerMoved(pos));
    h.event(egui::Event::PointerButton {
        pos,
        button: egui::PointerButton::Primary,
        pressed: true,
        modifiers: egui::Modifiers::COMMAND,
    });
    h.step();
    move_to(&mut h, px + Vec2::new(5.0, 5.0));
    press(&mut h, px + Vec2::new(5.0, 5.0), false);
    h.event(egui::Event::ModifiersChanged(egui::Modifiers::NONE));
    h.step();
    let app = h.state();
    let chosen = app.chosen_vertices();
    assert!(!chosen.is_empty(), "{}", app.status());
    let doc = app.document().expect("open");
    let k = doc
        .mesh
        .positions
        .iter()
        .position(|p| *p == tip)
        .expect("tip") as u32;
    assert!(chosen.contains(&k), "the nose tip is under the brush");
    // Only vertices near the pointer: within the brush (3 % of the diagonal)
    // of the stroke, so a small share of the head.
    assert!(
        chosen.len() < doc.mesh.positions.len() / 10,
        "{}",
        chosen.len()
    );
}

#[test]
fn every_model_opens_and_takes_a_drag_at_the_centre_of_the_view() {
    let models = all_models();
    assert!(models.len() >= 7, "{models:?}");
    for path in models {
        let mut h = open(
            Args {
                mesh: Some(path.clone()),
                controls: None,
            },
            "every",
        );
        let app = h.state();
        assert!(
            app.message().is_none(),
            "{}: {:?}",
            path.display(),
            app.message()
        );
        let doc = app.document().expect("open");
        let diag = doc.diagonal();
        let (_, size, _, _) = app.viewport_camera().expect("open");
        // The view is framed on the model: its centre is on it for these
        // (closed or nearly closed) models, else try a little off centre.
        let centre = Vec2::new(size[0] as f32 * 0.5, size[1] as f32 * 0.5);
        let mut placed = false;
        for off in [
            Vec2::ZERO,
            Vec2::new(20.0, 0.0),
            Vec2::new(0.0, 20.0),
            Vec2::new(-20.0, -10.0),
        ] {
            press(&mut h, centre + off, true);
            for k in 1..=5 {
                move_to(
                    &mut h,
                    centre + off + Vec2::new(-6.0 * k as f32, -3.0 * k as f32),
                );
            }
            press(&mut h, centre + off + Vec2::new(-30.0, -15.0), false);
            settle(&mut h);
            let n = h.state().document().expect("open").controls.deformations[0]
                .starts
                .len();
            if n > 0 {
                placed = true;
                break;
            }
        }
        assert!(
            placed,
            "{}: no surface near the view's centre",
            path.display()
        );
        eprintln!("{}: placed and dragged", path.display());
        let app = h.state();
        let frame = app.preview_frame().expect("a frame");
        assert!(
            frame.error.is_none(),
            "{}: {:?}",
            path.display(),
            frame.error
        );
        let doc = app.document().expect("open");
        let moved = doc
            .mesh
            .positions
            .iter()
            .zip(app.shown_positions().expect("open"))
            .any(|(a, b)| (*a - *b).length() > 1e-4 * diag as f32);
        // A start farther than R from every vertex (a face's middle on a
        // coarse box) moves nothing, and the diagnostics say so.
        let said = frame.diagnostics.as_ref().is_some_and(|d| {
            d.warnings
                .iter()
                .any(|w| matches!(w, csrbf::Warning::StartsFarFromMesh { .. }))
        });
        assert!(
            moved || said,
            "{}: the drag moved nothing, unexplained",
            path.display()
        );
    }
}

/// A file dropped on the window, as the integration hands it over.
#[derive(Debug)]
struct Dropped(PathBuf);

impl egui::DroppedFile for Dropped {
    fn path(&self) -> &Path {
        &self.0
    }
    fn bytes(&self) -> Result<Vec<u8>, String> {
        std::fs::read(&self.0).map_err(|e| e.to_string())
    }
}

#[test]
fn a_dropped_file_of_another_kind_is_named_with_the_formats_read() {
    let mut h = head("drop");
    pull_nose(&mut h);
    let kept = h.state().document().expect("open").controls.clone();
    let dir = state_dir("drop-files");
    let odd = dir.join("notes.txt");
    std::fs::write(&odd, "not a mesh").expect("write");
    h.input_mut()
        .dropped_files
        .push(std::sync::Arc::new(Dropped(odd)));
    h.run_steps(2);
    let (title, text) = h.state().message().expect("a dialog").clone();
    assert!(title.contains("dropped"), "{title}");
    assert!(
        text.contains("notes.txt") && text.contains("obj") && text.contains("glb"),
        "{text}"
    );
    assert_eq!(h.state().document().expect("open").controls, kept);
    assert!(std::fs::read_to_string(dir.join("notes.txt")).is_ok_and(|t| t == "not a mesh"));
}

#[test]
fn closing_with_unsaved_changes_asks_first() {
    let mut h = head("close");
    pull_nose(&mut h);
    let id = egui::ViewportId::ROOT;
    h.input_mut()
        .viewports
        .entry(id)
        .or_default()
        .events
        .push(egui::ViewportEvent::Close);
    h.run_steps(2);
    // The question is asked and the document is still there, unsaved.
    h.get_by_label("Unsaved changes");
    h.get_by_label("Cancel").click();
    h.run_steps(2);
    let doc = h.state().document().expect("still open");
    assert!(doc.dirty);
    assert_eq!(doc.controls.deformations[0].starts.len(), 1);
}

/// Issue 23: F1 (or ?) opens the keys and pointer gestures of the room
/// shown, and closes them again (so does Esc); Help > Keys and mouse opens
/// them too.
#[test]
fn f1_shows_the_keys_of_the_room_and_the_help_menu_opens_them() {
    let mut h = head("help");
    assert!(h.query_by_label("Keys and mouse").is_none());
    h.key_press(egui::Key::F1);
    h.run_steps(2);
    h.get_by_label("Keys and mouse");
    h.get_by_label("Ctrl+Z, Ctrl+Shift+Z or Ctrl+Y");
    h.get_by_label("P, S, V");
    h.key_press(egui::Key::F1);
    h.run_steps(2);
    assert!(h.query_by_label("P, S, V").is_none(), "F1 again closes it");
    h.get_by_label("Help").click();
    h.run_steps(3);
    h.get_by_label("Keys and mouse  F1").click();
    h.run_steps(2);
    h.get_by_label("P, S, V");
    // Esc closes it too, and only it (the selection stays).
    h.key_press(egui::Key::F1);
    h.run_steps(2);
    pull_nose(&mut h);
    h.key_press(egui::Key::F1);
    h.run_steps(2);
    h.get_by_label("P, S, V");
    let doc = h.state().document().expect("open");
    assert_eq!(doc.selection.0.len(), 1, "the pulled control is selected");
    h.key_press(egui::Key::Escape);
    h.run_steps(2);
    assert!(h.query_by_label("P, S, V").is_none(), "Esc closes it");
    let doc = h.state().document().expect("open");
    assert_eq!(doc.selection.0.len(), 1, "the selection is kept");
    h.get_by_label("Help").click();
    h.run_steps(3);
    h.get_by_label("Keys and mouse  F1").click();
    h.run_steps(2);
    // The Composer's own keys in the Composer.
    h.state_mut().new_scene();
    h.run_steps(2);
    h.get_by_label("Space");
    assert!(h.query_by_label("P, S, V").is_none());
}

/// Issue 23, small: after a drag the status says what was made (not "drag
/// to set its destination" any more); a click alone says it made a pin.
#[test]
fn after_a_drag_the_status_says_what_was_made() {
    let mut h = head("drag-status");
    let (px, _) = nose_pixel(&h);
    press(&mut h, px, true);
    assert!(h.state().status().contains("drag to set its destination"));
    for k in 1..=3 {
        move_to(&mut h, px - Vec2::new(10.0 * k as f32, 0.0));
    }
    press(&mut h, px - Vec2::new(30.0, 0.0), false);
    let status = h.state().status().to_string();
    assert!(
        status.contains("destination set") && status.contains("% of R"),
        "{status}"
    );
    assert!(!status.contains("drag to set"), "{status}");
    let (_, size, _, _) = h.state().viewport_camera().expect("open");
    let centre = Vec2::new(size[0] as f32 / 2.0, size[1] as f32 / 2.0);
    press(&mut h, centre, true);
    press(&mut h, centre, false);
    let status = h.state().status();
    assert!(status.contains("a pin"), "{status}");
}

/// Issue 23, the trial after it: "Save" in the unsaved-changes question
/// before opening another mesh, on controls never saved, asks where (a
/// file dialog), saves there, and then opens the mesh (the open was lost).
#[test]
fn saving_first_then_opens_the_mesh_asked_for() {
    let dir = state_dir("save-then-open");
    let mut h = head("save-then-open");
    pull_nose(&mut h);
    assert!(h.state().document().expect("open").dirty);
    let ctx = h.ctx.clone();
    let other = model("assimp_Suzanne_248.obj");
    h.state_mut().open_mesh(&ctx, &other);
    h.run_steps(2);
    h.get_by_label("Save").click();
    let saved = dir.join("first.json");
    support::choose(&mut h, &saved, "Save");
    settle(&mut h);
    let text = std::fs::read_to_string(&saved).expect("saved");
    assert_eq!(
        ControlFile::parse(&text).expect("parse").deformations[0]
            .starts
            .len(),
        1
    );
    let doc = h.state().document().expect("a mesh");
    assert!(
        doc.mesh_path.ends_with("assimp_Suzanne_248.obj"),
        "then opened: {}",
        doc.mesh_path.display()
    );
}

/// Issue 23, small: Esc closes an open menu (the Picker's own Esc, which
/// clears the selection, waits until no menu is open).
#[test]
fn esc_closes_the_edit_menu() {
    let mut h = head("esc-menu");
    pull_nose(&mut h);
    h.get_by_label("Edit").click();
    h.run_steps(3);
    h.get_by_label("Undo  Ctrl+Z");
    h.key_press(egui::Key::Escape);
    h.run_steps(3);
    assert!(
        h.query_by_label("Undo  Ctrl+Z").is_none(),
        "the menu closed"
    );
    let doc = h.state().document().expect("open");
    assert_eq!(doc.selection.0.len(), 1, "the selection is kept");
}

/// Issue 23, small: a drag whose press, moves and release all arrive in one
/// frame (a slow frame on a big mesh) still places the control where it was
/// pressed and drags its destination, instead of making a zero-length pin.
#[test]
fn a_drag_within_one_frame_is_a_drag_not_a_pin() {
    let mut h = head("fast-drag");
    let (px, _) = nose_pixel(&h);
    let (from, to) = (screen(&h, px), screen(&h, px - Vec2::new(40.0, 0.0)));
    let button = |pos, pressed| egui::Event::PointerButton {
        pos,
        button: egui::PointerButton::Primary,
        pressed,
        modifiers: egui::Modifiers::NONE,
    };
    h.event(egui::Event::PointerMoved(from));
    h.step();
    h.event(button(from, true));
    h.event(egui::Event::PointerMoved(to));
    h.event(button(to, false));
    h.step();
    h.run_steps(2);
    let doc = h.state().document().expect("open");
    let s = &doc.controls.deformations[0];
    assert_eq!(s.starts.len(), 1, "{}", h.state().status());
    let (cam, size, _, _) = h.state().viewport_camera().expect("open");
    let start_px = cam.project(s.starts[0].as_vec3(), size).expect("in view").0;
    assert!(
        start_px.distance(px) < 2.0,
        "placed where pressed: {start_px} vs {px}"
    );
    assert!(
        (s.targets[0] - s.starts[0]).length() > 0.0,
        "dragged, not a pin"
    );
}

/// Issue 23, bug 9: a start dragged carries its vector (the destination
/// keeps its offset, so the move does not grow); with Ctrl the start moves
/// alone. One undo step each.
#[test]
fn a_dragged_start_carries_its_vector_and_ctrl_moves_it_alone() {
    let mut h = head("carry");
    pull_nose(&mut h);
    let control = |h: &Harness<'_, StudioApp>| {
        let s = &h.state().document().expect("open").controls.deformations[0];
        (s.starts[0], s.targets[0])
    };
    let (a0, b0) = control(&h);
    let (px, _) = nose_pixel(&h);
    let steps = h.state().undo_steps();
    let drag = |h: &mut Harness<'_, StudioApp>, from: Vec2, to: Vec2, m: egui::Modifiers| {
        h.event(egui::Event::ModifiersChanged(m));
        press(h, from, true);
        move_to(h, (from + to) / 2.0);
        move_to(h, to);
        press(h, to, false);
        h.event(egui::Event::ModifiersChanged(egui::Modifiers::NONE));
        settle(h);
    };
    drag(&mut h, px, px + Vec2::new(0.0, 12.0), egui::Modifiers::NONE);
    let (a1, b1) = control(&h);
    assert!(a1.distance(a0) > 1e-3, "the start moved: {a0} -> {a1}");
    assert!(
        ((b1 - a1) - (b0 - a0)).length() < 1e-9,
        "the vector came along"
    );
    assert_eq!(h.state().undo_steps(), steps + 1);
    let (cam, size, _, _) = h.state().viewport_camera().expect("open");
    let at = cam.project(a1.as_vec3(), size).expect("in view").0;
    drag(
        &mut h,
        at,
        at + Vec2::new(0.0, 10.0),
        egui::Modifiers::COMMAND,
    );
    let (a2, b2) = control(&h);
    assert!(a2.distance(a1) > 1e-3, "the start moved");
    assert_eq!(b2, b1, "the destination stayed");
}

/// Issue 23, the trial after it: a start dragged in the deformed view lands
/// where the pointer is on the surface as drawn when the drag began,
/// whatever the path; it drifted with the shape its own move deformed (one
/// move and six moves to the same pixel ended 0.16 apart on the hand).
#[test]
fn a_dragged_start_lands_under_the_pointer_whatever_the_path() {
    let mut h = head("start-path");
    pull_nose(&mut h);
    let start = |h: &Harness<'_, StudioApp>| {
        h.state().document().expect("open").controls.deformations[0].starts[0]
    };
    let before = start(&h);
    let (cam, size, _, _) = h.state().viewport_camera().expect("open");
    let from = cam.project(before.as_vec3(), size).expect("in view").0;
    let to = from + Vec2::new(-6.0, 14.0);
    // In one move.
    press(&mut h, from, true);
    move_to(&mut h, to);
    press(&mut h, to, false);
    settle(&mut h);
    let one = start(&h);
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    settle(&mut h);
    assert_eq!(start(&h), before, "undone");
    // In seven, the preview answering each (the shape drawn changes).
    press(&mut h, from, true);
    for k in 1..=7 {
        move_to(&mut h, from + (to - from) * (k as f32 / 7.0));
        settle(&mut h);
    }
    press(&mut h, to, false);
    settle(&mut h);
    let seven = start(&h);
    let r = h.state().document().expect("open").controls.deformations[0]
        .options
        .radius;
    assert!(
        seven.distance(one) < 1e-6 * r,
        "one move {one}, seven moves {seven}"
    );
    assert!(one.distance(before) > 1e-3 * r, "the start moved");
}

/// Issue 23 ("a handle's pivot"): a handle's pivot is picked on the surface
/// (the shoulder, not the centre of the arm), kept in the control file's
/// rotation, and the selection's centre is back with one button.
#[test]
fn a_handles_pivot_is_picked_on_the_surface() {
    let mut h = suzanne_tall("pivot");
    h.get_by_label("Vertices").click();
    h.run_steps(1);
    let (_, size, _, _) = h.state().viewport_camera().expect("open");
    let centre = Vec2::new(size[0] as f32 / 2.0, size[1] as f32 / 2.0);
    let (a, b) = (
        centre + Vec2::new(40.0, -40.0),
        centre + Vec2::new(140.0, 40.0),
    );
    press(&mut h, a, true);
    move_to(&mut h, (a + b) * 0.5);
    press(&mut h, b, false);
    h.run_steps(1);
    h.get_by_label("Apply the chosen vertices").click();
    h.run_steps(2);
    settle(&mut h);
    // The status says what was made, and the status bar counts the
    // handle's vectors (the trial saw "0 controls").
    let status = h.state().status().to_string();
    assert!(status.contains("is a handle of"), "{status}");
    h.get_by_label_contains("from handles)");
    let handle = |h: &Harness<'_, StudioApp>| {
        let d = h.state().document().expect("open");
        d.controls.deformations[d.active_layer]
            .handle
            .clone()
            .expect("a handle")
    };
    assert_eq!(handle(&h).rotate.and_then(|r| r.pivot), None);
    h.get_by_label("pick on the surface").click();
    h.run_steps(1);
    press(&mut h, centre, true);
    press(&mut h, centre, false);
    settle(&mut h);
    let pivot = handle(&h).rotate.and_then(|r| r.pivot).expect("a pivot");
    // On the surface under the pointer, at rest.
    let (cam, size, _, _) = h.state().viewport_camera().expect("open");
    let at = cam.project(pivot.as_vec3(), size).expect("in view").0;
    assert!(
        at.distance(centre) < 2.0,
        "{at} vs {centre}: {}",
        h.state().status()
    );
    h.get_by_label("selection's centre").click();
    settle(&mut h);
    assert_eq!(handle(&h).rotate.and_then(|r| r.pivot), None);
    let status = h.state().status().to_string();
    assert!(status.contains("selection's centre again"), "{status}");
    // Along the surface on a handle's layer measures from the handle, as a
    // file without "from" reads (the trial found the moving starts).
    h.get_by_role_and_label(Role::ComboBox, "region").click();
    h.run_steps(3);
    h.get_by_label("along the surface").click();
    h.run_steps(2);
    settle(&mut h);
    let d = h.state().document().expect("open");
    let region = &d.controls.deformations[d.active_layer].region;
    assert_eq!(region.origin(), Some(csrbf::Origin::Handle), "{region}");
}

/// Issue 23: "Orbit about the selection" turns the view about the selected
/// start, which stays where it is on screen; without it the view turns
/// about its target and the start moves.
#[test]
fn orbiting_about_the_selection_keeps_the_selected_start_in_place() {
    let mut h = head("orbit-selection");
    pull_nose(&mut h);
    let start_px = |h: &Harness<'_, StudioApp>| {
        let s = h.state().document().expect("open").controls.deformations[0].starts[0];
        let (cam, size, _, _) = h.state().viewport_camera().expect("open");
        cam.project(s.as_vec3(), size).expect("in view").0
    };
    let orbit_drag = |h: &mut Harness<'_, StudioApp>| {
        let (_, size, _, _) = h.state().viewport_camera().expect("open");
        let from = screen(h, Vec2::new(size[0] as f32 * 0.6, size[1] as f32 * 0.6));
        let to = from + egui::vec2(120.0, 10.0);
        // Alt+left drag orbits (as a right drag does).
        let button = |pos, pressed| egui::Event::PointerButton {
            pos,
            button: egui::PointerButton::Primary,
            pressed,
            modifiers: egui::Modifiers::ALT,
        };
        h.event(egui::Event::ModifiersChanged(egui::Modifiers::ALT));
        h.event(egui::Event::PointerMoved(from));
        h.step();
        h.event(button(from, true));
        h.step();
        h.event(egui::Event::PointerMoved(from + egui::vec2(15.0, 5.0)));
        h.step();
        h.event(egui::Event::PointerMoved(to));
        h.step();
        h.event(button(to, false));
        h.event(egui::Event::ModifiersChanged(egui::Modifiers::NONE));
        h.step();
    };
    let before = start_px(&h);
    orbit_drag(&mut h);
    assert!(
        start_px(&h).distance(before) > 5.0,
        "about the target, the start moves"
    );
    h.get_by_label("View").click();
    h.run_steps(3);
    h.get_by_label("Orbit about the selection").click();
    h.run_steps(1);
    // Closed by clicking its title again (Esc would also clear the
    // selection once the menu is closed).
    if h.query_by_label("Orbit about the selection").is_some() {
        h.get_by_label("View").click();
        h.run_steps(2);
    }
    assert_eq!(h.state().document().expect("open").selection.0.len(), 1);
    let before = start_px(&h);
    orbit_drag(&mut h);
    let after = start_px(&h);
    assert!(after.distance(before) < 1.0, "{before} -> {after}");
}

/// Issue 23 ("edits that stay on the connected surface"): a layer whose
/// region is "along the surface" previews in the studio (the region is
/// measured on the mesh's triangles) and moves fewer vertices than the
/// same edit over the whole mesh, the nose included.
#[test]
fn a_layer_along_the_surface_moves_only_what_it_reaches() {
    let mesh = csrbf_mesh::read(&model("cgal_head.off")).expect("the head");
    let moved = |region: &str, test: &str| {
        let (h, tip, diag) = head_pulled(test, (0.5, 0.05), region);
        let frame = h.state().preview_frame().expect("a frame");
        assert!(frame.error.is_none(), "{:?}", frame.error);
        let shown = h.state().shown_positions().expect("shown").to_vec();
        let k = mesh.positions.iter().position(|p| *p == tip).expect("tip");
        assert!(shown[k].x < tip.x - 0.01 * diag as f32, "the nose moved");
        (mesh.positions.iter().zip(&shown))
            .filter(|(a, b)| a.distance(**b) > 1e-6 * diag as f32)
            .count()
    };
    let diag = mesh.diagonal() as f64;
    let all = moved("", "surface-all");
    let along = moved(
        &format!(
            r#""region": {{"connected": {{"distance": {}}}}},"#,
            0.1 * diag
        ),
        "surface-along",
    );
    assert!(along * 2 < all, "{along} of {all}");
}

/// The trial after issue 23: a region's falloff is shown and edited in the
/// studio (a file's falloff opened as "other", and an edge without one
/// tears: the elephant's leg stretched 5.95x at the seam).
#[test]
fn a_regions_falloff_is_shown_and_edited() {
    let (mut h, _, diag) = head_pulled(
        "falloff",
        (0.5, 0.05),
        r#""region": {"connected": {"distance": 0.2}, "falloff": 0.05},"#,
    );
    let region = |h: &Harness<'_, StudioApp>| {
        h.state().document().expect("open").controls.deformations[0]
            .region
            .clone()
    };
    let kind = h.get_by_role_and_label(Role::ComboBox, "region").value();
    assert_eq!(kind.as_deref(), Some("along the surface"));
    let shown = h.get_by_role_and_label(Role::SpinButton, "falloff").value();
    assert_eq!(
        shown.as_deref().and_then(|v| v.parse::<f64>().ok()),
        Some(0.05)
    );
    // 0: a hard cut, the region alone.
    h.get_by_role_and_label(Role::SpinButton, "falloff")
        .set_value_accesskit(0.0);
    settle(&mut h);
    assert!(
        matches!(region(&h), csrbf::Region::Connected { .. }),
        "{}",
        region(&h)
    );
    // A width: a falloff about the same region.
    let width = (0.02 * diag * 1e4).round() / 1e4;
    h.get_by_role_and_label(Role::SpinButton, "falloff")
        .set_value_accesskit(width);
    settle(&mut h);
    match region(&h) {
        csrbf::Region::Falloff { inner, width: w } => {
            assert!(matches!(*inner, csrbf::Region::Connected { .. }));
            assert!((w - width).abs() < 1e-9, "{w} vs {width}");
        }
        other => panic!("no falloff: {other}"),
    }
}

/// Issue 39: warnings number layers and controls as the panel and the
/// control file's JSON paths do, from 0 (issue 23 had the panel count from
/// 1 while the CLI counted from 0).
#[test]
fn warnings_number_layers_and_controls_as_the_panel_does() {
    let dir = state_dir("warn-numbers-files");
    let controls = dir.join("far.json");
    std::fs::write(
        &controls,
        r#"{"radius": 0.5, "controls": [
            {"from": [0, 0, 0], "to": [0, 0, 0]},
            {"from": [900, 900, 900], "to": [901, 900, 900]}]}"#,
    )
    .expect("write");
    let mut h = open(
        Args {
            mesh: Some(model("cgal_head.off")),
            controls: Some(controls),
        },
        "warn-numbers",
    );
    settle(&mut h);
    let shown = h.get_by_label_contains("start(s) lie farther than R");
    let text = format!("{shown:?}");
    // Both starts are off the head: the CLI says "deformation 0" and
    // "controls 0, 1", the panel "layer 0" and "controls 0, 1".
    assert!(
        text.contains("layer 0: ") && text.contains("controls 0, 1"),
        "{text}"
    );
}

/// Issue 23, bug 1: every way the Picker writes a file reads back to what it
/// shows: the deformed mesh (OBJ, PLY, glTF) through the mesh reader, the
/// fitted `.csrbf` through `csrbf apply`'s path, and a layer with no vector
/// yet (work in progress) through the control file's parser.
#[test]
fn every_file_the_picker_writes_reads_back_to_what_it_shows() {
    let mut h = head("writes");
    pull_nose(&mut h);
    let dir = state_dir("writes-out");
    let shown = h.state().shown_positions().expect("open").to_vec();
    let doc = h.state().document().expect("open").clone();
    let diag = doc.diagonal() as f32;
    for name in ["nose.obj", "nose.ply", "nose.glb"] {
        let path = dir.join(name);
        h.state_mut().export_mesh(&path);
        h.run_steps(1);
        assert!(h.state().message().is_none(), "{:?}", h.state().message());
        let back = csrbf_mesh::read(&path).expect("the mesh reader takes it");
        assert_eq!(back.positions.len(), shown.len(), "{name}");
        for (a, b) in back.positions.iter().zip(&shown) {
            assert!(a.distance(*b) <= 1e-6 * diag, "{name}: {a} vs {b}");
        }
    }
    let fitted = dir.join("nose.csrbf");
    h.state_mut().export_fitted(&fitted);
    h.run_steps(1);
    let replay = csrbf_edit::apply::load_replay(&fitted).expect("apply reads it");
    let again = csrbf::compose(&doc.mesh.positions, &replay.stages, replay.combine).expect("apply");
    for (a, b) in again.iter().zip(&shown) {
        assert!(a.distance(*b) <= 1e-6 * diag, "csrbf: {a} vs {b}");
    }
    // A layer added and left empty is saved, read back, and moves nothing.
    h.get_by_label("Add layer").click();
    h.run_steps(2);
    let controls = dir.join("wip.json");
    h.state_mut().save_to(&controls);
    h.run_steps(1);
    let file = ControlFile::parse(&std::fs::read_to_string(&controls).expect("saved"))
        .expect("the CLI's parser reads it");
    assert_eq!(file.deformations.len(), 2);
    assert!(file.deformations[1].starts.is_empty());
    let mut mesh = (*doc.mesh).clone();
    csrbf_edit::apply::deform_mesh(&mut mesh, &file, 1.0).expect("deform");
    for (a, b) in mesh.positions.iter().zip(&shown) {
        assert!(a.distance(*b) <= 1e-6 * diag, "wip: {a} vs {b}");
    }
}

/// Issue 23 (diagnostics beyond folds): a nose pulled far with a small
/// radius is reported as stretched in the panel (the faces past the limit
/// outlined in magenta), with its largest stretch.
#[test]
fn a_long_pull_is_reported_as_stretched() {
    let (h, _, _) = head_pulled("stretch", (0.08, 0.3), "");
    let d = h
        .state()
        .preview_frame()
        .and_then(|f| f.diagnostics.clone())
        .expect("diagnosed");
    assert!(
        !d.stretched.is_empty() && d.largest_stretch > d.stretch_limit,
        "{d:?}"
    );
    h.get_by_label_contains("(outlined in magenta)");
    h.get_by_label_contains(&format!("largest stretch {:.2}x", d.largest_stretch));
}

/// The head opened with one control vector from its nose tip pulled along
/// -X by `pull` of its diagonal, a radius of `radius` of its diagonal and
/// `extra` keys (`"region": ...,`) in the control file; with the tip and the
/// diagonal.
fn head_pulled(
    test: &str,
    (radius, pull): (f64, f64),
    extra: &str,
) -> (Harness<'static, StudioApp>, Vec3, f64) {
    let mesh = csrbf_mesh::read(&model("cgal_head.off")).expect("the head");
    let tip = mesh
        .positions
        .iter()
        .copied()
        .min_by(|a, b| a.x.total_cmp(&b.x))
        .expect("vertices");
    let diag = mesh.diagonal() as f64;
    let controls = state_dir(&format!("{test}-files")).join("pull.json");
    std::fs::write(
        &controls,
        format!(
            r#"{{"radius": {}, {extra} "controls": [{{"from": [{}, {}, {}], "to": [{}, {}, {}]}}]}}"#,
            radius * diag,
            tip.x,
            tip.y,
            tip.z,
            tip.x as f64 - pull * diag,
            tip.y,
            tip.z
        ),
    )
    .expect("write");
    let mut h = open(
        Args {
            mesh: Some(model("cgal_head.off")),
            controls: Some(controls),
        },
        test,
    );
    settle(&mut h);
    (h, tip, diag)
}

/// Issue 23 (diagnostics beyond folds): the preview checks the faces an
/// edit made pass through each other, as `csrbf deform` does; a gentle pull
/// makes none, and the panel says so.
#[test]
fn the_preview_checks_for_faces_passing_through_each_other() {
    let mut h = head("crossing");
    pull_nose(&mut h);
    let d = h
        .state()
        .preview_frame()
        .and_then(|f| f.diagnostics.clone())
        .expect("diagnosed");
    assert_eq!(d.self_intersections.as_deref(), Some(&[][..]));
    h.get_by_label("no face passes through another");
}

/// The bundled Suzanne in a window tall enough for the side panel's handle
/// section without scrolling.
fn suzanne_tall(test: &str) -> Harness<'static, StudioApp> {
    open_sized(
        Args {
            mesh: Some(model("assimp_Suzanne_248.obj")),
            controls: None,
        },
        test,
        [1280.0, 1400.0],
    )
}

/// Issue 42: Mirror > Plane reflects across the model's own plane of
/// symmetry of any orientation, and the image of a start on the surface is
/// put on the surface, as the edit layer's mirror says.
#[test]
fn mirror_across_the_found_plane_puts_the_image_on_the_surface() {
    let mesh = csrbf_mesh::read(&model("cgal_head.off")).expect("the head");
    let plane = csrbf_edit::symmetry::find_plane(&mesh.positions).expect("a plane");
    let far = (mesh.positions.iter())
        .map(|p| p.as_dvec3())
        .max_by(|a, b| plane.distance(*a).total_cmp(&plane.distance(*b)))
        .expect("vertices");
    let dir = state_dir("mirror-plane-files");
    let controls = dir.join("cheek.json");
    let to = far + csrbf::glam::DVec3::new(0.0, 0.5, 0.0);
    std::fs::write(
        &controls,
        format!(
            r#"{{"radius": 4, "controls": [{{"from": [{}, {}, {}], "to": [{}, {}, {}]}}]}}"#,
            far.x, far.y, far.z, to.x, to.y, to.z
        ),
    )
    .expect("write");
    let mut h = open(
        Args {
            mesh: Some(model("cgal_head.off")),
            controls: Some(controls),
        },
        "mirror-plane",
    );
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::A);
    h.run_steps(2);
    let want = csrbf_studio::Command::mirror_across(h.state().document().expect("open"), &plane)
        .expect("an image");
    h.get_by_label("Plane").click();
    h.run_steps(2);
    settle(&mut h);
    let doc = h.state().document().expect("open");
    let starts = &doc.controls.deformations[0].starts;
    assert_eq!(starts.len(), 2, "{}", h.state().status());
    let csrbf_studio::Command::Batch(b) = &want.command else {
        panic!("a batch")
    };
    let csrbf_studio::Command::Insert { start, .. } = b[0] else {
        panic!("an insert")
    };
    assert_eq!(starts[1], start);
    let bvh = csrbf_mesh::Bvh::new(&mesh.positions, &mesh.faces.triangles());
    let off = bvh
        .nearest(&mesh.positions, start.as_vec3())
        .expect("a face")
        .distance as f64;
    assert!(
        off < 1e-4 * mesh.diagonal() as f64,
        "{start} is {off} off the surface"
    );
    assert!(
        h.state()
            .status()
            .contains("Mirrored 1 control vector across the plane through")
    );
}

/// Writes a control file and opens it on the studio's mesh; its path.
fn write_and_open(h: &mut Harness<'_, StudioApp>, path: &Path, text: &str) -> PathBuf {
    std::fs::write(path, text).expect("write");
    h.state_mut().open_controls(path);
    settle(h);
    path.to_path_buf()
}

/// A volume mesh opens in the Picker by its boundary (vertex i is node i):
/// Export to a volume format writes every node moved as `csrbf deform`
/// moves it, the boundary where the viewport shows it and every cell
/// checked; to a surface format, the boundary; a surface mesh is not
/// written as a volume. A morph that turns cells inside out says so.
#[test]
fn a_volume_mesh_is_edited_by_its_boundary_and_exported_morphed() {
    let volume_path = csrbf_testkit::root().join("assets/volume/sphere_in_box.msh");
    let mut h = open(
        Args {
            mesh: Some(volume_path.clone()),
            controls: None,
        },
        "volume",
    );
    assert!(h.state().message().is_none(), "{:?}", h.state().message());
    let volume = csrbf_mesh::volume::read(&volume_path).expect("read");
    let doc = h.state().document().expect("open");
    assert_eq!(doc.mesh.positions.len(), volume.points.len());
    assert_eq!(doc.mesh.faces.len(), volume.boundary().len());
    assert!(
        h.state()
            .status()
            .contains("a volume mesh of 712 nodes and 2898 3D cells")
            && !h.state().status().contains("  "),
        "{}",
        h.state().status()
    );
    // A box face's middle pushed in a little.
    let dir = state_dir("volume-out");
    let controls = write_and_open(
        &mut h,
        &dir.join("push.json"),
        r#"{"radius": 0.9, "controls": [{"from": [1, 0, 0], "to": [0.9, 0.05, 0]}]}"#,
    );
    assert!(h.state().message().is_none(), "{:?}", h.state().message());
    let shown = h.state().shown_positions().expect("open").to_vec();
    let out = dir.join("pushed.vtu");
    h.state_mut().export_mesh(&out);
    h.run_steps(1);
    assert!(h.state().message().is_none(), "{:?}", h.state().message());
    assert!(
        h.state().status().contains("pushed.vtu")
            && h.state().status().contains("; 0 cell(s) inside out"),
        "{}",
        h.state().status()
    );
    let back = csrbf_mesh::volume::read(&out).expect("a volume file");
    assert_eq!(back.points.len(), volume.points.len());
    assert_eq!(back.cells.len(), volume.cells.len());
    let (moved, _) = csrbf_edit::volume::VolumeMorph::read(&controls)
        .expect("a morph")
        .run(&volume, 1.0, false, &mut |_| {})
        .expect("deform's morph");
    let diag = h.state().document().expect("open").diagonal() as f64;
    let mut on_boundary = vec![false; volume.points.len()];
    for f in volume.boundary() {
        for v in f {
            on_boundary[v as usize] = true;
        }
    }
    let mut moved_nodes = 0;
    for (i, p) in back.points.iter().enumerate() {
        assert!(
            p.distance(moved[i]) <= 1e-9 * diag,
            "node {i}: {p} vs {}",
            moved[i]
        );
        if on_boundary[i] {
            let s = shown[i].as_dvec3();
            assert!(
                p.distance(s) <= 1e-5 * diag,
                "node {i}: {p} exported, {s} shown"
            );
        }
        moved_nodes += usize::from(p.distance(volume.points[i]) > 1e-6);
    }
    assert!(
        moved_nodes > 10 && moved_nodes < volume.points.len(),
        "{moved_nodes}"
    );
    // A surface format: the boundary, said to be one.
    let surface = dir.join("pushed.obj");
    h.state_mut().export_mesh(&surface);
    h.run_steps(1);
    assert!(h.state().message().is_none(), "{:?}", h.state().message());
    assert!(
        h.state().status().contains("the volume's boundary faces"),
        "{}",
        h.state().status()
    );
    assert_eq!(
        csrbf_mesh::read(&surface).expect("a mesh").positions.len(),
        volume.points.len()
    );
    // Too far for its radius: cells turn inside out, and the export says so.
    write_and_open(
        &mut h,
        &dir.join("far.json"),
        r#"{"radius": 0.5, "controls": [{"from": [1, 0, 0], "to": [0.2, 0, 0]}]}"#,
    );
    h.state_mut().export_mesh(&dir.join("far.vtu"));
    h.run_steps(2);
    let (title, text) = h.state().message().expect("a dialog").clone();
    assert!(title.contains("inside out"), "{title}: {text}");
    // Written all the same, and said to be.
    assert!(
        text.contains("Exported") && text.contains("far.vtu"),
        "{text}"
    );
    assert_eq!(
        csrbf_mesh::volume::read(&dir.join("far.vtu"))
            .expect("written")
            .points
            .len(),
        volume.points.len()
    );
    h.get_by_label("OK").click();
    h.run_steps(1);
    // A surface mesh is not written as a volume mesh.
    let ctx = h.ctx.clone();
    h.state_mut().open_mesh(&ctx, &model("cgal_head.off"));
    h.run_steps(2);
    if h.state().message().is_some() {
        h.get_by_label("Discard").click();
        h.run_steps(3);
    }
    assert!(
        h.state()
            .document()
            .expect("open")
            .mesh_path
            .ends_with("cgal_head.off")
    );
    h.state_mut().export_mesh(&dir.join("head.vtu"));
    h.run_steps(1);
    let (_, text) = h.state().message().expect("a dialog").clone();
    assert!(
        text.contains("is a surface mesh") && text.contains(".obj"),
        "{text}"
    );
    assert!(!dir.join("head.vtu").exists());
}
