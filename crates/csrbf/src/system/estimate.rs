//! What a fit will cost, estimated from a sample of starts before anything
//! is built: a nearly dense system (R reaching most starts) is found in
//! O(64 n) instead of after minutes and gigabytes.

use glam::DVec3;

/// The estimate of a fit's size.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub struct Estimate {
    /// Number of starts.
    pub starts: usize,
    /// Mean number of other starts within R (from a sample).
    pub neighbours: f64,
    /// Share of all starts within R of a start.
    pub fraction: f64,
    /// Memory of the neighbour graph and a factor of that density, in bytes
    /// (about 12 bytes per pair within R).
    pub bytes: f64,
}

impl Estimate {
    /// Whether R reaches so many starts that the system is nearly dense
    /// (N^2 memory, N^3 work): more than 20 % of 2000 or more starts.
    pub fn nearly_dense(&self) -> bool {
        self.starts >= 2000 && self.fraction > 0.2
    }

    /// A radius that would bring the memory under `limit` (neighbours grow
    /// about as R^2 for starts on a surface).
    pub fn radius_for(&self, radius: f64, limit: u64) -> f64 {
        if self.bytes <= limit as f64 {
            radius
        } else {
            radius * (limit as f64 / self.bytes).sqrt()
        }
    }
}

/// Estimates the fit of `starts` at `radius` from up to 64 evenly spread
/// starts, each compared with all.
pub fn estimate(starts: &[DVec3], radius: f64) -> Estimate {
    let n = starts.len();
    if n == 0 {
        return Estimate {
            starts: 0,
            neighbours: 0.0,
            fraction: 0.0,
            bytes: 0.0,
        };
    }
    let r2 = radius * radius;
    let step = (n / 64).max(1);
    let sample: Vec<&DVec3> = starts.iter().step_by(step).collect();
    let within: usize = sample
        .iter()
        .map(|p| {
            starts
                .iter()
                .filter(|q| q.distance_squared(**p) < r2)
                .count()
                - 1
        })
        .sum();
    let neighbours = within as f64 / sample.len() as f64;
    Estimate {
        starts: n,
        neighbours,
        fraction: neighbours / n as f64,
        bytes: 12.0 * n as f64 * neighbours,
    }
}
