//! Blocked evaluation: points are bucketed into cells about R/2 wide, the
//! octree is asked once per cell for the starts near the cell's bounds, and
//! each point of the cell is tested against that short candidate list.

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use crate::kernel::Kernel;
use crate::octree::Octree;

/// A point type the engine evaluates at: f64 ([`DVec3`]) for numerics, f32
/// ([`Vec3`]) for vertex buffers. Public functions taking `&[P]` are thin
/// shells: they hand the slice to code compiled once inside this crate
/// ([`Point::slice`]), so its speed does not depend on the caller's build.
/// Sealed: implemented for `Vec3` and `DVec3` only.
pub trait Point: Copy + Send + Sync + sealed::Sealed {
    /// The point in f64.
    fn to_dvec3(self) -> DVec3;
    /// The slice as one of the two concrete kinds.
    fn slice(points: &[Self]) -> Points<'_>;
    /// The mutable slice as one of the two concrete kinds.
    fn slice_mut(points: &mut [Self]) -> PointsMut<'_>;
}

mod sealed {
    pub trait Sealed {}
    impl Sealed for glam::Vec3 {}
    impl Sealed for glam::DVec3 {}
}

/// A mutable slice of points of one of the two kinds.
#[derive(Debug)]
pub enum PointsMut<'a> {
    /// f32 points (vertex buffers).
    F32(&'a mut [Vec3]),
    /// f64 points.
    F64(&'a mut [DVec3]),
}

/// A slice of points of one of the two kinds [`Point`] is implemented for.
#[derive(Clone, Copy, Debug)]
pub enum Points<'a> {
    /// f32 points (vertex buffers).
    F32(&'a [Vec3]),
    /// f64 points.
    F64(&'a [DVec3]),
}

impl Point for DVec3 {
    #[inline]
    fn to_dvec3(self) -> DVec3 {
        self
    }
    fn slice(points: &[Self]) -> Points<'_> {
        Points::F64(points)
    }
    fn slice_mut(points: &mut [Self]) -> PointsMut<'_> {
        PointsMut::F64(points)
    }
}

impl Point for Vec3 {
    #[inline]
    fn to_dvec3(self) -> DVec3 {
        self.as_dvec3()
    }
    fn slice(points: &[Self]) -> Points<'_> {
        Points::F32(points)
    }
    fn slice_mut(points: &mut [Self]) -> PointsMut<'_> {
        PointsMut::F32(points)
    }
}

/// Points grouped by cell: `order` lists point indices cell by cell and
/// `cells[c]` is the range of cell `c` in it.
pub(crate) struct Blocks {
    pub(crate) order: Vec<u32>,
    pub(crate) cells: Vec<(usize, usize)>,
    /// Whether `order` is 0, 1, 2, ...: points were left in their order.
    pub(crate) identity: bool,
}

/// A buffer written by parallel tasks at scattered places, each place by
/// one task (a cell writes its points' values where the caller's order
/// puts them: no sorted copy and no second pass).
pub(crate) struct Scatter<'a, T> {
    ptr: *mut T,
    len: usize,
    _buffer: std::marker::PhantomData<&'a mut [T]>,
}

// SAFETY: the tasks write disjoint elements (see `Scatter::write`).
#[allow(unsafe_code)]
unsafe impl<T: Send> Send for Scatter<'_, T> {}
// SAFETY: as above.
#[allow(unsafe_code)]
unsafe impl<T: Send> Sync for Scatter<'_, T> {}

impl<'a, T> Scatter<'a, T> {
    /// Shares `out` for the time of the borrow.
    pub(crate) fn new(out: &'a mut [T]) -> Scatter<'a, T> {
        Scatter {
            ptr: out.as_mut_ptr(),
            len: out.len(),
            _buffer: std::marker::PhantomData,
        }
    }

    /// Writes element `i` (a bounds-checked index).
    ///
    /// # Safety
    /// No other task reads or writes element `i` while the buffer is shared:
    /// callers write place `k` of a cell's range in [`Blocks::order`] at
    /// `order[k]`; `order` is a permutation and cells do not overlap, so
    /// each index is written once, by one task.
    #[allow(unsafe_code)]
    #[inline]
    pub(crate) unsafe fn write(&self, i: usize, v: T) {
        assert!(i < self.len, "a point's place is within the buffer");
        // SAFETY: in bounds (checked above); no other access (the caller's promise).
        unsafe { self.ptr.add(i).write(v) }
    }

    /// Asks the CPU to bring element `i`'s cache line in (a hint: no effect
    /// out of bounds or off x86-64), so that a later [`Scatter::write`]
    /// there does not wait for memory.
    #[inline]
    pub(crate) fn prefetch(&self, i: usize) {
        #[cfg(target_arch = "x86_64")]
        if i < self.len {
            use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
            // SAFETY: a prefetch never faults, and `i` is in bounds.
            #[allow(unsafe_code)]
            unsafe {
                _mm_prefetch::<_MM_HINT_T0>(self.ptr.add(i).cast::<i8>().cast_const());
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = i;
    }
}

/// With this many starts or fewer, every start is a candidate for every
/// point: sorting points into cells would cost more than it saves.
const FEW_STARTS: usize = 48;

/// Refuses more points than a `u32` index names: the cells' order would
/// not be a permutation, and the tasks writing each point's place would
/// share places (more than 4 billion points: about 51 GB of f32 points).
fn assert_indexable(n: usize) {
    assert!(
        u32::try_from(n).is_ok(),
        "{n} points: at most {} can be sorted into cells",
        u32::MAX
    );
}

/// Points below this count are sorted into cells on one thread.
const PARALLEL_SORT: usize = 1 << 15;

/// Points below this count are evaluated on one thread.
pub(crate) const PARALLEL_POINTS: usize = 512;

impl Blocks {
    /// Groups `points` for evaluation against `starts` starts of radius R:
    /// runs of points in their own order when there are few starts, else
    /// cells about R/2 wide.
    pub(crate) fn for_starts<P: Point>(points: &[P], radius: f64, starts: usize) -> Blocks {
        assert_indexable(points.len());
        if starts > FEW_STARTS {
            return Blocks::new(points, radius * 0.5);
        }
        let n = points.len();
        const RUN: usize = 256;
        Blocks {
            order: (0..n as u32).collect(),
            cells: (0..n.div_ceil(RUN))
                .map(|c| (c * RUN, ((c + 1) * RUN).min(n)))
                .collect(),
            identity: true,
        }
    }

    /// Buckets `points` into cells of about `cell` width by a counting sort.
    pub(crate) fn new<P: Point>(points: &[P], cell: f64) -> Blocks {
        let n = points.len();
        assert_indexable(n);
        if n == 0 {
            return Blocks {
                order: Vec::new(),
                cells: Vec::new(),
                identity: true,
            };
        }
        let parallel = n >= PARALLEL_SORT;
        let (lo, hi) = if parallel {
            let empty = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
            points
                .par_chunks(PARALLEL_SORT)
                .map(point_bounds)
                .reduce(|| empty, |a, b| (a.0.min(b.0), a.1.max(b.1)))
        } else {
            point_bounds(points)
        };
        let extent = (hi - lo).max(DVec3::ZERO);
        let cap = (4 * n).clamp(64, 1 << 23) as f64;
        let mut h = if cell > 0.0 && cell.is_finite() {
            cell
        } else {
            extent.max_element().max(1.0)
        };
        let dims_of = |h: f64| (extent / h).floor().max(DVec3::ZERO) + 1.0;
        let mut dims = dims_of(h);
        while !(dims.x * dims.y * dims.z <= cap) {
            let grow = ((dims.x * dims.y * dims.z) / cap).cbrt().max(1.01);
            h = if grow.is_finite() {
                h * grow
            } else {
                extent.max_element().max(1.0)
            };
            dims = dims_of(h);
        }
        let d = [dims.x as usize, dims.y as usize, dims.z as usize];
        // A multiplication a point, not three divisions (a point on a
        // cell's face may land in its neighbour: either is right).
        let inv_h = 1.0 / h;
        let (lo, last) = (lo.to_array(), (dims - 1.0).to_array());
        let key = move |p: DVec3| -> usize {
            let p = p.to_array();
            let [ix, iy, iz] = std::array::from_fn(|a| {
                // Clamped as floats (`f64::max` and `min` ignore NaN: NaN
                // goes to cell 0, infinities to the first or last), so the
                // conversion needs no check and the key no branch.
                let v = ((p[a] - lo[a]) * inv_h).max(0.0).min(last[a]);
                debug_assert!((0.0..=last[a]).contains(&v));
                // SAFETY: `v` is finite and in 0..=d - 1 (clamped above),
                // and d - 1 < 2^23 (the cap), so it fits an i32 (whose
                // conversion vectorises).
                #[allow(unsafe_code)]
                let v = unsafe { v.to_int_unchecked::<i32>() };
                v as usize
            });
            ix + d[0] * (iy + d[1] * iz)
        };
        let buckets = d[0] * d[1] * d[2];
        // In parallel, each of a few runs of points counts its own buckets
        // (a histogram a run: only when the buckets are no more than the
        // points, so the histograms stay smaller than the points).
        let runs = if parallel {
            rayon::current_num_threads()
                .clamp(1, MAX_SORT_RUNS)
                .min(n / buckets.max(1))
                .max(1)
        } else {
            1
        };
        let (order, cells) = if runs > 1 {
            counting_sort_parallel(points, key, buckets, runs)
        } else {
            let keys: Vec<u32> = if parallel {
                points
                    .par_iter()
                    .map(|p| key(p.to_dvec3()) as u32)
                    .collect()
            } else {
                points.iter().map(|p| key(p.to_dvec3()) as u32).collect()
            };
            counting_sort(&keys, buckets)
        };
        Blocks {
            order,
            cells,
            identity: false,
        }
    }

    /// Splits `out` (one value per point, in `order`) into one slice per cell.
    pub(crate) fn split<'a, T>(&self, mut out: &'a mut [T]) -> Vec<&'a mut [T]> {
        let mut slices = Vec::with_capacity(self.cells.len());
        for &(s, e) in &self.cells {
            let (head, tail) = out.split_at_mut(e - s);
            slices.push(head);
            out = tail;
        }
        slices
    }
}

/// The bounds of `points` (NaN ignored, infinities kept), eight points at
/// a time in their own precision, so that the comparisons run in vectors.
fn point_bounds<P: Point>(points: &[P]) -> (DVec3, DVec3) {
    match P::slice(points) {
        Points::F32(p) => {
            let (lo, hi) = bounds_of(p, |p| p.to_array(), f32::INFINITY, f32::min, f32::max);
            (Vec3::from(lo).as_dvec3(), Vec3::from(hi).as_dvec3())
        }
        Points::F64(p) => {
            let (lo, hi) = bounds_of(p, |p| p.to_array(), f64::INFINITY, f64::min, f64::max);
            (DVec3::from(lo), DVec3::from(hi))
        }
    }
}

/// The bounds of `points` by coordinate, each of eight lanes of
/// accumulators taking every eighth point (`min` and `max` ignore NaN).
#[inline(always)]
fn bounds_of<T, E: Copy + std::ops::Neg<Output = E>>(
    points: &[T],
    coords: impl Fn(&T) -> [E; 3],
    infinity: E,
    min: impl Fn(E, E) -> E,
    max: impl Fn(E, E) -> E,
) -> ([E; 3], [E; 3]) {
    const W: usize = 8;
    let (mut lo, mut hi) = ([infinity; 3 * W], [-infinity; 3 * W]);
    let chunks = points.chunks_exact(W);
    let rest = chunks.remainder();
    for chunk in chunks {
        let mut c = [infinity; 3 * W];
        for (k, p) in chunk.iter().enumerate() {
            c[3 * k..3 * k + 3].copy_from_slice(&coords(p));
        }
        for k in 0..3 * W {
            lo[k] = min(lo[k], c[k]);
            hi[k] = max(hi[k], c[k]);
        }
    }
    let (mut l, mut h) = ([infinity; 3], [-infinity; 3]);
    for (k, (&a, &b)) in lo.iter().zip(&hi).enumerate() {
        (l[k % 3], h[k % 3]) = (min(l[k % 3], a), max(h[k % 3], b));
    }
    for p in rest {
        for (k, v) in coords(p).into_iter().enumerate() {
            (l[k], h[k]) = (min(l[k], v), max(h[k], v));
        }
    }
    (l, h)
}

/// `keys[k] = key(points[k])`, compiled again with AVX2 where the CPU has
/// it (the keys' arithmetic vectorises four points at a time).
fn fill_keys<P: Point>(points: &[P], keys: &mut [u32], key: &impl Fn(DVec3) -> usize) {
    #[inline(always)]
    fn body<P: Point>(points: &[P], keys: &mut [u32], key: &impl Fn(DVec3) -> usize) {
        for (p, k) in points.iter().zip(keys) {
            *k = key(p.to_dvec3()) as u32;
        }
    }
    #[cfg(target_arch = "x86_64")]
    if crate::simd::Avx2Fma::detect().is_some() {
        /// `body` with AVX2.
        ///
        /// # Safety
        /// The CPU has AVX2 and FMA.
        #[target_feature(enable = "avx2,fma")]
        #[allow(unsafe_code)]
        unsafe fn avx2<P: Point>(points: &[P], keys: &mut [u32], key: &impl Fn(DVec3) -> usize) {
            body(points, keys, key);
        }
        // SAFETY: an `Avx2Fma` exists only where the CPU has both.
        #[allow(unsafe_code)]
        unsafe {
            avx2(points, keys, key)
        };
        return;
    }
    body(points, keys, key);
}

/// Runs of points counted apart by a parallel sort into cells, at most.
const MAX_SORT_RUNS: usize = 8;

/// The points' indices bucket by bucket (`keys` gives each point's bucket,
/// below `buckets`), each bucket's in increasing order, and the non-empty
/// buckets' ranges in that list.
fn counting_sort(keys: &[u32], buckets: usize) -> (Vec<u32>, Vec<(usize, usize)>) {
    let mut counts = vec![0u32; buckets + 1];
    for &k in keys {
        counts[k as usize + 1] += 1;
    }
    for c in 1..counts.len() {
        counts[c] += counts[c - 1];
    }
    // The non-empty buckets, from the running counts (no pass over the
    // sorted points).
    let cells = counts
        .windows(2)
        .filter(|w| w[1] > w[0])
        .map(|w| (w[0] as usize, w[1] as usize))
        .collect();
    let mut next = counts;
    let mut order = vec![0u32; keys.len()];
    for (i, &k) in keys.iter().enumerate() {
        order[next[k as usize] as usize] = i as u32;
        next[k as usize] += 1;
    }
    (order, cells)
}

/// [`counting_sort`] on threads, the same result (`key` gives a point's
/// bucket): `runs` consecutive runs of points each compute their keys and
/// count their buckets at once; a bucket's places go to the runs in order
/// (so within a bucket, points stay in increasing order); then each run
/// writes its points' indices into its own places.
fn counting_sort_parallel<P: Point>(
    points: &[P],
    key: impl Fn(DVec3) -> usize + Sync,
    buckets: usize,
    runs: usize,
) -> (Vec<u32>, Vec<(usize, usize)>) {
    let n = points.len();
    let size = n.div_ceil(runs);
    let mut keys = vec![0u32; n];
    let mut places: Vec<Vec<u32>> = points
        .par_chunks(size)
        .zip(keys.par_chunks_mut(size))
        .map(|(ps, ks)| {
            // The keys first, then the counts: apart, each loop runs
            // without waiting on the other's memory.
            fill_keys(ps, ks, &key);
            let mut counts = vec![0u32; buckets];
            for &k in ks.iter() {
                counts[k as usize] += 1;
            }
            counts
        })
        .collect();
    // Each run's first place in each bucket, and the non-empty buckets.
    let mut cells = Vec::new();
    let mut next = 0u32;
    for b in 0..buckets {
        let first = next;
        for run in &mut places {
            let count = run[b];
            run[b] = next;
            next += count;
        }
        if next > first {
            cells.push((first as usize, next as usize));
        }
    }
    let mut order = vec![0u32; n];
    let out = Scatter::new(&mut order);
    keys.par_chunks(size)
        .zip(places.par_iter_mut())
        .enumerate()
        .for_each(|(r, (ks, place))| {
            for (j, &k) in ks.iter().enumerate() {
                let at = &mut place[k as usize];
                // SAFETY: each place is handed out once: the runs' places
                // in a bucket are disjoint ranges (the prefix sums above),
                // and a run advances its own.
                #[allow(unsafe_code)]
                unsafe {
                    out.write(*at as usize, (r * size + j) as u32)
                };
                *at += 1;
            }
        });
    (order, cells)
}

/// Candidate starts for a cell, gathered once, laid out by coordinate so
/// that the distance test runs over plain arrays (vectorised).
#[derive(Default)]
pub(crate) struct Candidates {
    xs: Vec<f64>,
    ys: Vec<f64>,
    zs: Vec<f64>,
    id: Vec<u32>,
    cpu: Option<crate::simd::Avx2Fma>,
    /// The bounds of the cell's points the candidates were gathered for.
    lo: DVec3,
    hi: DVec3,
}

impl Candidates {
    /// The starts within `radius` of the bounds of `cell_points`.
    pub(crate) fn gather(
        &mut self,
        octree: &Octree,
        cell_points: impl Iterator<Item = DVec3>,
        radius: f64,
    ) {
        let (lo, hi) = cell_points.fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), p| (lo.min(p), hi.max(p)),
        );
        self.xs.clear();
        self.ys.clear();
        self.zs.clear();
        self.id.clear();
        (self.lo, self.hi) = (lo, hi);
        octree.for_each_near_box(lo, hi, radius, |i, p| {
            self.xs.push(p.x);
            self.ys.push(p.y);
            self.zs.push(p.z);
            self.id.push(i);
        });
        self.cpu = crate::simd::Avx2Fma::detect();
    }

    /// Candidates gathered.
    pub(crate) fn len(&self) -> usize {
        self.id.len()
    }

    /// Calls `f(base, bits)` for every 64 candidates from `base`: bit `k`
    /// of `bits` is set when candidate `base + k` is closer than `radius`
    /// to `x` (the test of [`Candidates::for_each_offset`]).
    #[inline(always)]
    pub(crate) fn for_each_hit_mask(&self, x: DVec3, radius: f64, mut f: impl FnMut(usize, u64)) {
        let r2 = radius * radius;
        let n = self.xs.len();
        for base in (0..n).step_by(64) {
            let end = (base + 64).min(n);
            let (xs, ys, zs) = (
                &self.xs[base..end],
                &self.ys[base..end],
                &self.zs[base..end],
            );
            f(
                base,
                crate::simd::hit_mask(self.cpu, xs, ys, zs, x.to_array(), r2),
            );
        }
    }

    /// Calls `f(start index, phi)` for every candidate within `radius` of `x`.
    #[inline]
    pub(crate) fn for_each_weight(
        &mut self,
        x: DVec3,
        kernel: Kernel,
        radius: f64,
        f: impl FnMut(u32, f64),
    ) {
        // One copy of the loop per kernel, so phi is inlined in it.
        match kernel {
            Kernel::C0 => self.weights(x, radius, |r| Kernel::C0.eval(r), f),
            Kernel::C2 => self.weights(x, radius, |r| Kernel::C2.eval(r), f),
            Kernel::C4 => self.weights(x, radius, |r| Kernel::C4.eval(r), f),
            Kernel::C6 => self.weights(x, radius, |r| Kernel::C6.eval(r), f),
        }
    }

    /// An upper bound of |sum_j alpha_j grad(phi_j)| (spectral norm) over
    /// every point of the cell: sum_j |alpha_j| max|phi'| / R, the maximum
    /// of |phi'| taken over the distances the cell's box leaves possible.
    pub(crate) fn gradient_bound(&self, alpha: &[DVec3], kernel: Kernel, radius: f64) -> f64 {
        let inv = 1.0 / radius;
        let mut sum = 0.0;
        for k in 0..self.id.len() {
            let p = DVec3::new(self.xs[k], self.ys[k], self.zs[k]);
            let nearest = p.clamp(self.lo, self.hi);
            let r0 = p.distance(nearest) * inv;
            sum += alpha[self.id[k] as usize].length() * kernel.max_derivative_from(r0);
        }
        sum * inv
    }

    /// Calls `f(start index, x - start)` for every candidate closer than
    /// `radius` to `x`.
    #[inline(always)]
    pub(crate) fn for_each_offset(&mut self, x: DVec3, radius: f64, mut f: impl FnMut(u32, DVec3)) {
        // A bit mask of the hits per 64 candidates, then only the hits: no
        // branch per candidate (about half are hits, which a branch would
        // mispredict half the time).
        self.for_each_hit_mask(x, radius, |base, mut bits| {
            while bits != 0 {
                let k = base + bits.trailing_zeros() as usize;
                bits &= bits - 1;
                f(
                    self.id[k],
                    DVec3::new(x.x - self.xs[k], x.y - self.ys[k], x.z - self.zs[k]),
                );
            }
        });
    }

    #[inline(always)]
    fn weights(
        &mut self,
        x: DVec3,
        radius: f64,
        phi: impl Fn(f64) -> f64,
        mut f: impl FnMut(u32, f64),
    ) {
        let inv = 1.0 / radius;
        self.for_each_offset(x, radius, |j, off| f(j, phi(off.length() * inv)));
    }
}

/// Runs `work(cell_range, out_slice, candidates)` for every cell, in parallel
/// when there are enough points.
pub(crate) fn for_each_cell<T: Send>(
    blocks: &Blocks,
    out: &mut [T],
    parallel: bool,
    work: impl Fn((usize, usize), &mut [T], &mut Candidates) + Sync + Send,
) {
    for_each_cell_with(blocks, out, parallel, work);
}

/// Runs `work(scratch, cell)` for every one of `cells`, on the pool's
/// threads when `parallel` (a few cells a task at least, scratch made once
/// a task), else in order with one scratch: the loop over cells that writes
/// its own places (the f32 evaluation, a binding's product).
pub(crate) fn for_each_with_scratch<C: Sync, S: Default>(
    cells: &[C],
    parallel: bool,
    work: impl Fn(&mut S, &C) + Sync + Send,
) {
    if parallel {
        cells
            .par_iter()
            .with_min_len(2)
            .for_each_init(S::default, work);
    } else {
        let mut scratch = S::default();
        cells.iter().for_each(|c| work(&mut scratch, c));
    }
}

/// [`for_each_cell`] with scratch of any kind (one per thread).
pub(crate) fn for_each_cell_with<T: Send, S: Default>(
    blocks: &Blocks,
    out: &mut [T],
    parallel: bool,
    work: impl Fn((usize, usize), &mut [T], &mut S) + Sync + Send,
) {
    let slices = blocks.split(out);
    if parallel {
        blocks
            .cells
            .par_iter()
            .zip(slices)
            .with_min_len(2)
            .for_each_init(S::default, |scratch, (cell, out)| work(*cell, out, scratch));
    } else {
        let mut scratch = S::default();
        for (cell, out) in blocks.cells.iter().zip(slices) {
            work(*cell, out, &mut scratch);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synthetic::Rng;

    /// The parallel sort into cells is the serial one, index for index: for
    /// runs that do and do not divide the points, buckets crowded and
    /// empty, points that are not finite (bucket 0), f32 and f64 points.
    #[test]
    fn the_parallel_counting_sort_is_the_serial_one() {
        let mut rng = Rng::new(31);
        for (n, buckets) in [
            (1, 1),
            (7, 3),
            (1000, 1),
            (1000, 17),
            (4099, 512),
            (20_000, 30),
        ] {
            let mut points: Vec<DVec3> = (0..n).map(|_| rng.vec3()).collect();
            if n > 10 {
                points[3].y = f64::NAN;
                points[9] = DVec3::splat(f64::INFINITY);
            }
            // Buckets by x, then folded: some crowded, some empty.
            let key = |p: DVec3| ((p.x * 1.7 * buckets as f64) as usize) % buckets;
            let keys: Vec<u32> = points.iter().map(|p| key(*p) as u32).collect();
            let want = counting_sort(&keys, buckets);
            let mut seen = vec![false; n];
            for &i in &want.0 {
                assert!(!std::mem::replace(&mut seen[i as usize], true));
            }
            let narrow: Vec<Vec3> = points.iter().map(|p| p.as_vec3()).collect();
            let narrow_keys: Vec<u32> = narrow.iter().map(|p| key(p.as_dvec3()) as u32).collect();
            let narrow_want = counting_sort(&narrow_keys, buckets);
            for runs in 2..=MAX_SORT_RUNS {
                assert_eq!(
                    counting_sort_parallel(&points, key, buckets, runs),
                    want,
                    "{n} {runs}"
                );
                let got = counting_sort_parallel(&narrow, key, buckets, runs);
                assert_eq!(got, narrow_want, "f32 {n} {runs}");
            }
        }
    }
}
