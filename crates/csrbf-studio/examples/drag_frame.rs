//! Pointer move to frame drawn while dragging a destination, as the studio
//! does it: the edit, the engine's solve and evaluation, the normals, and the
//! picture at 1280x800 through `csrbf-render` (read back, so the GPU's work
//! is waited for: a slight overestimate of what the window shows). For big
//! meshes the same with the stand-in the studio draws while the model moves.
//! Also: opening the file to the first frame, and the longest frame the UI
//! draws while a full refit runs on the worker. The whole path in the real
//! window (the event loop, egui, the present) is `pointer_to_picture`'s.
//!
//! ```sh
//! cargo run --release -p csrbf-studio --example drag_frame -- assets/models/cgal_head.off
//! cargo run --release -p csrbf-studio --example drag_frame -- sphere:1000000
//! CONNECTED=0.1 cargo run --release -p csrbf-studio --example drag_frame -- sphere:100000
//! WRITE=sphere1m.ply cargo run --release -p csrbf-studio --example drag_frame -- sphere:1000000 1
//! ```

mod common;
use common::{median, ms, target};

use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

use csrbf::glam::{DVec3, Vec3};
use csrbf_mesh::StandIn;
use csrbf_render::{DrawOptions, Renderer, SceneRenderer, View, default_lights};
use csrbf_studio::{Command, Document, History, Live, Orbit, Preview, pick_surface};

const SIZE: [u32; 2] = [1280, 800];

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let arg = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "assets/models/cgal_head.off".into());
    let steps: usize = std::env::args()
        .nth(2)
        .and_then(|s| s.parse().ok())
        .unwrap_or(15);
    let opened = Instant::now();
    let (mesh, path) = match arg.strip_prefix("sphere:") {
        Some(n) => {
            // A triangulated UV sphere of about n vertices.
            let n: f64 = n.parse()?;
            let rings = (n / 2.0).sqrt().round().max(4.0) as u32;
            (
                csrbf_mesh::shapes::uv_sphere(0.4, rings, rings * 2),
                PathBuf::from(format!("sphere{}.ply", n as u64)),
            )
        }
        None => (csrbf_mesh::read(arg.as_ref())?, PathBuf::from(&arg)),
    };
    let read = opened.elapsed();
    // WRITE=FILE keeps the mesh (to open the same one in the studio).
    if let Ok(out) = std::env::var("WRITE") {
        csrbf_mesh::write(out.as_ref(), &mesh)?;
    }
    let triangles = mesh.faces.triangle_count();
    println!(
        "{}: {} vertices, {triangles} triangles (read {:.0} ms)",
        path.display(),
        mesh.positions.len(),
        ms(read)
    );

    // What opening does in the app: the tree, the scene's parts, the first frame.
    let (lo, hi) = mesh.bounds().ok_or("no vertices")?;
    let up = csrbf_mesh::guess_up(&mesh, &path).0;
    let orbit = Orbit::new(up, lo, hi, SIZE[0] as f32 / SIZE[1] as f32);
    let camera = orbit.camera();
    // As the studio: one sample per pixel on a software rasteriser or a big mesh.
    let samples = std::env::var("SAMPLES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1);
    let scene = csrbf_anim::still::mesh_scene(&path, mesh.clone(), None, 1.0, SIZE)?;
    let renderer = Renderer::with_samples(SIZE[0], SIZE[1], samples)?;
    let mut sr = SceneRenderer::on_renderer(&scene, renderer)?;
    drop(scene);
    let diag = mesh.diagonal() as f64;
    let mut doc = Document::new(mesh, path.clone(), diag * 0.1);
    let mut live = Live::new(&doc);
    let tris = live.triangles().to_vec();
    let stand_in = (triangles > csrbf_studio::app::BIG_MESH_TRIANGLES)
        .then(|| StandIn::new(&doc.mesh.positions, &tris));
    let mut normals = csrbf_mesh::triangle_vertex_normals(&doc.mesh.positions, &tris);
    let view = |overlay| View {
        camera,
        lights: default_lights(camera),
        background: [0.13, 0.14, 0.16],
        meshes: Vec::new(),
        lines: Vec::new(),
        overlay,
        options: DrawOptions::default(),
    };
    let full_frame = |sr: &mut SceneRenderer, p: &[Vec3], n: &[Vec3]| {
        sr.draw_object_into(&view(Vec::new()), 0, p, n, &target(sr));
        wait(sr);
    };
    full_frame(&mut sr, &doc.mesh.positions, &normals);
    println!(
        "open to first frame: {:.0} ms ({})",
        ms(opened.elapsed()),
        sr.renderer().adapter()
    );

    // A control vector at the surface under the viewport's centre.
    let hit = pick_surface(
        &camera,
        SIZE,
        csrbf_anim::Camera::centre_pixel(SIZE),
        &live,
        &doc.mesh.positions,
    )
    .ok_or("the centre of the view misses the model")?;
    let mut history = History::default();
    history.apply(&mut doc, Command::add(0, hit.rest, hit.rest))?;
    // CONNECTED=F: the layer's region follows the surface for F times the
    // diagonal from the start (the walk along the surface is cached).
    if let Some(f) = std::env::var("CONNECTED")
        .ok()
        .and_then(|f| f.parse::<f64>().ok())
    {
        doc.controls.deformations[0].region = csrbf::Region::Connected {
            distance: diag * f,
            from: csrbf::Origin::Starts,
        };
        println!("region: along the surface, {:.3} from the start", diag * f);
    }
    let t = Instant::now();
    live.update(&doc)?;
    println!(
        "first fit (one start, R 10 % of the diagonal): {:.1} ms",
        ms(t.elapsed())
    );

    let (right, _, _) = camera.basis();
    let mut runs: Vec<[f64; 3]> = Vec::new();
    let mut light_runs: Vec<[f64; 3]> = Vec::new();
    let mut engine: Vec<f64> = Vec::new();
    history.begin_drag();
    for k in 1..=steps {
        let goal = hit.rest + right.as_dvec3() * diag * 0.004 * k as f64;
        let t0 = Instant::now();
        history.apply(
            &mut doc,
            Command::SetTarget {
                layer: 0,
                index: 0,
                target: goal,
            },
        )?;
        live.update_positions(&doc)?;
        let engine_ms = ms(t0.elapsed());
        engine.push(engine_ms);
        if let Some(light) = &stand_in {
            // As the app: the stand-in's own normals; the full ones wait.
            let t3 = Instant::now();
            let (p, n) = light.shape(live.positions());
            sr.draw_stand_in_into(&view(Vec::new()), 0, &p, &n, &light.indices, &target(&sr));
            wait(&sr);
            let draw = ms(t3.elapsed());
            light_runs.push([engine_ms, draw, engine_ms + draw]);
        }
        let t0 = Instant::now();
        csrbf_mesh::triangle_vertex_normals_into(live.positions(), &tris, &mut normals);
        let t1 = Instant::now();
        full_frame(&mut sr, live.positions(), &normals);
        let t2 = Instant::now();
        runs.push([
            engine_ms + ms(t1 - t0),
            ms(t2 - t1),
            engine_ms + ms(t2 - t0),
        ]);
    }
    history.end_drag();
    let report = |name: &str, r: &[[f64; 3]]| {
        let col = |i: usize| median(r.iter().map(|x| x[i]).collect());
        let total = col(2);
        println!(
            "{name}: engine (+ full normals for the full mesh) {:.1} ms, draw {:.1} ms, pointer move to frame {:.1} ms = {:.1} fps (medians of {})",
            col(0),
            col(1),
            total,
            1e3 / total,
            r.len()
        );
    };
    println!(
        "engine alone (the edit, solve, evaluate): {:.1} ms (median)",
        median(engine.clone())
    );
    report("drag, full mesh", &runs);
    if !light_runs.is_empty() {
        report(
            &format!(
                "drag, stand-in of {} triangles",
                stand_in.as_ref().map_or(0, |s| s.indices.len() / 3)
            ),
            &light_runs,
        );
    }

    // A new start refits on the worker; the UI keeps drawing (the stand-in
    // for a big mesh) and polling. The longest of those frames is what a
    // person would see as a freeze.
    let mut preview = Preview::new(&doc, || {});
    preview.wait(Duration::from_secs(600));
    let far = doc.mesh.positions[doc.mesh.positions.len() / 3].as_dvec3();
    history.apply(
        &mut doc,
        Command::add(0, far, far + DVec3::splat(diag * 0.01)),
    )?;
    let t = Instant::now();
    preview.edit(&doc, true);
    let mut longest: f64 = 0.0;
    let mut frames = 0;
    let shown: Arc<Vec<Vec3>> = Arc::new(live.positions().to_vec());
    while !preview.is_settled() {
        let f0 = Instant::now();
        preview.poll();
        match &stand_in {
            Some(light) => {
                let (p, n) = light.shape(&shown);
                sr.draw_stand_in_into(&view(Vec::new()), 0, &p, &n, &light.indices, &target(&sr));
                wait(&sr);
            }
            None => full_frame(&mut sr, &shown, &normals),
        }
        longest = longest.max(ms(f0.elapsed()));
        frames += 1;
    }
    println!(
        "refit with a new start on the worker: {:.0} ms; the UI drew {frames} frames meanwhile, the longest {:.1} ms",
        ms(t.elapsed()),
        longest
    );
    Ok(())
}

/// Waits until the GPU has finished what was submitted.
fn wait(sr: &SceneRenderer) {
    let _ = sr
        .renderer()
        .device()
        .poll(wgpu::PollType::wait_indefinitely());
}
