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
}

/// The starts [`estimate`] compares with all: up to 64, evenly spread.
fn sample(starts: &[DVec3]) -> impl Iterator<Item = &DVec3> {
    starts.iter().step_by((starts.len() / 64).max(1))
}

/// A radius at most `radius` whose [`estimate`] fits in `limit` bytes, with
/// a margin of 2 % (so a rounded figure in a message fits too): the
/// largest one, for the estimate's sample. The estimate counts the pairs of
/// a sample start and another start closer than R, so the bound is the
/// (k+1)-th smallest of those distances, k the pairs the limit allows (a
/// rule such as "pairs grow as R^2" fails where R already reaches every
/// start: every smaller R it proposed was as large).
pub(crate) fn radius_within(starts: &[DVec3], radius: f64, limit: u64) -> f64 {
    let n = starts.len();
    let samples = sample(starts).count();
    if n < 2 || samples == 0 {
        return radius;
    }
    // 12 n pairs / samples <= limit.
    let allowed = (limit as f64 * samples as f64 / (12.0 * n as f64)).floor();
    let k = allowed.min(usize::MAX as f64) as usize;
    // The k+1 smallest squared distances (non-negative: their bits order
    // them), in a max-heap.
    let mut heap = std::collections::BinaryHeap::with_capacity(k.saturating_add(1).min(1 << 24));
    let r2 = radius * radius;
    for p in sample(starts) {
        let mut own = true;
        for q in starts {
            let d2 = q.distance_squared(*p);
            if d2 == 0.0 && own {
                own = false; // the sample start itself
                continue;
            }
            if d2 >= r2 {
                continue;
            }
            if heap.len() <= k {
                heap.push(d2.to_bits());
            } else if heap.peek().is_some_and(|&top| d2.to_bits() < top) {
                heap.pop();
                heap.push(d2.to_bits());
            }
        }
    }
    if heap.len() <= k {
        return radius; // fewer pairs than allowed within `radius`
    }
    let bound = heap.peek().map_or(r2, |&b| f64::from_bits(b));
    (bound.sqrt() * 0.98).min(radius)
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
    let sample: Vec<&DVec3> = sample(starts).collect();
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
