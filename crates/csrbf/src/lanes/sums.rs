//! The kernel sum over a cell's lanes ([`super::View`]): one plain
//! reference and two vector copies of it, chosen once per kernel and CPU.
//!
//! [`sum_body`] is the reference: the arithmetic one point at a time
//! (without fused multiply-adds), what a CPU without AVX2 and FMA runs.
//! The vector copies (`super::vector`) hold a point a lane, eight points a
//! register with AVX2 and sixteen with AVX-512, and do the reference's
//! operations in its order with fused multiply-adds: so the two widths
//! give every point the same sums bit for bit, and agree with the
//! reference to f32 rounding. The evaluation and a binding's product
//! choose the same copy ([`Sums::of`]), so they agree bit for bit.
//!
//! Sixteen lanes pay where the CPU runs 512-bit vectors at full width (AMD
//! Zen 5: a `vsqrtps` and an FMA take the same time at 256 and 512 bits, so
//! the rate per lane doubles); on Sapphire Rapids, measured,
//! they ran no faster than eight, and no slower.

use crate::kernel::Kernel;
use crate::simd::{Avx2Fma, Avx512};

use super::View;
#[cfg(target_arch = "x86_64")]
use super::vector::{sums_avx2_fma, sums_avx512};

/// Accumulators a point keeps for each of its three sums: candidate `j`
/// goes to accumulator `j % ACCUMULATORS`, and they are added at the end
/// ([`combine`]). Two halve the rounding's growth with the candidates and
/// the chains of dependent additions.
pub(super) const ACCUMULATORS: usize = 2;

/// The sum of a point's accumulators, in order.
#[inline(always)]
pub(super) fn combine<T: Copy>(acc: [T; ACCUMULATORS], add: impl Fn(T, T) -> T) -> T {
    acc.into_iter()
        .reduce(add)
        .expect("at least one accumulator")
}

/// The kernel sums of one kernel on this CPU, chosen once: with AVX-512
/// where the CPU has it, else AVX2 and FMA when the proof is given, else
/// the plain reference.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Sums {
    /// The copy chosen. Unsafe to call: a vector copy needs its
    /// instruction set, which the token [`Sums::choose`] was given proves.
    sums: SumsFn,
    /// Points a register of the copy holds (1 for the plain one).
    width: usize,
}

/// Points by axis: `x[axis][k]` is point `k`'s coordinate.
pub(crate) type Axes<'a> = [&'a [f32]; 3];

/// Sums by axis, written: `out[axis][k]` is point `k`'s.
pub(crate) type AxesMut<'a> = [&'a mut [f32]; 3];

/// One copy of the sums for one kernel.
type SumsFn = unsafe fn(View<'_>, Axes<'_>, AxesMut<'_>);

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
        fn copy<const K: u8>(cpu: Option<Avx2Fma>, wide: Option<Avx512>) -> Sums {
            #[cfg(target_arch = "x86_64")]
            match (wide, cpu) {
                (Some(_), _) => {
                    return Sums {
                        sums: sums_avx512::<K>,
                        width: 16,
                    };
                }
                (None, Some(_)) => {
                    return Sums {
                        sums: sums_avx2_fma::<K>,
                        width: 8,
                    };
                }
                (None, None) => {}
            }
            let _ = (cpu, wide);
            Sums {
                sums: sums_plain::<K>,
                width: 1,
            }
        }
        match kernel {
            Kernel::C0 => copy::<0>(cpu, wide),
            Kernel::C2 => copy::<2>(cpu, wide),
            Kernel::C4 => copy::<4>(cpu, wide),
            Kernel::C6 => copy::<6>(cpu, wide),
        }
    }

    /// Points a register holds: a call computes its points rounded up to a
    /// multiple of this (the lanes past them sum at the cell's centre and
    /// are dropped).
    pub(crate) fn width(self) -> usize {
        self.width
    }

    /// sum_j alpha_j phi(|x - s_j| / R) over a cell's lanes at each point
    /// of `xs` (by axis, in the lanes' frame, [`super::local`]), into `out`
    /// (by axis), for as many points as the shortest of the six arrays.
    pub(crate) fn run(self, l: View<'_>, xs: Axes<'_>, out: AxesMut<'_>) {
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

/// The sum at one point, candidate by candidate into [`ACCUMULATORS`]
/// accumulators, in the order the vector copies compute it (which fuse
/// the multiply-adds).
fn sum_body<const K: u8>(l: View<'_>, x: [f32; 3]) -> [f32; 3] {
    let fma = |a: f32, b: f32, c: f32| a * b + c;
    let mut acc = [[0.0f32; 3]; ACCUMULATORS];
    let [xs, ys, zs] = l.xyz;
    for j in 0..l.len() {
        let (dx, dy, dz) = (xs[j] - x[0], ys[j] - x[1], zs[j] - x[2]);
        let r = fma(dz, dz, fma(dy, dy, dx * dx)).sqrt();
        let t = 1.0 - r;
        let t = if t > 0.0 { t } else { 0.0 };
        let w = phi::<K>(t, r);
        let acc = &mut acc[j % ACCUMULATORS];
        for (acc, alpha) in acc.iter_mut().zip(l.alpha) {
            *acc = fma(w, alpha[j], *acc);
        }
    }
    [0, 1, 2].map(|c| combine(acc.map(|a| a[c]), |a, b| a + b))
}

/// The points a call sums: as many as the shortest of its six arrays.
pub(super) fn points_of(xs: &Axes<'_>, out: &AxesMut<'_>) -> usize {
    let lens = xs
        .iter()
        .map(|v| v.len())
        .chain(out.iter().map(|v| v.len()));
    lens.min().unwrap_or(0)
}

/// [`sum_body`] for every point of `xs`, into `out`.
fn sums_plain<const K: u8>(l: View<'_>, xs: Axes<'_>, out: AxesMut<'_>) {
    let n = points_of(&xs, &out);
    let [ox, oy, oz] = out;
    for k in 0..n {
        [ox[k], oy[k], oz[k]] = sum_body::<K>(l, [xs[0][k], xs[1][k], xs[2][k]]);
    }
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;
    use crate::lanes::{Coefficients, Lanes};
    use crate::octree::Octree;
    use crate::synthetic::Rng;

    /// `copy`'s sums at points given one by one, one by one.
    fn run(copy: Sums, l: View<'_>, xs: &[[f32; 3]]) -> Vec<[f32; 3]> {
        let axes: [Vec<f32>; 3] = [0, 1, 2].map(|c| xs.iter().map(|x| x[c]).collect());
        let mut out = [0; 3].map(|_| vec![0.0f32; xs.len()]);
        let [ox, oy, oz] = &mut out;
        copy.run(l, axes.each_ref().map(|v| &v[..]), [&mut ox[..], oy, oz]);
        (0..xs.len())
            .map(|k| out.each_ref().map(|v| v[k]))
            .collect()
    }

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
    /// from none to a few hundred, starts far from the origin; and gives a
    /// point the same sums alone as among others. Where the CPU lacks AVX2
    /// or AVX-512 the copies it lacks fall back to the narrower one, checked
    /// the same way
    /// ([`the_vector_copies_are_their_scalar_model_bit_for_bit`] says which
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
                lanes.gather(&octree, &Coefficients::new(&alpha), (lo, hi), r);
                assert!(lanes.candidates() <= n);
                assert_eq!(lanes.view().len(), lanes.candidates());
                // Points in one call: a block of two registers and a tail.
                let xs: Vec<DVec3> = (0..37).map(|_| lo + (hi - lo) * rng.vec3()).collect();
                let local: Vec<[f32; 3]> = xs.iter().map(|x| lanes.local(*x)).collect();
                let sums = copies.map(|(_, c)| run(c, lanes.view(), &local));
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
                        // A point's sums alone are its sums among others.
                        let alone = run(*copy, lanes.view(), &local[k..=k]);
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

    /// The vector copies' arithmetic at one point: [`sum_body`]'s order,
    /// with fused multiply-adds.
    fn model<const K: u8>(l: View<'_>, x: [f32; 3]) -> [f32; 3] {
        let mut acc = [[0.0f32; 3]; ACCUMULATORS];
        for j in 0..l.len() {
            let [dx, dy, dz] = [0, 1, 2].map(|c| l.xyz[c][j] - x[c]);
            let r = dz.mul_add(dz, dy.mul_add(dy, dx * dx)).sqrt();
            let t = 1.0 - r;
            let w = phi_fused::<K>(if t > 0.0 { t } else { 0.0 }, r);
            for (acc, alpha) in acc[j % ACCUMULATORS].iter_mut().zip(l.alpha) {
                *acc = w.mul_add(alpha[j], *acc);
            }
        }
        [0, 1, 2].map(|c| combine(acc.map(|a| a[c]), |a, b| a + b))
    }

    /// Each vector copy this CPU runs gives its scalar model's sums bit for
    /// bit, so the eight- and sixteen-lane copies give every point the same
    /// sums: candidate counts of 0 to 71 (a last pair of candidates whole
    /// or half), point counts of 1 to 40 (blocks of one register and two,
    /// full and not, at either width: 12 and 29 leave a last block of more
    /// than one eight-lane register), points near and far. The lanes are
    /// views of longer buffers holding NaN past their end: a read past a
    /// view's length that slipped past the slices' checks would make the
    /// sums NaN.
    #[test]
    fn the_vector_copies_are_their_scalar_model_bit_for_bit() {
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
            for (n, points) in [
                (0, 3),
                (1, 1),
                (2, 17),
                (7, 8),
                (16, 16),
                (33, 40),
                (71, 33),
                (5, 12),
                (9, 29),
            ] {
                // Coordinates within 1.6 R of the cell's centre (hits and
                // misses), coefficients of either sign; NaN past `n`.
                let buffers: Vec<Vec<f32>> = (0..6)
                    .map(|c| {
                        let mut v: Vec<f32> = (0..n)
                            .map(|_| (rng.f64() * 3.2 - 1.6) as f32 * if c < 3 { 1.0 } else { 2.0 })
                            .collect();
                        v.extend([f32::NAN; 8]);
                        v
                    })
                    .collect();
                let view = View {
                    xyz: [0, 1, 2].map(|c| &buffers[c][..n]),
                    alpha: [3, 4, 5].map(|c| &buffers[c][..n]),
                };
                let xs: Vec<[f32; 3]> = (0..points)
                    .map(|_| [0; 3].map(|_| (rng.f64() - 0.5) as f32))
                    .collect();
                for (copy, width) in &copies {
                    assert_eq!(copy.width(), *width);
                    let out = run(*copy, view, &xs);
                    for (x, got) in xs.iter().zip(&out) {
                        let want = match kernel {
                            Kernel::C0 => model::<0>(view, *x),
                            Kernel::C2 => model::<2>(view, *x),
                            Kernel::C4 => model::<4>(view, *x),
                            Kernel::C6 => model::<6>(view, *x),
                        };
                        let bits = |v: [f32; 3]| v.map(f32::to_bits);
                        assert_eq!(bits(*got), bits(want), "{kernel:?} n {n} width {width}");
                    }
                }
            }
        }
    }
}
