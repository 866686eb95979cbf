//! The f32 kernel sum of the vertex-buffer evaluation, eight or sixteen
//! candidates at a time.
//!
//! A cell's candidate starts are kept by coordinate, relative to the cell's
//! centre and in units of R (so every value is about 1 and f32 loses
//! nothing to the model's offset), with their coefficients, and padded to a
//! multiple of eight with far starts of zero coefficient. A point then
//! costs one pass over plain arrays with no branch and no gather:
//!
//! ```text
//! d = c - x (3 sub), r^2 (mul + 2 fma), r = sqrt, t = max(1 - r, 0),
//! phi(t, r) (C2: 4 ops), sum += phi * alpha (3 fma)
//! ```
//!
//! about 16 vector operations per register of candidates (eight or
//! sixteen), where a hit test and a scalar kernel per hit cost about 40
//! instructions per hit. `t = max(1 - r, 0)` makes phi zero beyond R
//! (every Wendland function is (1 - r)_+^k times a polynomial), so misses
//! cost the same lanes and need no mask.
//!
//! [`Sums`] (in `sums`) computes that sum, chosen once for a kernel and
//! CPU: a plain reference one lane at a time, an AVX2 copy of eight lanes a
//! register and an AVX-512 copy of sixteen. A [`crate::Binding`] keeps the
//! coordinates and fills each new deformation's coefficients into lanes
//! beside them.

mod sums;
#[cfg(target_arch = "x86_64")]
mod vector;

pub(crate) use sums::Sums;

use glam::{DVec3, Vec3};

use crate::deformation::Deformation;
use rayon::prelude::*;

use crate::evaluate::{Blocks, Candidates, PARALLEL_POINTS, Point, Scatter, for_each_cell_with};
use crate::octree::Octree;
use crate::simd::Avx2Fma;

/// Candidates per vector.
pub(crate) const LANES: usize = 8;

/// Where padding starts sit, in units of R from the cell's centre: far
/// beyond the support, and small enough that r^2 and phi's polynomial stay
/// finite for every kernel (so 0 * poly is 0, not NaN).
const FAR: f32 = 1.0e3;

/// One cell's candidates by coordinate (units of R about `centre`) and
/// their coefficients, padded to a multiple of [`LANES`].
#[derive(Debug, Default)]
pub(crate) struct Lanes {
    xyz: [Vec<f32>; 3],
    alpha: [Vec<f32>; 3],
    /// Candidates before padding.
    real: usize,
    /// The sum of the candidates' coefficients' sizes (|x| + |y| + |z|: the
    /// scale of the f32 sums' rounding).
    reach: f64,
    centre: DVec3,
    inv_radius: f64,
}

impl Lanes {
    /// The starts within `radius` of the box `lo..hi`, with their
    /// coefficients, about the box's centre.
    pub(crate) fn gather(
        &mut self,
        octree: &Octree,
        coefficients: &[DVec3],
        (lo, hi): (DVec3, DVec3),
        radius: f64,
    ) {
        for v in self.xyz.iter_mut().chain(&mut self.alpha) {
            v.clear();
        }
        self.centre = centre((lo, hi));
        self.inv_radius = 1.0 / radius;
        self.reach = 0.0;
        for_each_candidate(octree, (lo, hi), radius, |i, u| {
            let a = coefficients[i as usize];
            self.reach += a.abs().element_sum();
            for c in 0..3 {
                self.xyz[c].push(u[c]);
                self.alpha[c].push(a[c] as f32);
            }
        });
        self.real = self.xyz[0].len();
        let padded = self.real.next_multiple_of(LANES);
        for c in 0..3 {
            self.xyz[c].resize(padded, FAR);
            self.alpha[c].resize(padded, 0.0);
        }
    }

    /// The sum of the candidates' |coefficient|.
    pub(crate) fn reach(&self) -> f64 {
        self.reach
    }

    /// Candidates gathered (before padding).
    pub(crate) fn candidates(&self) -> usize {
        self.real
    }

    /// Lanes a point computes (candidates padded to a multiple of eight).
    pub(crate) fn lanes(&self) -> usize {
        self.xyz[0].len()
    }

    /// x in the lanes' frame (units of R about the centre).
    pub(crate) fn local(&self, x: DVec3) -> [f32; 3] {
        local(self.centre, self.inv_radius, x)
    }

    fn view(&self) -> View<'_> {
        View {
            xyz: [&self.xyz[0], &self.xyz[1], &self.xyz[2]],
            alpha: [&self.alpha[0], &self.alpha[1], &self.alpha[2]],
        }
    }
}

/// `x` in the frame of a cell's lanes: units of R (`inv_radius` = 1 / R)
/// about the cell's `centre`.
#[inline]
pub(crate) fn local(centre: DVec3, inv_radius: f64, x: DVec3) -> [f32; 3] {
    ((x - centre) * inv_radius).as_vec3().to_array()
}

/// The starts within `radius` of the box `lo..hi`, each with its
/// coordinates in the lanes' frame (units of R about the box's centre).
pub(crate) fn for_each_candidate(
    octree: &Octree,
    (lo, hi): (DVec3, DVec3),
    radius: f64,
    mut f: impl FnMut(u32, [f32; 3]),
) {
    let (centre, inv) = (centre((lo, hi)), 1.0 / radius);
    octree.for_each_near_box(lo, hi, radius, |i, p| f(i, local(centre, inv, p)));
}

/// Pads a cell's coordinate lanes to a multiple of [`LANES`] with far
/// starts (their kernel is zero at every point of the cell).
pub(crate) fn pad_far(xyz: &mut [Vec<f32>; 3], from: usize) {
    let padded = from + (xyz[0].len() - from).next_multiple_of(LANES);
    for v in xyz {
        v.resize(padded, FAR);
    }
}

/// Where a cell's lanes are centred: the middle of its points' bounds.
pub(crate) fn centre((lo, hi): (DVec3, DVec3)) -> DVec3 {
    // Not (lo + hi) / 2, which overflows near the largest f64.
    lo + (hi - lo) * 0.5
}

/// A cell's candidates in lanes, borrowed: their coordinates (as in
/// [`Lanes`]) and coefficients, each padded to the same multiple of
/// [`LANES`]. A [`crate::Binding`] keeps the coordinates and fills the
/// coefficients of each new deformation.
#[derive(Clone, Copy, Debug)]
pub(crate) struct View<'a> {
    pub(crate) xyz: [&'a [f32]; 3],
    pub(crate) alpha: [&'a [f32]; 3],
}

/// Points whose kernel sums are computed in one call.
const CHUNK: usize = 16;

/// The widest cell, in R, whose kernel sum runs in f32 about its centre
/// (cells are about R/2 wide when there are enough starts to sort points;
/// with few starts points run in their own order, a cell may span the
/// model, and f32 coordinates about its centre would lose digits).
const LANES_CELL: f64 = 4.0;

/// The finite bounds of a cell's points (an empty box when none is finite).
fn bounds<P: Point>(points: &[P], idx: &[u32]) -> (DVec3, DVec3) {
    finite_bounds(idx.iter().map(|&i| points[i as usize].to_dvec3()))
}

/// The bounds of the finite ones of `points` (an empty box when none is).
pub(crate) fn finite_bounds(points: impl Iterator<Item = DVec3>) -> (DVec3, DVec3) {
    points.filter(|x| x.is_finite()).fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(p), hi.max(p)),
    )
}

/// Whether a cell's kernel sum runs in f32 lanes.
pub(crate) fn narrow((lo, hi): (DVec3, DVec3), radius: f64) -> bool {
    (hi - lo).max_element() <= LANES_CELL * radius
}

/// [`Deformation::displacements_f32`]: by cells, each narrow cell's kernel
/// sum eight or sixteen candidates at a time in f32, a wide one's in f64 as
/// [`Deformation::displacements`] does; the polynomial part in f64.
pub(crate) fn displacements<P: Point>(d: &Deformation, points: &[P], out: &mut [Vec3]) {
    let blocks = Blocks::for_starts(points, d.radius(), d.starts().len());
    let (kernel, radius, alpha) = (d.kernel(), d.radius(), d.coefficients());
    let linear = d.affine().map(|a| a.linear());
    let sums_of = Sums::of(Avx2Fma::detect(), kernel);
    let reach = d.f32_reach();
    let out = Scatter::new(out);
    let cell = |(lanes, cand, xs64): &mut (Lanes, Candidates, Vec<DVec3>),
                &(s, e): &(usize, usize)| {
        let idx = &blocks.order[s..e];
        // The cell's points read once from their places in the caller's
        // order (scattered: the first touch of each is what costs), then
        // from this copy for the bounds, the frame and the polynomial part.
        xs64.clear();
        xs64.extend(idx.iter().map(|&i| points[i as usize].to_dvec3()));
        let cell = finite_bounds(xs64.iter().copied());
        let mut narrow = narrow(cell, radius);
        if narrow {
            lanes.gather(d.octree(), alpha, cell, radius);
            // Coefficients far larger than the moves cancel: f32 would
            // keep only their rounding.
            narrow = lanes.reach() <= reach;
        }
        if !narrow {
            cand.gather(d.octree(), xs64.iter().copied(), radius);
        }
        // The places of a chunk's points are fetched while the chunk
        // before sums (a point a cache line, when the caller's order is not
        // the cells'; in runs of the caller's order they are consecutive).
        let ahead = |from: usize| {
            if blocks.identity {
                return;
            }
            for &i in &idx[from.min(idx.len())..(from + CHUNK).min(idx.len())] {
                out.prefetch(i as usize);
            }
        };
        ahead(0);
        // A chunk's points' kernel sums in one call (two points at a time).
        let (mut local_xs, mut sums) = ([[0.0f32; 3]; CHUNK], [[0.0f32; 3]; CHUNK]);
        for (n, (chunk, xs)) in idx.chunks(CHUNK).zip(xs64.chunks(CHUNK)).enumerate() {
            ahead((n + 1) * CHUNK);
            if narrow {
                for (l, &x) in local_xs.iter_mut().zip(xs) {
                    *l = lanes.local(x);
                }
                sums_of.run(
                    lanes.view(),
                    &local_xs[..chunk.len()],
                    &mut sums[..chunk.len()],
                );
            }
            for ((&i, &x), sum) in chunk.iter().zip(xs).zip(&sums) {
                let v = if !x.is_finite() {
                    Vec3::NAN
                } else {
                    let mut v = linear.map_or(DVec3::ZERO, |l| l.eval(x));
                    if narrow {
                        v += DVec3::from_array(sum.map(f64::from));
                    } else {
                        cand.for_each_weight(x, kernel, radius, |j, w| v += alpha[j as usize] * w);
                    }
                    v.as_vec3()
                };
                // SAFETY: `i` is this cell's own point (`Blocks::order` is a
                // permutation and the cells do not overlap).
                #[allow(unsafe_code)]
                unsafe {
                    out.write(i as usize, v)
                };
            }
        }
    };
    if points.len() >= PARALLEL_POINTS {
        blocks
            .cells
            .par_iter()
            .with_min_len(2)
            .for_each_init(Default::default, cell);
    } else {
        let mut scratch = Default::default();
        blocks.cells.iter().for_each(|c| cell(&mut scratch, c));
    }
}

/// What [`Deformation::displacements_f32`] does at some points, counted
/// ([`Deformation::evaluation_counts`]): the figures a reader needs to set
/// its time against the machine's arithmetic rate.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[non_exhaustive]
pub struct EvaluationCounts {
    /// Points with finite coordinates.
    pub points: u64,
    /// Cells, each one octree query for its candidate starts.
    pub cells: u64,
    /// Point-candidate pairs visited: every point against every start its
    /// cell gathered (within R of the cell's bounds).
    pub candidates: u64,
    /// Kernel evaluations computed: in f32 lanes, each point's candidates
    /// rounded up to a multiple of eight (the sixteen-lane sum computes a
    /// cell's odd last eight in a register of sixteen, half of it masked:
    /// not counted); in the f64 path of a wide cell, one per hit.
    pub kernel_evaluations: u64,
    /// Pairs within R: the nonzero terms of the sums.
    pub hits: u64,
}

impl Deformation {
    /// Counts what [`Deformation::displacements_f32`] does at `points` (the
    /// same cells, the same candidates), without evaluating: cells,
    /// candidates visited, kernel evaluations and hits. A separate pass, so
    /// the evaluation itself carries no counters.
    pub fn evaluation_counts<P: Point>(&self, points: &[P]) -> EvaluationCounts {
        let blocks = Blocks::for_starts(points, self.radius(), self.starts().len());
        let radius = self.radius();
        let mut counts = vec![EvaluationCounts::default(); blocks.cells.len()];
        let one_each = Blocks {
            order: Vec::new(),
            cells: (0..counts.len()).map(|c| (c, c + 1)).collect(),
            identity: false,
        };
        let parallel = points.len() >= PARALLEL_POINTS;
        for_each_cell_with(
            &one_each,
            &mut counts,
            parallel,
            |(c, _), out, (lanes, cand): &mut (Lanes, Candidates)| {
                let (s, e) = blocks.cells[c];
                let idx = &blocks.order[s..e];
                let cell = bounds(points, idx);
                let narrow = narrow(cell, radius);
                let (gathered, computed) = if narrow {
                    lanes.gather(self.octree(), self.coefficients(), cell, radius);
                    (lanes.candidates(), lanes.lanes())
                } else {
                    let xs = idx.iter().map(|&i| points[i as usize].to_dvec3());
                    cand.gather(self.octree(), xs, radius);
                    (cand.len(), 0)
                };
                let n = &mut out[0];
                n.cells = 1;
                for &i in idx {
                    let x = points[i as usize].to_dvec3();
                    if !x.is_finite() {
                        continue;
                    }
                    let mut hits = 0;
                    self.octree().for_each_within(x, radius, |_, _| hits += 1);
                    n.points += 1;
                    n.candidates += gathered as u64;
                    n.hits += hits;
                    n.kernel_evaluations += if narrow { computed as u64 } else { hits };
                }
            },
        );
        counts
            .iter()
            .fold(EvaluationCounts::default(), |a, b| EvaluationCounts {
                points: a.points + b.points,
                cells: a.cells + b.cells,
                candidates: a.candidates + b.candidates,
                kernel_evaluations: a.kernel_evaluations + b.kernel_evaluations,
                hits: a.hits + b.hits,
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `displacements_f32` (cells, f32 lanes) against `displacements` (f64)
    /// on scenes with enough starts to sort points into cells, with and
    /// without the polynomial part, a point count that is no multiple of
    /// eight, a non-finite point; and its counts against brute force.
    #[test]
    fn the_f32_evaluation_agrees_with_the_f64_one_and_is_counted() {
        use crate::{Deformation, Polynomial};
        for poly in [Polynomial::None, Polynomial::Linear] {
            let s = crate::synthetic::scene_of("t", 3001, 300, None);
            let options = s.options.with_polynomial(poly);
            let d = Deformation::fit(&s.starts, &s.targets, options).expect("fit");
            let mut points = s.points.clone();
            points[17].x = f32::NAN;
            let (got, want) = (d.displacements_f32(&points), d.displacements(&points));
            let radius = d.radius();
            let mut pairs = 0;
            for (k, p) in points.iter().enumerate() {
                if k == 17 {
                    assert!(got[k].is_nan() && want[k].is_nan());
                    continue;
                }
                let p = p.as_dvec3();
                let near = d.starts().iter().zip(d.coefficients());
                let near = near.filter(|(s, _)| s.distance(p) < radius);
                let scale: f64 = near.map(|(_, a)| a.length()).sum::<f64>() + 1e-30;
                pairs += d.starts().iter().filter(|s| s.distance(p) < radius).count() as u64;
                let err = (got[k].as_dvec3() - want[k]).length();
                assert!(
                    err <= 2e-6 * scale + 1e-7 * want[k].length(),
                    "{k}: {err:e}"
                );
            }
            let c = d.evaluation_counts(&points);
            assert_eq!(c.points, points.len() as u64 - 1);
            assert_eq!(c.hits, pairs);
            assert!(c.cells > 1 && c.candidates >= c.hits);
            assert!(c.kernel_evaluations >= c.candidates);
            assert!(c.kernel_evaluations < c.candidates + LANES as u64 * c.points);
        }
    }
}
