//! A point's hits and kernel weights against its cell's candidates, eight
//! candidates (one mask byte) at a time, in f64: the hit test of the
//! evaluation (`|x - s|^2 < R^2`, the operations of [`crate::simd`]'s mask)
//! and phi(|x - s| / R) as [`Kernel::eval`] computes it, for all eight
//! lanes, so that the loops vectorise; the hits' weights are then stored in
//! order, each as its level: phi / phi(0) in 24-bit fixed point
//! ([`Levels`], three bytes).
//!
//! Three copies: the plain code (the reference, and the path without AVX2);
//! AVX2, a block in two vectors of four, the store of the hits' levels two
//! permutations, a byte shuffle and one unaligned store per block
//! (`COMPRESS`, `PACK`); and AVX-512, a whole cell in one call, a block in
//! one vector of eight and the hits' levels compressed by the hit mask
//! (1M points, one thread: a re-bind 145-153 ms with AVX2, 128-130 with
//! AVX-512). None uses fused multiply-adds: all give the levels of the weights
//! `Kernel::eval` gives, byte for byte (tested).

use std::mem::MaybeUninit;

use glam::DVec3;

use super::{BLOCK, LEVEL_BYTES, Levels};
use crate::evaluate::Candidates;
use crate::kernel::Kernel;
use crate::simd::{Avx2Fma, Avx512};

/// A cell's candidates by coordinate, padded to a multiple of eight with
/// infinite coordinates (|x - s|^2 is infinite, never below R^2: the
/// padding lanes are never hits).
#[derive(Default)]
pub(super) struct Lanes {
    xyz: [Vec<f64>; 3],
}

impl Lanes {
    /// The candidates of `cand`, padded.
    pub(super) fn pad(&mut self, cand: &Candidates) {
        let real = cand.len();
        let padded = real.next_multiple_of(BLOCK);
        for (axis, v) in self.xyz.iter_mut().enumerate() {
            v.clear();
            v.extend((0..real).map(|k| cand.start(k)[axis]));
            v.resize(padded, f64::INFINITY);
        }
    }

    /// Blocks of eight candidates.
    fn blocks(&self) -> usize {
        self.xyz[0].len() / BLOCK
    }

    /// Squared distances from `x` to the candidates of block `b`, and the
    /// block's hit bits.
    #[inline(always)]
    fn block(&self, b: usize, x: DVec3, r2: f64) -> ([f64; BLOCK], u8) {
        let [xs, ys, zs] = &self.xyz;
        let range = b * BLOCK..(b + 1) * BLOCK;
        let (cx, cy, cz) = (&xs[range.clone()], &ys[range.clone()], &zs[range]);
        let mut d2 = [0.0f64; BLOCK];
        for k in 0..BLOCK {
            let (dx, dy, dz) = (x.x - cx[k], x.y - cy[k], x.z - cz[k]);
            d2[k] = dx * dx + dy * dy + dz * dz;
        }
        let mut bits = 0u8;
        for (k, d) in d2.iter().enumerate() {
            bits |= u8::from(*d < r2) << k;
        }
        (d2, bits)
    }
}

/// [`Lanes::block`] with AVX2: the squared distances of block `b` in two
/// vectors of four, and its hit bits. (No closures in the vector code:
/// a closure does not inherit `target_feature`, so it would not inline.)
///
/// # Safety
/// The CPU has AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn block_avx2(
    lanes: &Lanes,
    b: usize,
    x: DVec3,
    r2: f64,
) -> ([std::arch::x86_64::__m256d; 2], u8) {
    use std::arch::x86_64::*;
    let range = b * BLOCK..(b + 1) * BLOCK;
    let [xs, ys, zs] = &lanes.xyz;
    let (cx, cy, cz) = (&xs[range.clone()], &ys[range.clone()], &zs[range]);
    let (px, py, pz) = (
        _mm256_set1_pd(x.x),
        _mm256_set1_pd(x.y),
        _mm256_set1_pd(x.z),
    );
    let r2 = _mm256_set1_pd(r2);
    let mut d2 = [_mm256_setzero_pd(); 2];
    let mut bits = 0;
    for (h, d2) in d2.iter_mut().enumerate() {
        // SAFETY: each of the three slices holds eight f64 (sliced above).
        let (sx, sy, sz) = unsafe {
            (
                _mm256_loadu_pd(cx.as_ptr().add(4 * h)),
                _mm256_loadu_pd(cy.as_ptr().add(4 * h)),
                _mm256_loadu_pd(cz.as_ptr().add(4 * h)),
            )
        };
        let (dx, dy, dz) = (
            _mm256_sub_pd(px, sx),
            _mm256_sub_pd(py, sy),
            _mm256_sub_pd(pz, sz),
        );
        // (dx dx + dy dy) + dz dz, as the plain code rounds it.
        let xy = _mm256_add_pd(_mm256_mul_pd(dx, dx), _mm256_mul_pd(dy, dy));
        *d2 = _mm256_add_pd(xy, _mm256_mul_pd(dz, dz));
        bits |= _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_LT_OQ>(*d2, r2)) << (4 * h);
    }
    (d2, bits as u8)
}

/// phi(r) of four lanes: [`Kernel::eval`]'s operations in its order.
///
/// # Safety
/// The CPU has AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn phi_avx2(kernel: Kernel, r: std::arch::x86_64::__m256d) -> std::arch::x86_64::__m256d {
    use std::arch::x86_64::*;
    let one = _mm256_set1_pd(1.0);
    let s = _mm256_sub_pd(one, r);
    let s2 = _mm256_mul_pd(s, s);
    let v = match kernel {
        Kernel::C0 => s2,
        Kernel::C2 => {
            let p = _mm256_add_pd(_mm256_mul_pd(_mm256_set1_pd(4.0), r), one);
            _mm256_mul_pd(_mm256_mul_pd(s2, s2), p)
        }
        Kernel::C4 => {
            let p = _mm256_add_pd(_mm256_mul_pd(_mm256_set1_pd(35.0), r), _mm256_set1_pd(18.0));
            let p = _mm256_add_pd(_mm256_mul_pd(p, r), _mm256_set1_pd(3.0));
            _mm256_mul_pd(_mm256_mul_pd(_mm256_mul_pd(s2, s2), s2), p)
        }
        Kernel::C6 => {
            let s4 = _mm256_mul_pd(s2, s2);
            let p = _mm256_add_pd(_mm256_mul_pd(_mm256_set1_pd(32.0), r), _mm256_set1_pd(25.0));
            let p = _mm256_add_pd(_mm256_mul_pd(p, r), _mm256_set1_pd(8.0));
            let p = _mm256_add_pd(_mm256_mul_pd(p, r), one);
            _mm256_mul_pd(_mm256_mul_pd(s4, s4), p)
        }
    };
    _mm256_blendv_pd(v, _mm256_setzero_pd(), _mm256_cmp_pd::<_CMP_GE_OQ>(r, one))
}

/// Writes a cell's rows: for each of `points` (in order), its mask bytes
/// into its row of `rows` (`lanes.blocks()` bytes each) and the levels of
/// its hits' weights into `levels`, straight after the previous point's;
/// returns the hits. A point that is not finite keeps its row as it is
/// (zeros) and has no levels. The first `3 hits` bytes of `levels` are then
/// initialised (a vector store may write up to 32 more).
///
/// With AVX-512 the whole cell is one call ([`fill_cell_avx512`]: a block
/// of eight candidates in one register); otherwise a call a point.
pub(super) fn fill_cell(
    (cpu, wide): (Option<Avx2Fma>, Option<Avx512>),
    lanes: &Lanes,
    points: &[DVec3],
    kernel: Kernel,
    radius: f64,
    rows: &mut [u8],
    levels: &mut [MaybeUninit<u8>],
) -> usize {
    #[cfg(target_arch = "x86_64")]
    if let Some(wide) = wide {
        let _ = wide;
        let f = match kernel {
            Kernel::C0 => fill_cell_avx512::<0>,
            Kernel::C2 => fill_cell_avx512::<1>,
            Kernel::C4 => fill_cell_avx512::<2>,
            Kernel::C6 => fill_cell_avx512::<3>,
        };
        // SAFETY: an `Avx512` exists only when the CPU has what
        // `fill_cell_avx512` is compiled for.
        #[allow(unsafe_code)]
        return unsafe { f(lanes, points, radius, rows, levels) };
    }
    let _ = wide;
    let mut w = 0;
    for (x, row) in points
        .iter()
        .zip(rows.chunks_exact_mut(lanes.blocks().max(1)))
    {
        if x.is_finite() {
            w += fill_row(
                cpu,
                lanes,
                *x,
                kernel,
                radius,
                row,
                &mut levels[LEVEL_BYTES * w..],
            );
        }
    }
    w
}

/// Writes one point's mask bytes into `row` and the levels of its hits'
/// weights into `levels` (three bytes each, from the first); returns the
/// hits. The first `3 hits` bytes of `levels` are then initialised (a
/// vector store may write up to 32 more).
pub(super) fn fill_row(
    cpu: Option<Avx2Fma>,
    lanes: &Lanes,
    x: DVec3,
    kernel: Kernel,
    radius: f64,
    row: &mut [u8],
    levels: &mut [MaybeUninit<u8>],
) -> usize {
    #[cfg(target_arch = "x86_64")]
    if let Some(cpu) = cpu {
        let _ = cpu;
        // SAFETY: an `Avx2Fma` exists only when the CPU has AVX2 and FMA.
        #[allow(unsafe_code)]
        return unsafe { fill_avx2(lanes, x, kernel, radius, row, levels) };
    }
    let _ = cpu;
    fill_plain(lanes, x, kernel, radius, row, levels)
}

/// The reference: the hits' levels stored one at a time.
pub(super) fn fill_plain(
    lanes: &Lanes,
    x: DVec3,
    kernel: Kernel,
    radius: f64,
    row: &mut [u8],
    levels: &mut [MaybeUninit<u8>],
) -> usize {
    let scale = Levels::of(kernel).per_weight;
    let out = (row, levels);
    match kernel {
        Kernel::C0 => fill_body(lanes, x, radius, out, |r| Kernel::C0.eval(r) * scale),
        Kernel::C2 => fill_body(lanes, x, radius, out, |r| Kernel::C2.eval(r) * scale),
        Kernel::C4 => fill_body(lanes, x, radius, out, |r| Kernel::C4.eval(r) * scale),
        Kernel::C6 => fill_body(lanes, x, radius, out, |r| Kernel::C6.eval(r) * scale),
    }
}

/// [`fill_plain`] with AVX2: the hit test and phi of a block in two
/// vectors of four, its hits' levels stored by two permutations and a byte
/// shuffle.
///
/// # Safety
/// The CPU has AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
#[target_feature(enable = "avx2,fma")]
unsafe fn fill_avx2(
    lanes: &Lanes,
    x: DVec3,
    kernel: Kernel,
    radius: f64,
    row: &mut [u8],
    levels: &mut [MaybeUninit<u8>],
) -> usize {
    use std::arch::x86_64::*;
    let (inv, r2) = (_mm256_set1_pd(1.0 / radius), radius * radius);
    let scale = _mm256_set1_pd(Levels::of(kernel).per_weight);
    // SAFETY: `PACK` and `JOIN` hold 32 bytes each.
    let (pack, join) = unsafe {
        (
            _mm256_loadu_si256(PACK.as_ptr().cast()),
            _mm256_loadu_si256(JOIN.as_ptr().cast()),
        )
    };
    let mut w = 0;
    for (b, r) in row.iter_mut().enumerate().take(lanes.blocks()) {
        // SAFETY: b is below `lanes.blocks()`; the CPU has AVX2 (our caller's promise).
        let (d2, bits) = unsafe { block_avx2(lanes, b, x, r2) };
        *r = bits;
        // SAFETY: as above.
        let (lo, hi) = unsafe {
            (
                phi_avx2(kernel, _mm256_mul_pd(_mm256_sqrt_pd(d2[0]), inv)),
                phi_avx2(kernel, _mm256_mul_pd(_mm256_sqrt_pd(d2[1]), inv)),
            )
        };
        // Levels: phi times the scale, rounded to the nearest integer (ties
        // to even, as `f64::round_ties_even`).
        let packed = _mm256_set_m128i(
            _mm256_cvtpd_epi32(_mm256_mul_pd(hi, scale)),
            _mm256_cvtpd_epi32(_mm256_mul_pd(lo, scale)),
        );
        match levels.get_mut(LEVEL_BYTES * w..LEVEL_BYTES * w + 32) {
            Some(out) => {
                // SAFETY: COMPRESS holds eight i32 for every byte, `out` 32
                // bytes.
                unsafe {
                    let idx = _mm256_loadu_si256(COMPRESS[bits as usize].as_ptr().cast());
                    // The hits' levels in order, then their low three bytes
                    // packed: twelve a half, then the two halves joined.
                    let v = _mm256_permutevar8x32_epi32(packed, idx);
                    let v = _mm256_permutevar8x32_epi32(_mm256_shuffle_epi8(v, pack), join);
                    _mm256_storeu_si256(out.as_mut_ptr().cast(), v);
                }
                w += ONES[bits as usize] as usize;
            }
            None => {
                let mut v = [0u32; BLOCK];
                // SAFETY: `v` holds eight u32.
                unsafe { _mm256_storeu_si256(v.as_mut_ptr().cast(), packed) };
                w = store_plain(&v, bits, levels, w);
            }
        }
    }
    w
}

/// [`fill_cell`] with AVX-512, kernel `Kernel::ALL[K]`: a block's eight
/// candidates in one register of f64, the hit test and phi as the plain
/// code computes them (no fused multiply-adds), the levels of the hits
/// compressed to the front by the hit mask, then packed as [`fill_avx2`]
/// packs them. There is no cut-off at r >= 1: only hits are kept, and a
/// hit (|x - s|^2 < R^2) has r at most a few ulps above 1, where phi is a
/// tiny non-negative power of 1 - r and its level 0, as the plain code's 0.
///
/// # Safety
/// The CPU has AVX-512 F and VL, AVX2, FMA and `popcnt` ([`Avx512`]).
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
#[target_feature(enable = "avx512f,avx512vl,avx2,fma,popcnt")]
unsafe fn fill_cell_avx512<const K: u8>(
    lanes: &Lanes,
    points: &[DVec3],
    radius: f64,
    rows: &mut [u8],
    levels: &mut [MaybeUninit<u8>],
) -> usize {
    use std::arch::x86_64::*;
    let kernel = Kernel::ALL[K as usize];
    let (inv, r2) = (
        _mm512_set1_pd(1.0 / radius),
        _mm512_set1_pd(radius * radius),
    );
    let scale = _mm512_set1_pd(Levels::of(kernel).per_weight);
    // SAFETY: `PACK` and `JOIN` hold 32 bytes each.
    let (pack, join) = unsafe {
        (
            _mm256_loadu_si256(PACK.as_ptr().cast()),
            _mm256_loadu_si256(JOIN.as_ptr().cast()),
        )
    };
    let [xs, ys, zs] = &lanes.xyz;
    let nb = lanes.blocks();
    let mut w = 0;
    for (x, row) in points.iter().zip(rows.chunks_exact_mut(nb.max(1))) {
        if !x.is_finite() {
            continue;
        }
        let (px, py, pz) = (
            _mm512_set1_pd(x.x),
            _mm512_set1_pd(x.y),
            _mm512_set1_pd(x.z),
        );
        let blocks = xs
            .chunks_exact(BLOCK)
            .zip(ys.chunks_exact(BLOCK))
            .zip(zs.chunks_exact(BLOCK))
            .zip(row.iter_mut());
        for (((cx, cy), cz), r) in blocks {
            // SAFETY: each chunk holds eight f64.
            let (sx, sy, sz) = unsafe {
                (
                    _mm512_loadu_pd(cx.as_ptr()),
                    _mm512_loadu_pd(cy.as_ptr()),
                    _mm512_loadu_pd(cz.as_ptr()),
                )
            };
            let (dx, dy, dz) = (
                _mm512_sub_pd(px, sx),
                _mm512_sub_pd(py, sy),
                _mm512_sub_pd(pz, sz),
            );
            // (dx dx + dy dy) + dz dz, as the plain code rounds it.
            let xy = _mm512_add_pd(_mm512_mul_pd(dx, dx), _mm512_mul_pd(dy, dy));
            let d2 = _mm512_add_pd(xy, _mm512_mul_pd(dz, dz));
            let bits = _mm512_cmp_pd_mask::<_CMP_LT_OQ>(d2, r2);
            *r = bits;
            if bits == 0 {
                continue;
            }
            // SAFETY: the CPU has AVX-512 F (our caller's promise).
            let phi = unsafe { phi_avx512(kernel, _mm512_mul_pd(_mm512_sqrt_pd(d2), inv)) };
            // Levels rounded to the nearest integer (ties to even), the
            // hits' first.
            let v =
                _mm256_maskz_compress_epi32(bits, _mm512_cvtpd_epi32(_mm512_mul_pd(phi, scale)));
            match levels.get_mut(LEVEL_BYTES * w..LEVEL_BYTES * w + 32) {
                Some(out) => {
                    let v = _mm256_permutevar8x32_epi32(_mm256_shuffle_epi8(v, pack), join);
                    // SAFETY: `out` holds 32 bytes.
                    unsafe { _mm256_storeu_si256(out.as_mut_ptr().cast(), v) };
                    w += bits.count_ones() as usize;
                }
                None => {
                    let mut level = [0u32; BLOCK];
                    // SAFETY: `level` holds eight u32.
                    unsafe { _mm256_storeu_si256(level.as_mut_ptr().cast(), v) };
                    // The hits' levels are first: store them as the first
                    // lanes' (their count's low bits).
                    let first = (1u16 << bits.count_ones()) - 1;
                    w = store_plain(&level, first as u8, levels, w);
                }
            }
        }
    }
    w
}

/// phi(r) of eight lanes: [`Kernel::eval`]'s operations in its order,
/// without the cut-off (see [`fill_cell_avx512`]).
///
/// # Safety
/// The CPU has AVX-512 F.
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
#[target_feature(enable = "avx512f")]
#[inline]
unsafe fn phi_avx512(kernel: Kernel, r: std::arch::x86_64::__m512d) -> std::arch::x86_64::__m512d {
    use std::arch::x86_64::*;
    let one = _mm512_set1_pd(1.0);
    let s = _mm512_sub_pd(one, r);
    let s2 = _mm512_mul_pd(s, s);
    match kernel {
        Kernel::C0 => s2,
        Kernel::C2 => {
            let p = _mm512_add_pd(_mm512_mul_pd(_mm512_set1_pd(4.0), r), one);
            _mm512_mul_pd(_mm512_mul_pd(s2, s2), p)
        }
        Kernel::C4 => {
            let p = _mm512_add_pd(_mm512_mul_pd(_mm512_set1_pd(35.0), r), _mm512_set1_pd(18.0));
            let p = _mm512_add_pd(_mm512_mul_pd(p, r), _mm512_set1_pd(3.0));
            _mm512_mul_pd(_mm512_mul_pd(_mm512_mul_pd(s2, s2), s2), p)
        }
        Kernel::C6 => {
            let s4 = _mm512_mul_pd(s2, s2);
            let p = _mm512_add_pd(_mm512_mul_pd(_mm512_set1_pd(32.0), r), _mm512_set1_pd(25.0));
            let p = _mm512_add_pd(_mm512_mul_pd(p, r), _mm512_set1_pd(8.0));
            let p = _mm512_add_pd(_mm512_mul_pd(p, r), one);
            _mm512_mul_pd(_mm512_mul_pd(s4, s4), p)
        }
    }
}

/// For the packing of eight levels (a u32 each, below 2^24) into 24 bytes:
/// each half's four low three-byte groups first (`PACK`, a byte shuffle
/// within each half), then the halves' twelve bytes side by side (`JOIN`,
/// the eight u32 lanes taken 0 1 2 4 5 6).
static PACK: [u8; 32] = {
    let mut t = [0x80u8; 32];
    let mut k = 0;
    while k < 12 {
        t[k] = (k / 3 * 4 + k % 3) as u8;
        t[16 + k] = t[k];
        k += 1;
    }
    t
};
static JOIN: [u32; BLOCK] = [0, 1, 2, 4, 5, 6, 7, 7];

#[inline(always)]
fn fill_body(
    lanes: &Lanes,
    x: DVec3,
    radius: f64,
    (row, levels): (&mut [u8], &mut [MaybeUninit<u8>]),
    scaled_phi: impl Fn(f64) -> f64,
) -> usize {
    let (inv, r2) = (1.0 / radius, radius * radius);
    let mut w = 0;
    for (b, r) in row.iter_mut().enumerate().take(lanes.blocks()) {
        let (d2, bits) = lanes.block(b, x, r2);
        *r = bits;
        if bits == 0 {
            continue;
        }
        let mut level = [0u32; BLOCK];
        for k in 0..BLOCK {
            // Every lane, hit or not (the loop vectorises); a lane out of
            // reach has phi 0, level 0.
            level[k] = scaled_phi(d2[k].sqrt() * inv).round_ties_even() as u32;
        }
        w = store_plain(&level, bits, levels, w);
    }
    w
}

/// Stores the levels of the set bits of `bits` from level `w` on (three
/// bytes each, little-endian); returns the next free level.
#[inline(always)]
fn store_plain(
    level: &[u32; BLOCK],
    mut bits: u8,
    levels: &mut [MaybeUninit<u8>],
    mut w: usize,
) -> usize {
    while bits != 0 {
        let k = bits.trailing_zeros() as usize;
        bits &= bits - 1;
        let bytes = level[k].to_le_bytes();
        for (o, b) in levels[LEVEL_BYTES * w..LEVEL_BYTES * (w + 1)]
            .iter_mut()
            .zip(bytes)
        {
            *o = MaybeUninit::new(b);
        }
        w += 1;
    }
    w
}

/// For each byte, the lanes of its set bits in order (lane j of the
/// result takes the j-th set bit's lane), then zeros.
static COMPRESS: [[i32; BLOCK]; 256] = compress_table();

/// The set bits of each byte (the baseline x86-64 this crate compiles for
/// has no `popcnt` instruction).
pub(super) static ONES: [u8; 256] = ones_table();

const fn compress_table() -> [[i32; BLOCK]; 256] {
    let mut t = [[0; BLOCK]; 256];
    let mut m = 0;
    while m < 256 {
        let (mut k, mut j) = (0, 0);
        while k < BLOCK {
            if (m >> k) & 1 == 1 {
                t[m][j] = k as i32;
                j += 1;
            }
            k += 1;
        }
        m += 1;
    }
    t
}

const fn ones_table() -> [u8; 256] {
    let mut t = [0; 256];
    let mut m = 0;
    while m < 256 {
        t[m] = (m as u8).count_ones() as u8;
        m += 1;
    }
    t
}
