//! Factor once, solve many: what an editor does while a destination is
//! dragged. The system (graph, ordering, Cholesky factor) is built once for
//! the starts; each new set of destinations is one solve, and a binding of
//! the mesh's points turns it into their displacements with the kernel sums
//! alone.
//!
//! `cargo run --release -p csrbf --example factor_once`

use csrbf::glam::{DVec3, Vec3};
use csrbf::synthetic::fibonacci_sphere;
use csrbf::{Binding, FitOptions, System};

fn main() -> Result<(), csrbf::Error> {
    // A mesh's points (a sphere of 200,000) and 400 starts on it.
    let points: Vec<Vec3> = fibonacci_sphere(200_000, DVec3::ZERO, 1.0, 0.0, 0)
        .into_iter()
        .map(|p| p.as_vec3())
        .collect();
    let starts = fibonacci_sphere(400, DVec3::ZERO, 1.0, 0.3, 1);
    let options = FitOptions::new(0.35);

    let t = std::time::Instant::now();
    let sys = System::new(&starts, options)?;
    let mut deformation = sys.solve(&starts)?; // the identity, to bind against
    let binding = Binding::new(&deformation, &points);
    println!(
        "built: {} starts, {:.1} neighbours each, {} solver, {:.1} ms (with the binding)",
        sys.stats().controls,
        sys.stats().neighbours_mean,
        sys.stats().solver,
        t.elapsed().as_secs_f64() * 1e3
    );

    // The drag: start 0's destination moves outwards a little each step.
    let mut shown = vec![Vec3::ZERO; points.len()];
    let mut targets = starts.clone();
    for step in 1..=5 {
        let t = std::time::Instant::now();
        targets[0] = starts[0] * (1.0 + 0.04 * step as f64);
        sys.solve_into(&targets, &mut deformation)?; // no refactoring
        binding.displacements_into(&deformation, &mut shown)?; // the kernel sums alone
        let moved = shown.iter().filter(|d| d.length() > 1e-6).count();
        println!(
            "step {step}: {moved} points moved, {:.2} ms",
            t.elapsed().as_secs_f64() * 1e3
        );
    }

    // Many variants at once (dataset augmentation): one solve each, in parallel.
    let variants: Vec<Vec<DVec3>> = (0..16)
        .map(|k| {
            let mut t = starts.clone();
            t[k] *= 1.05;
            t
        })
        .collect();
    let t = std::time::Instant::now();
    let all = sys.solve_many(&variants)?;
    println!(
        "{} variants solved in {:.1} ms",
        all.len(),
        t.elapsed().as_secs_f64() * 1e3
    );
    Ok(())
}
