//! The binding's vector code against its plain references, and the
//! binding against the f64 evaluation (issue 18: masks and 24-bit levels in
//! place of per-pair indices).

use std::mem::MaybeUninit;

use glam::{DVec3, Vec3};

use super::product::{cell_plain, cell_sums, level};
use super::weights::{Lanes, fill_cell, fill_plain, fill_row};
use super::{BLOCK, Binding, LEVEL_BYTES, LEVEL_TAIL, Levels};
use crate::evaluate::Candidates;
use crate::kernel::Kernel;
use crate::octree::Octree;
use crate::simd::{Avx2Fma, Avx512};
use crate::synthetic::Rng;
use crate::{Deformation, FitOptions, Polynomial};

/// Both copies find the same hits and store the same levels, byte for
/// byte, and those are `Kernel::eval` of the distance times the kernel's
/// scale, rounded to the nearest integer, in candidate order: for every
/// kernel, candidate counts that are and are not multiples of eight, and
/// none. A level times the step is the weight within half a step.
#[test]
fn weights_with_and_without_avx2_are_the_same_bits() {
    let mut rng = Rng::new(18);
    for kernel in Kernel::ALL {
        let scale = Levels::of(kernel);
        for n in [0, 1, 7, 8, 9, 30, 64, 203] {
            let radius = 0.05 + 0.2 * rng.f64();
            let offset = DVec3::new(3.0, -2.0, 0.5);
            let starts: Vec<DVec3> = (0..n).map(|_| offset + rng.vec3() * 0.3).collect();
            let octree = Octree::new(&starts);
            let (lo, hi) = (offset + 0.1, offset + 0.1 + radius * 0.5);
            let mut cand = Candidates::default();
            cand.gather(&octree, [lo, hi].into_iter(), radius);
            let mut lanes = Lanes::default();
            lanes.pad(&cand);
            let blocks = cand.len().div_ceil(BLOCK);
            for _ in 0..20 {
                let x = lo + (hi - lo) * rng.vec3();
                let phis: Vec<f64> = (0..cand.len())
                    .map(|k| x.distance(cand.start(k)))
                    .filter(|&d| d * d < radius * radius)
                    .map(|d| kernel.eval(d / radius))
                    .collect();
                let want: Vec<u32> = phis
                    .iter()
                    .map(|phi| (phi * scale.per_weight).round_ties_even() as u32)
                    .collect();
                for (phi, level) in phis.iter().zip(&want) {
                    let back = f64::from(*level) * scale.per_level;
                    assert!((back - phi).abs() <= 0.5 * scale.per_level * (1.0 + 1e-9));
                    assert!(*level < 1 << 24);
                }
                let count = want.len();
                // Room for the vector stores, and exactly the hits (so the
                // last blocks take the one-at-a-time store).
                for room in [LEVEL_BYTES * count + LEVEL_TAIL, LEVEL_BYTES * count] {
                    let nine = MaybeUninit::new(9u8);
                    let (mut m1, mut w1) = (vec![0u8; blocks], vec![nine; room]);
                    let (mut m2, mut w2) = (vec![0u8; blocks], vec![nine; room]);
                    let h1 = fill_plain(&lanes, x, kernel, radius, &mut m1, &mut w1);
                    let cpu = Avx2Fma::detect();
                    let h2 = fill_row(cpu, &lanes, x, kernel, radius, &mut m2, &mut w2);
                    assert_eq!((h1, h2), (count, count));
                    assert_eq!(m1, m2);
                    assert_eq!(read(&w1, count), want, "{kernel:?} n {n}");
                    assert_eq!(read(&w2, count), want, "{kernel:?} n {n}");
                    let ones: u32 = m1.iter().map(|m| m.count_ones()).sum();
                    assert_eq!(ones as usize, count);
                }
            }
        }
    }
}

/// A cell's rows in one call (with AVX-512 where the CPU has it: no
/// cut-off at r >= 1, the hits' levels compressed by the mask) are the
/// plain code's, point after point, byte for byte: for every kernel, with
/// points that are not finite (their rows stay zero, no levels), points on
/// and a hair inside the sphere of radius R around a start (r rounds to 1
/// or just below), room for the vector stores and exactly the hits.
#[test]
fn a_cell_with_and_without_avx512_is_the_same_bits() {
    let mut rng = Rng::new(21);
    if Avx512::detect().is_none() {
        eprintln!(
            "this CPU has no AVX-512: its path is not tested here (the AVX2 and plain ones are)"
        );
    }
    for kernel in Kernel::ALL {
        for n in [1, 8, 13, 64, 203] {
            let radius = 0.05 + 0.2 * rng.f64();
            let offset = DVec3::new(-1.0, 2.0, 0.25);
            let starts: Vec<DVec3> = (0..n).map(|_| offset + rng.vec3() * 0.3).collect();
            let octree = Octree::new(&starts);
            let (lo, hi) = (offset + 0.1, offset + 0.1 + radius * 0.5);
            let mut points: Vec<DVec3> = (0..40).map(|_| lo + (hi - lo) * rng.vec3()).collect();
            // On the sphere around the first start, and a hair inside.
            let dir = rng.vec3().normalize_or(DVec3::X);
            points.push(starts[0] + dir * radius);
            points.push(starts[0] + dir * radius * (1.0 - 1e-15));
            points.push(starts[0] + dir * radius * (1.0 - 1e-9));
            points.insert(3, DVec3::new(f64::NAN, 0.0, 0.0));
            points.insert(17, DVec3::splat(f64::INFINITY));
            let mut cand = Candidates::default();
            let finite = points.iter().copied().filter(|p| p.is_finite());
            cand.gather(&octree, finite, radius);
            let mut lanes = Lanes::default();
            lanes.pad(&cand);
            let blocks = cand.len().div_ceil(BLOCK);
            let rows = points.len() * blocks.max(1);
            // The plain code, a point at a time.
            let (mut m1, mut l1) = (vec![0u8; rows], Vec::new());
            for (x, row) in points.iter().zip(m1.chunks_exact_mut(blocks.max(1))) {
                if x.is_finite() {
                    let mut l = vec![MaybeUninit::new(0u8); LEVEL_BYTES * BLOCK * blocks];
                    let h = fill_plain(&lanes, *x, kernel, radius, row, &mut l);
                    l1.extend(read(&l, h));
                }
            }
            let count = l1.len();
            let full = LEVEL_BYTES * BLOCK * rows + LEVEL_TAIL;
            for room in [full, LEVEL_BYTES * count] {
                let (cpu, wide) = (Avx2Fma::detect(), Avx512::detect());
                for (cpu, wide) in [(cpu, wide), (cpu, None), (None, None)] {
                    let (mut m2, mut l2) = (vec![0u8; rows], vec![MaybeUninit::new(9u8); room]);
                    let h = fill_cell(
                        (cpu, wide),
                        &lanes,
                        &points,
                        kernel,
                        radius,
                        &mut m2,
                        &mut l2,
                    );
                    assert_eq!(h, count, "{kernel:?} n {n}");
                    assert_eq!(m2, m1, "{kernel:?} n {n}");
                    assert_eq!(read(&l2, count), l1, "{kernel:?} n {n}");
                }
            }
        }
    }
}

/// The first `count` levels of bytes that were all initialised (with 9,
/// then maybe written).
fn read(w: &[MaybeUninit<u8>], count: usize) -> Vec<u32> {
    // SAFETY: the tests make these buffers from initialised values.
    #[allow(unsafe_code)]
    let bytes: Vec<u8> = w.iter().map(|v| unsafe { v.assume_init() }).collect();
    (0..count).map(|k| level(&bytes, k)).collect()
}

/// The vector sum (f32 lanes) agrees with the plain one (f64) to f32
/// rounding of the terms' sizes, and with too few weights for its loads it
/// falls back to the plain sum.
#[test]
fn sums_with_and_without_avx2_agree() {
    let mut rng = Rng::new(19);
    for blocks in [1, 2, 3, 10, 17] {
        let points = 13;
        let rows: Vec<u8> = (0..points * blocks)
            .map(|_| (rng.f64() * 256.0) as u8)
            .collect();
        let hits: usize = rows.iter().map(|m| m.count_ones() as usize).sum();
        // Coefficients scaled by a step of 2^-24, as a binding scales them.
        let table: Vec<f32> = (0..blocks * 3 * BLOCK)
            .map(|_| ((rng.f64() * 2.0 - 1.0) / f64::from(1 << 24)) as f32)
            .collect();
        for room in [LEVEL_BYTES * BLOCK * blocks + LEVEL_TAIL, 0] {
            let levels: Vec<u8> = (0..LEVEL_BYTES * hits + room)
                .map(|_| (rng.f64() * 256.0) as u8)
                .collect();
            let mut want = vec![DVec3::ZERO; points];
            assert_eq!(cell_plain(&rows, blocks, &levels, &table, &mut want), hits);
            let mut got = vec![DVec3::ZERO; points];
            let used = cell_sums(Avx2Fma::detect(), &rows, blocks, &levels, &table, &mut got);
            assert_eq!(used, hits, "levels used: the rows' set bits");
            // The terms are at most 1 each: f32 sums of a few of them round
            // by a few units of 6e-8 of the row's total size.
            let size = (BLOCK * blocks) as f64;
            for (g, w) in got.iter().zip(&want) {
                let err = (*g - *w).length();
                if room == 0 {
                    assert!(err <= 1e-12 * (1.0 + w.length()), "{g} {w}");
                } else {
                    assert!(err <= 4e-7 * size, "{g} {w}: {err:e}");
                }
            }
        }
    }
}

/// A binding gives the f64 evaluation's displacements to the rounding of
/// its weights (half a level's step each) and its f32 sums: with cells
/// (many starts) and without (few), f32 and f64 points, a point that is not
/// finite, points out of every start's reach, cells of hundreds of points,
/// every kernel, with and without the polynomial part; and it counts every
/// pair within R once.
#[test]
fn a_binding_agrees_with_the_f64_evaluation_issue_18() {
    let mut rng = Rng::new(20);
    // The last: 3000 points in a few cells (hundreds a cell: a cell's points
    // are summed in chunks).
    for (starts, radius, spread) in [(30, 0.5, 1.6), (400, 0.2, 1.6), (60, 0.5, 0.3)] {
        for kernel in Kernel::ALL {
            for poly in [Polynomial::None, Polynomial::Linear] {
                let s: Vec<DVec3> = (0..starts).map(|_| rng.vec3()).collect();
                let t: Vec<DVec3> = s.iter().map(|p| *p + rng.vec3() * 0.02).collect();
                let options = FitOptions::new(radius)
                    .with_kernel(kernel)
                    .with_polynomial(poly);
                let d = Deformation::fit(&s, &t, options).expect("fit");
                // Points over a box wider than the starts' (some out of reach).
                let mut points: Vec<DVec3> = (0..3000)
                    .map(|_| rng.vec3() * spread + (0.5 - spread / 2.0))
                    .collect();
                points[7] = DVec3::new(f64::NAN, 0.5, 0.5);
                points[8] = DVec3::splat(40.0);
                let want = d.displacements(&points);
                let f64s = Binding::new(&d, &points).displacements(&d).expect("f64");
                let p32: Vec<Vec3> = points.iter().map(|p| p.as_vec3()).collect();
                let want32 = d.displacements(&p32);
                let binding = Binding::new(&d, &p32);
                let f32s = binding.displacements(&d).expect("f32");
                assert_eq!(binding.len(), points.len());
                let mut pairs = 0;
                for (k, p) in points.iter().enumerate() {
                    if k == 7 {
                        assert!(f64s[k].is_nan() && f32s[k].is_nan());
                        continue;
                    }
                    let near = d.starts().iter().zip(d.coefficients());
                    let near: Vec<(f64, f64)> = near
                        .filter(|(s, _)| s.distance(*p) < radius)
                        .map(|(s, a)| (a.length(), kernel.eval(s.distance(*p) / radius)))
                        .collect();
                    pairs += near.len();
                    // Levels (half a step each: 3e-8 of phi(0) times the
                    // coefficient), f32 coefficients and sums (6e-8 relative
                    // each), and the f32 result.
                    let terms: f64 = near.iter().map(|(a, phi)| a * phi).sum();
                    let coefficients: f64 = near.iter().map(|(a, _)| a).sum();
                    let step = Levels::of(kernel).per_level;
                    for (got, want) in [(f64s[k], want[k]), (f32s[k], want32[k])] {
                        let err = (got.as_dvec3() - want).length();
                        let tol =
                            0.5 * step * coefficients + 1e-7 * terms + 1e-7 * want.length() + 1e-12;
                        assert!(err <= tol, "{kernel:?} {poly:?} {k}: {err:e} > {tol:e}");
                    }
                }
                assert_eq!(binding.pairs(), pairs);
            }
        }
    }
}

/// Where nearby starts pull in opposite directions the coefficients exceed
/// the move, and so does a binding's difference from the f64 evaluation
/// relative to the move: still within the bound on the coefficients, and,
/// on these scenes (starts 0.03-0.3 R apart moving apart), within 5e-6 of
/// the largest move.
#[test]
fn a_binding_agrees_where_nearby_starts_pull_apart() {
    let mut rng = Rng::new(23);
    for gap in [0.3, 0.1, 0.03] {
        let radius = 0.3;
        let (mut s, mut t) = (Vec::new(), Vec::new());
        for _ in 0..40 {
            let p = rng.vec3();
            let dir = (rng.vec3() - 0.5).normalize() * gap * radius;
            let m = (rng.vec3() - 0.5) * 0.05;
            s.extend([p, p + dir]);
            t.extend([p + m, p + dir - m]);
        }
        let d = Deformation::fit(&s, &t, FitOptions::new(radius)).expect("fit");
        let points: Vec<Vec3> = (0..5000).map(|_| rng.vec3().as_vec3()).collect();
        let want = d.displacements(&points);
        let got = Binding::new(&d, &points).displacements(&d).expect("bound");
        let step = Levels::of(Kernel::C2).per_level;
        let (mut worst, mut largest) = (0.0f64, 0.0f64);
        for ((p, g), w) in points.iter().zip(&got).zip(&want) {
            let p = p.as_dvec3();
            let near = d.starts().iter().zip(d.coefficients());
            let (terms, coefficients) = near
                .filter(|(s, _)| s.distance(p) < radius)
                .map(|(s, a)| {
                    (
                        a.length() * Kernel::C2.eval(s.distance(p) / radius),
                        a.length(),
                    )
                })
                .fold((0.0, 0.0), |(t, c), (a, b)| (t + a, c + b));
            let err = (g.as_dvec3() - *w).length();
            let tol = 0.5 * step * coefficients + 1e-7 * terms + 1e-7 * w.length() + 1e-12;
            assert!(err <= tol, "gap {gap}: {err:e} > {tol:e}");
            worst = worst.max(err);
            largest = largest.max(w.length());
        }
        assert!(
            worst <= 5e-6 * largest,
            "gap {gap}: {worst:e} of {largest:e}"
        );
    }
}

/// A re-bind, reusing an earlier binding's memory (other starts, more or
/// fewer points, f32 or f64), gives what a new binding gives, bit for bit,
/// and refuses the deformations of the starts it was bound to before.
#[test]
fn a_rebind_is_a_new_binding() {
    let mut rng = Rng::new(24);
    let mut fit = |n: usize| {
        let s: Vec<DVec3> = (0..n).map(|_| rng.vec3()).collect();
        let t: Vec<DVec3> = s.iter().map(|p| *p + rng.vec3() * 0.02).collect();
        Deformation::fit(&s, &t, FitOptions::new(0.2)).expect("fit")
    };
    let (d1, d2) = (fit(300), fit(500));
    let mut rng = Rng::new(25);
    let many: Vec<Vec3> = (0..6000).map(|_| rng.vec3().as_vec3()).collect();
    let few: Vec<DVec3> = (0..700).map(|_| rng.vec3()).collect();
    let mut b = Binding::new(&d1, &many);
    b.rebind(&d2, &few);
    let want = Binding::new(&d2, &few);
    assert_eq!(
        b.displacements(&d2).expect("d2"),
        want.displacements(&d2).expect("d2")
    );
    assert_eq!(
        (b.len(), b.pairs(), b.bytes()),
        (want.len(), want.pairs(), want.bytes())
    );
    assert!(b.displacements(&d1).is_err(), "bound to d2's starts now");
    b.rebind(&d1, &many);
    let want = Binding::new(&d1, &many);
    assert_eq!(
        b.displacements(&d1).expect("d1"),
        want.displacements(&d1).expect("d1")
    );
    assert_eq!((b.len(), b.pairs()), (want.len(), want.pairs()));
    b.rebind(&d1, &[] as &[Vec3]);
    assert!(b.is_empty() && b.displacements(&d1).expect("none").is_empty());
}

/// No points, and points beyond every start's reach (cells with no hit),
/// bind and give empty or zero displacements.
#[test]
fn bindings_of_no_points_and_of_points_out_of_reach() {
    let mut rng = Rng::new(22);
    let s: Vec<DVec3> = (0..200).map(|_| rng.vec3()).collect();
    let t: Vec<DVec3> = s.iter().map(|p| *p + rng.vec3() * 0.01).collect();
    let d = Deformation::fit(&s, &t, FitOptions::new(0.2)).expect("fit");
    let none: [Vec3; 0] = [];
    let empty = Binding::new(&d, &none);
    assert!(empty.is_empty() && empty.pairs() == 0);
    assert_eq!(empty.displacements(&d).expect("empty"), Vec::<Vec3>::new());
    let far: Vec<Vec3> = (0..2000).map(|_| (rng.vec3() + 5.0).as_vec3()).collect();
    let b = Binding::new(&d, &far);
    assert_eq!(b.pairs(), 0);
    assert!(
        b.displacements(&d)
            .expect("far")
            .iter()
            .all(|v| *v == Vec3::ZERO)
    );
}
