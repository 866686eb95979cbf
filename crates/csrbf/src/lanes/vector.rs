//! The kernel sum in vector registers, written once over [`Vector`] and
//! compiled twice: eight points a register with AVX2 and FMA
//! ([`sums_avx2_fma`]), sixteen with AVX-512 ([`sums_avx512`]).
//!
//! Each lane is a point: a block of points (two registers' worth) goes
//! through the cell's candidates one at a time, each candidate's
//! coordinates and coefficients broadcast, so no lane ever meets another
//! and a sum needs no reduction across lanes. Every lane does
//! [`super::sums::sum_body`]'s operations in its order, with fused
//! multiply-adds; so every copy, at either width, gives a point the same
//! sums bit for bit, whatever its block.
//!
//! The generic functions are `#[inline(always)]` and reached only from the
//! two `#[target_feature]` entry points, so each is compiled whole for its
//! width, the intrinsics inlined.

// Intrinsics behind the CPU's instruction set: every call is unsafe, each
// function says what its caller promises.
#![allow(unsafe_code)]

use std::arch::x86_64::*;

use super::View;
use super::sums::ACCUMULATORS;
use super::sums::{Axes, AxesMut, points_of};

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
    /// The first `WIDTH` values of `v` (at least that many).
    unsafe fn load(v: &[f32]) -> Self;
    /// Into the first `WIDTH` values of `v` (at least that many).
    unsafe fn store(self, v: &mut [f32]);
    unsafe fn add(self, b: Self) -> Self;
    unsafe fn sub(self, b: Self) -> Self;
    unsafe fn mul(self, b: Self) -> Self;
    /// `self * b + c`, fused.
    unsafe fn mul_add(self, b: Self, c: Self) -> Self;
    unsafe fn sqrt(self) -> Self;
    unsafe fn max(self, b: Self) -> Self;
}

/// One intrinsic per method, at one width.
macro_rules! vector {
    ($t:ty, $width:expr, $set1:ident, $loadu:ident, $storeu:ident, $add:ident, $sub:ident,
     $mul:ident, $fmadd:ident, $sqrt:ident, $max:ident) => {
        impl Vector for $t {
            const WIDTH: usize = $width;
            #[inline(always)]
            unsafe fn splat(v: f32) -> Self {
                // SAFETY: the CPU has the instruction set (the trait's promise).
                unsafe { $set1(v) }
            }
            #[inline(always)]
            unsafe fn load(v: &[f32]) -> Self {
                assert!(v.len() >= $width);
                // SAFETY: `WIDTH` values are there (checked); the CPU has
                // the instruction set (the trait's promise).
                unsafe { $loadu(v.as_ptr()) }
            }
            #[inline(always)]
            unsafe fn store(self, v: &mut [f32]) {
                assert!(v.len() >= $width);
                // SAFETY: as in `load`.
                unsafe { $storeu(v.as_mut_ptr(), self) }
            }
            #[inline(always)]
            unsafe fn add(self, b: Self) -> Self {
                // SAFETY: the CPU has the instruction set (the trait's promise).
                unsafe { $add(self, b) }
            }
            #[inline(always)]
            unsafe fn sub(self, b: Self) -> Self {
                // SAFETY: as above.
                unsafe { $sub(self, b) }
            }
            #[inline(always)]
            unsafe fn mul(self, b: Self) -> Self {
                // SAFETY: as above.
                unsafe { $mul(self, b) }
            }
            #[inline(always)]
            unsafe fn mul_add(self, b: Self, c: Self) -> Self {
                // SAFETY: as above.
                unsafe { $fmadd(self, b, c) }
            }
            #[inline(always)]
            unsafe fn sqrt(self) -> Self {
                // SAFETY: as above.
                unsafe { $sqrt(self) }
            }
            #[inline(always)]
            unsafe fn max(self, b: Self) -> Self {
                // SAFETY: as above.
                unsafe { $max(self, b) }
            }
        }
    };
}

vector!(
    __m256,
    8,
    _mm256_set1_ps,
    _mm256_loadu_ps,
    _mm256_storeu_ps,
    _mm256_add_ps,
    _mm256_sub_ps,
    _mm256_mul_ps,
    _mm256_fmadd_ps,
    _mm256_sqrt_ps,
    _mm256_max_ps
);
vector!(
    __m512,
    16,
    _mm512_set1_ps,
    _mm512_loadu_ps,
    _mm512_storeu_ps,
    _mm512_add_ps,
    _mm512_sub_ps,
    _mm512_mul_ps,
    _mm512_fmadd_ps,
    _mm512_sqrt_ps,
    _mm512_max_ps
);

/// [`super::sums::sum_body`] with AVX2 and FMA, eight points a register.
///
/// # Safety
/// The CPU has AVX2 and FMA.
#[target_feature(enable = "avx2,fma")]
pub(super) unsafe fn sums_avx2_fma<const K: u8>(l: View<'_>, xs: Axes<'_>, out: AxesMut<'_>) {
    // SAFETY: the CPU has AVX2 and FMA (the caller's promise).
    unsafe { sums::<__m256, K>(l, xs, out) }
}

/// [`super::sums::sum_body`] with AVX-512, sixteen points a register.
///
/// # Safety
/// The CPU has AVX-512F, AVX2 and FMA.
#[target_feature(enable = "avx512f,avx2,fma")]
pub(super) unsafe fn sums_avx512<const K: u8>(l: View<'_>, xs: Axes<'_>, out: AxesMut<'_>) {
    // SAFETY: the CPU has AVX-512F, AVX2 and FMA (the caller's promise).
    unsafe { sums::<__m512, K>(l, xs, out) }
}

/// Points a block holds at most: two registers of sixteen.
const BLOCK: usize = 32;

/// The sums of every point of `xs` into `out`, a block of two registers
/// at a time (one when no more points are left), each register loaded from
/// and stored to the arrays straight, a last part-filled one through a
/// copy (its lanes past the points sum at the cell's centre, and are not
/// written).
///
/// # Safety
/// The CPU has `V`'s instruction set.
#[inline(always)]
unsafe fn sums<V: Vector, const K: u8>(l: View<'_>, xs: Axes<'_>, out: AxesMut<'_>) {
    let w = V::WIDTH;
    let n = points_of(&xs, &out);
    let [ox, oy, oz] = out;
    let mut out = [ox, oy, oz].map(|v| &mut v[..n]);
    let xs = xs.map(|v| &v[..n]);
    let mut k = 0;
    while k < n {
        let left = n - k;
        // SAFETY (both arms): the CPU's instruction set is the caller's
        // promise; `load` and `store` check their lengths.
        unsafe {
            if left >= 2 * w {
                let at = xs.map(|v| &v[k..]);
                let sums = block_sums::<V, K, 2>(l, at);
                for (o, s) in out.iter_mut().zip(sums) {
                    s[0].store(&mut o[k..]);
                    s[1].store(&mut o[k + w..]);
                }
                k += 2 * w;
            } else {
                // The last points, fewer than two registers: through a copy.
                let mut at = [[0.0f32; BLOCK]; 3];
                for (a, v) in at.iter_mut().zip(&xs) {
                    a[..left].copy_from_slice(&v[k..]);
                }
                let mut to = [[0.0f32; BLOCK]; 3];
                if left > w {
                    let sums = block_sums::<V, K, 2>(l, at.each_ref().map(|a| &a[..]));
                    for (t, s) in to.iter_mut().zip(sums) {
                        s[0].store(&mut t[..]);
                        s[1].store(&mut t[w..]);
                    }
                } else {
                    let sums = block_sums::<V, K, 1>(l, at.each_ref().map(|a| &a[..]));
                    for (t, s) in to.iter_mut().zip(sums) {
                        s[0].store(&mut t[..]);
                    }
                }
                for (o, t) in out.iter_mut().zip(&to) {
                    o[k..].copy_from_slice(&t[..left]);
                }
                k = n;
            }
        }
    }
}

/// The sums of the first `P` registers of points of `at` (by axis, each
/// at least `P` registers long) over every candidate of `l`, by axis and
/// register.
///
/// # Safety
/// The CPU has `V`'s instruction set.
#[inline(always)]
unsafe fn block_sums<V: Vector, const K: u8, const P: usize>(
    l: View<'_>,
    at: [&[f32]; 3],
) -> [[V; P]; 3] {
    let n = l.len();
    // Each array cut to `n`, so the indices below need no checks.
    let [xs, ys, zs] = l.xyz.map(|v| &v[..n]);
    let [ax, ay, az] = l.alpha.map(|v| &v[..n]);
    // SAFETY (the whole body): the caller's promise; every index below is
    // under `n`, at most each array's length (`View::len`).
    // (Loops, not closures: a closure is compiled without the entry
    // point's instruction set, and one left out of line calls each
    // intrinsic.)
    unsafe {
        let mut points = [[V::splat(0.0); 3]; P];
        for (q, p) in points.iter_mut().enumerate() {
            for (p, v) in p.iter_mut().zip(at) {
                *p = V::load(&v[q * V::WIDTH..]);
            }
        }
        let mut acc = [[[V::splat(0.0); 3]; P]; ACCUMULATORS];
        // Candidate j into accumulator j % ACCUMULATORS: whole groups, then
        // the last few into the first accumulators.
        let lanes = [xs, ys, zs, ax, ay, az];
        let whole = n - n % ACCUMULATORS;
        for j in (0..whole).step_by(ACCUMULATORS) {
            for (s, acc) in acc.iter_mut().enumerate() {
                candidate::<V, K, P>(acc, &points, lanes, j + s);
            }
        }
        for (s, j) in (whole..n).enumerate() {
            candidate::<V, K, P>(&mut acc[s], &points, lanes, j);
        }
        let mut out = [[V::splat(0.0); P]; 3];
        for (c, out) in out.iter_mut().enumerate() {
            for (q, out) in out.iter_mut().enumerate() {
                let mut sum = acc[0][q][c];
                for acc in &acc[1..] {
                    sum = sum.add(acc[q][c]);
                }
                *out = sum;
            }
        }
        out
    }
}

/// Candidate `j` of `lanes` (coordinates and coefficients, by axis)
/// added into `acc` at each register of `points`.
///
/// # Safety
/// The CPU has `V`'s instruction set.
#[inline(always)]
unsafe fn candidate<V: Vector, const K: u8, const P: usize>(
    acc: &mut [[V; 3]; P],
    points: &[[V; 3]; P],
    lanes: [&[f32]; 6],
    j: usize,
) {
    // SAFETY (the whole body): the caller's promise.
    unsafe {
        let c = [
            V::splat(lanes[0][j]),
            V::splat(lanes[1][j]),
            V::splat(lanes[2][j]),
        ];
        let a = [
            V::splat(lanes[3][j]),
            V::splat(lanes[4][j]),
            V::splat(lanes[5][j]),
        ];
        for (acc, p) in acc.iter_mut().zip(points) {
            let w = weight::<V, K>(c, *p);
            acc[0] = w.mul_add(a[0], acc[0]);
            acc[1] = w.mul_add(a[1], acc[1]);
            acc[2] = w.mul_add(a[2], acc[2]);
        }
    }
}

/// Phi of the candidate `c` (broadcast) at a register of points `p`:
/// [`super::sums::sum_body`]'s operations, in its order.
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

/// `iterations` rounds of twelve independent fused multiply-adds in
/// registers of `V` (enough chains to hide an FMA's latency on two pipes);
/// returns a value that depends on every one, so none is left out.
///
/// # Safety
/// The CPU has `V`'s instruction set.
#[inline(always)]
unsafe fn fma_chains<V: Vector>(iterations: usize) -> f32 {
    // SAFETY (the whole body): the caller's promise.
    unsafe {
        // Values the compiler cannot see, so it cannot fold the rounds.
        let [a, b, one] = std::hint::black_box([0.999_9f32, 1.0e-4, 1.0]);
        let (a, b) = (V::splat(a), V::splat(b));
        let mut acc = [V::splat(one); 12];
        for _ in 0..iterations {
            for acc in &mut acc {
                *acc = acc.mul_add(a, b);
            }
        }
        let mut sum = acc[0];
        for v in &acc[1..] {
            sum = sum.add(*v);
        }
        let mut out = [0.0f32; 16];
        sum.store(&mut out);
        out[0]
    }
}

/// [`fma_chains`] eight lanes wide.
///
/// # Safety
/// The CPU has AVX2 and FMA.
#[target_feature(enable = "avx2,fma")]
pub(super) unsafe fn fma_chains_avx2(iterations: usize) -> f32 {
    // SAFETY: the caller's promise.
    unsafe { fma_chains::<__m256>(iterations) }
}

/// [`fma_chains`] sixteen lanes wide.
///
/// # Safety
/// The CPU has AVX-512F, AVX2 and FMA.
#[target_feature(enable = "avx512f,avx2,fma")]
pub(super) unsafe fn fma_chains_avx512(iterations: usize) -> f32 {
    // SAFETY: the caller's promise.
    unsafe { fma_chains::<__m512>(iterations) }
}
