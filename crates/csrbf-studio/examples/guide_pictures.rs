//! The guide's pictures of the studio, drawn by the app itself through
//! kittest's wgpu renderer (on whatever adapter wgpu finds: Mesa's software
//! Vulkan driver on a machine without a GPU), so they never go stale:
//!
//! - `studio.png`: the Picker on the bundled head, a control vector pulling
//!   its nose selected (its support sphere, the layer's parameters, the
//!   selection and the diagnostics);
//! - `composer.png`: the Composer on the fish demo's scene at 2.17 s, the
//!   duck's position key at 4 s selected (its path, the scene camera, the
//!   timeline with every track);
//! - `demos.png`: the four demos' posters as one picture (the fish with its
//!   control vectors), for the README.
//!
//! `scripts/pictures.sh` runs it after `csrbf demo all` has written the
//! demos' scenes and posters into DEMOS:
//!
//! ```sh
//! cargo run --release -p csrbf-studio --example guide_pictures -- DEMOS OUT
//! ```

use std::path::{Path, PathBuf};
use std::time::Duration;

use csrbf_studio::app::{Args, StudioApp};
use csrbf_studio_core::compose::Track;
use eframe::egui;
use egui_kittest::Harness;

type Error = Box<dyn std::error::Error>;

fn main() -> Result<(), Error> {
    let mut args = std::env::args_os().skip(1).map(PathBuf::from);
    let (Some(demos), Some(out)) = (args.next(), args.next()) else {
        return Err(
            "usage: guide_pictures DEMOS OUT (DEMOS: what `csrbf demo all --out DEMOS` wrote)"
                .into(),
        );
    };
    std::fs::create_dir_all(&out)?;
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    // A state folder of its own: no recent files, no recovery offered.
    let state = std::env::temp_dir().join(format!("csrbf-guide-pictures-{}", std::process::id()));
    let written = (|| -> Result<(), Error> {
        picker(
            &root,
            &demos,
            &state.join("picker"),
            &out.join("studio.png"),
        )?;
        composer(
            &demos.join("fish/fish.scene.json"),
            &state.join("composer"),
            &out.join("composer.png"),
        )?;
        montage(&demos, &out.join("demos.png"))
    })();
    let _ = std::fs::remove_dir_all(&state);
    written
}

/// The Picker on the head with one control vector pulling its nose
/// forward and up, selected.
fn picker(root: &Path, demos: &Path, state: &Path, out: &Path) -> Result<(), Error> {
    let head = root.join("assets/models/cgal_head.off");
    let mesh = csrbf_mesh::read(&head)?;
    let tip = mesh
        .positions
        .iter()
        .copied()
        .min_by(|a, b| a.x.total_cmp(&b.x))
        .ok_or("the head has no vertices")?;
    let controls = demos.join("head_nose.json");
    std::fs::write(
        &controls,
        format!(
            r#"{{"radius": 3.62, "kernel": "c2",
 "controls": [{{"from": [{}, {}, {}], "to": [{}, {}, {}]}}]}}"#,
            tip.x,
            tip.y,
            tip.z,
            tip.x - 2.7,
            tip.y + 1.0,
            tip.z
        ),
    )?;
    let args = Args {
        mesh: Some(head),
        controls: Some(controls),
    };
    let mut h = open(args, state, [1024.0, 640.0]);
    if !h.state_mut().settle(Duration::from_secs(60)) {
        return Err("the Picker's preview did not settle within 60 s".into());
    }
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::A);
    h.run_steps(4);
    if let Some((title, text)) = h.state().message() {
        return Err(format!("the Picker said {title}: {text}").into());
    }
    save(&mut h, out)
}

/// The Composer on `scene` at 2.17 s with the first object's third
/// position key selected.
fn composer(scene: &Path, state: &Path, out: &Path) -> Result<(), Error> {
    if !scene.is_file() {
        return Err(format!(
            "{}: no such scene (run `csrbf demo all --out DEMOS` first)",
            scene.display()
        )
        .into());
    }
    let args = Args {
        mesh: Some(scene.to_path_buf()),
        controls: None,
    };
    let mut h = open(args, state, [1280.0, 800.0]);
    if h.state().loaded_scene().is_none() {
        return Err(format!(
            "{}: the Composer did not open it: {}",
            scene.display(),
            h.state().status()
        )
        .into());
    }
    h.state_mut().select_key((0, Track::Position, 2));
    h.state_mut().set_playhead(2.167);
    h.run_steps(4);
    save(&mut h, out)
}

/// The app opened on `args` in a window of `size` points drawn by wgpu,
/// with its own state folder, its first frames run.
fn open(args: Args, state: &Path, size: [f32; 2]) -> Harness<'static, StudioApp> {
    let state = state.to_path_buf();
    let mut h = Harness::builder()
        .with_size(size)
        .wgpu()
        .build_eframe(move |cc| StudioApp::with_state_dir(cc, args, Some(state)));
    h.run_steps(2);
    h
}

/// The harness's picture as a PNG at `out`, on the colour the window is
/// cleared to: the app's panels leave it to the clear colour, which the
/// harness's renderer leaves transparent (its pixels are premultiplied).
fn save(h: &mut Harness<'_, StudioApp>, out: &Path) -> Result<(), Error> {
    let mut image = h.render().map_err(|e| format!("drawing the window: {e}"))?;
    let clear = h.ctx.global_style().visuals.panel_fill;
    for p in image.pixels_mut() {
        let keep = 255 - u16::from(p[3]);
        for (c, b) in p.0.iter_mut().zip([clear.r(), clear.g(), clear.b()]) {
            *c = (u16::from(*c) + (u16::from(b) * keep + 127) / 255).min(255) as u8;
        }
        p[3] = 255;
    }
    image.save(out)?;
    println!("guide_pictures: wrote {}", out.display());
    Ok(())
}

/// The demos' posters, two by two at three quarters of their size (the fish with its
/// control vectors).
fn montage(demos: &Path, out: &Path) -> Result<(), Error> {
    let posters = [
        "face/poster.png",
        "fish/poster_controls.png",
        "ball/poster.png",
        "brick/poster.png",
    ];
    let mut tiles = Vec::new();
    for p in posters {
        let path = demos.join(p);
        let image = image::open(&path).map_err(|e| format!("{}: {e}", path.display()))?;
        tiles.push(image.to_rgba8());
    }
    let (w, h) = (tiles[0].width() * 3 / 4, tiles[0].height() * 3 / 4);
    let mut sheet = image::RgbaImage::new(2 * w, 2 * h);
    for (k, tile) in tiles.iter().enumerate() {
        let small = image::imageops::resize(tile, w, h, image::imageops::FilterType::Triangle);
        image::imageops::replace(
            &mut sheet,
            &small,
            i64::from(w) * (k as i64 % 2),
            i64::from(h) * (k as i64 / 2),
        );
    }
    sheet.save(out)?;
    println!("guide_pictures: wrote {}", out.display());
    Ok(())
}
