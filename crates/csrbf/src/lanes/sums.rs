//! The kernel sum over a cell's lanes ([`super::View`]): one plain
//! reference and two vector copies of it, chosen once per kernel and CPU.
//!
//! [`sum_body`] is the reference: the arithmetic one lane at a time (without
//! fused multiply-adds), what a CPU without AVX2 and FMA runs. The vector
//! copies (`super::vector`) compute eight lanes a register with AVX2 and
//! sixteen with AVX-512, with fused multiply-adds; the sixteen-lane copy
//! sums a lane's blocks in another order than the others (every other
//! block, then the halves added), so the three agree to f32 rounding, not
//! bit for bit. Each gives a point the same sums alone or paired, and the
//! evaluation and a binding's product choose the same copy
//! ([`Sums::of`]), so they agree bit for bit.
//!
//! Sixteen lanes pay where the CPU runs 512-bit vectors at full width (AMD
//! Zen 5: a `vsqrtps` and an FMA take the same time at 256 and 512 bits, so
//! the rate per lane doubles); on Sapphire Rapids (issue 18's fifth pass)
//! they ran no faster than eight, and no slower.

use crate::kernel::Kernel;
use crate::simd::{Avx2Fma, Avx512};

#[cfg(target_arch = "x86_64")]
use super::vector::{sums_avx2_fma, sums_avx512};
use super::{LANES, View};

/// The kernel sums of one kernel on this CPU, chosen once: with AVX-512
/// where the CPU has it, else AVX2 and FMA when the proof is given, else
/// the plain reference.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Sums {
    /// The copy chosen. Unsafe to call: a vector copy needs its
    /// instruction set, which the token [`Sums::choose`] was given proves.
    sums: SumsFn,
}

/// One copy of the sums for one kernel.
type SumsFn = unsafe fn(View<'_>, &[[f32; 3]], &mut [[f32; 3]]);

impl Sums {
    /// The widest sums this CPU runs (none but the plain reference without
    /// `cpu`).
    pub(crate) fn of(cpu: Option<Avx2Fma>, kernel: Kernel) -> Sums {
        Sums::choose(cpu, cpu.and_then(|_| Avx512::detect()), kernel)
    }

    /// The sums without AVX-512 (the eight-lane copy where `cpu` is given),
    /// for tests beside the wide one.
    #[cfg(test)]
    pub(crate) fn eight_lanes(cpu: Option<Avx2Fma>, kernel: Kernel) -> Sums {
        Sums::choose(cpu, None, kernel)
    }

    /// The copy for `kernel`: sixteen lanes with the AVX-512 proof, eight
    /// with the AVX2 one, else the plain reference.
    fn choose(cpu: Option<Avx2Fma>, wide: Option<Avx512>, kernel: Kernel) -> Sums {
        fn copy<const K: u8>(cpu: Option<Avx2Fma>, wide: Option<Avx512>) -> SumsFn {
            #[cfg(target_arch = "x86_64")]
            match (wide, cpu) {
                (Some(_), _) => return sums_avx512::<K>,
                (None, Some(_)) => return sums_avx2_fma::<K>,
                (None, None) => {}
            }
            let _ = (cpu, wide);
            sums_plain::<K>
        }
        let sums = match kernel {
            Kernel::C0 => copy::<0>(cpu, wide),
            Kernel::C2 => copy::<2>(cpu, wide),
            Kernel::C4 => copy::<4>(cpu, wide),
            Kernel::C6 => copy::<6>(cpu, wide),
        };
        Sums { sums }
    }

    /// sum_j alpha_j phi(|x - s_j| / R) over a cell's lanes at each point
    /// of `xs` (in the lanes' frame, [`super::local`]), into `out`.
    pub(crate) fn run(self, l: View<'_>, xs: &[[f32; 3]], out: &mut [[f32; 3]]) {
        // SAFETY: `choose` took a vector copy only with the proof that the
        // CPU has its instruction set (an `Avx2Fma` or `Avx512` exists only
        // then).
        #[allow(unsafe_code)]
        unsafe {
            (self.sums)(l, xs, out)
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
/// order the eight-lane vector copy computes it (which fuses the
/// multiply-adds).
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
    use crate::lanes::{FAR, Lanes};
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
    /// rounding) and with the plain one, for every kernel, start counts
    /// from none to a few hundred (lane counts odd and even multiples of
    /// eight), starts far from the origin; and gives a point the same sums
    /// alone as in a pair. Where the CPU lacks AVX2 or AVX-512 the copies it
    /// lacks fall back to the narrower one, checked the same way
    /// ([`the_vector_copies_are_their_scalar_models_bit_for_bit`] says which
    /// ran).
    #[test]
    fn every_copy_agrees_with_the_f64_sum() {
        let mut rng = Rng::new(18);
        for kernel in [Kernel::C0, Kernel::C2, Kernel::C4, Kernel::C6] {
            let copies = [
                ("plain", Sums::of(None, kernel)),
                ("avx2", Sums::eight_lanes(Avx2Fma::detect(), kernel)),
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

    /// phi with fused multiply-adds, as the vector copies compute it.
    fn phi_fused<const K: u8>(t: f32, r: f32) -> f32 {
        let t2 = t * t;
        match K {
            0 => t2,
            2 => t2 * t2 * 4.0f32.mul_add(r, 1.0),
            4 => t2 * t2 * t2 * 35.0f32.mul_add(r, 18.0).mul_add(r, 3.0),
            _ => {
                let t4 = t2 * t2;
                t4 * t4 * 32.0f32.mul_add(r, 25.0).mul_add(r, 8.0).mul_add(r, 1.0)
            }
        }
    }

    /// The vector copies' arithmetic one lane at a time: `width` lanes of
    /// accumulators, each taking every `width`-th candidate (an odd last
    /// eight in the low lanes), then with sixteen the high eight added to
    /// the low, then the eight summed as [`sum_body`] sums them.
    fn model<const K: u8>(l: View<'_>, x: [f32; 3], width: usize) -> [f32; 3] {
        let n = l
            .xyz
            .iter()
            .chain(&l.alpha)
            .map(|v| v.len())
            .min()
            .unwrap_or(0);
        let n = n - n % LANES;
        let mut acc = [[0.0f32; 16]; 3];
        for k in (0..n).step_by(width) {
            for (j, i) in (k..n.min(k + width)).enumerate() {
                let [dx, dy, dz] = [0, 1, 2].map(|c| l.xyz[c][i] - x[c]);
                let r = dz.mul_add(dz, dy.mul_add(dy, dx * dx)).sqrt();
                let t = 1.0 - r;
                let w = phi_fused::<K>(if t > 0.0 { t } else { 0.0 }, r);
                for (acc, alpha) in acc.iter_mut().zip(l.alpha) {
                    acc[j] = w.mul_add(alpha[i], acc[j]);
                }
            }
        }
        acc.map(|a| {
            let h: [f32; 8] =
                std::array::from_fn(|j| if width == 16 { a[j] + a[j + 8] } else { a[j] });
            ((h[0] + h[1]) + (h[2] + h[3])) + ((h[4] + h[5]) + (h[6] + h[7]))
        })
    }

    /// Each vector copy this CPU runs gives its scalar model's sums bit for
    /// bit (so the eight-lane copy gives every AVX2 machine the values it
    /// gave before the sixteen-lane one came), over lanes of 8 to 72
    /// (sixteen-lane registers full and with a masked last half), with
    /// points near and far, alone and in pairs. The lanes are views of
    /// longer buffers holding NaN past their end: a load past a view's
    /// length would make the sums NaN.
    #[test]
    fn the_vector_copies_are_their_scalar_models_bit_for_bit() {
        let cpu = Avx2Fma::detect();
        let wide = cpu.and(Avx512::detect()).is_some();
        if cpu.is_none() {
            eprintln!("this CPU has no AVX2 and FMA: no vector copy to check");
            return;
        }
        if !wide {
            eprintln!("this CPU has no AVX-512F: the sixteen-lane copy is not checked here");
        }
        let mut rng = Rng::new(1618);
        for kernel in [Kernel::C0, Kernel::C2, Kernel::C4, Kernel::C6] {
            let copies = [
                (Sums::eight_lanes(cpu, kernel), 8),
                (Sums::of(cpu, kernel), if wide { 16 } else { 8 }),
            ];
            for n in [8, 16, 24, 40, 64, 72] {
                // Coordinates within 1.6 R of the cell's centre (hits and
                // misses), coefficients of either sign; NaN past `n`.
                let mut buffers: Vec<Vec<f32>> = (0..6)
                    .map(|c| {
                        let mut v: Vec<f32> = (0..n)
                            .map(|_| (rng.f64() * 3.2 - 1.6) as f32 * if c < 3 { 1.0 } else { 2.0 })
                            .collect();
                        v.extend([f32::NAN; 8]);
                        v
                    })
                    .collect();
                // A few far starts of zero coefficient, as the padding.
                for i in (n - 3)..n {
                    for (c, b) in buffers.iter_mut().enumerate() {
                        b[i] = if c < 3 { FAR } else { 0.0 };
                    }
                }
                let view = View {
                    xyz: [0, 1, 2].map(|c| &buffers[c][..n]),
                    alpha: [3, 4, 5].map(|c| &buffers[c][..n]),
                };
                let xs: Vec<[f32; 3]> = (0..5)
                    .map(|_| [0; 3].map(|_| (rng.f64() - 0.5) as f32))
                    .collect();
                for (copy, width) in &copies {
                    let mut out = vec![[0.0f32; 3]; xs.len()];
                    copy.run(view, &xs, &mut out);
                    for (x, got) in xs.iter().zip(&out) {
                        let want = match kernel {
                            Kernel::C0 => model::<0>(view, *x, *width),
                            Kernel::C2 => model::<2>(view, *x, *width),
                            Kernel::C4 => model::<4>(view, *x, *width),
                            Kernel::C6 => model::<6>(view, *x, *width),
                        };
                        let bits = |v: [f32; 3]| v.map(f32::to_bits);
                        assert_eq!(bits(*got), bits(want), "{kernel:?} n {n} width {width}");
                    }
                }
            }
        }
    }
}
