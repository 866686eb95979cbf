//! Runtime dispatch of the few hot loops to AVX2 + FMA where the CPU has it.
//!
//! The crate compiles for baseline x86-64 (SSE2), which leaves most of a
//! modern CPU's vector width unused. Each hot loop is written once as an
//! `#[inline(always)]` body; a `#[target_feature]` wrapper compiles it again
//! with AVX2 and FMA, and is called only after a runtime check.

/// Whether this CPU has AVX2 and FMA (checked once, then cached by std).
#[inline]
pub(crate) fn has_avx2_fma() -> bool {
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

/// [`hit_mask_body`], dispatched on the CPU.
#[inline]
pub(crate) fn hit_mask(
    avx2: bool,
    xs: &[f64],
    ys: &[f64],
    zs: &[f64],
    x: [f64; 3],
    r2: f64,
) -> u64 {
    #[cfg(target_arch = "x86_64")]
    if avx2 {
        // SAFETY: `avx2` is true only when `has_avx2_fma()` said so.
        #[allow(unsafe_code)]
        unsafe {
            return hit_mask_avx2(xs, ys, zs, x, r2);
        }
    }
    let _ = avx2;
    hit_mask_body(xs, ys, zs, x, r2)
}
