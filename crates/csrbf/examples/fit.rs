//! Times fitting alone on the synthetic sphere scenes, for profiling:
//! `cargo run --release --example fit -p csrbf [-- STARTS REPEATS RADIUS]`.

use csrbf::synthetic::{fibonacci_sphere, radius_for_neighbours, smooth_displacements};
use csrbf::{FitOptions, System};
use glam::DVec3;

fn main() -> Result<(), csrbf::Error> {
    let args: Vec<f64> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let n = args.first().map_or(1000, |&v| v as usize);
    let reps = args.get(1).map_or(20, |&v| v as usize);
    let r = args
        .get(2)
        .copied()
        .unwrap_or_else(|| radius_for_neighbours(n, 0.4, 44.0));
    let c = DVec3::splat(0.5);
    let starts = fibonacci_sphere(n, c, 0.4, 0.3, 1);
    let targets: Vec<DVec3> = starts
        .iter()
        .zip(smooth_displacements(&starts, 0.2 * r, 2))
        .map(|(s, d)| *s + d)
        .collect();
    let mut times = Vec::new();
    for _ in 0..reps {
        let t = std::time::Instant::now();
        let sys = System::new(&starts, FitOptions::default().with_radius(r))?;
        let _d = sys.solve(&targets)?;
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    times.sort_by(f64::total_cmp);
    let sys = System::new(&starts, FitOptions::default().with_radius(r))?;
    println!(
        "fit median {:.3} ms; {:?}",
        times[times.len() / 2],
        sys.stats()
    );
    Ok(())
}
