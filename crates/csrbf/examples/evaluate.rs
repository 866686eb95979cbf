//! Times evaluation alone on the synthetic 1M-vertex scene, for profiling:
//! `cargo run --release --example evaluate -p csrbf [-- VERTICES STARTS REPEATS [RADIUS]]`.

use csrbf::Deformation;
use csrbf::synthetic::scene_of;

fn main() -> Result<(), csrbf::Error> {
    let args: Vec<f64> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let (v, n, reps) = (
        args.first().map_or(1_000_000, |&x| x as usize),
        args.get(1).map_or(10_000, |&x| x as usize),
        args.get(2).map_or(5, |&x| x as usize),
    );
    let s = scene_of("custom", v, n, args.get(3).copied());
    let r = s.options.radius;
    let d = Deformation::fit(&s.starts, &s.targets, s.options)?;
    let mut times = Vec::new();
    for _ in 0..reps {
        let t = std::time::Instant::now();
        let out = d.displacements_f32(&s.points);
        times.push(t.elapsed().as_secs_f64() * 1e3);
        std::hint::black_box(out);
    }
    times.sort_by(f64::total_cmp);
    println!(
        "evaluate median {:.4} ms ({v} points, {n} starts, R {r:.4})",
        times[times.len() / 2]
    );
    Ok(())
}
