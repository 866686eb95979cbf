//! Times evaluation alone on the synthetic 1M-vertex scene, for profiling:
//! `cargo run --release --example evaluate -p csrbf [-- VERTICES STARTS REPEATS [RADIUS]]`.

use csrbf::synthetic::{fibonacci_sphere, radius_for_neighbours, smooth_displacements};
use csrbf::{Deformation, FitOptions};
use glam::DVec3;

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
    let c = DVec3::splat(0.5);
    let r = args
        .get(3)
        .copied()
        .unwrap_or_else(|| radius_for_neighbours(n, 0.4, 44.0));
    let points: Vec<glam::Vec3> = fibonacci_sphere(v, c, 0.4, 0.0, 0)
        .into_iter()
        .map(|p| p.as_vec3())
        .collect();
    let starts = fibonacci_sphere(n, c, 0.4, 0.3, 1);
    let targets: Vec<DVec3> = starts
        .iter()
        .zip(smooth_displacements(&starts, 0.2 * r, 2))
        .map(|(s, d)| *s + d)
        .collect();
    let d = Deformation::fit(&starts, &targets, FitOptions::default().with_radius(r))?;
    let mut times = Vec::new();
    for _ in 0..reps {
        let t = std::time::Instant::now();
        let out = d.displacements_f32(&points);
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
