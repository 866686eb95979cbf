//! Runtime dispatch of the few hot loops to AVX2 + FMA where the CPU has it
//! (and of the f32 kernel sum to AVX-512).
//!
//! The crate compiles for baseline x86-64 (SSE2), which leaves most of a
//! modern CPU's vector width unused. Each hot loop is written once as an
//! `#[inline(always)]` body; a `#[target_feature]` wrapper compiles it again
//! with AVX2 and FMA, and is called only after a runtime check.

/// Proof that this CPU has AVX2 and FMA: only [`Avx2Fma::detect`] makes
/// one, so a safe function taking it may call code compiled for them.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Avx2Fma(());

impl Avx2Fma {
    /// The proof, when the CPU has both (checked once, then cached by std).
    #[inline]
    pub(crate) fn detect() -> Option<Avx2Fma> {
        has_avx2_fma().then_some(Avx2Fma(()))
    }
}

/// Proof that this CPU has AVX-512F besides AVX2 and FMA: only
/// [`Avx512::detect`] makes one.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Avx512(());

impl Avx512 {
    /// The proof, when the CPU has all three (checked once, then cached by
    /// std).
    #[inline]
    pub(crate) fn detect() -> Option<Avx512> {
        #[cfg(target_arch = "x86_64")]
        if has_avx2_fma() && std::arch::is_x86_feature_detected!("avx512f") {
            return Some(Avx512(()));
        }
        None
    }
}

/// Whether this CPU has AVX2 and FMA.
#[inline]
fn has_avx2_fma() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Dot product with eight accumulators; with `FMA`, fused multiply-adds in
/// 256-bit registers ([`dots_avx2`]). `FMA = true` only in bodies compiled
/// under `#[target_feature(enable = "avx2,fma")]` and entered after
/// [`Avx2Fma::detect`]: the rule every caller in this crate follows.
#[inline(always)]
pub(crate) fn dot<const FMA: bool>(a: &[f64], b: &[f64]) -> f64 {
    #[cfg(target_arch = "x86_64")]
    if FMA {
        // SAFETY: `FMA` is true only where the CPU has AVX2 and FMA (above).
        #[allow(unsafe_code)]
        return unsafe { dots_avx2(a, [b])[0] };
    }
    dot_portable::<FMA>(a, b)
}

/// [`dot`] in plain Rust (what a CPU without AVX2 runs). The compiler
/// vectorises it only to 128 bits; [`dots_avx2`] sums the same way.
#[inline(always)]
fn dot_portable<const FMA: bool>(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut acc = [0.0f64; 8];
    let mut ca = a.chunks_exact(8);
    let mut cb = b.chunks_exact(8);
    for (x, y) in (&mut ca).zip(&mut cb) {
        for k in 0..8 {
            acc[k] = if FMA {
                x[k].mul_add(y[k], acc[k])
            } else {
                acc[k] + x[k] * y[k]
            };
        }
    }
    let tail: f64 = ca
        .remainder()
        .iter()
        .zip(cb.remainder())
        .map(|(x, y)| x * y)
        .sum();
    ((acc[0] + acc[4]) + (acc[1] + acc[5])) + ((acc[2] + acc[6]) + (acc[3] + acc[7])) + tail
}

/// Four dot products of `a` with `b[0..4]` at once, each summed as [`dot`]
/// sums (eight accumulators): `a` is loaded once for the four, so the loop
/// does 5 loads for 4 multiply-adds where four calls to [`dot`] do 8.
#[inline(always)]
pub(crate) fn dot4<const FMA: bool>(a: &[f64], b: [&[f64]; 4]) -> [f64; 4] {
    #[cfg(target_arch = "x86_64")]
    if FMA {
        // SAFETY: `FMA` is true only where the CPU has AVX2 and FMA ([`dot`]).
        #[allow(unsafe_code)]
        return unsafe { dots_avx2(a, b) };
    }
    dot4_portable::<FMA>(a, b)
}

/// [`dot4`] in plain Rust.
#[inline(always)]
fn dot4_portable<const FMA: bool>(a: &[f64], b: [&[f64]; 4]) -> [f64; 4] {
    let n = b.iter().fold(a.len(), |n, x| n.min(x.len()));
    let a = &a[..n];
    let b = b.map(|x| &x[..n]);
    let mut acc = [[0.0f64; 8]; 4];
    let chunks = n / 8;
    for c in 0..chunks {
        let x = &a[8 * c..8 * c + 8];
        for t in 0..4 {
            let y = &b[t][8 * c..8 * c + 8];
            for k in 0..8 {
                acc[t][k] = if FMA {
                    x[k].mul_add(y[k], acc[t][k])
                } else {
                    acc[t][k] + x[k] * y[k]
                };
            }
        }
    }
    let mut out = [0.0; 4];
    for t in 0..4 {
        let tail: f64 = a[8 * chunks..]
            .iter()
            .zip(&b[t][8 * chunks..])
            .map(|(x, y)| x * y)
            .sum();
        let acc = &acc[t];
        out[t] = ((acc[0] + acc[4]) + (acc[1] + acc[5]))
            + ((acc[2] + acc[6]) + (acc[3] + acc[7]))
            + tail;
    }
    out
}

/// `M` dot products of `a` with `b[0..M]` (over their common length) in
/// 256-bit registers: per product two accumulators of four lanes, i.e. the
/// eight accumulators of [`dot_portable`], summed in the same order, so the
/// results equal `dot_portable::<true>` bit for bit.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
#[allow(unsafe_code)] // unaligned loads inside the slices' common length
fn dots_avx2<const M: usize>(a: &[f64], b: [&[f64]; M]) -> [f64; M] {
    use core::arch::x86_64::*;
    let n = b.iter().fold(a.len(), |n, x| n.min(x.len()));
    let chunks = n / 8;
    let mut acc = [[_mm256_setzero_pd(); 2]; M];
    for c in 0..chunks {
        let k = 8 * c;
        // SAFETY: k + 8 <= n, and n is at most every slice's length.
        let (x0, x1) = unsafe {
            (
                _mm256_loadu_pd(a.as_ptr().add(k)),
                _mm256_loadu_pd(a.as_ptr().add(k + 4)),
            )
        };
        for t in 0..M {
            let p = b[t].as_ptr();
            // SAFETY: as above.
            let (y0, y1) = unsafe { (_mm256_loadu_pd(p.add(k)), _mm256_loadu_pd(p.add(k + 4))) };
            acc[t][0] = _mm256_fmadd_pd(x0, y0, acc[t][0]);
            acc[t][1] = _mm256_fmadd_pd(x1, y1, acc[t][1]);
        }
    }
    let mut out = [0.0; M];
    for t in 0..M {
        // Lane k holds acc[k] + acc[k + 4] of the portable sum.
        let mut s = [0.0f64; 4];
        // SAFETY: `s` has room for four f64.
        unsafe { _mm256_storeu_pd(s.as_mut_ptr(), _mm256_add_pd(acc[t][0], acc[t][1])) };
        let tail: f64 = a[8 * chunks..n]
            .iter()
            .zip(&b[t][8 * chunks..n])
            .map(|(x, y)| x * y)
            .sum();
        out[t] = (s[0] + s[1]) + (s[2] + s[3]) + tail;
    }
    out
}

/// Bit k set when point k (of at most 64, by coordinate arrays) is closer
/// than sqrt(r2) to `x`.
#[inline(always)]
fn hit_mask_body(xs: &[f64], ys: &[f64], zs: &[f64], x: [f64; 3], r2: f64) -> u64 {
    let n = xs.len().min(ys.len()).min(zs.len()).min(64);
    let (xs, ys, zs) = (&xs[..n], &ys[..n], &zs[..n]);
    let mut bits = 0u64;
    for k in 0..n {
        let (dx, dy, dz) = (xs[k] - x[0], ys[k] - x[1], zs[k] - x[2]);
        bits |= ((dx * dx + dy * dy + dz * dz < r2) as u64) << k;
    }
    bits
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn hit_mask_avx2(xs: &[f64], ys: &[f64], zs: &[f64], x: [f64; 3], r2: f64) -> u64 {
    hit_mask_body(xs, ys, zs, x, r2)
}

/// [`hit_mask_body`], compiled for AVX2 when the proof is given.
#[inline]
pub(crate) fn hit_mask(
    cpu: Option<Avx2Fma>,
    xs: &[f64],
    ys: &[f64],
    zs: &[f64],
    x: [f64; 3],
    r2: f64,
) -> u64 {
    #[cfg(target_arch = "x86_64")]
    if let Some(Avx2Fma(())) = cpu {
        // SAFETY: an `Avx2Fma` exists only when the CPU has AVX2 and FMA.
        #[allow(unsafe_code)]
        unsafe {
            return hit_mask_avx2(xs, ys, zs, x, r2);
        }
    }
    let _ = cpu;
    hit_mask_body(xs, ys, zs, x, r2)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The scalar fallback and the AVX2 code agree (on a machine that has
    /// AVX2 both run; elsewhere the fallback is checked against itself).
    #[test]
    fn fallbacks_agree_with_the_vector_code() {
        let mut s = 0x2545_f491_4f6c_dd1du64;
        let mut r = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        for n in [0, 1, 7, 8, 33, 64] {
            let (xs, ys, zs): (Vec<f64>, Vec<f64>, Vec<f64>) = (0..n)
                .map(|_| (r(), r(), r()))
                .fold((vec![], vec![], vec![]), |mut a, p| {
                    a.0.push(p.0);
                    a.1.push(p.1);
                    a.2.push(p.2);
                    a
                });
            let q = [r(), r(), r()];
            let want = hit_mask(None, &xs, &ys, &zs, q, 0.3);
            assert_eq!(hit_mask(Avx2Fma::detect(), &xs, &ys, &zs, q, 0.3), want);
            assert_eq!(dot::<false>(&xs, &ys), dot::<false>(&ys, &xs));
            assert!((dot_portable::<true>(&xs, &ys) - dot::<false>(&xs, &ys)).abs() < 1e-12);
            // Four at once sum exactly as one at a time (same order), and
            // the 256-bit code exactly as the portable code with FMA.
            let four = [&ys[..], &zs[..], &xs[..], &ys[..]];
            let want = four.map(|b| dot_portable::<false>(&xs, b));
            assert_eq!(dot4_portable::<false>(&xs, four), want);
            #[cfg(target_arch = "x86_64")]
            if Avx2Fma::detect().is_some() {
                let want = four.map(|b| dot_portable::<true>(&xs, b));
                assert_eq!(dot4_portable::<true>(&xs, four), want);
                #[allow(unsafe_code)]
                // SAFETY: the CPU has AVX2 and FMA (checked just above).
                let got = unsafe { dots_avx2(&xs, four) };
                assert_eq!(got, want);
            }
        }
    }
}
