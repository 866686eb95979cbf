use glam::DVec3;

use super::{Grid, Octree};
use crate::testing::Rng;

fn brute(points: &[DVec3], q: DVec3, r: f64) -> Vec<u32> {
    (0..points.len() as u32)
        .filter(|&i| points[i as usize].distance_squared(q) < r * r)
        .collect()
}

#[test]
fn matches_brute_force_on_random_clouds() {
    for seed in 0..20 {
        let mut rng = Rng::new(seed);
        let n = 1 + rng.below(2000);
        // Mix of uniform points, a dense cluster and exact duplicates.
        let mut points: Vec<DVec3> = (0..n).map(|_| rng.vec3() * 3.0 - 1.0).collect();
        for k in 0..n / 10 {
            points.push(DVec3::splat(0.25) + rng.vec3() * 1e-4);
            if k % 3 == 0 {
                points.push(points[k]);
            }
        }
        let tree = Octree::new(&points);
        assert_eq!(tree.points.len(), points.len());
        for _ in 0..50 {
            let q = rng.vec3() * 4.0 - 1.5;
            let r = rng.f64() * 0.8;
            let mut got = tree.within(q, r);
            got.sort_unstable();
            assert_eq!(got, brute(&points, q, r), "seed {seed} q {q} r {r}");
        }
    }
}

#[test]
fn box_query_returns_every_candidate() {
    let mut rng = Rng::new(7);
    let points: Vec<DVec3> = (0..3000).map(|_| rng.vec3()).collect();
    let tree = Octree::new(&points);
    for _ in 0..30 {
        let lo = rng.vec3() * 0.8;
        let hi = lo + rng.vec3() * 0.2;
        let r = 0.05 + rng.f64() * 0.1;
        let mut cand = Vec::new();
        tree.for_each_near_box(lo, hi, r, |i, p| {
            assert_eq!(p, points[i as usize]);
            cand.push(i);
        });
        for _ in 0..20 {
            let q = lo + (hi - lo) * rng.vec3();
            for i in brute(&points, q, r) {
                assert!(cand.contains(&i));
            }
        }
    }
}

#[test]
fn degenerate_inputs() {
    assert!(Octree::new(&[]).within(DVec3::ZERO, 1.0).is_empty());
    let same = vec![DVec3::ONE; 100];
    let tree = Octree::new(&same);
    assert_eq!(tree.within(DVec3::ONE, 0.1).len(), 100);
    assert!(tree.depth() <= Octree::MAX_DEPTH);
    // Points on a line: depth grows but stays bounded.
    let line: Vec<DVec3> = (0..5000).map(|i| DVec3::new(i as f64, 0.0, 0.0)).collect();
    let tree = Octree::new(&line);
    assert_eq!(tree.within(DVec3::new(10.0, 0.0, 0.0), 2.5).len(), 5);
}

#[test]
fn nearest_matches_brute_force() {
    let mut rng = Rng::new(11);
    assert_eq!(Octree::new(&[]).nearest(DVec3::ZERO), None);
    let points: Vec<DVec3> = (0..1500).map(|_| rng.vec3() * 2.0).collect();
    let tree = Octree::new(&points);
    for _ in 0..200 {
        let q = rng.vec3() * 3.0 - 0.5;
        let want = points
            .iter()
            .map(|p| p.distance_squared(q))
            .fold(f64::INFINITY, f64::min);
        let (i, d2) = tree.nearest(q).expect("a point");
        assert_eq!(d2, want);
        assert_eq!(points[i as usize].distance_squared(q), want);
    }
}

/// The grid's box query gives the tree's points, each once, with their
/// coordinates in the caller's frame: on clouds uniform, clustered (many
/// points a cell), flat (a plane, as a surface's starts) and far from the
/// origin, with boxes inside, across and outside the cloud, radii from a
/// fraction of a cell to past the cloud, and the grid's cap on cells met
/// (cells wider than R/2).
#[test]
fn the_grid_box_query_gives_the_tree_s_points() {
    let mut rng = Rng::new(71);
    for (case, n) in [10, 500, 3000, 3000, 20_000].into_iter().enumerate() {
        let offset = DVec3::new(1e3, -2e3, 5e2);
        let points: Vec<DVec3> = (0..n)
            .map(|k| match case {
                1 => DVec3::splat(0.5) + rng.vec3() * 0.01,
                2 => DVec3::new(rng.f64(), rng.f64(), 0.25),
                3 => offset + rng.vec3(),
                _ if k % 7 == 0 => points_cluster(&mut rng),
                _ => rng.vec3(),
            })
            .collect();
        let base = if case == 3 { offset } else { DVec3::ZERO };
        let tree = Octree::new(&points);
        for r in [1e-3, 0.02, 0.1, 0.4, 3.0] {
            let grid = Grid::new(&tree.points, &tree.ids, r);
            for _ in 0..20 {
                let lo = base + rng.vec3() * 1.4 - 0.2;
                let hi = lo + rng.vec3() * r;
                let mut want = Vec::new();
                tree.for_each_near_box(lo, hi, r, |i, _| want.push(i));
                want.sort_unstable();
                let (mut ids, mut xyz) = (vec![7u32], [vec![0.5f32], vec![0.5], vec![0.5]]);
                let frame = |p: DVec3| (p - lo).as_vec3().to_array();
                grid.near_box_into((lo, hi), &mut ids, &mut xyz, frame);
                // Appended after what was there.
                assert_eq!((ids[0], xyz[0][0]), (7, 0.5));
                for (k, &i) in ids.iter().enumerate().skip(1) {
                    let u = frame(points[i as usize]);
                    assert_eq!([xyz[0][k], xyz[1][k], xyz[2][k]], u, "case {case} r {r}");
                }
                let mut got = ids[1..].to_vec();
                got.sort_unstable();
                assert_eq!(got, want, "case {case} r {r} box {lo}..{hi}");
                // The tree's own answer (its walk below `GRID_POINTS`
                // points, its grid from there), the same points.
                let (mut ids, mut xyz) = (Vec::new(), [vec![], vec![], vec![]]);
                tree.near_box_into((lo, hi), r, &mut ids, &mut xyz, frame);
                for (k, &i) in ids.iter().enumerate() {
                    let u = frame(points[i as usize]);
                    assert_eq!([xyz[0][k], xyz[1][k], xyz[2][k]], u, "case {case} r {r}");
                }
                ids.sort_unstable();
                assert_eq!(ids, want, "case {case} r {r}: the tree's answer");
            }
        }
    }
}

fn points_cluster(rng: &mut Rng) -> DVec3 {
    DVec3::splat(0.3) + rng.vec3() * 1e-3
}

/// A grid of points spanning more than f64 holds, or for a radius whose
/// half underflows, is one cell (its sizing ends) and still answers as the
/// tree does; a NaN or zero radius, too.
#[test]
fn a_grid_of_extreme_points_or_radii_answers_as_the_tree() {
    let mut rng = Rng::new(5);
    let wide: Vec<DVec3> = (0..40)
        .map(|k| DVec3::new(if k % 2 == 0 { 1e308 } else { -1e308 }, rng.f64(), 0.0))
        .collect();
    let flat: Vec<DVec3> = (0..40)
        .map(|_| DVec3::new(rng.f64(), rng.f64(), 0.0))
        .collect();
    let tiny = f64::from_bits(1); // the smallest subnormal: its half is 0
    for (points, radius) in [
        (&wide, 1.0),
        (&wide, 1e300),
        (&flat, tiny),
        (&flat, 0.0),
        (&flat, f64::NAN),
        (&flat, 0.3),
    ] {
        let tree = Octree::new(points);
        let grid = Grid::new(&tree.points, &tree.ids, radius);
        for lo in [DVec3::ZERO, DVec3::splat(0.4), DVec3::new(1e308, 0.0, 0.0)] {
            let hi = lo + 0.1;
            let mut want = Vec::new();
            tree.for_each_near_box(lo, hi, radius, |i, _| want.push(i));
            want.sort_unstable();
            let (mut ids, mut xyz) = (Vec::new(), [vec![], vec![], vec![]]);
            grid.near_box_into((lo, hi), &mut ids, &mut xyz, |p| p.as_vec3().to_array());
            ids.sort_unstable();
            assert_eq!(ids, want, "radius {radius} box at {lo}");
        }
    }
}
