//! The viewport's picture, drawn by the app's own wgpu path (the
//! `egui_wgpu` callback with `csrbf-render` inside) on the software Vulkan
//! driver: the head at rest, deformed with its control vectors, and folded
//! with the turned-over faces outlined in red. Compared to the PNGs in
//! `tests/snapshots/` with kittest's tolerance (regenerate them with
//! `UPDATE_SNAPSHOTS=1 cargo test -p csrbf-studio -- snapshots`).

use std::path::{Path, PathBuf};
use std::time::Duration;

use csrbf_studio::app::{Args, StudioApp};
use eframe::egui;
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;

fn head() -> PathBuf {
    csrbf_testkit::model("cgal_head.off")
}

/// The app on the head with `controls` (JSON text) opened, settled, its
/// viewport drawn; the viewport's pixels only (the status bar's timings
/// change from run to run).
fn viewport(name: &str, controls: Option<&str>) -> (image::RgbaImage, Harness<'static, StudioApp>) {
    let dir = csrbf_testkit::scratch(env!("CARGO_TARGET_TMPDIR"), &format!("studio-snap-{name}"));
    let controls = controls.map(|text| {
        let p = dir.join("controls.json");
        std::fs::write(&p, text).expect("write");
        p
    });
    let args = Args {
        mesh: Some(head()),
        controls,
    };
    let mut h = Harness::builder()
        .with_size([1000.0, 640.0])
        .wgpu()
        .build_eframe(move |cc| StudioApp::with_state_dir(cc, args, Some(dir)));
    h.run_steps(2);
    assert!(h.state_mut().settle(Duration::from_secs(60)));
    h.run_steps(2);
    let image = h.render().expect("the wgpu test renderer draws");
    let (_, size, corner, ppp) = h.state().viewport_camera().expect("open");
    let (x, y) = ((corner.x * ppp) as u32, (corner.y * ppp) as u32);
    let view = image::imageops::crop_imm(&image, x, y, size[0], size[1]).to_image();
    (view, h)
}

/// Control vectors from the head's nose tip (the vertex farthest along -X).
fn nose_file(pull: f64, radius: f64) -> String {
    let mesh = csrbf_mesh::read(&head()).expect("the bundled head");
    let tip = mesh
        .positions
        .iter()
        .copied()
        .min_by(|a, b| a.x.total_cmp(&b.x))
        .expect("vertices");
    format!(
        r#"{{"radius": {radius}, "kernel": "c2",
 "controls": [{{"from": [{}, {}, {}], "to": [{}, {}, {}]}}]}}"#,
        tip.x,
        tip.y,
        tip.z,
        tip.x as f64 - pull,
        tip.y,
        tip.z
    )
}

/// A shove along the surface, past the fold-free bound: the side of the
/// head nearest the camera (largest Z) pushed up by 0.8 R.
fn shove_file() -> String {
    let mesh = csrbf_mesh::read(&head()).expect("the bundled head");
    let p = mesh
        .positions
        .iter()
        .copied()
        .max_by(|a, b| a.z.total_cmp(&b.z))
        .expect("vertices");
    format!(
        r#"{{"radius": 2.0, "kernel": "c2",
 "controls": [{{"from": [{}, {}, {}], "to": [{}, {}, {}]}}]}}"#,
        p.x,
        p.y,
        p.z,
        p.x,
        p.y as f64 + 1.6,
        p.z
    )
}

fn count(img: &image::RgbaImage, f: impl Fn([u8; 4]) -> bool) -> usize {
    img.pixels().filter(|p| f(p.0)).count()
}

#[test]
fn the_head_at_rest_is_drawn_in_the_viewport() {
    let (view, _) = viewport("rest", None);
    // The model covers the middle of the picture, lit, over the background.
    let centre = view.get_pixel(view.width() / 2, view.height() / 2).0;
    let bg = view.get_pixel(3, 3).0;
    assert_ne!(centre, bg, "the centre shows the model");
    assert!(centre[0] > 120, "lit skin: {centre:?}");
    egui_kittest::image_snapshot(&view, "head_rest");
}

#[test]
fn the_deformed_head_is_drawn_with_its_control_vectors() {
    let (rest, _) = viewport("rest-for-deformed", None);
    let (view, h) = viewport("deformed", Some(&nose_file(3.0, 4.0)));
    let frame = h.state().preview_frame().expect("fitted");
    assert!(frame.error.is_none(), "{:?}", frame.error);
    // The pulled nose covers background pixels the rest head did not.
    let skin = |p: [u8; 4]| p[0] > 150 && p[1] > 110 && p[2] > 80 && p[0] as i32 > p[2] as i32 + 20;
    assert!(
        count(&view, skin) > count(&rest, skin) + 50,
        "the nose grew"
    );
    // The arrow (orange: linear (1, 0.55, 0.1), sRGB about (255, 196, 89))
    // is drawn over the surface.
    let orange = |p: [u8; 4]| {
        p[0] > 220 && (150..215).contains(&p[1]) && p[2] < 130 && p[0] as i32 - p[2] as i32 > 120
    };
    assert!(
        count(&view, orange) > 5,
        "the control vector's arrow is drawn"
    );
    egui_kittest::image_snapshot(&view, "head_deformed");
}

#[test]
fn turned_over_faces_are_outlined_in_red() {
    let (view, h) = viewport("folded", Some(&shove_file()));
    let d = h
        .state()
        .preview_frame()
        .and_then(|f| f.diagnostics.clone())
        .expect("diagnosed");
    assert!(!d.flipped.is_empty(), "this edit folds: {d:?}");
    // Linear (1, 0.1, 0.1): sRGB about (255, 89, 89).
    let red = |p: [u8; 4]| p[0] > 200 && p[1] < 120 && p[2] < 120;
    assert!(count(&view, red) > 10, "the flipped faces are outlined");
    egui_kittest::image_snapshot(&view, "head_folded");
}

/// Issue 23, bug 2: after a scene was shown in the Composer, the Picker's
/// viewport draws its mesh again (it was black: the Composer's picture took
/// the one GPU slot, and the Picker's mesh had been handed over once).
#[test]
fn the_pickers_viewport_draws_its_mesh_again_after_the_composer() {
    let (before, mut h) = viewport("picker-after-composer", None);
    let scene = csrbf_testkit::root().join("assets/scenes/face.scene.json");
    h.state_mut().open_scene(&scene);
    h.run_steps(3);
    assert_eq!(h.state().mode(), csrbf_studio::app::Mode::Compose);
    // The Composer's picture is drawn (a harness draws only when asked).
    h.render().expect("the Composer draws");
    h.get_by_label("Picker").click();
    h.run_steps(3);
    assert_eq!(h.state().mode(), csrbf_studio::app::Mode::Pick);
    let image = h.render().expect("the wgpu test renderer draws");
    let (_, size, corner, ppp) = h.state().viewport_camera().expect("open");
    let (x, y) = ((corner.x * ppp) as u32, (corner.y * ppp) as u32);
    let after = image::imageops::crop_imm(&image, x, y, size[0], size[1]).to_image();
    let centre = after.get_pixel(after.width() / 2, after.height() / 2).0;
    assert!(centre[0] > 120, "the head is drawn, lit: {centre:?}");
    let (mean, far) = difference(&before, &after, 0);
    assert!(mean < 2.0 && far < 0.01, "the same picture: {mean} {far}");
}

/// Mean absolute difference of two pictures' RGB (0..255), and the share of
/// pixels that differ by more than 60 in some channel; the top `skip` rows
/// (the viewport's time label) are left out.
fn difference(a: &image::RgbaImage, b: &image::RgbaImage, skip: u32) -> (f64, f64) {
    assert_eq!(a.dimensions(), b.dimensions());
    let (mut sum, mut far, mut n) = (0u64, 0usize, 0usize);
    for (x, y, p) in a.enumerate_pixels() {
        if y < skip {
            continue;
        }
        let q = b.get_pixel(x, y);
        let d: Vec<u32> = (0..3).map(|k| p.0[k].abs_diff(q.0[k]) as u32).collect();
        sum += d.iter().map(|&v| v as u64).sum::<u64>();
        far += usize::from(d.iter().any(|&v| v > 60));
        n += 1;
    }
    (sum as f64 / (3 * n) as f64, far as f64 / n as f64)
}

/// Issue 9: what the Composer shows through the scene camera is what
/// `csrbf animate` renders (`csrbf_render::movie::render_movie`, its frame
/// loop) at the same times, within a tolerance for edges (the viewport draws
/// one sample per pixel on a software rasteriser, the movie four).
#[test]
fn the_composer_shows_through_the_scene_camera_what_csrbf_animate_renders() {
    let assets = csrbf_testkit::root().join("assets");
    let scene_path = assets.join("scenes/face.scene.json");
    let dir = csrbf_testkit::scratch(env!("CARGO_TARGET_TMPDIR"), "studio-snap-compose");
    let args = Args {
        mesh: Some(scene_path.clone()),
        controls: None,
    };
    let state = dir.join("state");
    let mut h = Harness::builder()
        .with_size([1000.0, 800.0])
        .wgpu()
        .build_eframe(move |cc| StudioApp::with_state_dir(cc, args, Some(state)));
    h.run_steps(2);
    h.key_press(egui::Key::C);
    h.run_steps(2);
    let times = [0.0, 1.2, 2.4];
    let mut shown = Vec::new();
    let mut size = [0, 0];
    for &t in &times {
        h.state_mut().set_playhead(t);
        h.run_steps(3);
        let image = h.render().expect("the wgpu test renderer draws");
        let (_, s, gate) = h.state().compose_camera().expect("a scene");
        let ppp = s[0] as f32 / gate.width();
        let (x, y) = (
            (gate.min.x * ppp).round() as u32,
            (gate.min.y * ppp).round() as u32,
        );
        size = s;
        shown.push(image::imageops::crop_imm(&image, x, y, s[0], s[1]).to_image());
    }
    // The movie at those times and the viewport's size, as PNG frames.
    let scene = csrbf_anim::Scene::load(&scene_path).expect("face");
    let mut options = csrbf_render::movie::MovieOptions::of(&scene);
    options.size = size;
    options.from = times[0];
    options.to = times[2];
    options.fps = 1.0 / (times[1] - times[0]);
    let frames = dir.join("frames");
    csrbf_render::movie::render_movie(&scene, &frames, options, &mut |_, _| true)
        .expect("the movie");
    for (k, view) in shown.iter().enumerate() {
        let png = frames.join(format!("frame_{k:05}.png"));
        let movie = png_image(&png);
        let (mean, far) = difference(view, &movie, 24);
        assert!(
            mean < 1.0 && far < 0.005,
            "t = {}: mean {mean:.2}, {:.2} % far",
            times[k],
            far * 100.0
        );
        // And the test can tell frames apart: another time differs more.
        let other = png_image(&frames.join(format!("frame_{:05}.png", usize::from(k == 0))));
        let (mean_other, far_other) = difference(view, &other, 24);
        eprintln!(
            "t = {}: mean {mean:.2}, {:.2} % far; against another time {mean_other:.2}, {:.2} %",
            times[k],
            far * 100.0,
            far_other * 100.0
        );
        assert!(
            far_other > 3.0 * far.max(0.002) && mean_other > mean,
            "t = {}: another time's frame differs by only {mean_other:.2} ({:.2} %)",
            times[k],
            far_other * 100.0
        );
    }
}

/// A PNG read by the scene's own texture reader.
fn png_image(path: &Path) -> image::RgbaImage {
    let t = csrbf_anim::load_texture(path).expect("a frame");
    image::RgbaImage::from_raw(t.width, t.height, t.rgba).expect("RGBA")
}
