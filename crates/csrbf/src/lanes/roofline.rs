//! The arithmetic bound of an evaluation on this machine: its kernel
//! evaluations, a register of lanes at a time, at the vector operations
//! each register costs (`weight` and the three sums: 16 for C2, see
//! [`crate::lanes`]), each at the rate this machine runs fused
//! multiply-adds of that width, measured when asked on every thread of the
//! pool at once. Measured in the same run as the evaluation it bounds, so
//! a slower moment of a shared machine slows both.

use std::time::Instant;

use crate::deformation::Deformation;
use crate::kernel::Kernel;
use crate::simd::{Avx2Fma, Avx512};

use super::EvaluationCounts;

/// The time an evaluation's arithmetic takes on this machine at its FMA
/// rate ([`Deformation::roofline`]), and what it is made of: every vector
/// operation counted at that rate (the bound this project sets itself; a
/// core whose additions run on pipes of their own could beat it).
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub struct Roofline {
    /// Lanes a register of the kernel sum holds on this CPU (16 with
    /// AVX-512, 8 with AVX2 and FMA, else 1).
    pub lanes: u32,
    /// Threads that ran the measurement at once (the pool's, as the
    /// evaluation).
    pub threads: u32,
    /// Fused multiply-add instructions a nanosecond, each `lanes` wide,
    /// every thread together: the best of a few runs.
    pub fma_per_ns: f64,
    /// Vector operations a register of kernel evaluations costs: 13 for
    /// C0, 16 for C2, 18 for C4, 19 for C6 (three subtractions, a
    /// multiply and two fused multiply-adds for r^2, a square root,
    /// 1 - r, a max, the kernel's polynomial, three fused multiply-adds
    /// into the sums).
    pub operations: u32,
    /// The counted kernel evaluations over `lanes`, times `operations`, at
    /// `fma_per_ns`, in ms: the evaluation's time over this is its multiple
    /// of the roofline.
    pub bound_ms: f64,
}

impl Roofline {
    /// Milliseconds `multiply_adds` double-precision multiply-adds take at
    /// this machine's measured rate, every thread at once (a register holds
    /// half as many f64 lanes as f32): the bound a numeric factorisation of
    /// that many ([`crate::SystemStats::factor_flops`]) is measured against.
    pub fn f64_bound_ms(&self, multiply_adds: f64) -> f64 {
        let lanes = f64::from((self.lanes / 2).max(1));
        multiply_adds / (self.fma_per_ns * lanes) * 1e-6
    }
}

/// Vector operations a register of kernel evaluations of `kernel` costs
/// (`vector::weight` and the sums' three fused multiply-adds).
fn operations(kernel: Kernel) -> u32 {
    13 + match kernel {
        Kernel::C0 => 0,
        Kernel::C2 => 3,
        Kernel::C4 => 5,
        Kernel::C6 => 6,
    }
}

impl Deformation {
    /// The arithmetic bound of an evaluation that did `counts`
    /// ([`Deformation::evaluation_counts`]): measures this machine's rate
    /// of fused multiply-adds at the kernel sum's width, on every thread
    /// of the pool at once (about a tenth of a second), and sets the
    /// counted kernel evaluations against it. An evaluation's time over
    /// `bound_ms` says how far from the machine's arithmetic it runs.
    pub fn roofline(&self, counts: &EvaluationCounts) -> Roofline {
        let (lanes, fma_per_ns) = measure();
        let operations = operations(self.kernel());
        let registers = counts.kernel_evaluations as f64 / f64::from(lanes);
        Roofline {
            lanes,
            threads: rayon::current_num_threads() as u32,
            fma_per_ns,
            operations,
            bound_ms: registers * f64::from(operations) / fma_per_ns * 1e-6,
        }
    }
}

/// The kernel sum's lanes on this CPU and its FMA instructions a
/// nanosecond, every thread of the pool at once: the best of five runs of
/// about 15 ms.
fn measure() -> (u32, f64) {
    let cpu = Avx2Fma::detect();
    let wide = cpu.and_then(|_| Avx512::detect());
    let lanes = match (wide, cpu) {
        (Some(_), _) => 16,
        (None, Some(_)) => 8,
        (None, None) => 1,
    };
    let chains = |iterations: usize| -> f32 {
        #[cfg(target_arch = "x86_64")]
        {
            // SAFETY: each copy runs only with the proof that the CPU has
            // its instruction set.
            #[allow(unsafe_code)]
            unsafe {
                if wide.is_some() {
                    return super::vector::fma_chains_avx512(iterations);
                }
                if cpu.is_some() {
                    return super::vector::fma_chains_avx2(iterations);
                }
            }
        }
        plain_chains(iterations)
    };
    // Twelve instructions a round; every thread at once.
    let run = |iterations: usize| {
        let start = Instant::now();
        let sums = rayon::broadcast(|_| chains(iterations));
        std::hint::black_box(sums);
        let ns = start.elapsed().as_secs_f64() * 1e9;
        let fmas = 12.0 * iterations as f64 * rayon::current_num_threads() as f64;
        fmas / ns.max(1.0)
    };
    // Rounds for about 15 ms, from a short first run.
    let guess = run(1 << 16);
    let threads = rayon::current_num_threads() as f64;
    let iterations = (15e6 * guess / (12.0 * threads)).clamp(1e5, 1e9) as usize;
    let best = (0..5).map(|_| run(iterations)).fold(0.0, f64::max);
    (lanes, best)
}

/// [`super::vector`]'s FMA chains one lane wide, without FMA (what a CPU
/// without AVX2 and FMA runs the kernel sum with). The compiler may put
/// the twelve chains in SSE's four lanes: then the rate is four lanes',
/// and the bound stricter than one lane's.
fn plain_chains(iterations: usize) -> f32 {
    // Values the compiler cannot see, so it cannot fold the rounds.
    let [a, b, one] = std::hint::black_box([0.999_9f32, 1.0e-4, 1.0]);
    let mut acc = [one; 12];
    for _ in 0..iterations {
        for acc in &mut acc {
            *acc = *acc * a + b;
        }
    }
    acc.iter().sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bound is the counted registers at the measured rate, of the
    /// evaluation's width on this CPU, at a positive, finite rate.
    #[test]
    fn the_bound_is_the_counted_work_at_the_measured_rate() {
        let s = crate::synthetic::scene_of("t", 2000, 200, None);
        let d = Deformation::fit(&s.starts, &s.targets, s.options).expect("fit");
        let counts = d.evaluation_counts(&s.points);
        let r = d.roofline(&counts);
        assert!(r.fma_per_ns.is_finite() && r.fma_per_ns > 0.0);
        // The width of the kernel sum the evaluation runs on this CPU.
        let sums = crate::lanes::Sums::of(Avx2Fma::detect(), d.kernel());
        assert_eq!(r.lanes as usize, sums.width());
        assert_eq!(r.operations, operations(d.kernel()));
        let want = counts.kernel_evaluations as f64 / f64::from(r.lanes) * f64::from(r.operations)
            / r.fma_per_ns
            * 1e-6;
        assert!((r.bound_ms - want).abs() <= 1e-12 * want);
        assert_eq!(operations(Kernel::C2), 16);
    }
}
