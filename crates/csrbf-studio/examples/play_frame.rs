//! Playback in the Composer, without a window: for each scene, the time to
//! open it (read, check, fit, bind) and the time of one frame as the studio
//! plays it (the scene at the next time, normals, and the picture through
//! `csrbf-render` at the viewport's size, one sample per pixel as on a
//! software rasteriser, waited for). The four demo scenes, and a scene of
//! the 126k-vertex subdivided Suzanne when `../shared/models` has it.
//!
//! `OUT=DIR` keeps the scene files (to play them in the real app:
//! `scripts/playback_figures.sh`).
//!
//! ```sh
//! cargo run --release -p csrbf-studio --example play_frame
//! ```

mod common;
use common::{median, ms, target};

use std::path::{Path, PathBuf};
use std::time::Instant;

use csrbf_anim::{Frame, Scene};
use csrbf_render::{SceneOptions, SceneRenderer};

/// The studio's viewport in a 1280x800 window (the side panel and the
/// timeline take the rest).
const SIZE: [u32; 2] = [920, 520];

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::var("OUT").map(PathBuf::from).unwrap_or_else(|_| {
        std::env::temp_dir().join(format!("csrbf-play-{}", std::process::id()))
    });
    std::fs::create_dir_all(&out)?;
    let mut scenes = Vec::new();
    for name in csrbf_anim::demos::DEMOS {
        let demo = csrbf_anim::demos::demo(name).ok_or("demo")?;
        scenes.push(demo.write(&out, name)?);
    }
    let suzanne = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/models/assimp_SuzanneSubdiv_252.obj");
    if suzanne.exists() {
        scenes.push(suzanne_scene(&suzanne, &out)?);
    } else {
        eprintln!("{} is missing: no 126k scene", suzanne.display());
    }
    println!("| scene | vertices | open | scene at a time | frame (scene + picture) | fps |");
    println!("|---|---|---|---|---|---|");
    for path in scenes {
        let t = Instant::now();
        let scene = Scene::load(&path)?;
        let open = t.elapsed();
        let vertices: usize = scene.objects.iter().map(|o| o.mesh.positions.len()).sum();
        let mut r = SceneRenderer::with_samples(&scene, SIZE[0], SIZE[1], 1)?;
        let target = target(&r);
        let mut frame = Frame::default();
        let fps = scene.file.fps;
        let n = scene.frame_count().min(90);
        let mut times = Vec::new();
        let mut scene_times = Vec::new();
        for k in 0..n + 3 {
            let t = Instant::now();
            scene.frame_into(k as f64 / fps, &mut frame);
            let computed = t.elapsed();
            r.draw_frame_into(
                &scene,
                &frame,
                SceneOptions::default(),
                &[],
                &[],
                &[],
                &[],
                &target,
            );
            let _ = r
                .renderer()
                .device()
                .poll(wgpu::PollType::wait_indefinitely());
            // The first frames upload buffers and compile pipelines.
            if k >= 3 {
                times.push(ms(t.elapsed()));
                scene_times.push(ms(computed));
            }
        }
        let m = median(times);
        println!(
            "| {} | {vertices} | {:.0} ms | {:.1} ms | {m:.1} ms | {:.0} |",
            path.file_name().unwrap_or_default().to_string_lossy(),
            ms(open),
            median(scene_times),
            1e3 / m
        );
    }
    Ok(())
}

/// A scene of the 126k-vertex Suzanne: it travels along three keys, turns,
/// and a deformation of 40 control vectors phases in and out.
fn suzanne_scene(mesh: &Path, out: &Path) -> Result<PathBuf, Box<dyn std::error::Error>> {
    let m = csrbf_mesh::read(mesh)?;
    let (lo, hi) = m.bounds().ok_or("empty")?;
    let diag = (hi - lo).length() as f64;
    let mut controls = Vec::new();
    for (k, p) in m
        .positions
        .iter()
        .step_by(m.positions.len() / 40)
        .take(40)
        .enumerate()
    {
        let d = if k % 4 == 0 { 0.05 * diag } else { 0.0 };
        controls.push(format!(
            r#"{{"from": [{}, {}, {}], "to": [{}, {}, {}]}}"#,
            p.x,
            p.y,
            p.z,
            p.x,
            p.y as f64 + d,
            p.z
        ));
    }
    let c = out.join("suzanne126k.controls.json");
    std::fs::write(
        &c,
        format!(
            r#"{{"radius": {}, "kernel": "c2", "controls": [{}]}}"#,
            0.2 * diag,
            controls.join(",")
        ),
    )?;
    let d = diag;
    let scene = format!(
        r#"{{"duration": 4, "fps": 30, "size": [1280, 720],
  "camera": {{"eye": [0, {e1}, {e2}], "target": [0, 0, 0]}},
  "objects": [{{"name": "suzanne", "mesh": {mesh:?},
    "parts": [{{"name": "all", "color": [0.7, 0.5, 0.3],
      "deformations": [{{"controls": "suzanne126k.controls.json",
        "phase": [{{"time": 0, "phase": 0}}, {{"time": 2, "phase": 1}}, {{"time": 4, "phase": 0}}]}}]}}],
    "trajectory": [{{"time": 0, "position": [{a}, 0, 0]}}, {{"time": 2, "position": [0, {b}, 0]}}, {{"time": 4, "position": [{c}, 0, 0]}}],
    "orientation": [{{"time": 0, "euler": [0, -30, 0]}}, {{"time": 4, "euler": [0, 30, 0]}}]}}]}}"#,
        e1 = 0.3 * d,
        e2 = 2.2 * d,
        mesh = mesh.display().to_string(),
        a = -0.3 * d,
        b = 0.1 * d,
        c = 0.3 * d,
    );
    let path = out.join("suzanne126k.scene.json");
    std::fs::write(&path, scene)?;
    Ok(path)
}
