//! Times evaluation alone on the synthetic 1M-vertex scene, for profiling:
//! `cargo run --release --example evaluate -p csrbf [-- VERTICES STARTS REPEATS]`.

use csrbf::synthetic::{fibonacci_sphere, radius_for_neighbours, smooth_displacements};
use csrbf::{Deformation, FitOptions};
use glam::DVec3;

fn main() -> Result<(), csrbf::Error> {
    let args: Vec<usize> = std::env::args().skip(1).filter_map(|a| a.parse().ok()).collect();
    let (v, n, reps) = (
        args.first().copied().unwrap_or(1_000_000),
        args.get(1).copied().unwrap_or(10_000),
        args.get(2).copied().unwrap_or(5),
    );
    let c = DVec3::splat(0.5);
    let r = radius_for_neighbours(n, 0.4, 44.0);
    let points: Vec<glam::Vec3> = fibonacci_sphere(v, c, 0.4, 0.0, 0).into_iter().map(|p| p.as_vec3()).collect();
    let starts = fibonacci_sphere(n, c, 0.4, 0.3, 1);
    let targets: Vec<DVec3> = starts.iter().zip(smooth_displacements(&starts, 0.2 * r, 2)).map(|(s, d)| *s + d).collect();
    let d = Deformation::fit(&starts, &targets, FitOptions::default().with_radius(r))?;
    for _ in 0..reps {
        let t = std::time::Instant::now();
        let out = d.displacements_f32(&points);
        println!("evaluate {:.1} ms ({} points)", t.elapsed().as_secs_f64() * 1e3, out.len());
    }
    Ok(())
}
