//! Helpers for the engine's own tests.

pub(crate) use crate::synthetic::Rng;

/// Asserts |a - b| <= tol * max(1, |b|), printing the difference.
#[track_caller]
pub(crate) fn assert_close(a: f64, b: f64, tol: f64, what: &str) {
    let diff = (a - b).abs();
    assert!(
        diff <= tol * b.abs().max(1.0),
        "{what}: {a} vs {b}, difference {diff:e} over tolerance {tol:e}"
    );
}

/// A grid of triangles in the plane z = 0, `n` x `n` cells over [0, 1]^2.
pub(crate) fn grid(n: usize) -> (Vec<glam::Vec3>, Vec<[u32; 3]>) {
    let at = |i: usize, j: usize| (j * (n + 1) + i) as u32;
    let v = (0..=n)
        .flat_map(|j| (0..=n).map(move |i| glam::Vec3::new(i as f32, j as f32, 0.0) / n as f32))
        .collect();
    let t = (0..n)
        .flat_map(|j| {
            (0..n).flat_map(move |i| {
                [
                    [at(i, j), at(i + 1, j), at(i + 1, j + 1)],
                    [at(i, j), at(i + 1, j + 1), at(i, j + 1)],
                ]
            })
        })
        .collect();
    (v, t)
}
