//! Times fitting alone on the synthetic sphere scenes, for profiling:
//! `cargo run --release --example bench_fit -p csrbf [-- STARTS REPEATS RADIUS]`.

use csrbf::System;
use csrbf::synthetic::scene_of;

fn main() -> Result<(), csrbf::Error> {
    let args: Vec<f64> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let n = args.first().map_or(1000, |&v| v as usize);
    let reps = args.get(1).map_or(20, |&v| v as usize);
    let s = scene_of("custom", 0, n, args.get(2).copied());
    // The whole fit, and its two parts: the system (graph to factor) and
    // the solve for the destinations (with the deformation it makes).
    let (mut times, mut systems, mut solves) = (Vec::new(), Vec::new(), Vec::new());
    for _ in 0..reps {
        let t = std::time::Instant::now();
        let sys = System::new(&s.starts, s.options)?;
        let built = t.elapsed();
        let _d = sys.solve(&s.targets)?;
        let all = t.elapsed();
        times.push(all.as_secs_f64() * 1e3);
        systems.push(built.as_secs_f64() * 1e3);
        solves.push((all - built).as_secs_f64() * 1e3);
    }
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let sys = System::new(&s.starts, s.options)?;
    println!(
        "fit median {:.3} ms (system {:.3}, solve {:.3}); {:?}",
        median(times),
        median(systems),
        median(solves),
        sys.stats()
    );
    Ok(())
}
