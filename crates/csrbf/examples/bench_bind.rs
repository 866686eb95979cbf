//! Times binding and refitting alone on a synthetic scene, for profiling:
//! `cargo run --release --example bench_bind -p csrbf [-- SCENE REPEATS]` (SCENE:
//! one of `csrbf::synthetic::SCENES`, default 1m). Prints the medians of
//! bind, solve, refit through the binding (without the solve) and evaluate,
//! the binding's size, and the largest difference between the binding and
//! the f64 evaluation. `BIND_ONLY` (bind, then re-bind reusing the memory),
//! `REFIT_ONLY`, `SOLVE_ONLY` or `EVALUATE_ONLY` set: that phase alone.
//! `SPATIAL_ORDER` set: the points sorted into cells of R/2 first (a mesh
//! whose vertices come in spatial runs), against the scenes' Fibonacci
//! order, whose neighbours are scattered through memory.

use csrbf::synthetic::scene;
use csrbf::{Binding, System};
use glam::{DVec3, Vec3};

/// The median and the fastest of some runs, in ms: on a shared machine
/// the fastest is the least disturbed.
#[derive(Clone, Copy)]
struct Times {
    median: f64,
    min: f64,
}

impl std::fmt::Display for Times {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{:.2} ms (fastest {:.2})", self.median, self.min)
    }
}

fn timed<T>(reps: usize, mut f: impl FnMut() -> T) -> (Times, T) {
    let mut times = Vec::new();
    let mut last = None;
    for _ in 0..reps.max(1) {
        // The previous run's result dropped first, outside the timing.
        drop(last.take());
        let t = std::time::Instant::now();
        let out = f();
        times.push(t.elapsed().as_secs_f64() * 1e3);
        last = Some(out);
    }
    times.sort_by(f64::total_cmp);
    let times = Times {
        median: times[times.len() / 2],
        min: times[0],
    };
    (times, last.expect("one run"))
}

fn median<T>(reps: usize, f: impl FnMut() -> T) -> (f64, T) {
    let (t, out) = timed(reps, f);
    (t.median, out)
}

fn main() -> Result<(), csrbf::Error> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let name = args.first().map_or("1m", String::as_str);
    let reps = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(5);
    // "VERTICES/STARTS" for a scene of that size.
    let custom = name.split_once('/').and_then(|(v, n)| {
        Some(csrbf::synthetic::scene_of(
            "custom",
            v.parse().ok()?,
            n.parse().ok()?,
            None,
        ))
    });
    let Some(mut s) = custom.or_else(|| scene(name)) else {
        eprintln!("unknown scene {name}");
        return Ok(());
    };
    if std::env::var_os("SPATIAL_ORDER").is_some() {
        // Points in the order of cells of R/2 (z, y, x), as a mesh whose
        // vertices are stored in spatial runs would give them: what the
        // scattered reads and writes of the scene's Fibonacci order cost.
        let h = 0.5 * s.options.radius;
        let key = |p: &Vec3| (p.as_dvec3() / h).floor().as_ivec3().to_array();
        s.points.sort_by_key(|p| {
            let [x, y, z] = key(p);
            (z, y, x)
        });
    }
    let sys = System::new(&s.starts, s.options)?;
    let d = sys.solve(&s.targets)?;
    if std::env::var_os("EVALUATE_ONLY").is_some() {
        let (t, _) = timed(reps, || d.displacements_f32(&s.points));
        println!("evaluate {t}");
        return Ok(());
    }
    if std::env::var_os("SOLVE_ONLY").is_some() {
        let (t, _) = timed(reps, || sys.solve(&s.targets));
        println!("solve {t}");
        return Ok(());
    }
    if std::env::var_os("BIND_ONLY").is_some() {
        let (ms, b) = median(reps, || Binding::new(&d, &s.points));
        println!("bind {ms:.2} ms, {} pairs", b.pairs());
        let mut b = b;
        let (ms, _) = median(reps, || b.rebind(&d, &s.points));
        println!("rebind {ms:.2} ms, {} pairs", b.pairs());
        return Ok(());
    }
    let (bind_ms, binding) = median(reps.min(3), || Binding::new(&d, &s.points));
    if std::env::var_os("REFIT_ONLY").is_some() {
        let mut out = vec![Vec3::ZERO; s.points.len()];
        let (t, _) = timed(50, || binding.displacements_into(&d, &mut out));
        println!("refit {t}");
        return Ok(());
    }
    let moved: Vec<DVec3> = s
        .targets
        .iter()
        .map(|t| *t + DVec3::Z * 0.01 * s.options.radius)
        .collect();
    let (solve_ms, d2) = median(reps, || sys.solve(&moved));
    let d2 = d2?;
    let mut out = vec![Vec3::ZERO; s.points.len()];
    let (refit_ms, r) = median(reps, || binding.displacements_into(&d2, &mut out));
    r?;
    let (evaluate_ms, _) = median(reps, || d2.displacements_f32(&s.points));
    println!(
        "{name}: bind {bind_ms:.2} ms | solve {solve_ms:.2} ms | refit (product) {refit_ms:.2} ms | evaluate {evaluate_ms:.2} ms | {:.2} MB, {} pairs",
        binding.bytes() as f64 / 1e6,
        binding.pairs()
    );
    let want = d2.displacements(&s.points);
    let worst = out
        .iter()
        .zip(&want)
        .map(|(a, b)| (a.as_dvec3() - *b).length())
        .fold(0.0, f64::max);
    let largest = want.iter().map(|d| d.length()).fold(0.0, f64::max);
    println!(
        "binding against f64: largest difference {worst:.3e} (largest displacement {largest:.3e})"
    );
    Ok(())
}
