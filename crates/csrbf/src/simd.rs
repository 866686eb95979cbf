//! Runtime dispatch of the few hot loops to AVX2 + FMA where the CPU has it.
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

/// Dot product with eight accumulators; with `FMA`, fused multiply-adds
/// (only in code compiled with the `fma` feature, else they are library calls).
#[inline(always)]
pub(crate) fn dot<const FMA: bool>(a: &[f64], b: &[f64]) -> f64 {
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
            assert!((dot::<true>(&xs, &ys) - dot::<false>(&xs, &ys)).abs() < 1e-12);
        }
    }
}
