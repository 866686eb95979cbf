//! Checking the starts and building the neighbour graph (starts within R).

use glam::{DMat3, DVec3};

use rayon::prelude::*;

use super::{FitOptions, SystemStats};
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

/// Below this many neighbour entries (each pair within R counted from both
/// ends: starts times their mean neighbours, estimated from a sample) the
/// neighbour graph is built on one thread: waking rayon's second worker
/// and gathering the parts costs more than it saves. Measured on two cores:
/// 1,200 and 2,000 starts of 44 neighbours (53k and 88k pairs) took 0.6 and
/// 0.9 ms on one thread, 0.15 ms more on two; 4,000 starts of 60 on a
/// scanned surface (240k) 2.8 ms on one, 1.6-1.9 ms on two (before leaves
/// were queried in groups: 1.0 ms on two now).
pub(super) const PARALLEL_PAIRS: f64 = 150_000.0;

/// Groups of leaves handed to one rayon task on the parallel path.
const CHUNK_GROUPS: usize = 4;

/// Consecutive octree leaves (near each other in the tree's order) share
/// one query for the starts near them while their bounds stay within this
/// many R a side and they hold at most [`GROUP_STARTS`] starts. A leaf of
/// a dozen starts is smaller than R on a surface of 60 neighbours a start:
/// its query found half a group's candidates for a tenth of the starts to
/// test them against (the scan's graph 1.52 -> 1.03 ms with groups; 1 R:
/// 1.17, 3 R: 1.07).
const GROUP_REACH: f64 = 2.0;

/// The most starts a group of leaves holds.
const GROUP_STARTS: usize = 160;

/// Neighbour lists within R (no self), the first pair of starts too close
/// to tell apart, and every near pair (closer than [`NEAR_FRACTION`] R).
///
/// Works by groups of octree leaves: the candidates near a group's box are
/// found once, sorted by index, and tested against each of the group's
/// starts, so each start's neighbours come out in increasing order without
/// a sort.
/// On both cores when `pairs`, the neighbour entries estimated (`None`: too
/// few starts to estimate), reach [`PARALLEL_PAIRS`].
pub(super) fn neighbour_graph(
    starts: &[DVec3],
    octree: &Octree,
    radius: f64,
    kernel: Kernel,
    pairs: Option<f64>,
) -> (Graph, Option<ClosePair>, Vec<(u32, u32)>) {
    let parallel = pairs.is_some_and(|p| p >= PARALLEL_PAIRS);
    neighbour_graph_with(starts, octree, radius, kernel, parallel)
}

/// [`neighbour_graph`], on one thread or on the pool: the same graph.
fn neighbour_graph_with(
    starts: &[DVec3],
    octree: &Octree,
    radius: f64,
    kernel: Kernel,
    parallel: bool,
) -> (Graph, Option<ClosePair>, Vec<(u32, u32)>) {
    let n = starts.len();
    let leaves: Vec<_> = octree.leaves().collect();
    let groups = groups(&leaves, radius);
    let rows = |groups: &[Group<'_, '_>]| rows_of_groups(starts, groups, octree, radius, kernel);
    let parts: Vec<Rows> = if !parallel {
        vec![rows(&groups)]
    } else {
        groups.par_chunks(CHUNK_GROUPS).map(rows).collect()
    };
    // Scatter the rows, found group by group, into the starts' order.
    let mut offsets = vec![0usize; n + 1];
    for p in &parts {
        for &(i, b, e) in &p.rows {
            offsets[i as usize + 1] = (e - b) as usize;
        }
    }
    for i in 0..n {
        offsets[i + 1] += offsets[i];
    }
    let mut neighbours = vec![0u32; offsets[n]];
    let mut near = Vec::new();
    let mut close: Option<ClosePair> = None;
    for p in &parts {
        for &(i, b, e) in &p.rows {
            let o = offsets[i as usize];
            neighbours[o..o + (e - b) as usize]
                .copy_from_slice(&p.neighbours[b as usize..e as usize]);
        }
        near.extend_from_slice(&p.near);
        if let Some(c) = p.close
            && close.is_none_or(|k| (c.second, c.first) < (k.second, k.first))
        {
            close = Some(c);
        }
    }
    // By the later start, then the earlier: the order of the rows.
    near.sort_unstable_by_key(|&(j, i)| (i, j));
    (Graph::from_parts(offsets, neighbours), close, near)
}

/// One octree leaf: its starts' indices, the starts and its tight bounds.
type Leaf<'a> = (&'a [u32], &'a [DVec3], DVec3, DVec3);

/// Consecutive leaves and the bounds of all their starts.
type Group<'a, 'b> = (&'b [Leaf<'a>], DVec3, DVec3);

/// The leaves in groups of consecutive ones, each within [`GROUP_REACH`]
/// R a side and of at most [`GROUP_STARTS`] starts (a leaf alone may be
/// larger).
fn groups<'a, 'b>(leaves: &'b [Leaf<'a>], radius: f64) -> Vec<Group<'a, 'b>> {
    let mut out = Vec::new();
    let mut first = 0;
    while first < leaves.len() {
        let (_, points, mut min, mut max) = leaves[first];
        let mut count = points.len();
        let mut last = first + 1;
        while let Some(&(_, p, lo, hi)) = leaves.get(last) {
            let (min2, max2) = (min.min(lo), max.max(hi));
            if count + p.len() > GROUP_STARTS || (max2 - min2).max_element() > GROUP_REACH * radius
            {
                break;
            }
            (min, max, count, last) = (min2, max2, count + p.len(), last + 1);
        }
        out.push((&leaves[first..last], min, max));
        first = last;
    }
    out
}

/// The neighbour lists of the starts of some leaves, each row
/// `(start, begin, end)` a range of `neighbours`; the close pair with the
/// lowest (later start, earlier start) and the near pairs among them.
#[derive(Default)]
struct Rows {
    rows: Vec<(u32, u32, u32)>,
    neighbours: Vec<u32>,
    close: Option<ClosePair>,
    near: Vec<(u32, u32)>,
}

fn rows_of_groups(
    starts: &[DVec3],
    groups: &[Group<'_, '_>],
    octree: &Octree,
    radius: f64,
    kernel: Kernel,
) -> Rows {
    let phi0 = kernel.eval(0.0);
    let r2 = radius * radius;
    let near2 = (NEAR_FRACTION * radius).powi(2);
    let cpu = crate::simd::Avx2Fma::detect();
    let mut out = Rows::default();
    let mut cand: Vec<u32> = Vec::new();
    let (mut xs, mut ys, mut zs) = (Vec::new(), Vec::new(), Vec::new());
    for &(leaves, min, max) in groups {
        cand.clear();
        // The octree's points are the starts: sort bare indices, then
        // look the coordinates up.
        octree.for_each_near_box(min, max, radius, |j, _| cand.push(j));
        cand.sort_unstable();
        xs.clear();
        ys.clear();
        zs.clear();
        xs.extend(cand.iter().map(|&j| starts[j as usize].x));
        ys.extend(cand.iter().map(|&j| starts[j as usize].y));
        zs.extend(cand.iter().map(|&j| starts[j as usize].z));
        for (&i, &q) in leaves
            .iter()
            .flat_map(|&(ids, points, _, _)| ids.iter().zip(points))
        {
            let begin = out.neighbours.len() as u32;
            for c0 in (0..cand.len()).step_by(64) {
                let c1 = (c0 + 64).min(cand.len());
                let mut bits = crate::simd::hit_mask(
                    cpu,
                    &xs[c0..c1],
                    &ys[c0..c1],
                    &zs[c0..c1],
                    [q.x, q.y, q.z],
                    r2,
                );
                while bits != 0 {
                    let j = cand[c0 + bits.trailing_zeros() as usize];
                    let p = starts[j as usize];
                    bits &= bits - 1;
                    if j == i {
                        continue;
                    }
                    // The same squared distance as the mask's, term by term.
                    let d = p - q;
                    let d2 = d.x * d.x + d.y * d.y + d.z * d.z;
                    // A pair too close to tell apart is always a near pair
                    // (every kernel falls by far more than 1e-10 phi(0)
                    // within 1 % of R: `close_pairs_are_near_pairs`), so
                    // only near pairs need the kernel.
                    if j < i && d2 < near2 {
                        out.near.push((j, i));
                        if phi0 - kernel.eval(d2.sqrt() / radius) <= 1e-10 * phi0
                            && out
                                .close
                                .is_none_or(|c| (i, j) < (c.second as u32, c.first as u32))
                        {
                            out.close = Some(ClosePair {
                                first: j as usize,
                                second: i as usize,
                                d2,
                            });
                        }
                    }
                    out.neighbours.push(j);
                }
            }
            out.rows.push((i, begin, out.neighbours.len() as u32));
        }
    }
    out
}

pub(super) fn neighbour_counts(graph: &Graph, stats: &mut SystemStats) {
    let n = graph.len().max(1);
    stats.neighbours_min = (0..graph.len()).map(|i| graph.degree(i)).min().unwrap_or(0);
    stats.neighbours_max = (0..graph.len()).map(|i| graph.degree(i)).max().unwrap_or(0);
    stats.neighbours_mean = graph.edge_entries() as f64 / n as f64;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::Rng;

    /// Random starts in a cube with a few pairs nearly on top of each other.
    fn starts_with_near_pairs(n: usize, seed: u64) -> Vec<DVec3> {
        let mut rng = Rng::new(seed);
        let mut s: Vec<DVec3> = (0..n).map(|_| rng.vec3()).collect();
        for k in (0..n).step_by(97).skip(1) {
            let j = rng.below(k);
            s[k] = s[j] + DVec3::new(1e-4, 0.0, 0.0) * rng.f64();
        }
        s
    }

    /// Starts on a sphere, a surface as a scan's: many small leaves to a
    /// group at a small radius.
    fn starts_on_a_sphere(n: usize, seed: u64) -> Vec<DVec3> {
        let mut rng = Rng::new(seed);
        (0..n)
            .map(|_| (rng.vec3() - DVec3::splat(0.5)).normalize_or(DVec3::X) * 0.5)
            .collect()
    }

    /// Each leaf once, in order, in groups of at most GROUP_STARTS starts
    /// within GROUP_REACH R a side (or of one leaf).
    #[test]
    fn groups_take_every_leaf_once_within_their_bounds() {
        for (starts, radius) in [
            (starts_on_a_sphere(3000, 5), 0.04),
            (starts_with_near_pairs(1500, 3), 0.15),
            (starts_on_a_sphere(500, 6), 2.0),
        ] {
            let octree = Octree::new(&starts);
            let leaves: Vec<_> = octree.leaves().collect();
            let groups = groups(&leaves, radius);
            assert!(
                groups.len() < leaves.len() || leaves.len() < 2,
                "some leaves together"
            );
            let mut at = 0;
            for &(members, min, max) in &groups {
                assert!(!members.is_empty());
                for (k, leaf) in members.iter().enumerate() {
                    assert_eq!(leaf.0.as_ptr(), leaves[at + k].0.as_ptr(), "in order");
                    for p in leaf.1 {
                        assert!(
                            p.cmpge(min).all() && p.cmple(max).all(),
                            "inside the bounds"
                        );
                    }
                }
                at += members.len();
                if members.len() > 1 {
                    let count: usize = members.iter().map(|l| l.0.len()).sum();
                    assert!(count <= GROUP_STARTS);
                    assert!((max - min).max_element() <= GROUP_REACH * radius);
                }
            }
            assert_eq!(at, leaves.len(), "every leaf");
        }
    }

    #[test]
    fn one_thread_and_parallel_paths_give_the_same_graph() {
        for (starts, radius) in [
            (starts_with_near_pairs(1500, 3), 0.15),
            (starts_on_a_sphere(3000, 5), 0.04),
        ] {
            let near = same_graph_on_both_paths(&starts, radius);
            assert!(!near.is_empty() || radius < 0.1, "the near pairs made");
        }
    }

    /// The graph of `starts` on one thread and on the pool, against brute
    /// force; its near pairs.
    fn same_graph_on_both_paths(starts: &[DVec3], radius: f64) -> Vec<(u32, u32)> {
        let octree = Octree::new(starts);
        let kernel = Kernel::C2;
        let (g1, c1, n1) = neighbour_graph_with(starts, &octree, radius, kernel, false);
        let (g2, c2, n2) = neighbour_graph_with(starts, &octree, radius, kernel, true);
        assert_eq!(g1, g2);
        assert_eq!(n1, n2);
        assert_eq!(
            c1.map(|c| (c.first, c.second)),
            c2.map(|c| (c.first, c.second))
        );
        // Against brute force: every pair within R, no self, sorted rows.
        for i in 0..starts.len() {
            let want: Vec<u32> = (0..starts.len())
                .filter(|&j| j != i && starts[i].distance_squared(starts[j]) < radius * radius)
                .map(|j| j as u32)
                .collect();
            assert_eq!(g1.neighbours(i), &want[..], "row {i}");
        }
        n1
    }

    #[test]
    fn a_duplicate_is_found_on_both_paths() {
        let mut starts = starts_with_near_pairs(1200, 4);
        starts[900] = starts[17];
        let octree = Octree::new(&starts);
        for parallel in [false, true] {
            let (_, close, _) = neighbour_graph_with(&starts, &octree, 0.1, Kernel::C0, parallel);
            let c = close.expect("the duplicate");
            assert_eq!((c.first, c.second, c.d2), (17, 900, 0.0));
        }
    }

    /// The graph asks the kernel whether a pair is too close only for near
    /// pairs: that is right only while every kernel falls by more than
    /// 1e-10 phi(0) within [`NEAR_FRACTION`] R.
    #[test]
    fn close_pairs_are_near_pairs() {
        for kernel in Kernel::ALL {
            let phi0 = kernel.eval(0.0);
            assert!(
                phi0 - kernel.eval(NEAR_FRACTION) > 1e-6 * phi0,
                "{kernel:?}"
            );
        }
    }
}
