//! Checking the starts and building the neighbour graph (starts within R).

use glam::{DMat3, DVec3};

use super::{FitOptions, SystemStats, maybe_par_map};
use crate::error::FitError;
use crate::kernel::{Kernel, Polynomial};
use crate::octree::Octree;
use crate::ordering::Graph;

pub(super) fn validate(starts: &[DVec3], options: &FitOptions) -> Result<(), FitError> {
    if !(options.radius > 0.0 && options.radius.is_finite()) {
        return Err(FitError::BadRadius(options.radius));
    }
    if starts.is_empty() {
        return Err(FitError::NoControls);
    }
    if let Some(i) = starts.iter().position(|s| !s.is_finite()) {
        return Err(FitError::NotFinite {
            index: i,
            what: "start",
        });
    }
    // Starts spread over a subnormal extent (or beyond f32's range) cannot be
    // told apart or fitted meaningfully: say so, rather than "coplanar".
    let (lo, hi) = starts.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    let extent = (hi - lo).max_element();
    let size = lo.abs().max(hi.abs()).max_element();
    if size > f32::MAX as f64
        || (starts.len() > 1 && extent > 0.0 && extent < f64::MIN_POSITIVE * 1e10)
    {
        return Err(FitError::StartScale { extent, size });
    }
    if options.polynomial == Polynomial::Linear {
        if starts.len() < 4 {
            return Err(FitError::TooFewForLinear(starts.len()));
        }
        if coplanar(starts) {
            return Err(FitError::CoplanarStarts);
        }
    }
    Ok(())
}

/// Whether the points lie (nearly) on one plane: the smallest principal
/// variance is negligible against the largest.
fn coplanar(points: &[DVec3]) -> bool {
    let n = points.len() as f64;
    let c = points.iter().copied().sum::<DVec3>() / n;
    let mut m = DMat3::ZERO;
    for p in points {
        let d = *p - c;
        m += DMat3::from_cols(d * d.x, d * d.y, d * d.z);
    }
    let scale = m.x_axis.x + m.y_axis.y + m.z_axis.z;
    if !(scale > 0.0) {
        return true;
    }
    let m = m * (1.0 / scale);
    // det = product of eigenvalues; with a trace of 1 the largest is >= 1/3.
    m.determinant() < 1e-12
}

/// A pair of starts that cannot be told apart: coincident, or so close that
/// the kernel's value differs from phi(0) by less than its rounding.
#[derive(Clone, Copy, Debug)]
pub(super) struct ClosePair {
    pub(super) first: usize,
    pub(super) second: usize,
    pub(super) d2: f64,
}

/// Starts closer than this fraction of R are a "near pair": fine with the
/// same move, refused when their moves differ by more than their distance
/// (see [`crate::FitError::ConflictingStarts`]).
pub const NEAR_FRACTION: f64 = 0.01;

/// Neighbour lists within R (no self), the first pair of starts too close
/// to tell apart, and every near pair (closer than [`NEAR_FRACTION`] R).
pub(super) fn neighbour_graph(
    starts: &[DVec3],
    octree: &Octree,
    radius: f64,
    kernel: Kernel,
) -> (Graph, Option<ClosePair>, Vec<(u32, u32)>) {
    let phi0 = kernel.eval(0.0);
    let near2 = (NEAR_FRACTION * radius).powi(2);
    type Row = (Vec<u32>, Option<ClosePair>, Vec<(u32, u32)>);
    let lists: Vec<Row> = maybe_par_map(starts.len(), 256, |i| {
        let mut l = Vec::new();
        let mut close: Option<ClosePair> = None;
        let mut near = Vec::new();
        octree.for_each_within(starts[i], radius, |j, d2| {
            let j = j as usize;
            if j == i {
                return;
            }
            if j < i && d2 < near2 {
                near.push((j as u32, i as u32));
            }
            if j < i
                && phi0 - kernel.eval(d2.sqrt() / radius) <= 1e-10 * phi0
                && close.is_none_or(|c| j < c.first)
            {
                close = Some(ClosePair {
                    first: j,
                    second: i,
                    d2,
                });
            }
            l.push(j as u32);
        });
        l.sort_unstable();
        (l, close, near)
    });
    let close = lists.iter().find_map(|(_, c, _)| *c);
    let near: Vec<(u32, u32)> = lists
        .iter()
        .flat_map(|(_, _, n)| n.iter().copied())
        .collect();
    let mut offsets = Vec::with_capacity(starts.len() + 1);
    offsets.push(0);
    let mut flat = Vec::with_capacity(lists.iter().map(|(l, _, _)| l.len()).sum());
    for (l, _, _) in &lists {
        flat.extend_from_slice(l);
        offsets.push(flat.len());
    }
    (Graph::from_parts(offsets, flat), close, near)
}

pub(super) fn neighbour_counts(graph: &Graph, stats: &mut SystemStats) {
    let n = graph.len().max(1);
    stats.neighbours_min = (0..graph.len()).map(|i| graph.degree(i)).min().unwrap_or(0);
    stats.neighbours_max = (0..graph.len()).map(|i| graph.degree(i)).max().unwrap_or(0);
    stats.neighbours_mean = graph.edge_entries() as f64 / n as f64;
}
