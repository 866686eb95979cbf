//! Times evaluation alone on the synthetic 1M-vertex scene, for profiling:
//! `cargo run --release --example bench_evaluate -p csrbf [-- VERTICES STARTS REPEATS [RADIUS]]`.

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
    let c = d.evaluation_counts(&s.points);
    println!(
        "evaluate median {:.4} ms ({v} points, {n} starts, R {r:.4}; {} cells, {} candidates, {} kernel evaluations, {} hits)",
        times[times.len() / 2],
        c.cells,
        c.candidates,
        c.kernel_evaluations,
        c.hits
    );
    // The f32 path against the f64 one: largest difference, absolute and
    // relative to the largest displacement.
    let (f32s, f64s) = (d.displacements_f32(&s.points), d.displacements(&s.points));
    let worst = f32s
        .iter()
        .zip(&f64s)
        .map(|(a, b)| (a.as_dvec3() - *b).length())
        .fold(0.0, f64::max);
    let largest = f64s.iter().map(|d| d.length()).fold(0.0, f64::max);
    println!(
        "f32 against f64: largest difference {worst:.3e} ({:.3e} of the largest displacement {largest:.3e})",
        worst / largest
    );
    Ok(())
}
