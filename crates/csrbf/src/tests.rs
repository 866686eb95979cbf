//! Properties of the whole engine, checked with seeded random inputs against
//! plain references.

use glam::{DMat3, DVec3, Vec3};

use crate::testing::{Rng, assert_close};
use crate::*;

fn fitted(deformation: Deformation, region: Region, phase: f64) -> FittedStage {
    FittedStage {
        deformation,
        region,
        phase,
        sweep: None,
        rigid_part: false,
    }
}

/// Random distinct starts in the unit cube and random destinations.
fn scene(n: usize, seed: u64) -> (Vec<DVec3>, Vec<DVec3>) {
    let mut rng = Rng::new(seed);
    let starts: Vec<DVec3> = (0..n).map(|_| rng.vec3()).collect();
    let targets = starts
        .iter()
        .map(|s| *s + (rng.vec3() - 0.5) * 0.1)
        .collect();
    (starts, targets)
}

fn options(kernel: Kernel, poly: Polynomial, radius: f64, solver: SolverChoice) -> FitOptions {
    FitOptions::new(radius)
        .with_kernel(kernel)
        .with_polynomial(poly)
        .with_solver(solver)
}

const SOLVERS: [SolverChoice; 2] = [SolverChoice::Skyline, SolverChoice::Supernodal];

#[test]
fn interpolates_exactly_at_the_starts() {
    for seed in 0..6 {
        for kernel in Kernel::ALL {
            for poly in Polynomial::ALL {
                for solver in SOLVERS {
                    let (s, t) = scene(60 + seed as usize * 17, seed);
                    let d =
                        Deformation::fit(&s, &t, options(kernel, poly, 0.45, solver)).expect("fit");
                    let scale = t
                        .iter()
                        .zip(&s)
                        .map(|(a, b)| (*a - *b).length())
                        .fold(0.0, f64::max);
                    for (si, ti) in s.iter().zip(&t) {
                        let err = (d.map(*si) - *ti).length();
                        assert!(
                            err <= 1e-9 * scale,
                            "{kernel} {poly} {solver:?}: residual {err:e}"
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn matches_a_dense_solve_of_the_full_system() {
    for seed in 0..4 {
        let (s, t) = scene(40, 100 + seed);
        for (poly, solver) in Polynomial::ALL
            .into_iter()
            .flat_map(|p| SOLVERS.into_iter().map(move |s| (p, s)))
        {
            let d = Deformation::fit(&s, &t, options(Kernel::C2, poly, 0.5, solver)).expect("fit");
            // Dense [A P; P^T 0] with P = (1, x, y, z), solved by elimination.
            let n = s.len();
            let m = if poly == Polynomial::Linear { n + 4 } else { n };
            let mut a = vec![vec![0.0; m]; m];
            for i in 0..n {
                for j in 0..n {
                    a[i][j] = Kernel::C2.eval(s[i].distance(s[j]) / 0.5);
                }
                if poly == Polynomial::Linear {
                    let p = [1.0, s[i].x, s[i].y, s[i].z];
                    for k in 0..4 {
                        a[i][n + k] = p[k];
                        a[n + k][i] = p[k];
                    }
                }
            }
            let mut rng = Rng::new(seed);
            for c in 0..3 {
                let mut b: Vec<f64> = (0..n).map(|i| t[i][c] - s[i][c]).collect();
                b.resize(m, 0.0);
                let x = crate::skyline::tests::dense_solve(&a, &b);
                for _ in 0..20 {
                    let q = rng.vec3();
                    let mut want: f64 = (0..n)
                        .map(|j| x[j] * Kernel::C2.eval(q.distance(s[j]) / 0.5))
                        .sum();
                    if poly == Polynomial::Linear {
                        want += x[n] + x[n + 1] * q.x + x[n + 2] * q.y + x[n + 3] * q.z;
                    }
                    assert_close(d.displacement_at(q)[c], want, 1e-9, "against dense");
                }
            }
        }
    }
}

#[test]
fn linear_reproduces_affine_maps() {
    for seed in 0..8 {
        let mut rng = Rng::new(seed);
        let (s, _) = scene(50, seed);
        let m = DMat3::from_cols(rng.vec3() - 0.5, rng.vec3() - 0.5, rng.vec3() - 0.5) * 0.3
            + DMat3::IDENTITY;
        let shift = rng.vec3() - 0.5;
        let t: Vec<DVec3> = s.iter().map(|p| m * *p + shift).collect();
        for kernel in Kernel::ALL {
            let d = Deformation::fit(
                &s,
                &t,
                options(kernel, Polynomial::Linear, 0.4, SolverChoice::Auto),
            )
            .expect("fit");
            for _ in 0..50 {
                let q = rng.vec3() * 3.0 - 1.0;
                let err = (d.map(q) - (m * q + shift)).length();
                assert!(
                    err < 1e-9,
                    "{kernel}: affine map not reproduced, error {err:e}"
                );
            }
        }
    }
}

#[test]
fn a_placed_map_is_the_fit_of_the_placed_controls() {
    // D'(s R x) = s R D(x) everywhere, and it is what fitting the placed
    // starts and destinations with radius s r gives.
    for seed in 0..4 {
        let mut rng = Rng::new(100 + seed);
        let (s, t) = scene(70, seed);
        let scale = 0.01 + rng.vec3().x * 40.0;
        let axis = (rng.vec3() - 0.5).normalize();
        let rotation = glam::DQuat::from_axis_angle(axis, 6.0 * rng.vec3().y - 3.0);
        let place = |p: DVec3| rotation * p * scale;
        for poly in Polynomial::ALL {
            let opts = options(Kernel::C2, poly, 0.4, SolverChoice::Auto);
            let d = Deformation::fit(&s, &t, opts).expect("fit");
            let placed = d.placed(scale, rotation);
            let (ps, pt): (Vec<DVec3>, Vec<DVec3>) = s
                .iter()
                .zip(&t)
                .map(|(a, b)| (place(*a), place(*b)))
                .unzip();
            let refit = Deformation::fit(&ps, &pt, opts.with_radius(0.4 * scale)).expect("fit");
            assert_eq!(placed.radius(), 0.4 * scale);
            for _ in 0..60 {
                let x = rng.vec3() * 1.6 - 0.3;
                let want = place(d.map(x) - x);
                let tol = 1e-9 * scale;
                let got = placed.map(place(x)) - place(x);
                assert!((got - want).length() < tol, "{poly}: {got} vs {want}");
                let fit = refit.map(place(x)) - place(x);
                assert!(
                    (fit - want).length() < 1e-7 * scale,
                    "{poly}: refit {fit} vs {want}"
                );
            }
        }
    }
}

/// A system rebuilt from the one before equals a new one: a start moved
/// within its neighbours (the structure kept), another kernel (kept), a
/// start moved across a neighbour's reach (made again), on both solvers.
#[test]
fn a_rebuilt_system_equals_a_new_one() {
    for solver in SOLVERS {
        let (s, t) = scene(400, 3);
        let opts = options(Kernel::C2, Polynomial::Linear, 0.3, solver);
        let sys = System::new(&s, opts).expect("fit");
        let mut near = s.clone();
        near[17] += DVec3::splat(1e-7);
        let mut far = s.clone();
        far[17] = DVec3::new(0.5, 0.5, 0.5);
        let c4 = opts.with_kernel(Kernel::C4);
        for (starts, o, kept) in [(&near, opts, true), (&s, c4, true), (&far, opts, false)] {
            let again = sys.rebuild(starts, o).expect("rebuilt");
            assert_eq!(again.stats().reused, kept, "{solver:?} kept {kept}");
            let fresh = System::new(starts, o).expect("new");
            let (a, b) = (again.solve(&t).expect("a"), fresh.solve(&t).expect("b"));
            for _ in 0..3 {
                for x in [DVec3::splat(0.3), DVec3::new(0.7, 0.2, 0.5), starts[17]] {
                    assert_close(a.map(x).x, b.map(x).x, 1e-10, "rebuilt vs new");
                    assert_close(a.map(x).z, b.map(x).z, 1e-10, "rebuilt vs new");
                }
            }
            assert_eq!(a.fingerprint(), b.fingerprint());
        }
    }
}

#[test]
fn none_is_exactly_zero_beyond_the_radius() {
    for seed in 0..5 {
        let (s, t) = scene(80, seed);
        let r = 0.2;
        let d = Deformation::fit(
            &s,
            &t,
            options(Kernel::C4, Polynomial::None, r, SolverChoice::Auto),
        )
        .expect("fit");
        let mut rng = Rng::new(seed + 50);
        let points: Vec<DVec3> = (0..2000).map(|_| rng.vec3() * 1.6 - 0.3).collect();
        let disp = d.displacements(&points);
        for (p, dp) in points.iter().zip(&disp) {
            let near = s
                .iter()
                .map(|q| q.distance(*p))
                .fold(f64::INFINITY, f64::min);
            if near >= r {
                assert_eq!(
                    *dp,
                    DVec3::ZERO,
                    "moved at {p}, {near} from the nearest start"
                );
            }
        }
    }
}

#[test]
fn the_map_is_symmetric_in_the_order_of_controls() {
    let (s, t) = scene(70, 9);
    let d1 = Deformation::fit(
        &s,
        &t,
        options(Kernel::C2, Polynomial::Linear, 0.4, SolverChoice::Skyline),
    )
    .expect("fit");
    let rev_s: Vec<DVec3> = s.iter().rev().copied().collect();
    let rev_t: Vec<DVec3> = t.iter().rev().copied().collect();
    let d2 = Deformation::fit(
        &rev_s,
        &rev_t,
        options(
            Kernel::C2,
            Polynomial::Linear,
            0.4,
            SolverChoice::Supernodal,
        ),
    )
    .expect("fit");
    let mut rng = Rng::new(3);
    for _ in 0..100 {
        let q = rng.vec3();
        assert!((d1.map(q) - d2.map(q)).length() < 1e-10);
    }
}

#[test]
fn solving_again_equals_a_fresh_fit() {
    let (s, t) = scene(200, 4);
    for solver in SOLVERS {
        let opts = options(Kernel::C2, Polynomial::Linear, 0.3, solver);
        let sys = System::new(&s, opts).expect("system");
        let _ = sys.solve(&t).expect("first");
        let t2: Vec<DVec3> = s
            .iter()
            .map(|p| *p + DVec3::new(0.01, 0.0, p.x * 0.05))
            .collect();
        let again = sys.solve(&t2).expect("again");
        let fresh = Deformation::fit(&s, &t2, opts).expect("fresh");
        for (a, b) in again.coefficients().iter().zip(fresh.coefficients()) {
            assert!((*a - *b).length() < 1e-12);
        }
    }
}

#[test]
fn blocked_evaluation_and_binding_match_pointwise_evaluation() {
    let (s, t) = scene(300, 11);
    let d = Deformation::fit(
        &s,
        &t,
        options(Kernel::C2, Polynomial::Linear, 0.25, SolverChoice::Auto),
    )
    .expect("fit");
    let mut rng = Rng::new(12);
    // Enough points to take the parallel path.
    let pts: Vec<Vec3> = (0..20_000)
        .map(|_| (rng.vec3() * 1.2 - 0.1).as_vec3())
        .collect();
    let blocked = d.displacements(&pts);
    let binding = Binding::new(&d, &pts);
    let bound = binding.displacements(&d).expect("binding");
    for (i, p) in pts.iter().enumerate() {
        let want = d.displacement_at(p.as_dvec3());
        assert!((blocked[i] - want).length() < 1e-12);
        assert!((bound[i].as_dvec3() - want).length() < 1e-5 * (1.0 + want.length()));
    }
    // New destinations through the same binding.
    let sys = System::new(
        &s,
        *System::new(&s, FitOptions::new(0.25)).expect("s").options(),
    )
    .expect("system");
    let d2 = sys
        .solve(&s.iter().map(|p| *p * 1.01).collect::<Vec<_>>())
        .expect("solve");
    let bound2 = binding.displacements(&d2).expect("binding");
    for (i, p) in pts.iter().enumerate().step_by(97) {
        let want = d2.displacement_at(p.as_dvec3());
        assert!((bound2[i].as_dvec3() - want).length() < 1e-5);
    }
}

#[test]
fn frames_scale_the_displacement_by_the_phase() {
    let rest = vec![Vec3::ZERO, Vec3::ONE];
    let disp = vec![Vec3::X, Vec3::Y * 2.0];
    let mut out = vec![Vec3::ZERO; 2];
    frame(&rest, &disp, 0.25, &mut out).expect("frame");
    assert_eq!(out, vec![Vec3::X * 0.25, Vec3::new(1.0, 1.5, 1.0)]);
    assert_eq!(
        frame(&rest, &disp, 1.5, &mut out),
        Err(Error::BadPhase(1.5))
    );
    assert!(frame(&rest, &disp, f64::NAN, &mut out).is_err());
}

#[test]
fn bad_controls_are_named() {
    let (mut s, t) = scene(10, 1);
    let lin = FitOptions::new(0.5).with_polynomial(Polynomial::Linear);
    assert_eq!(
        Deformation::fit::<DVec3>(&[], &[], lin).err(),
        Some(FitError::NoControls)
    );
    for r in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert_eq!(
            Deformation::fit(&s, &t, lin.with_radius(r))
                .err()
                .map(|e| e.to_string().contains("radius")),
            Some(true)
        );
    }
    s[7] = s[3];
    assert_eq!(
        Deformation::fit(&s, &t, lin).err(),
        Some(FitError::DuplicateStart {
            first: 3,
            second: 7
        })
    );
    s[7].x = f64::NAN;
    assert_eq!(
        Deformation::fit(&s, &t, lin).err(),
        Some(FitError::NotFinite {
            index: 7,
            what: "start"
        })
    );
    assert_eq!(
        Deformation::fit(&s[..3], &t[..3], lin).err(),
        Some(FitError::TooFewForLinear(3))
    );
    let flat: Vec<DVec3> = (0..20)
        .map(|i| DVec3::new(i as f64 * 0.1, (i % 3) as f64 * 0.1, 0.5))
        .collect();
    assert_eq!(
        Deformation::fit(&flat, &flat, lin).err(),
        Some(FitError::CoplanarStarts)
    );
    // `none` handles the same flat set.
    assert!(Deformation::fit(&flat, &flat, lin.with_polynomial(Polynomial::None)).is_ok());
    let (s, t) = scene(10, 1);
    let sys = System::new(&s, lin).expect("system");
    assert_eq!(
        sys.solve(&t[..4]).err(),
        Some(FitError::TargetCount {
            expected: 10,
            got: 4
        })
    );
}

#[test]
fn near_coincident_starts_are_named() {
    let mut s: Vec<DVec3> = scene(30, 2).0;
    s[20] = s[5] + DVec3::splat(1e-13);
    let t = s.clone();
    for solver in SOLVERS {
        for kernel in Kernel::ALL {
            let err =
                Deformation::fit(&s, &t, options(kernel, Polynomial::None, 0.5, solver)).err();
            assert!(
                matches!(
                    err,
                    Some(FitError::StartsTooClose {
                        first: 5,
                        second: 20,
                        ..
                    })
                ),
                "{solver:?} {kernel}: {err:?}"
            );
        }
    }
}

#[test]
fn a_failed_pivot_names_the_control_in_the_callers_numbering() {
    // Indefinite 3 x 3 pattern through the skyline path: rows are renumbered,
    // the error must come back in the caller's numbering.
    use crate::ordering::Graph;
    use crate::skyline::{Envelope, Profile};
    let g = Graph::from_lists(&[vec![2], vec![], vec![0]]);
    let perm = vec![1, 2, 0];
    let mut p = Profile::zeros(Envelope::new(&g, &perm));
    for i in 0..3 {
        p.set(i, i, 1.0);
    }
    p.set(2, 1, 3.0); // rows 1, 2 are controls 2, 0
    let err = crate::solver::Factor::skyline(p, perm).err();
    assert_eq!(err, Some(FitError::NotPositiveDefinite { control: 0 }));
}

#[test]
fn replay_file_round_trips_bit_exact_and_detects_damage() {
    let (s, t) = scene(50, 5);
    let d1 = Deformation::fit(
        &s,
        &t,
        options(Kernel::C4, Polynomial::Linear, 0.3, SolverChoice::Auto),
    )
    .expect("fit");
    let d2 = Deformation::fit(
        &s,
        &t,
        options(Kernel::C0, Polynomial::None, 0.2, SolverChoice::Auto),
    )
    .expect("fit");
    let stages = vec![
        fitted(d1, Region::All, 1.0),
        fitted(
            d2,
            Region::Sphere {
                center: DVec3::splat(0.5),
                radius: 0.3,
            },
            0.25,
        ),
        fitted(
            Deformation::fit(&s, &t, FitOptions::new(0.3)).expect("fit"),
            Region::Group("lips".into()),
            0.5,
        ),
    ];
    let bytes = format::encode(&stages, Combine::Add);
    let back = format::decode(&bytes).expect("decode");
    // Every field of every stage, the phase too (issue 10), and the combine.
    assert_eq!(back.stages, stages);
    assert_eq!(back.combine, Combine::Add);
    let back = back.stages;
    for (a, b) in back.iter().zip(&stages) {
        assert_eq!(
            a.deformation.displacement_at(DVec3::splat(0.4)),
            b.deformation.displacement_at(DVec3::splat(0.4))
        );
    }
    // Every truncation and a flipped byte anywhere are refused, never a panic.
    for cut in (0..bytes.len()).step_by(7) {
        assert!(format::decode(&bytes[..cut]).is_err());
    }
    for at in (0..bytes.len()).step_by(13) {
        let mut bad = bytes.clone();
        bad[at] ^= 0x40;
        assert!(format::decode(&bad).is_err(), "flip at {at} accepted");
    }
    let mut v6 = bytes.clone();
    v6[6] = 6;
    assert!(
        format::decode(&v6)
            .err()
            .is_some_and(|e| e.to_string().contains("version 6"))
    );
    // Without a stamp a file is version 4, which builds before the stamp
    // read; with one, version 5.
    assert_eq!(u16::from_le_bytes([bytes[6], bytes[7]]), 4);
    // A stamp round-trips, and names the mesh it was made on.
    let faces = [[0u32, 1, 2], [2, 1, 3]];
    let stamp = format::MeshStamp::of(4, Some(faces.iter().map(|f| &f[..])));
    let stamped =
        format::decode(&format::encode_for(&stages, Combine::Add, Some(stamp))).expect("stamped");
    assert_eq!(stamped.mesh, Some(stamp));
    assert!(stamp.check(&stamp).is_ok());
    // Faces in another order, or listed from another corner, index the same
    // vertices; a face changed does not.
    let reordered = [[1u32, 3, 2], [0, 1, 2]];
    let same = format::MeshStamp::of(4, Some(reordered.iter().map(|f| &f[..])));
    assert!(stamp.check(&same).is_ok());
    let changed = [[0u32, 1, 2], [2, 1, 0]];
    let other = format::MeshStamp::of(4, Some(changed.iter().map(|f| &f[..])));
    assert!(stamp.check(&other).is_err());
    assert!(
        stamp
            .check(&format::MeshStamp::of(5, None::<std::iter::Empty<&[u32]>>))
            .is_err()
    );
    assert!(
        stamp
            .check(&format::MeshStamp::of(4, None::<std::iter::Empty<&[u32]>>))
            .is_ok()
    );
}

#[test]
fn pipeline_composes_in_order_on_regions() {
    let mut rng = Rng::new(21);
    let rest: Vec<Vec3> = (0..500).map(|_| rng.vec3().as_vec3()).collect();
    // Stage 1 translates everything by +x; stage 2 scales about the origin.
    let s: Vec<DVec3> = scene(12, 3).0;
    let shift: Vec<DVec3> = s.iter().map(|p| *p + DVec3::X * 0.1).collect();
    let scale_s: Vec<DVec3> = s.iter().map(|p| *p * 2.0).collect();
    let scaled: Vec<DVec3> = scale_s.iter().map(|p| *p * 1.5).collect();
    // Affine maps everywhere: the linear polynomial reproduces them.
    let opts = FitOptions::new(0.5).with_polynomial(Polynomial::Linear);
    let mut p = Pipeline::new(rest.clone());
    p.push(Stage::new(s.clone(), shift, opts));
    p.push(Stage::new(scale_s, scaled, opts));
    let out = p.evaluate().expect("evaluate").to_vec();
    for (o, r) in out.iter().zip(&rest) {
        let want = (r.as_dvec3() + DVec3::X * 0.1) * 1.5;
        assert!((o.as_dvec3() - want).length() < 1e-5, "{o} vs {want}");
    }
    // A region: only points in the box move in stage 1.
    let region = Region::Box {
        min: DVec3::ZERO,
        max: DVec3::splat(0.5),
    };
    p.set_region(0, region.clone()).expect("region");
    let out = p.evaluate().expect("evaluate").to_vec();
    for (o, r) in out.iter().zip(&rest) {
        let inside = r.cmple(Vec3::splat(0.5)).all();
        let want = (r.as_dvec3() + if inside { DVec3::X * 0.1 } else { DVec3::ZERO }) * 1.5;
        assert!((o.as_dvec3() - want).length() < 1e-5);
    }
}

#[test]
fn pipeline_recomputes_only_what_a_change_invalidates() {
    let mut rng = Rng::new(8);
    let rest: Vec<Vec3> = (0..300).map(|_| rng.vec3().as_vec3()).collect();
    let (s, t) = scene(20, 8);
    let opts = FitOptions::new(0.5);
    let mut p = Pipeline::new(rest);
    p.push(Stage::new(s.clone(), t.clone(), opts));
    p.push(Stage::new(s.clone(), t.clone(), opts));
    p.evaluate().expect("evaluate");
    let w0 = p.work();
    assert_eq!((w0.systems, w0.solves, w0.bindings), (2, 2, 2));
    p.evaluate().expect("evaluate");
    assert_eq!(p.work(), w0, "nothing changed, nothing recomputed");
    // The last stage's phase: one output, nothing else.
    p.set_phase(1, 0.5).expect("phase");
    p.evaluate().expect("evaluate");
    let w1 = p.work();
    assert_eq!(
        (
            w1.systems,
            w1.solves,
            w1.bindings,
            w1.displacements,
            w1.outputs
        ),
        (2, 2, 2, 2, w0.outputs + 1)
    );
    // New destinations in stage 1: re-solve, no new system, no new binding of stage 1;
    // stage 2's input moved, so it binds again but does not re-factor.
    p.set_targets(0, s.iter().map(|q| *q + DVec3::Y * 0.01).collect())
        .expect("targets");
    p.evaluate().expect("evaluate");
    let w2 = p.work();
    assert_eq!(w2.systems, 2);
    assert_eq!(w2.solves, 3);
    assert_eq!(w2.bindings, 3);
    // A new radius in stage 2 rebuilds only stage 2's system.
    p.set_options(1, opts.with_radius(0.4)).expect("options");
    let out = p.evaluate().expect("evaluate").to_vec();
    assert_eq!(p.work().systems, 3);
    assert!(p.set_phase(0, 2.0).is_err());
    // The re-bound stages (their bindings' memory reused) give what a new
    // pipeline of the same stages gives, bit for bit.
    let moved: Vec<DVec3> = s.iter().map(|q| *q + DVec3::Y * 0.01).collect();
    let mut fresh = Pipeline::new(p.rest().to_vec());
    fresh.push(Stage::new(s.clone(), moved, opts));
    fresh.push(Stage::new(s.clone(), t.clone(), opts.with_radius(0.4)));
    fresh.set_phase(1, 0.5).expect("phase");
    assert_eq!(fresh.evaluate().expect("evaluate"), &out[..]);
}

#[test]
fn system_reports_the_papers_memory_figures() {
    let (s, _) = scene(92, 17);
    let sys = System::new(&s, FitOptions::new(0.3)).expect("system");
    let st = sys.stats();
    assert_eq!(st.controls, 92);
    assert_eq!(st.dense_bytes, 33856);
    assert!(st.profile_bytes < st.dense_bytes);
    assert!(st.envelope <= st.envelope_before);
    assert_eq!(
        st.nonzeros,
        92 + (st.neighbours_mean * 92.0).round() as usize
    );
}

/// Issue 6: one meaning for a file of several deformations, in the one-shot
/// and the lazy form, for both ways of combining them.
#[test]
fn chain_and_add_mean_the_same_in_compose_and_the_pipeline() {
    let mut rng = Rng::new(33);
    let rest: Vec<Vec3> = (0..400).map(|_| rng.vec3().as_vec3()).collect();
    let (s1, t1) = scene(15, 4);
    let (s2, t2) = scene(12, 5);
    let opts = FitOptions::new(0.45);
    let d1 = Deformation::fit(&s1, &t1, opts).expect("fit 1");
    let d2 = Deformation::fit(&s2, &t2, opts).expect("fit 2");
    let half = Region::Box {
        min: DVec3::ZERO,
        max: DVec3::new(0.6, 1.0, 1.0),
    };
    let stages = vec![
        fitted(d1.clone(), Region::All, 1.0),
        fitted(d2.clone(), half.clone(), 0.5),
    ];
    let none = |_: &str| None;
    // Add: both displacements at the rest points.
    let added = compose(&rest, &stages, Combine::Add).expect("add");
    let in_half = half.select(&rest, &none).expect("select");
    for (i, (p, r)) in added.iter().zip(&rest).enumerate() {
        let mut want = r.as_dvec3() + d1.displacement_at(r.as_dvec3());
        if in_half.binary_search(&(i as u32)).is_ok() {
            want += d2.displacement_at(r.as_dvec3()) * 0.5;
        }
        assert!((p.as_dvec3() - want).length() < 1e-5, "add, point {i}");
    }
    // Chain: the second at the points the first moved.
    let chained = compose(&rest, &stages, Combine::Chain).expect("chain");
    for (i, (p, r)) in chained.iter().zip(&rest).enumerate() {
        let x = (r.as_dvec3() + d1.displacement_at(r.as_dvec3()))
            .as_vec3()
            .as_dvec3();
        let mut want = x;
        if in_half.binary_search(&(i as u32)).is_ok() {
            want += d2.displacement_at(x) * 0.5;
        }
        assert!((p.as_dvec3() - want).length() < 1e-5, "chain, point {i}");
    }
    assert!(added != chained);
    // The lazy pipeline gives the same points either way, and switching rebinds.
    let mut p = Pipeline::new(rest.clone());
    p.push(Stage::new(s1, t1, opts));
    p.push(Stage::new(s2, t2, opts).with_region(half).with_phase(0.5));
    for (combine, want) in [(Combine::Chain, &chained), (Combine::Add, &added)] {
        p.set_combine(combine);
        let got = p.evaluate().expect("evaluate");
        for (a, b) in got.iter().zip(want.iter()) {
            assert!(a.distance(*b) < 1e-5, "{combine}");
        }
    }
    assert_eq!("add".parse::<Combine>(), Ok(Combine::Add));
    assert!("blend".parse::<Combine>().is_err());
}

/// The f64 composition means what the f32 one means (to f32's rounding),
/// both ways of combining, and leaves a point no stage reaches bit for bit.
#[test]
fn the_f64_composition_agrees_and_keeps_unreached_points_exactly() {
    let mut rng = Rng::new(35);
    let rest: Vec<DVec3> = (0..500).map(|_| rng.vec3() * 1.5 + 1e-9).collect();
    let rest32: Vec<Vec3> = rest.iter().map(|p| p.as_vec3()).collect();
    let (s1, t1) = scene(15, 6);
    let (s2, t2) = scene(12, 7);
    let opts = FitOptions::new(0.45);
    let d1 = Deformation::fit(&s1, &t1, opts).expect("fit 1");
    let d2 = Deformation::fit(&s2, &t2, opts).expect("fit 2");
    let half = Region::Box {
        min: DVec3::ZERO,
        max: DVec3::new(0.6, 1.0, 1.0),
    };
    let stages = vec![fitted(d1, Region::All, 1.0), fitted(d2, half, 0.5)];
    let none = |_: &str| None;
    let mut unreached = 0;
    for combine in [Combine::Add, Combine::Chain] {
        let wide = compose_f64(&rest, &stages, combine, &none).expect("f64");
        let narrow = compose(&rest32, &stages, combine).expect("f32");
        for (i, ((a, b), r)) in wide.iter().zip(&narrow).zip(&rest).enumerate() {
            assert!((*a - b.as_dvec3()).length() < 1e-5, "{combine}, point {i}");
            if stages
                .iter()
                .all(|s| s.deformation.displacement_at(*r) == DVec3::ZERO)
            {
                assert_eq!(a, r, "point {i} is out of reach and must not move");
                unreached += 1;
            }
        }
    }
    assert!(
        unreached > 10,
        "the scene leaves points out of reach ({unreached})"
    );
}

/// Issue 6: a region's falloff scales the displacement by the weight the
/// region gives each point, in `compose` and the `Pipeline` alike.
#[test]
fn falloffs_scale_the_displacement_smoothly() {
    let rest: Vec<Vec3> = (0..60)
        .map(|i| Vec3::new(i as f32 * 0.05, 0.0, 0.0))
        .collect();
    let d = Deformation::fit(
        &[DVec3::new(1.5, 0.0, 0.0)],
        &[DVec3::new(1.5, 0.3, 0.0)],
        FitOptions::new(2.0),
    )
    .expect("fit");
    let region = Region::Falloff {
        inner: Box::new(Region::Box {
            min: DVec3::new(-1.0, -1.0, -1.0),
            max: DVec3::new(1.0, 1.0, 1.0),
        }),
        width: 0.8,
    };
    let none = |_: &str| None;
    let (sel, w) = region.weights(&rest, &none).expect("weights");
    let out = compose(
        &rest,
        &[fitted(d.clone(), region.clone(), 1.0)],
        Combine::Chain,
    )
    .expect("compose");
    for (i, p) in rest.iter().enumerate() {
        let weight = sel
            .iter()
            .position(|&k| k as usize == i)
            .map_or(0.0, |k| w[k]);
        let want = p.as_dvec3() + d.displacement_at(p.as_dvec3()) * weight as f64;
        assert!((out[i].as_dvec3() - want).length() < 1e-5, "point {i}");
    }
    // Inside moves fully, past the blend nothing moves, and the blend is monotone.
    assert!(out[10].y > 0.0 && out[59].y == 0.0);
    let ys: Vec<f32> = (20..37)
        .map(|i| out[i].y / d.displacement_at(rest[i].as_dvec3()).y as f32)
        .collect();
    assert!(ys.windows(2).all(|p| p[1] <= p[0] + 1e-6), "{ys:?}");
    let mut p = Pipeline::new(rest.clone());
    p.push(
        Stage::new(
            vec![DVec3::new(1.5, 0.0, 0.0)],
            vec![DVec3::new(1.5, 0.3, 0.0)],
            FitOptions::new(2.0),
        )
        .with_region(region),
    );
    let lazy = p.evaluate().expect("evaluate");
    for (a, b) in lazy.iter().zip(&out) {
        assert!(a.distance(*b) < 1e-5);
    }
}

/// Issue 10: bad stage indices, phases and bindings get errors of their own.
#[test]
fn stage_indices_phases_and_bindings_are_named() {
    let (s, t) = scene(12, 9);
    let opts = FitOptions::new(0.5);
    let mut p = Pipeline::new(vec![Vec3::ZERO; 4]);
    p.push(Stage::new(s.clone(), t.clone(), opts).with_phase(7.0));
    // The stage is named (issue 39: "stages[0]: phase must be ...").
    let e = p.evaluate().err();
    assert_eq!(
        e,
        Some(Error::Stage {
            index: 0,
            source: Box::new(Error::BadPhase(7.0))
        })
    );
    assert_eq!(e.and_then(|e| e.stage()), Some(0));
    assert_eq!(p.set_phase(0, 2.0), Err(Error::BadPhase(2.0)));
    p.set_phase(0, 0.5).expect("phase");
    assert!(p.evaluate().is_ok());
    // A region no point could be in is refused when it is set.
    let bad = Region::Sphere {
        center: DVec3::ZERO,
        radius: f64::NAN,
    };
    assert!(matches!(p.set_region(0, bad), Err(Error::Region(_))));
    assert_eq!(
        p.set_phase(9, 0.5),
        Err(Error::StageIndex { index: 9, count: 1 })
    );
    assert!(
        p.deformation(3)
            .err()
            .is_some_and(|e| e.to_string().contains("stage 3 does not exist"))
    );
    let d = Deformation::fit(&s, &t, opts).expect("fit");
    let other = Deformation::fit(&s[..5], &t[..5], opts).expect("fit");
    let b = Binding::new(&d, &[Vec3::ZERO; 3]);
    assert!(matches!(
        b.displacements(&other),
        Err(Error::BindingMismatch {
            bound_starts: 12,
            starts: 5,
            ..
        })
    ));
}

/// Issue 7: a nearly dense system is refused from an estimate, before its
/// graph or factor take gigabytes; the limit can be lifted knowingly.
#[test]
fn dense_systems_are_refused_before_any_allocation() {
    let mut rng = Rng::new(77);
    let starts: Vec<DVec3> = (0..20_000).map(|_| rng.vec3()).collect();
    let t = std::time::Instant::now();
    let e = System::new(&starts, FitOptions::new(10.0)).expect_err("refused");
    assert!(
        t.elapsed().as_secs() < 10,
        "the refusal must come from the estimate"
    );
    let FitError::TooLarge {
        bytes,
        limit,
        suggested_radius,
        ..
    } = e.clone()
    else {
        panic!("{e}");
    };
    assert!(bytes > limit as f64 && suggested_radius < 10.0);
    let msg = e.to_string();
    assert!(
        msg.contains("the limit of 4 GiB") && msg.contains("smaller R"),
        "{msg}"
    );
    // The radius it suggests fits, and is near the largest that does: here
    // R = 10 reaches every start, so halving it (or any R^2 rule) would not.
    assert!(estimate(&starts, suggested_radius).bytes <= limit as f64);
    assert!(estimate(&starts, suggested_radius * 1.05).bytes > limit as f64);
    let tight = FitOptions::new(0.3).with_memory_limit(50_000_000);
    let Err(FitError::TooLarge {
        suggested_radius: r,
        ..
    }) = System::new(&starts, tight)
    else {
        panic!("50 MB refuses R = 0.3");
    };
    assert!(estimate(&starts, r).bytes <= 5e7 && estimate(&starts, r * 1.05).bytes > 5e7);
    assert!(System::new(&starts, tight.with_radius(r)).is_ok());
    let est = estimate(&starts, 10.0);
    assert!(est.nearly_dense() && est.fraction > 0.99);
    // A small limit refuses a sparse system too, and a large one lets it through.
    let sparse = FitOptions::new(0.05);
    assert!(System::new(&starts, sparse.with_memory_limit(1000)).is_err());
    assert!(System::new(&starts, sparse).is_ok());
}

/// Issue 10: reading a pipeline's results does not need `&mut`.
#[test]
fn pipeline_results_are_read_without_recomputing() {
    let (s, t) = scene(10, 3);
    let mut p = Pipeline::new(vec![Vec3::splat(0.5); 3]);
    p.push(Stage::new(s, t.clone(), FitOptions::new(0.6)));
    assert!(p.output().is_none() && p.fitted(0).is_none());
    let out = p.evaluate().expect("evaluate").to_vec();
    assert_eq!(p.output(), Some(&out[..]));
    assert!(p.fitted(0).is_some());
    p.set_targets(0, t).expect("targets");
    assert!(
        p.output().is_none() && p.fitted(0).is_none(),
        "stale results are not shown"
    );
    assert!(p.fitted(7).is_none());
}

/// Issue 7: near-duplicate starts (1e-4 apart at R 3.5) with moves 0.5
/// apart used to give "largest move 722"; they are refused naming both. The
/// same pair moving alike is fine.
#[test]
fn near_starts_with_conflicting_moves_are_named() {
    let starts = [
        DVec3::new(2.15, 10.18, 4.42),
        DVec3::new(2.15, 10.18, 4.42 + 1e-4),
        DVec3::new(0.0, 8.0, 4.0),
    ];
    let opts = FitOptions::new(3.5);
    let apart = [
        starts[0] + DVec3::Y * 0.5,
        starts[1] + DVec3::NEG_Y * 0.0,
        starts[2],
    ];
    let e = Deformation::fit(&starts, &apart, opts).expect_err("conflict");
    assert!(
        matches!(
            e,
            FitError::ConflictingStarts {
                first: 0,
                second: 1,
                ..
            }
        ),
        "{e}"
    );
    assert!(
        e.to_string()
            .contains("controls 0 and 1 start 1e-4 apart (0.002857 % of R)"),
        "{e}"
    );
    let alike = [
        starts[0] + DVec3::Y * 0.5,
        starts[1] + DVec3::Y * 0.5,
        starts[2],
    ];
    let d = Deformation::fit(&starts, &alike, opts).expect("same move");
    assert!((d.map(starts[0]) - alike[0]).length() < 1e-6);
}

/// Issue 7: starts out of range are named as such, not as "coplanar".
#[test]
fn starts_out_of_range_are_named_for_what_they_are() {
    let far = [
        DVec3::splat(1e300),
        DVec3::new(1e300, 0.0, 0.0),
        DVec3::Y,
        DVec3::Z,
        DVec3::X,
    ];
    let opts = FitOptions::new(1.0).with_polynomial(Polynomial::Linear);
    assert!(matches!(
        Deformation::fit(&far, &far, opts),
        Err(FitError::StartScale { .. })
    ));
    let tiny: Vec<DVec3> = (0..5)
        .map(|i| {
            DVec3::new(
                i as f64 * 1e-310,
                (i % 2) as f64 * 1e-310,
                (i / 3) as f64 * 1e-310,
            )
        })
        .collect();
    let e = Deformation::fit(&tiny, &tiny, opts).expect_err("subnormal");
    assert!(e.to_string().contains("rescale the model"), "{e}");
}

/// Issue 7: seeded mutations of `.csrbf` files give an error or a valid
/// value, never a panic (control files: the edit layer's tests).
#[test]
fn the_replay_reader_survives_thousands_of_mutations() {
    use crate::fuzz::mutate;
    let (s, t) = scene(40, 3);
    let lin = FitOptions::new(0.4).with_polynomial(Polynomial::Linear);
    let stages = vec![
        fitted(
            Deformation::fit(&s, &t, lin).expect("fit"),
            Region::Group("lips".into()),
            0.5,
        ),
        fitted(
            Deformation::fit(&s, &t, FitOptions::new(0.3)).expect("fit"),
            Region::All,
            1.0,
        ),
    ];
    let replay = format::encode(&stages, Combine::Add);
    let all: Vec<&[u8]> = vec![&replay];
    let mut rng = Rng::new(4242);
    let (mut read, mut refused) = (0, 0);
    for case in 0..3000 {
        let input = mutate(&replay, &mut rng, &all);
        match std::panic::catch_unwind(|| format::decode(&input).is_ok()) {
            Ok(true) => read += 1,
            Ok(false) => refused += 1,
            Err(_) => panic!("case {case} panicked"),
        }
    }
    // A checksummed file: most mutations are refused, and the reader
    // still reads the file itself.
    assert!(
        format::decode(&replay).is_ok() && refused > 0,
        "{read} read, {refused} refused"
    );
}

/// Issue 21: the library as a caller uses it.
mod library {
    use super::*;

    /// The example: same count, kernel and radius, other starts.
    #[test]
    fn a_binding_refuses_a_deformation_of_other_starts() {
        let o = FitOptions::new(1.0);
        let da = Deformation::fit(&[DVec3::ZERO], &[DVec3::new(0.0, 0.1, 0.0)], o).expect("a");
        let db =
            Deformation::fit(&[DVec3::splat(5.0)], &[DVec3::new(5.0, 5.1, 5.0)], o).expect("b");
        let binding = Binding::new(&da, &[Vec3::ZERO]);
        let e = binding
            .displacements(&db)
            .expect_err("other starts accepted");
        assert!(matches!(e, Error::BindingMismatch { .. }), "{e}");
        assert!(e.to_string().contains("other starts"), "{e}");
        // One coordinate's last bit is enough.
        let nudged = DVec3::new(0.0, 0.0, f64::from_bits(1));
        let dc = Deformation::fit(&[nudged], &[DVec3::new(0.0, 0.1, 0.0)], o).expect("c");
        assert!(binding.displacements(&dc).is_err());
        // Any deformation of the same starts is accepted, whatever its destinations.
        let dd = Deformation::fit(&[DVec3::ZERO], &[DVec3::new(0.3, 0.0, 0.0)], o).expect("d");
        let got = binding.displacements(&dd).expect("same starts");
        assert!((got[0].x - 0.3).abs() < 1e-6);
        // So does a deformation read back from its bytes.
        let back = Deformation::from_bytes(&dd.to_bytes()).expect("bytes");
        assert_eq!(back, dd);
        assert!(binding.displacements(&back).is_ok());
        // solve_into refuses a deformation another system solved.
        let sys = System::new(&[DVec3::splat(5.0)], o).expect("system");
        let mut other = da.clone();
        assert_eq!(
            sys.solve_into(&[DVec3::splat(5.0)], &mut other),
            Err(Error::SystemMismatch)
        );
        assert_eq!(
            other, da,
            "a refused solve_into left the deformation as it was"
        );
    }

    #[test]
    fn system_binds_solves_into_and_solves_many_like_one_at_a_time() {
        let (s, t) = scene(60, 21);
        let sys = System::new(&s, FitOptions::new(0.4)).expect("system");
        let mut rng = Rng::new(5);
        let points: Vec<Vec3> = (0..700).map(|_| rng.vec3().as_vec3()).collect();
        let bound = sys.bind(&points);
        let d = sys.solve(&t).expect("solve");
        // Solving shares the starts, it does not copy them.
        assert!(std::ptr::eq(d.starts().as_ptr(), sys.starts().as_ptr()));
        assert_eq!(d.fingerprint(), sys.fingerprint());
        let via_new = Binding::new(&d, &points).displacements(&d).expect("new");
        assert_eq!(bound.displacements(&d).expect("bind"), via_new);
        // solve_into gives the deformation solve gives.
        let t2: Vec<DVec3> = t.iter().map(|p| *p + DVec3::new(0.0, 0.0, 0.02)).collect();
        let mut into = d.clone();
        sys.solve_into(&t2, &mut into).expect("solve_into");
        assert_eq!(into, sys.solve(&t2).expect("solve 2"));
        // Many at once, in parallel, as one at a time.
        let sets = vec![t.clone(), t2.clone(), s.clone()];
        let many = sys.solve_many(&sets).expect("solve_many");
        let mut out = vec![Vec3::ZERO; points.len() * sets.len()];
        bound.displacements_many(&many, &mut out).expect("many");
        for (k, set) in sets.iter().enumerate() {
            let one = sys.solve(set).expect("one");
            assert_eq!(many[k], one);
            let want = bound.displacements(&one).expect("one");
            assert_eq!(&out[k * points.len()..(k + 1) * points.len()], &want[..]);
        }
        // The identity (targets = starts) moves nothing.
        assert!(out[2 * points.len()..].iter().all(|d| d.length() < 1e-6));
        assert!(matches!(
            bound.displacements_many(&many, &mut out[1..]),
            Err(Error::PointCount { .. })
        ));
        assert!(matches!(
            sys.solve_many(&[t.clone(), t[1..].to_vec()]),
            Err(FitError::TargetCount { .. })
        ));
    }

    #[test]
    fn into_and_in_place_agree_with_the_allocating_calls() {
        let (s, t) = scene(80, 22);
        for poly in [Polynomial::None, Polynomial::Linear] {
            let d =
                Deformation::fit(&s, &t, FitOptions::new(0.35).with_polynomial(poly)).expect("fit");
            let mut rng = Rng::new(9);
            let p64: Vec<DVec3> = (0..1500).map(|_| rng.vec3()).collect();
            let p32: Vec<Vec3> = p64.iter().map(|p| p.as_vec3()).collect();
            let mut o64 = vec![DVec3::ZERO; p64.len()];
            d.displacements_into(&p64, &mut o64).expect("into");
            assert_eq!(o64, d.displacements(&p64));
            let mut o32 = vec![Vec3::ZERO; p32.len()];
            d.displacements_f32_into(&p32, &mut o32).expect("into f32");
            assert_eq!(o32, d.displacements_f32(&p32));
            let mut moved = p64.clone();
            d.deform_in_place(&mut moved, 0.25).expect("in place");
            for ((m, p), o) in moved.iter().zip(&p64).zip(&o64) {
                assert_eq!(*m, *p + *o * 0.25);
            }
            let mut moved32 = p32.clone();
            d.deform_in_place(&mut moved32, 1.0).expect("in place f32");
            for ((m, p), o) in moved32.iter().zip(&p32).zip(&o32) {
                assert_eq!(*m, *p + *o);
            }
            assert!(matches!(
                d.displacements_into(&p64, &mut o64[1..]),
                Err(Error::PointCount { .. })
            ));
            assert_eq!(
                d.deform_in_place(&mut moved, 1.5),
                Err(Error::BadPhase(1.5))
            );
        }
    }

    /// A NaN point gets a NaN displacement on every path, with or without
    /// the polynomial part, and its neighbours are not affected.
    #[test]
    fn a_non_finite_point_gets_nan_everywhere() {
        // Enough starts that points are sorted into cells, and few.
        for n in [5, 200] {
            let (s, t) = scene(n, 23);
            for poly in [Polynomial::None, Polynomial::Linear] {
                let d = Deformation::fit(&s, &t, FitOptions::new(0.4).with_polynomial(poly))
                    .expect("fit");
                let mut rng = Rng::new(1);
                let mut pts: Vec<DVec3> = (0..900).map(|_| rng.vec3()).collect();
                let clean = d.displacements(&pts);
                for (k, bad) in [
                    (0, f64::NAN),
                    (450, f64::INFINITY),
                    (899, f64::NEG_INFINITY),
                ] {
                    pts[k].y = bad;
                }
                let got = d.displacements(&pts);
                let got32 = d.displacements_f32(&pts);
                let pts32: Vec<Vec3> = pts.iter().map(|p| p.as_vec3()).collect();
                let bound = Binding::new(&d, &pts32).displacements(&d).expect("binding");
                for i in 0..pts.len() {
                    if [0, 450, 899].contains(&i) {
                        assert!(
                            got[i].is_nan() && got32[i].is_nan() && bound[i].is_nan(),
                            "{i}"
                        );
                        assert!(d.displacement_at(pts[i]).is_nan());
                    } else {
                        assert_eq!(got[i], clean[i], "point {i} changed by a NaN neighbour");
                        assert!((bound[i].as_dvec3() - clean[i]).length() < 1e-6);
                    }
                }
            }
        }
    }

    #[test]
    fn impossible_regions_are_refused_naming_the_field() {
        let pts = [Vec3::ZERO, Vec3::X];
        let none = |_: &str| None;
        let cases = [
            (
                Region::Sphere {
                    center: DVec3::ZERO,
                    radius: f64::NAN,
                },
                "sphere.radius",
            ),
            (
                Region::Sphere {
                    center: DVec3::ZERO,
                    radius: -1.0,
                },
                "sphere.radius",
            ),
            (
                Region::Sphere {
                    center: DVec3::new(f64::NAN, 0.0, 0.0),
                    radius: 1.0,
                },
                "sphere.center",
            ),
            (
                Region::Box {
                    min: DVec3::new(0.0, 2.0, 0.0),
                    max: DVec3::ONE,
                },
                "box.min.y",
            ),
            (
                Region::Box {
                    min: DVec3::ZERO,
                    max: DVec3::new(1.0, f64::NAN, 1.0),
                },
                "box.max",
            ),
            (
                Region::Falloff {
                    inner: Box::new(Region::All),
                    width: -0.5,
                },
                "falloff width",
            ),
            (
                Region::Falloff {
                    inner: Box::new(Region::Box {
                        min: DVec3::ONE,
                        max: DVec3::ZERO,
                    }),
                    width: 0.5,
                },
                "box.min.x",
            ),
        ];
        let d = Deformation::fit(&[DVec3::ZERO], &[DVec3::Y], FitOptions::new(1.0)).expect("fit");
        for (region, field) in cases {
            let e = region.select(&pts, &none).expect_err("accepted");
            assert!(e.to_string().contains(field), "{region}: {e}");
            assert!(matches!(e, Error::Region(RegionError::Invalid(_))));
            let stage = FittedStage::new(d.clone()).with_region(region.clone());
            assert!(compose(&pts, &[stage], Combine::Chain).is_err());
            let mut p = Pipeline::new(pts.to_vec());
            p.push(
                Stage::new(vec![DVec3::ZERO], vec![DVec3::Y], FitOptions::new(1.0))
                    .with_region(region),
            );
            assert!(p.evaluate().is_err());
        }
        // An empty box of zero size and a sphere of radius 0 are fine.
        let point_box = Region::Box {
            min: DVec3::ZERO,
            max: DVec3::ZERO,
        };
        assert_eq!(point_box.select(&pts, &none).expect("point box"), vec![0]);
    }

    /// A pipeline saves to `.csrbf` directly, and the file replays it.
    #[test]
    fn a_pipeline_saves_and_replays() {
        let mut rng = Rng::new(77);
        let rest: Vec<Vec3> = (0..500).map(|_| rng.vec3().as_vec3()).collect();
        let (s1, t1) = scene(20, 31);
        let (s2, t2) = scene(15, 32);
        for combine in Combine::ALL {
            let mut p = Pipeline::new(rest.clone())
                .with_combine(combine)
                .with_groups(vec![("left".into(), (0..250).collect())]);
            p.push(Stage::new(s1.clone(), t1.clone(), FitOptions::new(0.4)));
            p.push(
                Stage::new(s2.clone(), t2.clone(), FitOptions::new(0.3))
                    .with_region(Region::Group("left".into()))
                    .with_phase(0.5),
            );
            let bytes = p.to_replay().expect("replay").to_bytes();
            let back = format::Replay::from_bytes(&bytes).expect("decode");
            assert_eq!(back.combine, combine);
            assert_eq!(back.stages[1].phase, 0.5);
            let groups = |n: &str| (n == "left").then(|| (0..250).collect());
            let replayed = back.compose(&rest, &groups).expect("compose");
            let evaluated = p.evaluate().expect("evaluate");
            let worst = replayed
                .iter()
                .zip(evaluated)
                .map(|(a, b)| a.distance(*b))
                .fold(0.0f32, f32::max);
            // The binding's f32 sums against the f64 evaluation (see Binding).
            assert!(worst < 1e-6, "{combine}: {worst}");
            // A file of two deformations is not one deformation.
            let e = Deformation::from_bytes(&bytes).expect_err("two read as one");
            assert!(e.to_string().contains("2 deformations"), "{e}");
        }
    }
}

/// A radius thousands of times the model's size makes the system nearly
/// singular: coefficients 1e8 times the moves that cancel. f32 sums keep
/// only their rounding there (a user's armadillo was off by 252 units for
/// moves of 30), so the f32 evaluation and a binding's product sum such
/// cells in f64: both agree with the f64 evaluation, as on a well-posed
/// scene, and the interpolation still holds at the starts.
#[test]
fn a_radius_far_larger_than_the_model_keeps_f32_paths_right() {
    let mut rng = Rng::new(41);
    // A model about 2 units across, its points in f32 as a mesh holds them.
    let points: Vec<Vec3> = (0..3000)
        .map(|_| (rng.vec3() * 2.0 - 1.0).as_vec3())
        .collect();
    let starts = [
        DVec3::new(0.5, 0.2, 0.1),
        DVec3::new(-0.4, 0.3, -0.2),
        DVec3::new(0.1, -0.6, 0.4),
    ];
    let moves = [
        DVec3::new(0.0, 0.05, 0.0),
        DVec3::new(0.05, 0.0, 0.0),
        DVec3::new(0.0, 0.0, -0.3),
    ];
    let targets: Vec<DVec3> = starts.iter().zip(&moves).map(|(s, m)| *s + *m).collect();
    for radius in [1e4, 1.0] {
        let d = Deformation::fit(&starts, &targets, FitOptions::new(radius)).expect("fit");
        let amplification = d
            .coefficients()
            .iter()
            .map(|a| a.length())
            .fold(0.0, f64::max)
            / 0.3;
        if radius > 1.0 {
            assert!(
                amplification > 1e6,
                "the scene is the ill-posed one: {amplification:e}"
            );
        }
        let want = d.displacements(&points);
        let f32s = d.displacements_f32(&points);
        let bound = Binding::new(&d, &points).displacements(&d).expect("bound");
        for (what, got) in [("f32 evaluation", &f32s), ("binding", &bound)] {
            let worst = got
                .iter()
                .zip(&want)
                .map(|(g, w)| (g.as_dvec3() - *w).length())
                .fold(0.0, f64::max);
            assert!(
                worst <= 1e-5 * 0.3,
                "R {radius}, {what}: off by {worst:e} for moves of 0.3"
            );
        }
        for (s, t) in starts.iter().zip(&targets) {
            assert!(
                (d.map(*s) - *t).length() < 1e-6,
                "R {radius}: interpolation"
            );
        }
    }
}

/// `starts_out_of_reach` (a System's, before any solve, and a Deformation's)
/// names exactly the starts that every point is R or farther from.
#[test]
fn starts_out_of_reach_are_those_every_point_is_r_from() {
    let mut rng = Rng::new(43);
    let points: Vec<Vec3> = (0..2000)
        .map(|_| (rng.vec3() * 2.0 - 1.0).as_vec3())
        .collect();
    let radius = 0.05;
    let starts: Vec<DVec3> = (0..60)
        .map(|k| {
            if k % 2 == 0 {
                points[k * 7].as_dvec3() + (rng.vec3() - 0.5) * radius
            } else {
                rng.vec3() * 3.0 - 1.5
            }
        })
        .collect();
    let want: Vec<usize> = (0..starts.len())
        .filter(|&j| {
            points
                .iter()
                .all(|p| p.as_dvec3().distance_squared(starts[j]) >= radius * radius)
        })
        .collect();
    assert!(!want.is_empty() && want.len() < starts.len());
    let s = System::new(&starts, FitOptions::new(radius)).expect("system");
    assert_eq!(s.starts_out_of_reach(&points), want);
    assert_eq!(
        s.solve(&starts)
            .expect("solve")
            .starts_out_of_reach(&points),
        want
    );
    assert_eq!(
        s.starts_out_of_reach::<Vec3>(&[]),
        (0..starts.len()).collect::<Vec<_>>()
    );
    // f64 points are measured as they are: rounded to f32, this point
    // would be 1.5e-9 nearer, within R of the start.
    let p = DVec3::new(0.1, 0.0, 0.0);
    let one =
        System::new(&[p + DVec3::X * 0.5 * (1.0 + 1e-12)], FitOptions::new(0.5)).expect("system");
    assert_eq!(one.starts_out_of_reach(&[p]), [0]);
    assert!(one.starts_out_of_reach(&[p.as_vec3()]).is_empty());
}

/// A system of 2,000 starts or more is dissected first, its band orderings
/// made beside the symbolic analysis: either way `Auto` still takes the
/// solver of fewer multiply-adds, reports both solvers' figures, takes the
/// least envelope of the three band orderings, and gives the forced
/// solvers' deformation. A thin strip (a narrow band) goes to the profile,
/// a sphere (a wide one) to the supernodal factor.
#[test]
fn a_large_system_takes_the_solver_of_fewer_multiply_adds() {
    let mut rng = Rng::new(45);
    let strip: Vec<DVec3> = (0..2400)
        .map(|i| DVec3::new(i as f64 * 0.01, rng.f64() * 0.03, rng.f64() * 0.03))
        .collect();
    let sphere = crate::synthetic::fibonacci_sphere(3000, DVec3::splat(0.5), 0.4, 0.3, 5);
    let sphere_radius = crate::synthetic::radius_for_neighbours(3000, 0.4, 40.0);
    for (name, starts, radius, want) in [
        ("strip", strip, 0.035, "skyline"),
        ("sphere", sphere, sphere_radius, "supernodal"),
    ] {
        let targets: Vec<DVec3> = starts
            .iter()
            .map(|s| *s + (rng.vec3() - 0.5) * 0.2 * radius)
            .collect();
        let fit = |solver| {
            let o = options(Kernel::C2, Polynomial::Linear, radius, solver);
            let system = System::new(&starts, o).expect("fit");
            let d = system.solve(&targets).expect("solve");
            (system.stats().clone(), d)
        };
        let (stats, auto) = fit(SolverChoice::Auto);
        assert_eq!(stats.solver, want, "{name}");
        assert!(
            stats.bandwidth > 0 && stats.skyline_flops > 0.0,
            "{name}: {stats:?}"
        );
        let tried: Vec<&str> = stats
            .orderings
            .iter()
            .map(|o| o.ordering.as_str())
            .collect();
        assert_eq!(tried, ["rcm", "breadth-first", "identity"], "{name}");
        let least = stats.orderings.iter().map(|o| o.envelope).min();
        assert_eq!(Some(stats.envelope), least, "{name}: {stats:?}");
        if want == "supernodal" {
            assert!(
                stats.factor_flops < stats.skyline_flops,
                "{name}: {stats:?}"
            );
        } else {
            // Its starts are in order along it: the caller's order is the
            // least envelope (measured once, as the band before).
            assert_eq!(stats.ordering, "identity", "{name}: {stats:?}");
            assert_eq!(stats.envelope, stats.envelope_before, "{name}");
            assert_eq!(stats.factor_flops, stats.skyline_flops, "{name}");
        }
        for solver in SOLVERS {
            let (_, forced) = fit(solver);
            for s in starts.iter().step_by(97) {
                let gap = (auto.map(*s) - forced.map(*s)).length();
                assert!(gap <= 1e-9 * radius, "{name} {solver:?}: {gap:e} at {s}");
            }
        }
    }
}
