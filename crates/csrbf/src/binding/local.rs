//! A narrow cell's weights in f32, as the evaluation computes them: the
//! candidates about the cell's centre and in units of R (as
//! [`crate::lanes`] keeps them), r = sqrt(r^2) and phi(max(1 - r, 0), r) by
//! [`crate::lanes::phi`]'s operations, eight candidates a vector. A
//! candidate is a hit when 1 - r > 0, where the evaluation's weight is not
//! zero; so a binding stores the very weights
//! [`crate::Deformation::displacements_f32`] sums (the AVX2 copy fuses the
//! multiply-adds as the evaluation's does; the plain copy, the reference,
//! rounds each).
//!
//! A cell too wide for f32 coordinates about its centre (few starts: points
//! in their own order) takes the f64 weights of [`super::weights`].

use std::mem::MaybeUninit;

use glam::DVec3;

use super::BLOCK;
use super::weights::{COMPRESS, ONES};
use crate::evaluate::Candidates;
use crate::kernel::Kernel;
use crate::lanes::{FAR, phi};
use crate::simd::Avx2Fma;

/// A cell's candidates by coordinate, about the centre of its points'
/// bounds in units of R, padded to a multiple of eight with far starts.
#[derive(Default)]
pub(super) struct Local {
    xyz: [Vec<f32>; 3],
    centre: DVec3,
    inv_radius: f64,
}

impl Local {
    /// The candidates of `cand` (gathered for points within `bounds`).
    pub(super) fn pad(&mut self, cand: &Candidates, (lo, hi): (DVec3, DVec3), radius: f64) {
        self.centre = (lo + hi) * 0.5;
        self.inv_radius = 1.0 / radius;
        let padded = cand.len().next_multiple_of(BLOCK);
        for (axis, v) in self.xyz.iter_mut().enumerate() {
            v.clear();
            v.extend(
                (0..cand.len())
                    .map(|k| ((cand.start(k)[axis] - self.centre[axis]) * self.inv_radius) as f32),
            );
            v.resize(padded, FAR);
        }
    }

    /// `x` in the cell's frame (units of R about the centre).
    pub(super) fn local(&self, x: DVec3) -> [f32; 3] {
        ((x - self.centre) * self.inv_radius).as_vec3().to_array()
    }
}

/// Writes one point's mask bytes into `row` and the weights of its hits
/// into `weights` (from the first); returns the hits. `x` is given by
/// [`Local::local`]. The first `hits` elements of `weights` are then
/// initialised (a vector store may write up to eight more).
pub(super) fn fill_local(
    cpu: Option<Avx2Fma>,
    l: &Local,
    kernel: Kernel,
    x: [f32; 3],
    row: &mut [u8],
    weights: &mut [MaybeUninit<f32>],
) -> usize {
    #[cfg(target_arch = "x86_64")]
    if let Some(cpu) = cpu {
        let _ = cpu;
        // SAFETY: an `Avx2Fma` exists only when the CPU has AVX2 and FMA.
        #[allow(unsafe_code)]
        unsafe {
            return match kernel {
                Kernel::C0 => fill_avx2::<0>(l, x, row, weights),
                Kernel::C2 => fill_avx2::<2>(l, x, row, weights),
                Kernel::C4 => fill_avx2::<4>(l, x, row, weights),
                Kernel::C6 => fill_avx2::<6>(l, x, row, weights),
            };
        }
    }
    let _ = cpu;
    fill_local_plain(l, kernel, x, row, weights)
}

/// The reference: one lane at a time, each operation rounded.
pub(super) fn fill_local_plain(
    l: &Local,
    kernel: Kernel,
    x: [f32; 3],
    row: &mut [u8],
    weights: &mut [MaybeUninit<f32>],
) -> usize {
    match kernel {
        Kernel::C0 => fill_body::<0>(l, x, row, weights),
        Kernel::C2 => fill_body::<2>(l, x, row, weights),
        Kernel::C4 => fill_body::<4>(l, x, row, weights),
        Kernel::C6 => fill_body::<6>(l, x, row, weights),
    }
}

#[inline(always)]
fn fill_body<const K: u8>(
    l: &Local,
    x: [f32; 3],
    row: &mut [u8],
    weights: &mut [MaybeUninit<f32>],
) -> usize {
    let fma = |a: f32, b: f32, c: f32| a * b + c;
    let [xs, ys, zs] = &l.xyz;
    let mut w = 0;
    let blocks = xs.chunks_exact(BLOCK).zip(ys.chunks_exact(BLOCK));
    for ((byte, (cx, cy)), cz) in row.iter_mut().zip(blocks).zip(zs.chunks_exact(BLOCK)) {
        let mut bits = 0u8;
        for k in 0..BLOCK {
            let (dx, dy, dz) = (cx[k] - x[0], cy[k] - x[1], cz[k] - x[2]);
            let r = fma(dz, dz, fma(dy, dy, dx * dx)).sqrt();
            let t = 1.0 - r;
            if t > 0.0 {
                bits |= 1 << k;
                weights[w] = MaybeUninit::new(phi::<K>(t, r));
                w += 1;
            }
        }
        *byte = bits;
    }
    w
}

/// [`fill_body`] in AVX2 and FMA: a block in one vector, its hits' weights
/// stored by one permutation (`COMPRESS`) and one unaligned store.
///
/// # Safety
/// The CPU has AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
#[target_feature(enable = "avx2,fma")]
unsafe fn fill_avx2<const K: u8>(
    l: &Local,
    x: [f32; 3],
    row: &mut [u8],
    weights: &mut [MaybeUninit<f32>],
) -> usize {
    use std::arch::x86_64::*;
    let [xs, ys, zs] = &l.xyz;
    let n = xs.len().min(ys.len()).min(zs.len()).min(row.len() * BLOCK);
    let (px, py, pz) = (
        _mm256_set1_ps(x[0]),
        _mm256_set1_ps(x[1]),
        _mm256_set1_ps(x[2]),
    );
    let (zero, one) = (_mm256_setzero_ps(), _mm256_set1_ps(1.0));
    let mut w = 0;
    for (b, byte) in row.iter_mut().enumerate().take(n / BLOCK) {
        let k = b * BLOCK;
        // SAFETY: k + 8 <= n <= the length of every array.
        let (cx, cy, cz) = unsafe {
            (
                _mm256_loadu_ps(xs.as_ptr().add(k)),
                _mm256_loadu_ps(ys.as_ptr().add(k)),
                _mm256_loadu_ps(zs.as_ptr().add(k)),
            )
        };
        let (dx, dy, dz) = (
            _mm256_sub_ps(cx, px),
            _mm256_sub_ps(cy, py),
            _mm256_sub_ps(cz, pz),
        );
        let r2 = _mm256_fmadd_ps(dz, dz, _mm256_fmadd_ps(dy, dy, _mm256_mul_ps(dx, dx)));
        let r = _mm256_sqrt_ps(r2);
        let t = _mm256_sub_ps(one, r);
        let bits = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_GT_OQ>(t, zero)) as u8;
        *byte = bits;
        if bits == 0 {
            continue;
        }
        // SAFETY: the CPU has AVX2 and FMA (our caller's promise).
        let v = unsafe { crate::lanes::phi_avx2::<K>(t, r) };
        match weights.get_mut(w..w + BLOCK) {
            Some(out) => {
                // SAFETY: COMPRESS holds eight i32 for every byte, `out` eight f32.
                unsafe {
                    let idx = _mm256_loadu_si256(COMPRESS[bits as usize].as_ptr().cast());
                    _mm256_storeu_ps(out.as_mut_ptr().cast(), _mm256_permutevar8x32_ps(v, idx));
                }
                w += ONES[bits as usize] as usize;
            }
            None => {
                let mut lanes = [0.0f32; BLOCK];
                // SAFETY: `lanes` holds eight f32.
                unsafe { _mm256_storeu_ps(lanes.as_mut_ptr(), v) };
                for (k, &phi) in lanes.iter().enumerate() {
                    if bits & (1 << k) != 0 {
                        weights[w] = MaybeUninit::new(phi);
                        w += 1;
                    }
                }
            }
        }
    }
    w
}
