//! The product a new deformation costs: per cell, the coefficients of its
//! candidates in a small table (f32, eight candidates a block, by
//! coordinate); per point, the sum over its mask's set bits of weight times
//! coefficient.
//!
//! The table's coefficients are scaled by the levels' step, so a stored
//! level (an integer below 2^24, exact in f32) multiplies them as it is.
//! With AVX2 and FMA a block of eight candidates is two 16-byte loads of
//! levels (the second from where the block's upper half's levels begin),
//! one byte shuffle that spreads the levels of the set bits to their lanes
//! and zeroes the others (`DECODE`), a conversion to f32, and three fused
//! multiply-adds in f32 lanes (as
//! [`crate::Deformation::displacements_f32`] sums); a point's
//! eight lanes are added by pairs in f32, the pairs in f64. No block is
//! skipped: whether a block is empty is as hard to predict as a coin, and a
//! mispredicted branch cost more than the block (refit 68 ms with the
//! branch, 26 ms without, at 1M points).
//! [`cell_plain`] is the same sum one hit at a time in f64: the reference of
//! the tests and the path without AVX2.
//!
//! Each cell writes its points' displacements straight to their places in
//! the caller's buffer (the binding's `order`), so a refit allocates
//! nothing and makes one pass. Those places are scattered when the
//! caller's order is not the cells' (a point a cache line), so a cell sums
//! its points sixteen at a time and asks for the next sixteen places' lines
//! meanwhile (at 1M points on a sphere: product 24 -> 21 ms). The
//! coefficient table sits on 32-byte boundaries: no load of it straddles
//! two cache lines.

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use super::{BLOCK, Binding, Cell, LEVEL_BYTES, LEVEL_TAIL, Levels};
use crate::deformation::{Deformation, Linear};
use crate::evaluate::{PARALLEL_POINTS, Point, Scatter};
use crate::simd::Avx2Fma;

/// f32 values per block of the coefficient table: x, y, z of eight candidates.
const TABLE: usize = 3 * BLOCK;

/// Eight f32 lanes on a 32-byte boundary: the coefficient table is made of
/// them, so that no load of a block's coefficients straddles two cache lines.
#[derive(Clone, Copy, Default)]
#[repr(C, align(32))]
struct Lanes([f32; BLOCK]);

/// The table's f32, block after block.
fn flat(table: &[Lanes]) -> &[f32] {
    // SAFETY: `Lanes` is `repr(C)`, eight f32 and 32 bytes (no padding), so
    // `table.len()` of them are `8 * table.len()` f32 in a row.
    #[allow(unsafe_code)]
    unsafe {
        std::slice::from_raw_parts(table.as_ptr().cast::<f32>(), table.len() * BLOCK)
    }
}

/// Points summed at a time: the places of the next chunk's points are
/// fetched into the cache while a chunk sums, so that writing a point where
/// the caller's order puts it (a cache line of its own, when the caller's
/// order is not the cells') does not wait for memory.
const CHUNK: usize = 16;

/// Per-thread scratch: the cell's coefficient table and a chunk's sums.
#[derive(Default)]
struct Scratch {
    table: Vec<Lanes>,
    sums: Vec<DVec3>,
}

/// Writes D of `d` at every bound point into `out` (point order; `out`
/// holds one vector per bound point).
pub(super) fn displacements(b: &Binding, d: &Deformation, out: &mut [Vec3]) {
    assert_eq!(out.len(), b.len(), "one displacement per bound point");
    let cpu = Avx2Fma::detect();
    let parallel = out.len() >= PARALLEL_POINTS;
    let out = Scatter::new(out);
    let work = |s: &mut Scratch, c: &Cell| cell(b, d, cpu, *c, s, &out);
    if parallel {
        b.cells
            .par_iter()
            .with_min_len(2)
            .for_each_init(Scratch::default, work);
    } else {
        let mut scratch = Scratch::default();
        b.cells.iter().for_each(|c| work(&mut scratch, c));
    }
}

/// One cell's points.
fn cell(
    b: &Binding,
    d: &Deformation,
    cpu: Option<Avx2Fma>,
    c: Cell,
    s: &mut Scratch,
    out: &Scatter<'_, Vec3>,
) {
    let alpha = d.coefficients();
    let step = Levels::of(b.kernel).per_level;
    s.table.clear();
    let g = &b.groups[c.group];
    let cell = c.point..c.point + c.points;
    // The cell's places in the caller's order (`None`: they are its own).
    let places = b.order.as_deref().map(|o| &o[cell.clone()]);
    let ids = &g.ids[c.id..c.id + c.blocks * BLOCK];
    // The table of coefficients (scaled by the step), and the sum of their
    // sizes in the same pass.
    let mut reach = 0.0;
    for block in ids.chunks_exact(BLOCK) {
        for axis in 0..3 {
            let mut lanes = Lanes::default();
            for (l, &j) in lanes.0.iter_mut().zip(block) {
                let a = alpha.get(j as usize).map_or(0.0, |a| a[axis]);
                reach += a.abs();
                *l = (a * step) as f32;
            }
            s.table.push(lanes);
        }
    }
    // Coefficients far larger than the moves cancel: f32 sums (and the
    // levels' rounding) would keep only their rounding, so such a cell is
    // computed in f64, as `Deformation::displacements` computes it.
    if reach > d.f32_reach() {
        let place = |k: usize| places.map_or(cell.start + k, |p| p[k] as usize);
        for k in 0..c.points {
            let x = match &b.rest {
                super::Rest::F32(p) => p[cell.start + k].as_dvec3(),
                super::Rest::F64(p) => p[cell.start + k],
            };
            // SAFETY: as in `Chunk::write`.
            #[allow(unsafe_code)]
            unsafe {
                out.write(place(k), d.displacement_at(x).as_vec3())
            };
        }
        return;
    }
    let linear = d.affine().map(|a| a.linear());
    let ahead = |from: usize| {
        if let Some(p) = places {
            for &i in &p[from.min(c.points)..(from + CHUNK).min(c.points)] {
                out.prefetch(i as usize);
            }
        }
    };
    ahead(0);
    let mut used = 0;
    for first in (0..c.points).step_by(CHUNK) {
        let n = CHUNK.min(c.points - first);
        // The next chunk's places are fetched while this one sums.
        ahead(first + CHUNK);
        s.sums.clear();
        s.sums.resize(n, DVec3::ZERO);
        let rows = &g.masks[c.mask + first * c.blocks..c.mask + (first + n) * c.blocks];
        used += cell_sums(
            cpu,
            rows,
            c.blocks,
            &g.levels[c.level + LEVEL_BYTES * used..],
            flat(&s.table),
            &mut s.sums,
        );
        let chunk = Chunk {
            sums: &s.sums,
            places: places.map(|p| &p[first..first + n]),
            first: cell.start + first,
        };
        match &b.rest {
            super::Rest::F32(p) => chunk.write(&p[chunk.first..chunk.first + n], linear, out),
            super::Rest::F64(p) => chunk.write(&p[chunk.first..chunk.first + n], linear, out),
        }
    }
    // Points with a non-finite coordinate (no hits; rare) get NaN.
    let from = b.nonfinite.partition_point(|&k| (k as usize) < cell.start);
    for &k in b.nonfinite[from..]
        .iter()
        .take_while(|&&k| cell.contains(&(k as usize)))
    {
        let i = places.map_or(k as usize, |p| p[k as usize - cell.start] as usize);
        // SAFETY: as in `Chunk::write`.
        #[allow(unsafe_code)]
        unsafe {
            out.write(i, Vec3::NAN)
        };
    }
}

/// A chunk of a cell's points: their kernel sums, their places in the
/// caller's order (`None`: their own, from `first`).
struct Chunk<'a> {
    sums: &'a [DVec3],
    places: Option<&'a [u32]>,
    first: usize,
}

impl Chunk<'_> {
    /// Writes each point's displacement (its sum, and the polynomial part at
    /// `rest`, the chunk's points) at its place in `out`.
    #[inline(always)]
    fn write<P: Point>(&self, rest: &[P], linear: Option<Linear>, out: &Scatter<'_, Vec3>) {
        let place = |k: usize| self.places.map_or(self.first + k, |p| p[k] as usize);
        for (k, (x, sum)) in rest.iter().zip(self.sums).enumerate() {
            let v = match linear {
                Some(l) => l.eval(x.to_dvec3()) + *sum,
                None => *sum,
            };
            // SAFETY: each place belongs to this chunk's cell alone, and
            // `order` maps places to points one to one (a permutation, see
            // `Blocks`).
            #[allow(unsafe_code)]
            unsafe {
                out.write(place(k), v.as_vec3())
            };
        }
    }
}

/// Each row's sum over the set bits of its `blocks` mask bytes of level
/// times (scaled) coefficient, into `sums`: [`cell_avx2`] where the CPU has
/// it, else [`cell_plain`]. Returns the levels used (the rows' set bits).
pub(super) fn cell_sums(
    cpu: Option<Avx2Fma>,
    rows: &[u8],
    blocks: usize,
    levels: &[u8],
    table: &[f32],
    sums: &mut [DVec3],
) -> usize {
    #[cfg(target_arch = "x86_64")]
    if let Some(cpu) = cpu {
        let _ = cpu;
        // SAFETY: an `Avx2Fma` exists only when the CPU has AVX2 and FMA.
        #[allow(unsafe_code)]
        if let Some(used) = unsafe { cell_avx2(rows, blocks, levels, table, sums) } {
            return used;
        }
    }
    let _ = cpu;
    cell_plain(rows, blocks, levels, table, sums)
}

/// Level `k` of `levels` (three bytes, little-endian).
pub(super) fn level(levels: &[u8], k: usize) -> u32 {
    let b = &levels[LEVEL_BYTES * k..LEVEL_BYTES * (k + 1)];
    u32::from_le_bytes([b[0], b[1], b[2], 0])
}

/// The reference: one hit at a time, in candidate order, in f64. Returns
/// the levels used.
pub(super) fn cell_plain(
    rows: &[u8],
    blocks: usize,
    levels: &[u8],
    table: &[f32],
    sums: &mut [DVec3],
) -> usize {
    let mut p = 0;
    for (row, sum) in rows.chunks_exact(blocks.max(1)).zip(sums) {
        *sum = DVec3::ZERO;
        for (b, &m) in row.iter().enumerate() {
            let t = &table[b * TABLE..(b + 1) * TABLE];
            let mut bits = m;
            while bits != 0 {
                let k = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let a = DVec3::new(t[k].into(), t[BLOCK + k].into(), t[2 * BLOCK + k].into());
                *sum += a * f64::from(level(levels, p));
                p += 1;
            }
        }
    }
    p
}

/// For each mask byte, the byte shuffle that spreads its set bits' levels
/// to their lanes: in each half (four lanes, 16 bytes), lane `k`, when bit
/// `k` is set, takes the three bytes of its level (the count of set bits
/// below it in its half, from the half's first level) and a zero; the
/// other lanes' bytes are 0x80 (zeroed). The lower half reads from the
/// block's first level, the upper from its first level past the lower
/// half's ([`STEPS`]).
static DECODE: [[u8; 32]; 256] = decode_table();

/// For each mask byte, the bytes from a block's first level to its upper
/// half's first (three times the set bits of the low four), and to the
/// next block's first (three times all its set bits).
static STEPS: [[u8; 2]; 256] = steps_table();

const fn decode_table() -> [[u8; 32]; 256] {
    let mut t = [[0x80; 32]; 256];
    let mut m = 0;
    while m < 256 {
        let mut half = 0;
        while half < 2 {
            let mut c = 0;
            let mut k = 0;
            while k < 4 {
                if (m >> (4 * half + k)) & 1 == 1 {
                    let mut byte = 0;
                    while byte < LEVEL_BYTES {
                        t[m][16 * half + 4 * k + byte] = (LEVEL_BYTES * c + byte) as u8;
                        byte += 1;
                    }
                    c += 1;
                }
                k += 1;
            }
            half += 1;
        }
        m += 1;
    }
    t
}

const fn steps_table() -> [[u8; 2]; 256] {
    let mut t = [[0; 2]; 256];
    let mut m = 0;
    while m < 256 {
        let low = (m as u8 & 15).count_ones() as usize;
        let all = (m as u8).count_ones() as usize;
        t[m] = [(LEVEL_BYTES * low) as u8, (LEVEL_BYTES * all) as u8];
        m += 1;
    }
    t
}

/// [`cell_plain`] with AVX2 and FMA: per block, the levels of its set bits
/// spread to their lanes and summed with the coefficients in f32 lanes
/// ([`row_avx2`]). Returns the levels used, or `None`, having written
/// nothing trustworthy, when a row's loads would leave `levels` or `table`
/// (a binding always leaves room; the caller then takes the plain sum).
///
/// # Safety
/// The CPU has AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
#[target_feature(enable = "avx2,fma")]
unsafe fn cell_avx2(
    rows: &[u8],
    blocks: usize,
    levels: &[u8],
    table: &[f32],
    sums: &mut [DVec3],
) -> Option<usize> {
    if blocks == 0 || table.len() < blocks * TABLE {
        return (blocks == 0).then_some(0);
    }
    let mut p = 0;
    for (row, sum) in rows.chunks_exact(blocks).zip(sums) {
        // A row's loads reach at most eight levels a byte, and the tail,
        // past its first.
        if p + LEVEL_BYTES * BLOCK * blocks + LEVEL_TAIL > levels.len() {
            return None;
        }
        // SAFETY: the row's blocks lie in `table` (checked above), its loads
        // of levels within `levels` (checked above); the CPU has AVX2 and
        // FMA (our caller's promise).
        let (total, used) = unsafe { row_avx2(row, levels.as_ptr().add(p), table.as_ptr()) };
        *sum = total;
        p += used;
    }
    Some(p / LEVEL_BYTES)
}

/// One row's sums: for each block (mask byte), the levels of its set bits
/// from `w` spread to their lanes (`DECODE`, the other lanes zeroed) and
/// multiplied into the block's coefficients (`t`, 24 f32 a block). Two
/// sets of accumulators, for even and odd blocks: with one, each block
/// waited for the previous block's fused multiply-adds. Returns the sums
/// and the bytes of levels used. Pointers advance by block (no index
/// arithmetic, no bounds checks in the loop: the caller checked the row's
/// extent).
///
/// # Safety
/// The CPU has AVX2 and FMA; `t` points at `24 * row.len()` f32, and `w`
/// at three bytes for each of the row's set bits plus [`LEVEL_TAIL`].
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn row_avx2(row: &[u8], mut w: *const u8, mut t: *const f32) -> (DVec3, usize) {
    use std::arch::x86_64::*;
    let first = w;
    let (mut even, mut odd) = ([_mm256_setzero_ps(); 3], [_mm256_setzero_ps(); 3]);
    let mut pairs = row.chunks_exact(2);
    for two in &mut pairs {
        // SAFETY: the caller's promise covers every block of the row.
        unsafe {
            w = block(two[0], w, t, &mut even);
            w = block(two[1], w, t.add(TABLE), &mut odd);
            t = t.add(2 * TABLE);
        }
    }
    if let [m] = pairs.remainder() {
        // SAFETY: as above.
        w = unsafe { block(*m, w, t, &mut even) };
    }
    // SAFETY: the CPU has AVX2; `w` advanced from `first` within one array.
    unsafe {
        (
            totals(
                _mm256_add_ps(even[0], odd[0]),
                _mm256_add_ps(even[1], odd[1]),
                _mm256_add_ps(even[2], odd[2]),
            ),
            w.offset_from(first) as usize,
        )
    }
}

/// Adds a block (mask byte `m`, levels from `w`, coefficients at `t`) to
/// `acc`; returns the next block's first level.
///
/// # Safety
/// The CPU has AVX2 and FMA; `w` points at 28 readable bytes (the block's
/// levels lie in them) and `t` at 24 f32.
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn block(
    m: u8,
    w: *const u8,
    t: *const f32,
    acc: &mut [std::arch::x86_64::__m256; 3],
) -> *const u8 {
    use std::arch::x86_64::*;
    let [upper, next] = STEPS[m as usize];
    // SAFETY: the 16 bytes at w and at w + upper (at most 12) are within
    // the caller's 28; DECODE has 32 bytes for every byte, t 24 f32.
    unsafe {
        let halves = _mm256_loadu2_m128i(w.add(upper as usize).cast(), w.cast());
        let spread = _mm256_loadu_si256(DECODE[m as usize].as_ptr().cast());
        let e = _mm256_cvtepi32_ps(_mm256_shuffle_epi8(halves, spread));
        acc[0] = _mm256_fmadd_ps(e, _mm256_loadu_ps(t), acc[0]);
        acc[1] = _mm256_fmadd_ps(e, _mm256_loadu_ps(t.add(BLOCK)), acc[1]);
        acc[2] = _mm256_fmadd_ps(e, _mm256_loadu_ps(t.add(2 * BLOCK)), acc[2]);
        w.add(next as usize)
    }
}

/// The sums of the eight lanes of `x`, `y` and `z`: neighbouring lanes
/// added in f32, the four pair sums in f64.
///
/// # Safety
/// The CPU has AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn totals(
    x: std::arch::x86_64::__m256,
    y: std::arch::x86_64::__m256,
    z: std::arch::x86_64::__m256,
) -> DVec3 {
    use std::arch::x86_64::*;
    // [x01 x23 y01 y23 | x45 x67 y45 y67] and [z01 z23 z01 z23 | z45 z67 ..].
    let (xy, zz) = (_mm256_hadd_ps(x, y), _mm256_hadd_ps(z, z));
    // [x0145 x2367 y0145 y2367] and [z0145 z2367 ..], then [x z y z].
    let a = _mm256_add_pd(
        _mm256_cvtps_pd(_mm256_castps256_ps128(xy)),
        _mm256_cvtps_pd(_mm256_extractf128_ps::<1>(xy)),
    );
    let b = _mm256_add_pd(
        _mm256_cvtps_pd(_mm256_castps256_ps128(zz)),
        _mm256_cvtps_pd(_mm256_extractf128_ps::<1>(zz)),
    );
    let t = _mm256_hadd_pd(a, b);
    let mut v = [0.0f64; 4];
    // SAFETY: `v` holds four f64.
    unsafe { _mm256_storeu_pd(v.as_mut_ptr(), t) };
    DVec3::new(v[0], v[2], v[1])
}
