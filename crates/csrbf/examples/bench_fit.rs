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
    let mut times = Vec::new();
    for _ in 0..reps {
        let t = std::time::Instant::now();
        let sys = System::new(&s.starts, s.options)?;
        let _d = sys.solve(&s.targets)?;
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    times.sort_by(f64::total_cmp);
    let sys = System::new(&s.starts, s.options)?;
    println!(
        "fit median {:.3} ms; {:?}",
        times[times.len() / 2],
        sys.stats()
    );
    Ok(())
}
