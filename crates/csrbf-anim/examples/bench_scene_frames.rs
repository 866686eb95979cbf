//! Times `Scene::frame` for a scene file:
//! `cargo run --release --example bench_scene_frames -p csrbf-anim -- SCENE [REPEATS]`.

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let path = args.next().ok_or("give a scene file")?;
    let reps: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(50);
    let scene = csrbf_anim::Scene::load(path.as_ref())?;
    let mut frame = csrbf_anim::Frame::default();
    let t = std::time::Instant::now();
    for r in 0..reps {
        scene.frame_into(r as f64 / reps as f64 * scene.file.duration, &mut frame);
        std::hint::black_box(&frame);
    }
    let v: usize = scene.objects.iter().map(|o| o.mesh.positions.len()).sum();
    println!(
        "{path}: {v} vertices, {:.3} ms per frame",
        t.elapsed().as_secs_f64() * 1e3 / reps as f64
    );
    Ok(())
}
