//! Times `Scene::frame` for a demo, for profiling:
//! `cargo run --release --example bench_frames -p csrbf-anim -- fish 2000`.

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let name = args.next().unwrap_or_else(|| "fish".into());
    let reps: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(200);
    let demo = csrbf_anim::demos::demo(&name).ok_or("unknown demo")?;
    let dir = std::env::temp_dir().join(format!("csrbf-frames-{}", std::process::id()));
    demo.write(&dir, &name)?;
    let scene = csrbf_anim::Scene::from_file(demo.scene, &dir, "demo".as_ref())?;
    let frames = scene.frame_count();
    let mut frame = csrbf_anim::Frame::default();
    let t = std::time::Instant::now();
    for r in 0..reps {
        scene.frame_into((r % frames) as f64 / scene.file.fps, &mut frame);
        std::hint::black_box(&frame);
    }
    println!(
        "{name}: {:.1} us per frame",
        t.elapsed().as_secs_f64() * 1e6 / reps as f64
    );
    std::fs::remove_dir_all(&dir)?;
    Ok(())
}
