//! The kernel sum in vector registers, written once over [`Vector`] and
//! compiled twice: eight lanes a register with AVX2 and FMA
//! ([`sums_avx2_fma`]), sixteen with AVX-512 ([`sums_avx512`]).
//!
//! Every lane does [`super::sums::sum_body`]'s operations in its order, with
//! fused multiply-adds; two points go at a time (they share the lanes'
//! loads; four at a time measured no faster), each with its own
//! accumulators, so a point's sums are the same alone or paired. Sixteen
//! lanes take a cell's blocks of eight two at a time, an odd last one in
//! the low half with far starts of zero coefficient above it, and add the
//! halves before the eight-lane reduction: the two widths agree to f32
//! rounding, not bit for bit.
//!
//! The generic functions are `#[inline(always)]` and reached only from the
//! two `#[target_feature]` entry points, so each is compiled whole for its
//! width, the intrinsics inlined.

// Intrinsics behind the CPU's instruction set: every call is unsafe, each
// function says what its caller promises.
#![allow(unsafe_code)]

use std::arch::x86_64::*;

use super::{FAR, LANES, View};

/// The operations of the kernel sum at one width. Each is an intrinsic of
/// the width's instruction set.
///
/// # Safety
/// Every method may be called only where the CPU has that instruction set
/// (AVX2 and FMA for `__m256`, AVX-512F besides for `__m512`).
trait Vector: Copy {
    /// Lanes a register.
    const WIDTH: usize;
    unsafe fn splat(v: f32) -> Self;
    /// Lanes `k..k + WIDTH` of `v`; lanes at `n` and beyond (`n` a multiple
    /// of eight, `k + 8 <= n <= v.len()`) are `fill`, and not read.
    unsafe fn load(v: &[f32], k: usize, n: usize, fill: f32) -> Self;
    unsafe fn sub(self, b: Self) -> Self;
    unsafe fn mul(self, b: Self) -> Self;
    /// `self * b + c`, fused.
    unsafe fn mul_add(self, b: Self, c: Self) -> Self;
    unsafe fn sqrt(self) -> Self;
    unsafe fn max(self, b: Self) -> Self;
    /// A point's three sums from its accumulators.
    unsafe fn reduce(acc: [Self; 3]) -> [f32; 3];
}

impl Vector for __m256 {
    const WIDTH: usize = 8;
    #[inline(always)]
    unsafe fn splat(v: f32) -> Self {
        // SAFETY: the CPU has the instruction set (the trait's promise).
        unsafe { _mm256_set1_ps(v) }
    }
    #[inline(always)]
    unsafe fn load(v: &[f32], k: usize, n: usize, _fill: f32) -> Self {
        debug_assert!(k + 8 <= n && n <= v.len());
        // SAFETY: k + 8 <= n <= v.len() (the caller's promise).
        unsafe { _mm256_loadu_ps(v.as_ptr().add(k)) }
    }
    #[inline(always)]
    unsafe fn sub(self, b: Self) -> Self {
        // SAFETY: the CPU has the instruction set (the trait's promise).
        unsafe { _mm256_sub_ps(self, b) }
    }
    #[inline(always)]
    unsafe fn mul(self, b: Self) -> Self {
        // SAFETY: the CPU has the instruction set (the trait's promise).
        unsafe { _mm256_mul_ps(self, b) }
    }
    #[inline(always)]
    unsafe fn mul_add(self, b: Self, c: Self) -> Self {
        // SAFETY: the CPU has the instruction set (the trait's promise).
        unsafe { _mm256_fmadd_ps(self, b, c) }
    }
    #[inline(always)]
    unsafe fn sqrt(self) -> Self {
        // SAFETY: the CPU has the instruction set (the trait's promise).
        unsafe { _mm256_sqrt_ps(self) }
    }
    #[inline(always)]
    unsafe fn max(self, b: Self) -> Self {
        // SAFETY: the CPU has the instruction set (the trait's promise).
        unsafe { _mm256_max_ps(self, b) }
    }
    /// Two horizontal adds of x with y and z with itself, one of those,
    /// then the halves.
    #[inline(always)]
    unsafe fn reduce(acc: [Self; 3]) -> [f32; 3] {
        let mut v = [0.0f32; 4];
        // SAFETY: the CPU has AVX (the trait's promise); `v` holds four f32.
        unsafe {
            let xyz = _mm256_hadd_ps(
                _mm256_hadd_ps(acc[0], acc[1]),
                _mm256_hadd_ps(acc[2], acc[2]),
            );
            let sums = _mm_add_ps(_mm256_castps256_ps128(xyz), _mm256_extractf128_ps::<1>(xyz));
            _mm_storeu_ps(v.as_mut_ptr(), sums);
        }
        [v[0], v[1], v[2]]
    }
}

impl Vector for __m512 {
    const WIDTH: usize = 16;
    #[inline(always)]
    unsafe fn splat(v: f32) -> Self {
        // SAFETY: the CPU has the instruction set (the trait's promise).
        unsafe { _mm512_set1_ps(v) }
    }
    #[inline(always)]
    unsafe fn load(v: &[f32], k: usize, n: usize, fill: f32) -> Self {
        debug_assert!(k + 8 <= n && n <= v.len() && n.is_multiple_of(8));
        // SAFETY: k + 16 <= n <= v.len(), or k + 8 <= n and the masked
        // load reads only the low eight lanes (the caller's promise).
        unsafe {
            let at = v.as_ptr().add(k);
            if k + 16 <= n {
                _mm512_loadu_ps(at)
            } else {
                _mm512_mask_loadu_ps(_mm512_set1_ps(fill), 0x00ff, at)
            }
        }
    }
    #[inline(always)]
    unsafe fn sub(self, b: Self) -> Self {
        // SAFETY: the CPU has the instruction set (the trait's promise).
        unsafe { _mm512_sub_ps(self, b) }
    }
    #[inline(always)]
    unsafe fn mul(self, b: Self) -> Self {
        // SAFETY: the CPU has the instruction set (the trait's promise).
        unsafe { _mm512_mul_ps(self, b) }
    }
    #[inline(always)]
    unsafe fn mul_add(self, b: Self, c: Self) -> Self {
        // SAFETY: the CPU has the instruction set (the trait's promise).
        unsafe { _mm512_fmadd_ps(self, b, c) }
    }
    #[inline(always)]
    unsafe fn sqrt(self) -> Self {
        // SAFETY: the CPU has the instruction set (the trait's promise).
        unsafe { _mm512_sqrt_ps(self) }
    }
    #[inline(always)]
    unsafe fn max(self, b: Self) -> Self {
        // SAFETY: the CPU has the instruction set (the trait's promise).
        unsafe { _mm512_max_ps(self, b) }
    }
    /// The high eight lanes added to the low, then the eight-lane
    /// reduction.
    #[inline(always)]
    unsafe fn reduce(acc: [Self; 3]) -> [f32; 3] {
        // SAFETY: the CPU has AVX-512F (the trait's promise), and so the
        // AVX the eight-lane reduction uses.
        unsafe {
            let half = |v: __m512| {
                let high = _mm256_castpd_ps(_mm512_extractf64x4_pd::<1>(_mm512_castps_pd(v)));
                _mm256_add_ps(_mm512_castps512_ps256(v), high)
            };
            <__m256 as Vector>::reduce([half(acc[0]), half(acc[1]), half(acc[2])])
        }
    }
}

/// [`super::sums::sum_body`] with AVX2 and FMA, eight lanes a register.
///
/// # Safety
/// The CPU has AVX2 and FMA.
#[target_feature(enable = "avx2,fma")]
pub(super) unsafe fn sums_avx2_fma<const K: u8>(
    l: View<'_>,
    xs: &[[f32; 3]],
    out: &mut [[f32; 3]],
) {
    // SAFETY: the CPU has AVX2 and FMA (the caller's promise).
    unsafe { sums::<__m256, K>(l, xs, out) }
}

/// [`super::sums::sum_body`] with AVX-512, sixteen lanes a register.
///
/// # Safety
/// The CPU has AVX-512F, AVX2 and FMA.
#[target_feature(enable = "avx512f,avx2,fma")]
pub(super) unsafe fn sums_avx512<const K: u8>(l: View<'_>, xs: &[[f32; 3]], out: &mut [[f32; 3]]) {
    // SAFETY: the CPU has AVX-512F, AVX2 and FMA (the caller's promise).
    unsafe { sums::<__m512, K>(l, xs, out) }
}

/// The sums of every point of `xs` into `out`, two points at a time.
///
/// # Safety
/// The CPU has `V`'s instruction set.
#[inline(always)]
unsafe fn sums<V: Vector, const K: u8>(l: View<'_>, xs: &[[f32; 3]], out: &mut [[f32; 3]]) {
    let lanes = [
        l.xyz[0], l.xyz[1], l.xyz[2], l.alpha[0], l.alpha[1], l.alpha[2],
    ];
    let n = lanes.map(<[f32]>::len).into_iter().min().unwrap_or(0);
    let n = n - n % LANES;
    let two = xs.len() / 2 * 2;
    let (xs2, xs1) = xs.split_at(two);
    let (out2, out1) = out.split_at_mut(two);
    for (x, o) in xs2.chunks_exact(2).zip(out2.chunks_exact_mut(2)) {
        // SAFETY: n is a multiple of eight, at most every array's length;
        // the CPU's instruction set is the caller's promise.
        let sums = unsafe { points::<V, K, 2>(lanes, n, [x[0], x[1]]) };
        o.copy_from_slice(&sums);
    }
    for (x, o) in xs1.iter().zip(out1) {
        // SAFETY: as above.
        *o = unsafe { points::<V, K, 1>(lanes, n, [*x])[0] };
    }
}

/// The sums of `P` points over the first `n` lanes, each point with its own
/// accumulators.
///
/// # Safety
/// The CPU has `V`'s instruction set; `n` is a multiple of eight and at
/// most the length of every array of `lanes`.
#[inline(always)]
unsafe fn points<V: Vector, const K: u8, const P: usize>(
    lanes: [&[f32]; 6],
    n: usize,
    xs: [[f32; 3]; P],
) -> [[f32; 3]; P] {
    // SAFETY (the whole body): the caller's promises.
    unsafe {
        let mut at = [[V::splat(0.0); 3]; P];
        for (a, x) in at.iter_mut().zip(&xs) {
            *a = [V::splat(x[0]), V::splat(x[1]), V::splat(x[2])];
        }
        let mut acc = [[V::splat(0.0); 3]; P];
        for k in (0..n).step_by(V::WIDTH) {
            let c = [
                V::load(lanes[0], k, n, FAR),
                V::load(lanes[1], k, n, FAR),
                V::load(lanes[2], k, n, FAR),
            ];
            let a = [
                V::load(lanes[3], k, n, 0.0),
                V::load(lanes[4], k, n, 0.0),
                V::load(lanes[5], k, n, 0.0),
            ];
            for (acc, p) in acc.iter_mut().zip(&at) {
                let w = weight::<V, K>(c, *p);
                *acc = [
                    w.mul_add(a[0], acc[0]),
                    w.mul_add(a[1], acc[1]),
                    w.mul_add(a[2], acc[2]),
                ];
            }
        }
        let mut out = [[0.0; 3]; P];
        for (o, acc) in out.iter_mut().zip(acc) {
            *o = V::reduce(acc);
        }
        out
    }
}

/// Phi of a register of candidates' coordinates `c` at a point `p`
/// (broadcast): [`super::sums::sum_body`]'s operations, in its order.
///
/// # Safety
/// The CPU has `V`'s instruction set.
#[inline(always)]
unsafe fn weight<V: Vector, const K: u8>(c: [V; 3], p: [V; 3]) -> V {
    // SAFETY (the whole body): the caller's promise.
    unsafe {
        let (zero, one) = (V::splat(0.0), V::splat(1.0));
        let (dx, dy, dz) = (c[0].sub(p[0]), c[1].sub(p[1]), c[2].sub(p[2]));
        let r = dz.mul_add(dz, dy.mul_add(dy, dx.mul(dx))).sqrt();
        let t = one.sub(r).max(zero);
        let t2 = t.mul(t);
        match K {
            0 => t2,
            2 => t2.mul(t2).mul(V::splat(4.0).mul_add(r, one)),
            4 => {
                let q = V::splat(35.0)
                    .mul_add(r, V::splat(18.0))
                    .mul_add(r, V::splat(3.0));
                t2.mul(t2).mul(t2).mul(q)
            }
            _ => {
                let t4 = t2.mul(t2);
                let q = V::splat(32.0).mul_add(r, V::splat(25.0));
                let q = q.mul_add(r, V::splat(8.0)).mul_add(r, one);
                t4.mul(t4).mul(q)
            }
        }
    }
}
