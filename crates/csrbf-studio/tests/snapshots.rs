//! The viewport's picture, drawn by the app's own wgpu path (the
//! `egui_wgpu` callback with `csrbf-render` inside) on the software Vulkan
//! driver: the head at rest, deformed with its control vectors, and folded
//! with the turned-over faces outlined in red. Compared to the PNGs in
//! `tests/snapshots/` with kittest's tolerance (regenerate them with
//! `UPDATE_SNAPSHOTS=1 cargo test -p csrbf-studio --test snapshots`).

use std::path::{Path, PathBuf};
use std::time::Duration;

use csrbf_studio::app::{Args, StudioApp};
use egui_kittest::Harness;

fn head() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/models/cgal_head.off")
}

/// The app on the head with `controls` (JSON text) opened, settled, its
/// viewport drawn; the viewport's pixels only (the status bar's timings
/// change from run to run).
fn viewport(name: &str, controls: Option<&str>) -> (image::RgbaImage, Harness<'static, StudioApp>) {
    let dir = std::env::temp_dir().join(format!("csrbf-studio-snap-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp folder");
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
