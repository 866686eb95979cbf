//! The product a new deformation costs: per cell, the coefficients of its
//! candidates in a small table (f64, eight candidates a block, by
//! coordinate); per point, the sum over its mask's set bits of weight times
//! coefficient, in f64.
//!
//! With AVX2 and FMA a block of eight candidates is one unaligned load of
//! eight weights, spread to the lanes of the set bits by one permutation
//! (`EXPAND`, the unset lanes zeroed), and six fused multiply-adds in f64.
//! No block is skipped: whether a block is empty is as hard to predict as a
//! coin, and a mispredicted branch cost more than the block (refit 68 ms
//! with the branch, 26 ms without, at 1M points). [`cell_plain`] is the same
//! sum one hit at a time: the reference of the tests and the path without
//! AVX2.

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use super::weights::ONES;
use super::{BLOCK, Binding, Cell};
use crate::deformation::Deformation;
use crate::evaluate::PARALLEL_POINTS;
use crate::simd::Avx2Fma;

/// f64 values per block of the coefficient table: x, y, z of eight candidates.
const TABLE: usize = 3 * BLOCK;

/// Per-thread scratch: the cell's coefficient table and its points' sums.
#[derive(Default)]
struct Scratch {
    table: Vec<f64>,
    sums: Vec<DVec3>,
}

/// Writes D of `d` at every bound point into `out`, in cell order.
pub(super) fn displacements(b: &Binding, d: &Deformation, out: &mut [Vec3]) {
    let cpu = Avx2Fma::detect();
    let parallel = out.len() >= PARALLEL_POINTS;
    let mut parts = Vec::with_capacity(b.cells.len());
    let mut rest = out;
    for c in &b.cells {
        let (head, tail) = std::mem::take(&mut rest).split_at_mut(c.points);
        parts.push((*c, head));
        rest = tail;
    }
    let work = |s: &mut Scratch, (c, out): (Cell, &mut [Vec3])| cell(b, d, cpu, c, s, out);
    if parallel {
        parts
            .into_par_iter()
            .with_min_len(2)
            .for_each_init(Scratch::default, work);
    } else {
        let mut scratch = Scratch::default();
        parts.into_iter().for_each(|p| work(&mut scratch, p));
    }
}

/// One cell's points.
fn cell(
    b: &Binding,
    d: &Deformation,
    cpu: Option<Avx2Fma>,
    c: Cell,
    s: &mut Scratch,
    out: &mut [Vec3],
) {
    let alpha = d.coefficients();
    s.table.clear();
    for block in b.ids[c.id..c.id + c.blocks * BLOCK].chunks_exact(BLOCK) {
        for axis in 0..3 {
            let a = block
                .iter()
                .map(|&j| alpha.get(j as usize).map_or(0.0, |a| a[axis]));
            s.table.extend(a);
        }
    }
    s.sums.clear();
    s.sums.resize(c.points, DVec3::ZERO);
    let rows = &b.masks[c.mask..c.mask + c.points * c.blocks];
    cell_sums(
        cpu,
        rows,
        c.blocks,
        &b.weights[c.weight..],
        &s.table,
        &mut s.sums,
    );
    let affine = d.affine();
    for (k, (o, sum)) in out.iter_mut().zip(&s.sums).enumerate() {
        let x = b.rest.at(c.point + k);
        *o = if x.is_finite() {
            (affine.map_or(DVec3::ZERO, |a| a.eval(x)) + *sum).as_vec3()
        } else {
            Vec3::NAN
        };
    }
}

impl super::Rest {
    /// Point `k` in cell order, in f64.
    #[inline]
    fn at(&self, k: usize) -> DVec3 {
        match self {
            super::Rest::F32(p) => p[k].as_dvec3(),
            super::Rest::F64(p) => p[k],
        }
    }
}

/// Each row's sum over the set bits of its `blocks` mask bytes of weight
/// times coefficient, into `sums`: [`cell_avx2`] where the CPU has it, else
/// [`cell_plain`].
pub(super) fn cell_sums(
    cpu: Option<Avx2Fma>,
    rows: &[u8],
    blocks: usize,
    weights: &[f32],
    table: &[f64],
    sums: &mut [DVec3],
) {
    #[cfg(target_arch = "x86_64")]
    if let Some(cpu) = cpu {
        let _ = cpu;
        // SAFETY: an `Avx2Fma` exists only when the CPU has AVX2 and FMA.
        #[allow(unsafe_code)]
        if unsafe { cell_avx2(rows, blocks, weights, table, sums) } {
            return;
        }
    }
    let _ = cpu;
    cell_plain(rows, blocks, weights, table, sums);
}

/// The reference: one hit at a time, in candidate order.
pub(super) fn cell_plain(
    rows: &[u8],
    blocks: usize,
    weights: &[f32],
    table: &[f64],
    sums: &mut [DVec3],
) {
    let mut p = 0;
    for (row, sum) in rows.chunks_exact(blocks.max(1)).zip(sums) {
        *sum = DVec3::ZERO;
        for (b, &m) in row.iter().enumerate() {
            let t = &table[b * TABLE..(b + 1) * TABLE];
            let mut bits = m;
            while bits != 0 {
                let k = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let a = DVec3::new(t[k], t[BLOCK + k], t[2 * BLOCK + k]);
                *sum += a * f64::from(weights[p]);
                p += 1;
            }
        }
    }
}

/// For each mask byte, the lane each of the eight lanes takes its weight
/// from (the count of set bits below it), and -1 (sign bit set: zeroed)
/// for the lanes of unset bits.
static EXPAND: [[i32; BLOCK]; 256] = expand_table();

const fn expand_table() -> [[i32; BLOCK]; 256] {
    let mut t = [[-1; BLOCK]; 256];
    let mut m = 0;
    while m < 256 {
        let (mut k, mut c) = (0, 0);
        while k < BLOCK {
            if (m >> k) & 1 == 1 {
                t[m][k] = c;
                c += 1;
            }
            k += 1;
        }
        m += 1;
    }
    t
}

/// [`cell_plain`] with AVX2 and FMA: per block, eight weights loaded from
/// the row's next unused one, spread to the lanes of the set bits, and
/// summed with the coefficients in f64. Returns false, having written
/// nothing trustworthy, when a row's loads would leave `weights` or `table`
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
    weights: &[f32],
    table: &[f64],
    sums: &mut [DVec3],
) -> bool {
    use std::arch::x86_64::*;
    if blocks == 0 || table.len() < blocks * TABLE {
        return blocks == 0;
    }
    let mut p = 0;
    for (row, sum) in rows.chunks_exact(blocks).zip(sums) {
        // A row reads at most eight weights past its first for each byte.
        if p + BLOCK * (blocks + 1) > weights.len() {
            return false;
        }
        // Two sets of accumulators, for even and odd blocks: with one, each
        // block waited for the previous block's fused multiply-adds.
        let (mut even, mut odd) = ([_mm256_setzero_pd(); 6], [_mm256_setzero_pd(); 6]);
        let mut pairs = row.chunks_exact(2);
        let mut b = 0;
        for two in &mut pairs {
            // SAFETY: as for `block` (b and b + 1 are below `blocks`).
            unsafe {
                p = block(two[0], b, p, weights, table, &mut even);
                p = block(two[1], b + 1, p, weights, table, &mut odd);
            }
            b += 2;
        }
        if let [m] = pairs.remainder() {
            // SAFETY: as for `block` (b is below `blocks`).
            p = unsafe { block(*m, b, p, weights, table, &mut even) };
        }
        let mut acc = even;
        for k in 0..6 {
            acc[k] = _mm256_add_pd(even[k], odd[k]);
        }
        // SAFETY: the CPU has AVX2 (our caller's promise).
        *sum = unsafe {
            DVec3::new(
                total(acc[0], acc[1]),
                total(acc[2], acc[3]),
                total(acc[4], acc[5]),
            )
        };
    }
    true
}

/// Adds block `b` of a row (mask byte `m`, weights from `p`) to `acc`;
/// returns the next unused weight.
///
/// # Safety
/// The CPU has AVX2 and FMA; `p + 8 <= weights.len()` and
/// `(b + 1) * 24 <= table.len()`.
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn block(
    m: u8,
    b: usize,
    p: usize,
    weights: &[f32],
    table: &[f64],
    acc: &mut [std::arch::x86_64::__m256d; 6],
) -> usize {
    use std::arch::x86_64::*;
    // SAFETY: the eight weights from p and the 24 values of block b lie
    // within their arrays (the caller's promise); EXPAND has eight lanes
    // for every byte.
    let (v, idx, a) = unsafe {
        let t = table.as_ptr().add(b * TABLE);
        (
            _mm256_loadu_ps(weights.as_ptr().add(p)),
            _mm256_loadu_si256(EXPAND[m as usize].as_ptr().cast()),
            [
                _mm256_loadu_pd(t),
                _mm256_loadu_pd(t.add(4)),
                _mm256_loadu_pd(t.add(8)),
                _mm256_loadu_pd(t.add(12)),
                _mm256_loadu_pd(t.add(16)),
                _mm256_loadu_pd(t.add(20)),
            ],
        )
    };
    let spread = _mm256_permutevar8x32_ps(v, idx);
    let e = _mm256_blendv_ps(spread, _mm256_setzero_ps(), _mm256_castsi256_ps(idx));
    let lo = _mm256_cvtps_pd(_mm256_castps256_ps128(e));
    let hi = _mm256_cvtps_pd(_mm256_extractf128_ps::<1>(e));
    for c in 0..3 {
        acc[2 * c] = _mm256_fmadd_pd(lo, a[2 * c], acc[2 * c]);
        acc[2 * c + 1] = _mm256_fmadd_pd(hi, a[2 * c + 1], acc[2 * c + 1]);
    }
    p + ONES[m as usize] as usize
}

/// The sum of the eight lanes of `lo` and `hi`.
///
/// # Safety
/// The CPU has AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn total(lo: std::arch::x86_64::__m256d, hi: std::arch::x86_64::__m256d) -> f64 {
    use std::arch::x86_64::*;
    let s = _mm256_add_pd(lo, hi);
    let h = _mm_add_pd(_mm256_castpd256_pd128(s), _mm256_extractf128_pd::<1>(s));
    _mm_cvtsd_f64(_mm_add_sd(h, _mm_unpackhi_pd(h, h)))
}
