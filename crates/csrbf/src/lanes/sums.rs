//! The kernel sum over a cell's lanes ([`super::View`]): one plain
//! reference and two vector copies of it, chosen once per kernel and CPU.
//!
//! [`sum_body`] is the reference: the arithmetic one lane at a time (without
//! fused multiply-adds), what a CPU without AVX2 and FMA runs. The AVX2 copy
//! computes eight lanes a register, the AVX-512 copy sixteen (two blocks of
//! eight side by side, the last block of an odd count alone in the low
//! half); both take two points at a time, sharing the candidates' loads, and
//! fuse the multiply-adds. The AVX-512 copy sums a lane's blocks in another
//! order than the others (every other block, then the halves added), so the
//! three agree to f32 rounding, not bit for bit; each copy gives a point the
//! same sums alone or paired, and the evaluation and a binding's product
//! choose the same copy ([`Sums::of`]), so they agree bit for bit.
//!
//! Sixteen lanes pay where the CPU runs 512-bit vectors at full width (AMD
//! Zen 5: a `vsqrtps` and an FMA take the same time at 256 and 512 bits, so
//! the rate per lane doubles); measured on Sapphire Rapids (issue 18's fifth
//! pass) they ran no faster than eight, and no slower.

use crate::kernel::Kernel;
use crate::simd::{Avx2Fma, Avx512};

use super::{LANES, View};

/// The kernel sums of one kernel on this CPU, chosen once: with AVX-512
/// where the CPU has it, else AVX2 and FMA when the proof is given, else
/// the plain reference.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Sums {
    kernel: Kernel,
    cpu: Option<Avx2Fma>,
    wide: Option<Avx512>,
}

impl Sums {
    /// The widest sums this CPU runs (none but the plain reference without
    /// `cpu`).
    pub(crate) fn of(cpu: Option<Avx2Fma>, kernel: Kernel) -> Sums {
        let wide = cpu.and_then(|_| Avx512::detect());
        Sums { kernel, cpu, wide }
    }

    /// These sums without AVX-512 (the eight-lane copy, for tests and
    /// measurements beside the wide one).
    #[cfg(test)]
    pub(crate) fn eight_lanes(self) -> Sums {
        Sums { wide: None, ..self }
    }

    /// sum_j alpha_j phi(|x - s_j| / R) over a cell's lanes at each point
    /// of `xs` (in the lanes' frame, [`super::local`]), into `out`.
    pub(crate) fn run(self, l: View<'_>, xs: &[[f32; 3]], out: &mut [[f32; 3]]) {
        #[cfg(target_arch = "x86_64")]
        if let Some(wide) = self.wide {
            let _ = wide;
            // SAFETY: an `Avx512` exists only when the CPU has AVX-512F,
            // AVX2 and FMA.
            #[allow(unsafe_code)]
            unsafe {
                match self.kernel {
                    Kernel::C0 => sums_avx512::<0>(l, xs, out),
                    Kernel::C2 => sums_avx512::<2>(l, xs, out),
                    Kernel::C4 => sums_avx512::<4>(l, xs, out),
                    Kernel::C6 => sums_avx512::<6>(l, xs, out),
                }
            }
            return;
        }
        #[cfg(target_arch = "x86_64")]
        if let Some(cpu) = self.cpu {
            let _ = cpu;
            // SAFETY: an `Avx2Fma` exists only when the CPU has AVX2 and FMA.
            #[allow(unsafe_code)]
            unsafe {
                match self.kernel {
                    Kernel::C0 => sums_avx2_fma::<0>(l, xs, out),
                    Kernel::C2 => sums_avx2_fma::<2>(l, xs, out),
                    Kernel::C4 => sums_avx2_fma::<4>(l, xs, out),
                    Kernel::C6 => sums_avx2_fma::<6>(l, xs, out),
                }
            }
            return;
        }
        match self.kernel {
            Kernel::C0 => sums_plain::<0>(l, xs, out),
            Kernel::C2 => sums_plain::<2>(l, xs, out),
            Kernel::C4 => sums_plain::<4>(l, xs, out),
            Kernel::C6 => sums_plain::<6>(l, xs, out),
        }
    }
}

/// phi as a function of t = max(1 - r, 0) and r, in f32 (the formulas of
/// [`Kernel::eval`]).
#[inline(always)]
fn phi<const K: u8>(t: f32, r: f32) -> f32 {
    let fma = |a: f32, b: f32, c: f32| a * b + c;
    let t2 = t * t;
    match K {
        0 => t2,
        2 => t2 * t2 * fma(4.0, r, 1.0),
        4 => t2 * t2 * t2 * fma(fma(35.0, r, 18.0), r, 3.0),
        _ => {
            let t4 = t2 * t2;
            t4 * t4 * fma(fma(fma(32.0, r, 25.0), r, 8.0), r, 1.0)
        }
    }
}

/// The sum, eight lanes of accumulators over the padded arrays, in the
/// order [`sums_avx2_fma`] computes it (which fuses the multiply-adds).
fn sum_body<const K: u8>(l: View<'_>, x: [f32; 3]) -> [f32; 3] {
    let fma = |a: f32, b: f32, c: f32| a * b + c;
    let mut acc = [[0.0f32; LANES]; 3];
    let [xs, ys, zs] = l.xyz;
    let [ax, ay, az] = l.alpha;
    let chunks = xs
        .chunks_exact(LANES)
        .zip(ys.chunks_exact(LANES))
        .zip(zs.chunks_exact(LANES))
        .zip(ax.chunks_exact(LANES))
        .zip(ay.chunks_exact(LANES))
        .zip(az.chunks_exact(LANES));
    for (((((cx, cy), cz), ax), ay), az) in chunks {
        for k in 0..LANES {
            let (dx, dy, dz) = (cx[k] - x[0], cy[k] - x[1], cz[k] - x[2]);
            let r = fma(dz, dz, fma(dy, dy, dx * dx)).sqrt();
            let t = 1.0 - r;
            let t = if t > 0.0 { t } else { 0.0 };
            let w = phi::<K>(t, r);
            acc[0][k] = fma(w, ax[k], acc[0][k]);
            acc[1][k] = fma(w, ay[k], acc[1][k]);
            acc[2][k] = fma(w, az[k], acc[2][k]);
        }
    }
    acc.map(|a| ((a[0] + a[1]) + (a[2] + a[3])) + ((a[4] + a[5]) + (a[6] + a[7])))
}

/// Phi of eight candidates' coordinates `c` at a point `p` (broadcast):
/// [`sum_body`]'s operations, in its order.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
fn weight_avx2<const K: u8>(
    c: [std::arch::x86_64::__m256; 3],
    p: [std::arch::x86_64::__m256; 3],
) -> std::arch::x86_64::__m256 {
    use std::arch::x86_64::*;
    let (zero, one) = (_mm256_setzero_ps(), _mm256_set1_ps(1.0));
    let k = _mm256_set1_ps;
    let (dx, dy, dz) = (
        _mm256_sub_ps(c[0], p[0]),
        _mm256_sub_ps(c[1], p[1]),
        _mm256_sub_ps(c[2], p[2]),
    );
    let r2 = _mm256_fmadd_ps(dz, dz, _mm256_fmadd_ps(dy, dy, _mm256_mul_ps(dx, dx)));
    let r = _mm256_sqrt_ps(r2);
    let t = _mm256_max_ps(_mm256_sub_ps(one, r), zero);
    let t2 = _mm256_mul_ps(t, t);
    match K {
        0 => t2,
        2 => _mm256_mul_ps(_mm256_mul_ps(t2, t2), _mm256_fmadd_ps(k(4.0), r, one)),
        4 => {
            let q = _mm256_fmadd_ps(_mm256_fmadd_ps(k(35.0), r, k(18.0)), r, k(3.0));
            _mm256_mul_ps(_mm256_mul_ps(_mm256_mul_ps(t2, t2), t2), q)
        }
        _ => {
            let t4 = _mm256_mul_ps(t2, t2);
            let q = _mm256_fmadd_ps(k(32.0), r, k(25.0));
            let q = _mm256_fmadd_ps(_mm256_fmadd_ps(q, r, k(8.0)), r, one);
            _mm256_mul_ps(_mm256_mul_ps(t4, t4), q)
        }
    }
}

/// A point's three sums from its eight lanes of accumulators: two
/// horizontal adds of x with y and z with itself, one of those, then the
/// halves.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
fn reduce_avx2(acc: [std::arch::x86_64::__m256; 3]) -> [f32; 3] {
    use std::arch::x86_64::*;
    let xyz = _mm256_hadd_ps(
        _mm256_hadd_ps(acc[0], acc[1]),
        _mm256_hadd_ps(acc[2], acc[2]),
    );
    let sums = _mm_add_ps(_mm256_castps256_ps128(xyz), _mm256_extractf128_ps::<1>(xyz));
    let mut v = [0.0f32; 4];
    // SAFETY: `v` holds four f32.
    #[allow(unsafe_code)]
    unsafe {
        _mm_storeu_ps(v.as_mut_ptr(), sums)
    };
    [v[0], v[1], v[2]]
}

/// [`sum_body`] in AVX2 and FMA intrinsics for every point of `xs` (into
/// `out`): eight lanes a register, the same operations in the same order
/// per lane, two points at a time (they share the lanes' loads; a point's
/// sums are the same alone or paired).
///
/// # Safety
/// The CPU has AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
#[target_feature(enable = "avx2,fma")]
unsafe fn sums_avx2_fma<const K: u8>(l: View<'_>, xs: &[[f32; 3]], out: &mut [[f32; 3]]) {
    use std::arch::x86_64::*;
    let [cxs, cys, czs] = l.xyz;
    let [axs, ays, azs] = l.alpha;
    let n = [cxs, cys, czs, axs, ays, azs]
        .map(|v| v.len())
        .into_iter()
        .min()
        .unwrap_or(0);
    let n = n - n % LANES;
    let lanes = [cxs, cys, czs, axs, ays, azs];
    let at = |x: &[f32; 3]| x.map(|v| _mm256_set1_ps(v));
    let two = xs.len() / 2 * 2;
    let (xs2, xs1) = xs.split_at(two);
    let (out2, out1) = out.split_at_mut(two);
    for (x, o) in xs2.chunks_exact(2).zip(out2.chunks_exact_mut(2)) {
        let (p, q) = (at(&x[0]), at(&x[1]));
        let mut acc = [_mm256_setzero_ps(); 6];
        for k in (0..n).step_by(LANES) {
            // SAFETY: k + 8 <= n <= the length of every array.
            #[allow(unsafe_code)]
            let [cx, cy, cz, ax, ay, az] =
                unsafe { lanes.map(|v| _mm256_loadu_ps(v.as_ptr().add(k))) };
            let (w, v) = (
                weight_avx2::<K>([cx, cy, cz], p),
                weight_avx2::<K>([cx, cy, cz], q),
            );
            acc = [
                _mm256_fmadd_ps(w, ax, acc[0]),
                _mm256_fmadd_ps(w, ay, acc[1]),
                _mm256_fmadd_ps(w, az, acc[2]),
                _mm256_fmadd_ps(v, ax, acc[3]),
                _mm256_fmadd_ps(v, ay, acc[4]),
                _mm256_fmadd_ps(v, az, acc[5]),
            ];
        }
        o[0] = reduce_avx2([acc[0], acc[1], acc[2]]);
        o[1] = reduce_avx2([acc[3], acc[4], acc[5]]);
    }
    for (x, o) in xs1.iter().zip(out1) {
        let p = at(x);
        let mut acc = [_mm256_setzero_ps(); 3];
        for k in (0..n).step_by(LANES) {
            // SAFETY: as above.
            #[allow(unsafe_code)]
            let [cx, cy, cz, ax, ay, az] =
                unsafe { lanes.map(|v| _mm256_loadu_ps(v.as_ptr().add(k))) };
            let w = weight_avx2::<K>([cx, cy, cz], p);
            acc = [
                _mm256_fmadd_ps(w, ax, acc[0]),
                _mm256_fmadd_ps(w, ay, acc[1]),
                _mm256_fmadd_ps(w, az, acc[2]),
            ];
        }
        *o = reduce_avx2(acc);
    }
}

/// Phi of sixteen candidates' coordinates `c` at a point `p` (broadcast):
/// [`weight_avx2`]'s operations at twice the width.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,fma")]
#[inline]
fn weight_avx512<const K: u8>(
    c: [std::arch::x86_64::__m512; 3],
    p: [std::arch::x86_64::__m512; 3],
) -> std::arch::x86_64::__m512 {
    use std::arch::x86_64::*;
    let (zero, one) = (_mm512_setzero_ps(), _mm512_set1_ps(1.0));
    let k = _mm512_set1_ps;
    let (dx, dy, dz) = (
        _mm512_sub_ps(c[0], p[0]),
        _mm512_sub_ps(c[1], p[1]),
        _mm512_sub_ps(c[2], p[2]),
    );
    let r2 = _mm512_fmadd_ps(dz, dz, _mm512_fmadd_ps(dy, dy, _mm512_mul_ps(dx, dx)));
    let r = _mm512_sqrt_ps(r2);
    let t = _mm512_max_ps(_mm512_sub_ps(one, r), zero);
    let t2 = _mm512_mul_ps(t, t);
    match K {
        0 => t2,
        2 => _mm512_mul_ps(_mm512_mul_ps(t2, t2), _mm512_fmadd_ps(k(4.0), r, one)),
        4 => {
            let q = _mm512_fmadd_ps(_mm512_fmadd_ps(k(35.0), r, k(18.0)), r, k(3.0));
            _mm512_mul_ps(_mm512_mul_ps(_mm512_mul_ps(t2, t2), t2), q)
        }
        _ => {
            let t4 = _mm512_mul_ps(t2, t2);
            let q = _mm512_fmadd_ps(k(32.0), r, k(25.0));
            let q = _mm512_fmadd_ps(_mm512_fmadd_ps(q, r, k(8.0)), r, one);
            _mm512_mul_ps(_mm512_mul_ps(t4, t4), q)
        }
    }
}

/// The lanes `k..k + 16` of a cell's six arrays (coordinates, then
/// coefficients); with `half`, only `k..k + 8`, the high lanes a far start
/// of zero coefficient.
///
/// # Safety
/// The CPU has AVX-512F; `k + 16` (`k + 8` with `half`) is at most the
/// length of every array.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,fma")]
#[inline]
#[allow(unsafe_code)]
unsafe fn load_avx512(lanes: [&[f32]; 6], k: usize, half: bool) -> [std::arch::x86_64::__m512; 6] {
    use std::arch::x86_64::*;
    let far = _mm512_set1_ps(super::FAR);
    let zero = _mm512_setzero_ps();
    let mut v = [zero; 6];
    for (i, (a, v)) in lanes.iter().zip(&mut v).enumerate() {
        // SAFETY: the caller's bounds; a masked load reads only the lanes
        // its mask sets (the low eight).
        unsafe {
            let at = a.as_ptr().add(k);
            *v = if half {
                _mm512_mask_loadu_ps(if i < 3 { far } else { zero }, 0x00ff, at)
            } else {
                _mm512_loadu_ps(at)
            };
        }
    }
    v
}

/// A point's three sums from its sixteen lanes of accumulators: the high
/// eight added to the low, then [`reduce_avx2`].
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,fma")]
#[inline]
fn reduce_avx512(acc: [std::arch::x86_64::__m512; 3]) -> [f32; 3] {
    use std::arch::x86_64::*;
    let halves = |v: __m512| {
        let high = _mm256_castpd_ps(_mm512_extractf64x4_pd::<1>(_mm512_castps_pd(v)));
        _mm256_add_ps(_mm512_castps512_ps256(v), high)
    };
    reduce_avx2(acc.map(halves))
}

/// [`sum_body`] in AVX-512 intrinsics for every point of `xs` (into
/// `out`): sixteen lanes a register (blocks of eight two at a time, an odd
/// last one in the low half), two points at a time as [`sums_avx2_fma`]
/// (four at a time measured no faster).
///
/// # Safety
/// The CPU has AVX-512F, AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
#[target_feature(enable = "avx512f,avx2,fma")]
unsafe fn sums_avx512<const K: u8>(l: View<'_>, xs: &[[f32; 3]], out: &mut [[f32; 3]]) {
    let lanes = [
        l.xyz[0], l.xyz[1], l.xyz[2], l.alpha[0], l.alpha[1], l.alpha[2],
    ];
    let n = lanes.map(<[f32]>::len).into_iter().min().unwrap_or(0);
    let n = n - n % LANES;
    let two = xs.len() / 2 * 2;
    let (xs2, xs1) = xs.split_at(two);
    let (out2, out1) = out.split_at_mut(two);
    for (x, o) in xs2.chunks_exact(2).zip(out2.chunks_exact_mut(2)) {
        // SAFETY: n is a multiple of eight, at most every array's length.
        let sums = unsafe { points_avx512::<K, 2>(lanes, n, [x[0], x[1]]) };
        o.copy_from_slice(&sums);
    }
    for (x, o) in xs1.iter().zip(out1) {
        // SAFETY: as above.
        *o = unsafe { points_avx512::<K, 1>(lanes, n, [*x])[0] };
    }
}

/// The sums of `P` points over the first `n` lanes: each point's own
/// accumulators, so a point's sums do not depend on its company.
///
/// # Safety
/// The CPU has AVX-512F, AVX2 and FMA; `n` is a multiple of eight and at
/// most the length of every array of `lanes`.
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
#[target_feature(enable = "avx512f,avx2,fma")]
#[inline]
unsafe fn points_avx512<const K: u8, const P: usize>(
    lanes: [&[f32]; 6],
    n: usize,
    xs: [[f32; 3]; P],
) -> [[f32; 3]; P] {
    use std::arch::x86_64::*;
    let at = xs.map(|x| x.map(|v| _mm512_set1_ps(v)));
    let mut acc = [[_mm512_setzero_ps(); 3]; P];
    // Loads of sixteen lanes, then at most one of eight.
    for k in (0..n).step_by(2 * LANES) {
        let half = k + 2 * LANES > n;
        // SAFETY: k + 16 <= n, or k + 8 <= n with `half`.
        let [cx, cy, cz, ax, ay, az] = unsafe { load_avx512(lanes, k, half) };
        for (acc, p) in acc.iter_mut().zip(&at) {
            let w = weight_avx512::<K>([cx, cy, cz], *p);
            *acc = [
                _mm512_fmadd_ps(w, ax, acc[0]),
                _mm512_fmadd_ps(w, ay, acc[1]),
                _mm512_fmadd_ps(w, az, acc[2]),
            ];
        }
    }
    acc.map(|a| reduce_avx512(a))
}

/// [`sum_body`] for every point of `xs`, into `out`.
fn sums_plain<const K: u8>(l: View<'_>, xs: &[[f32; 3]], out: &mut [[f32; 3]]) {
    for (x, o) in xs.iter().zip(out) {
        *o = sum_body::<K>(l, *x);
    }
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;
    use crate::lanes::Lanes;
    use crate::octree::Octree;
    use crate::synthetic::Rng;

    /// The plain f64 sum over every start within R of `x`.
    fn reference(starts: &[DVec3], alpha: &[DVec3], kernel: Kernel, r: f64, x: DVec3) -> DVec3 {
        starts
            .iter()
            .zip(alpha)
            .map(|(s, a)| *a * kernel.eval(s.distance(x) / r))
            .sum()
    }

    /// Every copy this CPU runs agrees with the f64 sum to f32 accuracy
    /// (relative to the sum of |alpha_j| within R, the scale of the
    /// rounding) and with the plain one, for every kernel, candidate counts
    /// that are and are not multiples of eight and of sixteen (and none),
    /// starts far from the origin; and gives a point the same sums alone
    /// as in a pair. Where the CPU lacks AVX2 or AVX-512 the copies it
    /// lacks fall back to the narrower one, checked the same way.
    #[test]
    fn every_copy_agrees_with_the_f64_sum() {
        let mut rng = Rng::new(18);
        for kernel in [Kernel::C0, Kernel::C2, Kernel::C4, Kernel::C6] {
            let copies = [
                ("plain", Sums::of(None, kernel)),
                ("avx2", Sums::of(Avx2Fma::detect(), kernel).eight_lanes()),
                ("avx512", Sums::of(Avx2Fma::detect(), kernel)),
            ];
            for n in [0, 1, 7, 8, 9, 16, 23, 24, 30, 64, 100, 203] {
                let r = 0.05 + 0.2 * rng.f64();
                let offset = DVec3::new(3.0, -2.0, 0.5); // far from the origin
                let starts: Vec<DVec3> = (0..n).map(|_| offset + rng.vec3() * 0.3).collect();
                let alpha: Vec<DVec3> = (0..n).map(|_| rng.vec3() * 4.0 - 2.0).collect();
                let octree = Octree::new(&starts);
                let (lo, hi) = (offset + 0.1, offset + 0.1 + r * 0.5);
                let mut lanes = Lanes::default();
                lanes.gather(&octree, &alpha, (lo, hi), r);
                assert_eq!(lanes.lanes() % LANES, 0);
                assert!(lanes.candidates() <= n && lanes.lanes() < lanes.candidates() + LANES);
                // Points in one call (an odd count: pairs and one alone).
                let xs: Vec<DVec3> = (0..21).map(|_| lo + (hi - lo) * rng.vec3()).collect();
                let local: Vec<[f32; 3]> = xs.iter().map(|x| lanes.local(*x)).collect();
                let sums = copies.map(|(_, c)| {
                    let mut out = vec![[0.0f32; 3]; xs.len()];
                    c.run(lanes.view(), &local, &mut out);
                    out
                });
                for (k, x) in xs.iter().enumerate() {
                    let want = reference(&starts, &alpha, kernel, r, *x);
                    // f32 rounds r and phi by about 1e-7 (phi and its slope
                    // are at most a few): the error scales with the
                    // coefficients in reach.
                    let scale: f64 = starts
                        .iter()
                        .zip(&alpha)
                        .filter(|(s, _)| s.distance(*x) < r)
                        .map(|(_, a)| a.length())
                        .sum::<f64>()
                        + 1e-30;
                    let plain = DVec3::from_array(sums[0][k].map(f64::from));
                    for ((what, copy), sums) in copies.iter().zip(&sums) {
                        let got = DVec3::from_array(sums[k].map(f64::from));
                        let err = (got - want).length() / scale;
                        assert!(err < 2e-6, "{kernel:?} n {n} {what}: error {err:e}");
                        assert!((got - plain).length() / scale < 2e-6, "{what}");
                        // A point's sums alone are its sums in a pair.
                        let mut alone = [[0.0f32; 3]];
                        copy.run(lanes.view(), &local[k..=k], &mut alone);
                        let bits = |v: [f32; 3]| v.map(f32::to_bits);
                        assert_eq!(bits(alone[0]), bits(sums[k]), "{what}");
                    }
                }
            }
        }
    }
}
