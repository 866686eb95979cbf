//! Helpers for the engine's own tests.

pub(crate) use crate::synthetic::{Rng, grid};

/// Asserts |a - b| <= tol * max(1, |b|), printing the difference.
#[track_caller]
pub(crate) fn assert_close(a: f64, b: f64, tol: f64, what: &str) {
    let diff = (a - b).abs();
    assert!(
        diff <= tol * b.abs().max(1.0),
        "{what}: {a} vs {b}, difference {diff:e} over tolerance {tol:e}"
    );
}
