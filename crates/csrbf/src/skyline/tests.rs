#![allow(clippy::needless_range_loop)] // dense reference code indexes matrices
use glam::DVec3;

use super::*;
use crate::ordering::{Graph, reverse_cuthill_mckee};
use crate::testing::{Rng, assert_close};

/// A random sparse SPD matrix (diagonally dominant) and its pattern.
fn random_spd(n: usize, rng: &mut Rng) -> (Vec<Vec<f64>>, Graph) {
    let mut a = vec![vec![0.0; n]; n];
    let mut lists = vec![Vec::new(); n];
    for _ in 0..3 * n {
        let (i, j) = (rng.below(n), rng.below(n));
        if i != j && a[i][j] == 0.0 {
            let v = rng.f64() - 0.5;
            a[i][j] = v;
            a[j][i] = v;
            lists[i].push(j as u32);
            lists[j].push(i as u32);
        }
    }
    for i in 0..n {
        a[i][i] = 1.0 + a[i].iter().map(|v| v.abs()).sum::<f64>();
    }
    (a, Graph::from_lists(&lists))
}

/// Dense Gaussian elimination with partial pivoting: the plain reference.
pub(crate) fn dense_solve(a: &[Vec<f64>], b: &[f64]) -> Vec<f64> {
    let n = b.len();
    let mut m: Vec<Vec<f64>> = a
        .iter()
        .zip(b)
        .map(|(r, &v)| {
            let mut r = r.clone();
            r.push(v);
            r
        })
        .collect();
    for c in 0..n {
        let p = (c..n)
            .max_by(|&x, &y| m[x][c].abs().total_cmp(&m[y][c].abs()))
            .unwrap_or(c);
        m.swap(c, p);
        for r in c + 1..n {
            let f = m[r][c] / m[c][c];
            for k in c..=n {
                m[r][k] -= f * m[c][k];
            }
        }
    }
    let mut x = vec![0.0; n];
    for r in (0..n).rev() {
        let s: f64 = (r + 1..n).map(|k| m[r][k] * x[k]).sum();
        x[r] = (m[r][n] - s) / m[r][r];
    }
    x
}

#[test]
fn factor_and_solve_match_a_dense_solve() {
    for seed in 0..25 {
        let mut rng = Rng::new(seed);
        let n = 1 + rng.below(80);
        let (a, g) = random_spd(n, &mut rng);
        let perm = reverse_cuthill_mckee(&g);
        let env = Envelope::new(&g, &perm);
        let mut p = Profile::zeros(env);
        for (i, &oi) in perm.iter().enumerate() {
            for (j, &oj) in perm.iter().enumerate().take(i + 1) {
                p.set(i, j, a[oi as usize][oj as usize]);
            }
        }
        for (i, &oi) in perm.iter().enumerate() {
            for (j, &oj) in perm.iter().enumerate() {
                assert_eq!(
                    p.get(i, j),
                    a[oi as usize][oj as usize],
                    "pattern lost an entry"
                );
            }
        }
        // The scalar fallback gives the same factor as the dispatched code.
        let mut scalar = p.clone();
        scalar.factor_scalar().expect("SPD");
        p.factor().expect("SPD");
        for i in 0..n {
            for j in 0..=i {
                assert_close(
                    p.get(i, j),
                    scalar.get(i, j),
                    1e-12,
                    "scalar vs vector factor",
                );
            }
        }
        let b: Vec<DVec3> = (0..n).map(|_| rng.vec3()).collect();
        let mut x: Vec<DVec3> = perm.iter().map(|&o| b[o as usize]).collect();
        p.solve_in_place(&mut x);
        for c in 0..3 {
            let want = dense_solve(&a, &b.iter().map(|v| v[c]).collect::<Vec<_>>());
            for (new, &old) in perm.iter().enumerate() {
                assert_close(x[new][c], want[old as usize], 1e-10, "skyline vs dense");
            }
        }
    }
}

#[test]
fn indefinite_matrix_names_the_failing_row() {
    let g = Graph::from_lists(&[vec![1], vec![0]]);
    let mut p = Profile::zeros(Envelope::new(&g, &[0, 1]));
    p.set(0, 0, 1.0);
    p.set(1, 0, 2.0);
    p.set(1, 1, 1.0);
    assert_eq!(p.factor(), Err(factor::PivotError { row: 1 }));
}

#[test]
fn envelope_counts() {
    // A path 0-1-2-3 in order: one entry per row below the diagonal.
    let g = Graph::from_lists(&[vec![1], vec![0, 2], vec![1, 3], vec![2]]);
    let e = Envelope::new(&g, &[0, 1, 2, 3]);
    assert_eq!(e.off_diagonal(), 3);
    assert_eq!(e.bandwidth(), 1);
    assert_eq!(e.paper_bytes(), 4 * (8 + 3));
}

/// The blocked factor (four columns at a time) against the plain row-by-row
/// reference, on profiles wide enough for many blocks and with ragged row
/// starts (rows of a block that start after its first column).
#[test]
fn blocked_factor_matches_the_row_by_row_reference() {
    for seed in 0..12 {
        let mut rng = Rng::new(100 + seed);
        let n = 50 + rng.below(250);
        let (a, g) = random_spd(n, &mut rng);
        let perm: Vec<u32> = if seed % 2 == 0 {
            reverse_cuthill_mckee(&g)
        } else {
            (0..n as u32).collect()
        };
        let mut p = Profile::zeros(Envelope::new(&g, &perm));
        for (i, &oi) in perm.iter().enumerate() {
            for (j, &oj) in perm.iter().enumerate().take(i + 1) {
                p.set(i, j, a[oi as usize][oj as usize]);
            }
        }
        let mut reference = p.clone();
        reference.factor_scalar().expect("SPD");
        p.factor().expect("SPD");
        // Same products, summed in another order: agreement to rounding.
        for i in 0..n {
            for j in 0..=i {
                assert_close(
                    p.get(i, j),
                    reference.get(i, j),
                    1e-12,
                    "blocked vs reference",
                );
            }
        }
    }
}
