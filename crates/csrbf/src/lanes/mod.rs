//! The f32 kernel sum of the vertex-buffer evaluation, eight or sixteen
//! points at a time.
//!
//! A cell's candidate starts are kept by coordinate, relative to the cell's
//! centre and in units of R (so every value is about 1 and f32 loses
//! nothing to the model's offset), with their coefficients. A register
//! holds a point a lane; each candidate in turn, broadcast, costs the
//! register one pass with no branch and no gather:
//!
//! ```text
//! d = c - x (3 sub), r^2 (mul + 2 fma), r = sqrt, t = max(1 - r, 0),
//! phi(t, r) (C2: 4 ops), sum += phi * alpha (3 fma)
//! ```
//!
//! about 16 vector operations per candidate and register of points (eight
//! or sixteen), where a hit test and a scalar kernel per hit cost about 40
//! instructions per hit. `t = max(1 - r, 0)` makes phi zero beyond R
//! (every Wendland function is (1 - r)_+^k times a polynomial), so misses
//! cost the same lanes and need no mask, and each lane's sums are its own:
//! nothing is added across lanes.
//!
//! [`Sums`] (in `sums`) computes that sum, chosen once for a kernel and
//! CPU: a plain reference one point at a time, an AVX2 copy of eight points
//! a register and an AVX-512 copy of sixteen. A [`crate::Binding`] keeps
//! the coordinates and fills each new deformation's coefficients into lanes
//! beside them.

mod roofline;
mod sums;
#[cfg(target_arch = "x86_64")]
mod vector;

pub use roofline::Roofline;
pub(crate) use sums::Sums;

use glam::{DVec3, Vec3};

use crate::deformation::{Deformation, Linear};

use crate::evaluate::{
    Blocks, Candidates, PARALLEL_POINTS, Point, Scatter, for_each_cell_with, for_each_with_scratch,
};
use crate::octree::Octree;
use crate::simd::Avx2Fma;

/// One cell's candidates by coordinate (units of R about `centre`) and
/// their coefficients.
#[derive(Debug, Default)]
pub(crate) struct Lanes {
    /// The candidates' indices.
    ids: Vec<u32>,
    xyz: [Vec<f32>; 3],
    alpha: [Vec<f32>; 3],
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
        coefficients: &Coefficients,
        (lo, hi): (DVec3, DVec3),
        radius: f64,
    ) {
        self.ids.clear();
        for v in &mut self.xyz {
            v.clear();
        }
        self.centre = centre((lo, hi));
        self.inv_radius = 1.0 / radius;
        gather_candidates(octree, (lo, hi), radius, &mut self.ids, &mut self.xyz);
        self.reach = coefficients.fill(&self.ids, &mut self.alpha);
    }

    /// The sum of the candidates' |coefficient|.
    pub(crate) fn reach(&self) -> f64 {
        self.reach
    }

    /// Candidates gathered.
    pub(crate) fn candidates(&self) -> usize {
        self.xyz[0].len()
    }

    /// x in the lanes' frame (units of R about the centre).
    #[cfg(test)]
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

/// Each start's coefficient as a cell's lanes take it (in f32) and its
/// size (|x| + |y| + |z| in f64: the scale of the f32 sums' rounding),
/// made once for an evaluation or a binding's product, not once for each
/// cell a start is a candidate of.
pub(crate) struct Coefficients {
    lanes: Vec<[f32; 3]>,
    sizes: Vec<f64>,
}

impl Coefficients {
    pub(crate) fn new(alpha: &[DVec3]) -> Coefficients {
        Coefficients {
            lanes: alpha.iter().map(|a| a.as_vec3().to_array()).collect(),
            sizes: alpha.iter().map(|a| a.abs().element_sum()).collect(),
        }
    }

    /// The coefficients of the starts `ids` into `out` by axis (cleared
    /// first); returns the sum of their sizes, added in `ids`' order.
    pub(crate) fn fill(&self, ids: &[u32], out: &mut [Vec<f32>; 3]) -> f64 {
        for v in out.iter_mut() {
            v.clear();
            v.resize(ids.len(), 0.0);
        }
        let [ax, ay, az] = out.each_mut().map(|v| &mut v[..]);
        let mut reach = 0.0;
        for (k, &j) in ids.iter().enumerate() {
            let a = self.lanes[j as usize];
            reach += self.sizes[j as usize];
            (ax[k], ay[k], az[k]) = (a[0], a[1], a[2]);
        }
        reach
    }
}

/// `x` in the frame of a cell's lanes: units of R (`inv_radius` = 1 / R)
/// about the cell's `centre`.
#[inline]
pub(crate) fn local(centre: DVec3, inv_radius: f64, x: DVec3) -> [f32; 3] {
    ((x - centre) * inv_radius).as_vec3().to_array()
}

/// Appends the starts within `radius` of the box `lo..hi` to `ids`, and
/// their coordinates in the lanes' frame (units of R about the box's
/// centre) to `xyz`.
pub(crate) fn gather_candidates(
    octree: &Octree,
    (lo, hi): (DVec3, DVec3),
    radius: f64,
    ids: &mut Vec<u32>,
    xyz: &mut [Vec<f32>; 3],
) {
    let (centre, inv) = (centre((lo, hi)), 1.0 / radius);
    octree.near_box_into((lo, hi), radius, ids, xyz, |p| local(centre, inv, p));
}

/// Where a cell's lanes are centred: the middle of its points' bounds.
pub(crate) fn centre((lo, hi): (DVec3, DVec3)) -> DVec3 {
    // Not (lo + hi) / 2, which overflows near the largest f64.
    lo + (hi - lo) * 0.5
}

/// A cell's candidates in lanes, borrowed: their coordinates (as in
/// [`Lanes`]) and coefficients. A [`crate::Binding`] keeps the coordinates
/// and fills the coefficients of each new deformation.
#[derive(Clone, Copy, Debug)]
pub(crate) struct View<'a> {
    pub(crate) xyz: [&'a [f32]; 3],
    pub(crate) alpha: [&'a [f32]; 3],
}

impl View<'_> {
    /// The candidates: the shortest array's length (all six have it).
    pub(crate) fn len(&self) -> usize {
        let lens = self.xyz.iter().chain(&self.alpha).map(|v| v.len());
        lens.min().unwrap_or(0)
    }
}

/// Points whose kernel sums are computed in one call: a multiple of every
/// copy's register (so a cell's points are computed rounded up to one
/// register, [`Sums::width`]), and of the blocks of two registers the
/// vector copies take.
pub(crate) const CHUNK: usize = 32;

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

/// A narrow cell's sums, ready to write: its lanes, the kernel sum chosen
/// for them, the polynomial part, its frame's centre and its places.
/// The evaluation and a binding's product both write a narrow cell with
/// it, so they give the same values bit for bit.
pub(crate) struct Narrow<'a> {
    pub(crate) view: View<'a>,
    pub(crate) sums: Sums,
    pub(crate) linear: Option<Linear>,
    /// The centre of the cell's lanes' frame and 1 / R: its points' frame
    /// is computed a chunk at a time ([`local`]'s operations).
    pub(crate) centre: DVec3,
    pub(crate) inv_radius: f64,
    /// The cell's places in the caller's order (`None`: its own, from
    /// `first`).
    pub(crate) places: Option<&'a [u32]>,
    pub(crate) first: usize,
}

impl Narrow<'_> {
    /// Writes the displacement of each of the cell's `points` (in cell
    /// order) at its place: a chunk at a time, the points' frame, the
    /// kernel sums, the polynomial part, then the chunk's writes. While a
    /// chunk sums, the next chunk's places are fetched into the cache, so
    /// that writing a point where the caller's order puts it (a cache line
    /// of its own, when that order is not the cells') does not wait for
    /// memory.
    ///
    /// # Safety
    /// Each of the cell's places (`places`, or `first..first + points.len()`)
    /// belongs to this call alone: no other task reads or writes `out` there
    /// while it runs (the cells' places are a permutation and do not
    /// overlap: see `Blocks`).
    #[allow(unsafe_code)]
    pub(crate) unsafe fn write<P: Point>(
        &self,
        points: &[P],
        out: &Scatter<'_, Vec3>,
        scratch: &mut ChunkScratch,
    ) {
        let ChunkScratch {
            x,
            frame,
            sums,
            v,
            values,
        } = scratch;
        let ahead = |from: usize| {
            if let Some(p) = self.places {
                for &i in &p[from.min(p.len())..(from + CHUNK).min(p.len())] {
                    out.prefetch(i as usize);
                }
            }
        };
        ahead(0);
        let linear = self.linear.unwrap_or(Linear::ZERO);
        let cpu = Avx2Fma::detect();
        for (n, chunk) in points.chunks(CHUNK).enumerate() {
            ahead((n + 1) * CHUNK);
            let from = n * CHUNK;
            // By coordinate (past the chunk's points: an earlier chunk's,
            // computed and not written).
            for (k, p) in chunk.iter().enumerate() {
                [x[0][k], x[1][k], x[2][k]] = p.to_dvec3().to_array();
            }
            // The frame (`local`'s operations, so the values a cell's lanes
            // were gathered about).
            let c = self.centre.to_array();
            for ((u, x), c) in frame.iter_mut().zip(&*x).zip(c) {
                for (u, x) in u.iter_mut().zip(x) {
                    *u = ((x - c) * self.inv_radius) as f32;
                }
            }
            let local = frame.each_ref().map(|u| &u[..chunk.len()]);
            let [sx, sy, sz] = &mut *sums;
            self.sums.run(self.view, local, [&mut sx[..], sy, sz]);
            eval_plus(cpu, &linear, x, sums, v);
            for (k, value) in values.iter_mut().enumerate().take(chunk.len()) {
                *value = Vec3::new(v[0][k], v[1][k], v[2][k]);
            }
            let values = &values[..chunk.len()];
            match self.places {
                Some(places) => {
                    for (&i, v) in places[from..from + chunk.len()].iter().zip(values) {
                        // SAFETY: the place is this call's alone (the
                        // caller's promise, above).
                        #[allow(unsafe_code)]
                        unsafe {
                            out.write(i as usize, *v)
                        };
                    }
                }
                None => {
                    for (k, v) in values.iter().enumerate() {
                        // SAFETY: as above.
                        #[allow(unsafe_code)]
                        unsafe {
                            out.write(self.first + from + k, *v)
                        };
                    }
                }
            }
        }
    }
}

/// A chunk's arrays for [`Narrow::write`], kept in a task's scratch from
/// cell to cell: zeroed when the scratch is made (once a task, as rayon
/// splits the cells), not for each chunk (a cell of a few points must not
/// pay for clearing them). Lanes past a chunk's points hold an earlier
/// chunk's values: computed, never written.
#[derive(Clone)]
pub(crate) struct ChunkScratch {
    x: [[f64; CHUNK]; 3],
    frame: [[f32; CHUNK]; 3],
    sums: [[f32; CHUNK]; 3],
    v: [[f32; CHUNK]; 3],
    values: [Vec3; CHUNK],
}

impl Default for ChunkScratch {
    fn default() -> ChunkScratch {
        ChunkScratch {
            x: [[0.0; CHUNK]; 3],
            frame: [[0.0; CHUNK]; 3],
            sums: [[0.0; CHUNK]; 3],
            v: [[0.0; CHUNK]; 3],
            values: [Vec3::ZERO; CHUNK],
        }
    }
}

/// [`Linear::eval_plus`] with AVX2 where the CPU has it (`cpu`).
#[inline]
fn eval_plus(
    cpu: Option<Avx2Fma>,
    linear: &Linear,
    x: &[[f64; CHUNK]; 3],
    sums: &[[f32; CHUNK]; 3],
    out: &mut [[f32; CHUNK]; 3],
) {
    #[cfg(target_arch = "x86_64")]
    if cpu.is_some() {
        /// `Linear::eval_plus` compiled with AVX2.
        ///
        /// # Safety
        /// The CPU has AVX2.
        #[target_feature(enable = "avx2,fma")]
        #[allow(unsafe_code)]
        unsafe fn avx2(
            linear: &Linear,
            x: &[[f64; CHUNK]; 3],
            sums: &[[f32; CHUNK]; 3],
            out: &mut [[f32; CHUNK]; 3],
        ) {
            linear.eval_plus(x, sums, out);
        }
        // SAFETY: an `Avx2Fma` exists only where the CPU has AVX2 and FMA.
        #[allow(unsafe_code)]
        unsafe {
            avx2(linear, x, sums, out)
        };
        return;
    }
    let _ = cpu;
    linear.eval_plus(x, sums, out);
}

/// Per-thread scratch of the evaluation: a cell's points, in f64 and in its
/// frame, its lanes, and its candidates when summed in f64.
#[derive(Default)]
struct Scratch {
    points: Vec<DVec3>,
    chunk: ChunkScratch,
    lanes: Lanes,
    candidates: Candidates,
}

/// [`Deformation::displacements_f32`]: by cells, each narrow cell's kernel
/// sum eight or sixteen points at a time in f32, a wide one's in f64 as
/// [`Deformation::displacements`] does; the polynomial part in f64.
pub(crate) fn displacements<P: Point>(d: &Deformation, points: &[P], out: &mut [Vec3]) {
    let blocks = Blocks::for_starts(points, d.radius(), d.starts().len());
    let (kernel, radius, alpha) = (d.kernel(), d.radius(), d.coefficients());
    let linear = d.affine().map(|a| a.linear());
    let sums = Sums::of(Avx2Fma::detect(), kernel);
    let reach = d.f32_reach();
    let coefficients = Coefficients::new(alpha);
    // The starts' grid built before the cells ask for it at once.
    d.octree().prepare_box_queries(radius);
    let out = Scatter::new(out);
    let cell = |s: &mut Scratch, &(first, end): &(usize, usize)| {
        let idx = &blocks.order[first..end];
        let places = (!blocks.identity).then_some(idx);
        // The cell's points read once from their places in the caller's
        // order (scattered: the first touch of each is what costs), then
        // from this copy for the bounds, the frame and the polynomial part.
        // (A copy in cell order written by the sort measured slower.)
        s.points.clear();
        s.points
            .extend(idx.iter().map(|&i| points[i as usize].to_dvec3()));
        let cell_points = &s.points[..];
        let cell = finite_bounds(cell_points.iter().copied());
        let mut narrow = narrow(cell, radius);
        if narrow {
            s.lanes.gather(d.octree(), &coefficients, cell, radius);
            // Coefficients far larger than the moves cancel: f32 would
            // keep only their rounding.
            narrow = s.lanes.reach() <= reach;
        }
        if narrow {
            let lanes = &s.lanes;
            let narrow = Narrow {
                view: lanes.view(),
                sums,
                linear,
                centre: lanes.centre,
                inv_radius: lanes.inv_radius,
                places,
                first,
            };
            // SAFETY: the cell's places are its own: `Blocks::order` is a
            // permutation and the cells do not overlap (or, points in their
            // own order, the cell's range is its own).
            #[allow(unsafe_code)]
            unsafe {
                narrow.write(cell_points, &out, &mut s.chunk)
            };
            return;
        }
        s.candidates
            .gather(d.octree(), cell_points.iter().copied(), radius);
        for (k, &x) in cell_points.iter().enumerate() {
            let v = if x.is_finite() {
                let mut v = linear.map_or(DVec3::ZERO, |l| l.eval(x));
                s.candidates
                    .for_each_weight(x, kernel, radius, |j, w| v += alpha[j as usize] * w);
                v.as_vec3()
            } else {
                Vec3::NAN
            };
            let place = places.map_or(first + k, |p| p[k] as usize);
            // SAFETY: `place` is this cell's own point (`Blocks::order` is
            // a permutation and the cells do not overlap).
            #[allow(unsafe_code)]
            unsafe {
                out.write(place, v)
            };
        }
    };
    for_each_with_scratch(&blocks.cells, points.len() >= PARALLEL_POINTS, cell);
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
    /// Kernel evaluations computed: in f32 lanes, a cell's candidates times
    /// its points rounded up to a register of points (eight or sixteen on
    /// a CPU with AVX2 or AVX-512, else one); in the f64 path of a wide
    /// cell, one per hit.
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
        let width = Sums::of(Avx2Fma::detect(), self.kernel()).width() as u64;
        let coefficients = Coefficients::new(self.coefficients());
        self.octree().prepare_box_queries(radius);
        for_each_cell_with(
            &one_each,
            &mut counts,
            parallel,
            |(c, _), out, (lanes, cand): &mut (Lanes, Candidates)| {
                let (s, e) = blocks.cells[c];
                let idx = &blocks.order[s..e];
                let cell = bounds(points, idx);
                let mut narrow = narrow(cell, radius);
                let gathered = if narrow {
                    lanes.gather(self.octree(), &coefficients, cell, radius);
                    // Coefficients that would cancel in f32 are summed in
                    // f64, hit by hit, as the evaluation sums them.
                    narrow = lanes.reach() <= self.f32_reach();
                    lanes.candidates()
                } else {
                    let xs = idx.iter().map(|&i| points[i as usize].to_dvec3());
                    cand.gather(self.octree(), xs, radius);
                    cand.len()
                };
                let n = &mut out[0];
                n.cells = 1;
                if narrow {
                    // Every point of the cell, finite or not, in registers.
                    let lanes = (idx.len() as u64).next_multiple_of(width);
                    n.kernel_evaluations = lanes * gathered as u64;
                }
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
                    if !narrow {
                        n.kernel_evaluations += hits;
                    }
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
            // Every cell narrow here: its candidates at its points rounded
            // up to a register (the one non-finite point included).
            let width = Sums::of(Avx2Fma::detect(), d.kernel()).width() as u64;
            let most = c.candidates + width * c.cells * d.starts().len() as u64;
            assert!(c.kernel_evaluations >= c.candidates && c.kernel_evaluations < most);
        }
    }
}
