//! The supernodal factor's two triangular solves for what a deformation
//! asks of them: one to four right-hand sides (x y z, or a DVec4), each row
//! of them held as four f64 (one 256-bit vector).
//!
//! faer's general solve multiplies each supernode's block below its
//! diagonal by the few solved columns through its matrix product, which
//! first packs the block into a buffer of its own: at 1m (27 MB of L, three
//! right-hand sides; `perf`) the packing alone took 16 % of the solve and
//! the product's kernels 45 %, where the solve need only read L once each
//! way (7.5-11.5 ms then, about 5 ms here: 54 MB read at the 17 GB/s one
//! core streams would be 3.2 ms).
//! Here each supernode's rows (its diagonal block's and those below it)
//! are gathered into a work buffer, L's columns are read straight from the
//! factor (forward: four columns at a time subtracted from the rows below
//! them; backward: each column a dot product with the rows below it), and
//! the rows are put back.

use faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky;

use crate::simd::Avx2Fma;
use crate::skyline::Rhs;

/// The right-hand sides of one row, up to four (the rest zero).
type Row = [f64; 4];

/// How many right-hand sides a value may carry for [`solve_in_place`].
pub(crate) const MAX_LANES: usize = 4;

/// Solves L L^T x = b in place for the supernodal factor (`symbolic`,
/// `values`) with fill-reducing order `forward` (new row `i` is the
/// caller's row `forward[i]`; `None`: the caller's order). `b` holds one
/// value per row in the caller's numbering, of at most [`MAX_LANES`] lanes.
pub(crate) fn solve_in_place<T: Rhs>(
    symbolic: &SymbolicSupernodalCholesky<u32>,
    forward: Option<&[u32]>,
    values: &[f64],
    b: &mut [T],
) {
    assert!(T::LANES <= MAX_LANES, "at most four right-hand sides a row");
    let n = symbolic.nrows();
    assert_eq!(b.len(), n, "one value per row of the factor");
    let old = |i: usize| forward.map_or(i, |f| f[i] as usize);
    let mut x: Vec<Row> = (0..n)
        .map(|i| {
            let v = b[old(i)];
            std::array::from_fn(|k| if k < T::LANES { v.lane(k) } else { 0.0 })
        })
        .collect();
    let mut work = Vec::new();
    match Avx2Fma::detect() {
        Some(cpu) => solve_with(cpu, symbolic, values, &mut x, &mut work),
        None => solve_body::<false>(symbolic, values, &mut x, &mut work),
    }
    for (i, r) in x.iter().enumerate() {
        let v = &mut b[old(i)];
        for (k, &lane) in r.iter().enumerate().take(T::LANES) {
            v.set_lane(k, lane);
        }
    }
}

/// [`solve_body`] compiled for AVX2 and FMA (the proof given).
fn solve_with(
    _cpu: Avx2Fma,
    symbolic: &SymbolicSupernodalCholesky<u32>,
    values: &[f64],
    x: &mut [Row],
    work: &mut Vec<Row>,
) {
    // SAFETY: an `Avx2Fma` exists only when the CPU has AVX2 and FMA.
    #[cfg(target_arch = "x86_64")]
    #[allow(unsafe_code)]
    unsafe {
        solve_avx2(symbolic, values, x, work)
    }
    // No such proof is ever made elsewhere; the plain body compiles.
    #[cfg(not(target_arch = "x86_64"))]
    solve_body::<false>(symbolic, values, x, work)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn solve_avx2(
    symbolic: &SymbolicSupernodalCholesky<u32>,
    values: &[f64],
    x: &mut [Row],
    work: &mut Vec<Row>,
) {
    solve_body::<true>(symbolic, values, x, work)
}

/// One supernode: its first column, its rows below the diagonal block and
/// its values (column-major, `width + below.len()` rows by `width`).
struct Node<'a> {
    start: usize,
    width: usize,
    below: &'a [u32],
    values: &'a [f64],
}

impl Node<'_> {
    /// Rows of its block.
    fn rows(&self) -> usize {
        self.width + self.below.len()
    }

    /// Column `c` of its block, from the diagonal down.
    #[inline(always)]
    fn column(&self, c: usize) -> &[f64] {
        let rows = self.rows();
        &self.values[c * rows + c..(c + 1) * rows]
    }

    /// Its rows of `x` into `work` (the diagonal block's, then those below).
    #[inline(always)]
    fn gather(&self, x: &[Row], work: &mut Vec<Row>) {
        work.clear();
        work.extend_from_slice(&x[self.start..self.start + self.width]);
        work.extend(self.below.iter().map(|&r| x[r as usize]));
    }
}

/// Supernode `s` of the factor.
#[inline(always)]
fn node<'a>(
    symbolic: &'a SymbolicSupernodalCholesky<u32>,
    values: &'a [f64],
    s: usize,
) -> Node<'a> {
    let start = symbolic.supernode_begin()[s] as usize;
    let width = symbolic.supernode_end()[s] as usize - start;
    let below = symbolic.supernode(s).pattern();
    let at = symbolic.col_ptr_for_val();
    let values = &values[at[s] as usize..at[s + 1] as usize];
    debug_assert_eq!(values.len(), (width + below.len()) * width);
    Node {
        start,
        width,
        below,
        values,
    }
}

/// `d - l x`, lane by lane (fused where `FMA`).
#[inline(always)]
fn mul_sub<const FMA: bool>(d: Row, l: f64, x: Row) -> Row {
    std::array::from_fn(|k| {
        if FMA {
            (-l).mul_add(x[k], d[k])
        } else {
            d[k] - l * x[k]
        }
    })
}

/// `acc + l x`, lane by lane (fused where `FMA`).
#[inline(always)]
fn mul_add<const FMA: bool>(acc: Row, l: f64, x: Row) -> Row {
    std::array::from_fn(|k| {
        if FMA {
            l.mul_add(x[k], acc[k])
        } else {
            acc[k] + l * x[k]
        }
    })
}

/// Forward (L y = b) then backward (L^T x = y) over every supernode.
#[inline(always)]
fn solve_body<const FMA: bool>(
    symbolic: &SymbolicSupernodalCholesky<u32>,
    values: &[f64],
    x: &mut [Row],
    work: &mut Vec<Row>,
) {
    let count = symbolic.n_supernodes();
    for s in 0..count {
        let node = node(symbolic, values, s);
        node.gather(x, work);
        forward_node::<FMA>(&node, work);
        x[node.start..node.start + node.width].copy_from_slice(&work[..node.width]);
        for (&r, v) in node.below.iter().zip(&work[node.width..]) {
            x[r as usize] = *v;
        }
    }
    for s in (0..count).rev() {
        let node = node(symbolic, values, s);
        node.gather(x, work);
        backward_node::<FMA>(&node, work);
        x[node.start..node.start + node.width].copy_from_slice(&work[..node.width]);
    }
}

/// One supernode's part of L y = b on its gathered rows: its diagonal
/// block's rows solved, the rows below updated. Four columns at a time:
/// their 4 x 4 triangle column by column, then the rows below it take the
/// four columns' terms in one pass (a row loaded and stored once for four
/// multiply-adds).
#[inline(always)]
fn forward_node<const FMA: bool>(node: &Node<'_>, work: &mut [Row]) {
    let mut j = 0;
    while j < node.width {
        let k = (node.width - j).min(4);
        for c in j..j + k {
            let col = node.column(c);
            let xc = work[c].map(|v| v / col[0]);
            work[c] = xc;
            for (i, &l) in (c + 1..j + k).zip(&col[1..]) {
                work[i] = mul_sub::<FMA>(work[i], l, xc);
            }
        }
        let (done, rest) = work.split_at_mut(j + k);
        let rest_of = |c: usize| &node.column(c)[j + k - c..];
        if k == 4 {
            let n = rest.len();
            let cols = [0, 1, 2, 3].map(|t| &rest_of(j + t)[..n]);
            let xs = [0, 1, 2, 3].map(|t| done[j + t]);
            // Two rows a step.
            for i in (0..n - n % 2).step_by(2) {
                let (mut a, mut b) = (rest[i], rest[i + 1]);
                for t in 0..4 {
                    a = mul_sub::<FMA>(a, cols[t][i], xs[t]);
                    b = mul_sub::<FMA>(b, cols[t][i + 1], xs[t]);
                }
                (rest[i], rest[i + 1]) = (a, b);
            }
            if n % 2 == 1 {
                let mut a = rest[n - 1];
                for t in 0..4 {
                    a = mul_sub::<FMA>(a, cols[t][n - 1], xs[t]);
                }
                rest[n - 1] = a;
            }
        } else {
            for (c, &xc) in done.iter().enumerate().skip(j) {
                for (d, &l) in rest.iter_mut().zip(rest_of(c)) {
                    *d = mul_sub::<FMA>(*d, l, xc);
                }
            }
        }
        j += k;
    }
}

/// One supernode's part of L^T x = y on its gathered rows (those below
/// the diagonal block already solved), last columns first, four at a time:
/// the four columns' dot products with the solved rows below them in one
/// pass (a row loaded once for four multiply-adds, two rows a step: eight
/// sums in flight where one dot product's chain of multiply-adds would
/// wait on each other), then their 4 x 4 triangle.
#[inline(always)]
fn backward_node<const FMA: bool>(node: &Node<'_>, work: &mut [Row]) {
    let mut end = node.width;
    while end > 0 {
        let start = end.saturating_sub(4);
        let (head, solved) = work.split_at_mut(end);
        let below = |c: usize| &node.column(c)[end - c..];
        let mut sums = [[0.0; 4]; 4];
        if end - start == 4 {
            sums = dots4::<FMA>([0, 1, 2, 3].map(|t| below(start + t)), solved);
        } else {
            for c in start..end {
                sums[c - start] = dots4::<FMA>([below(c); 4], solved)[0];
            }
        }
        for c in (start..end).rev() {
            let col = node.column(c);
            let mut v: Row = std::array::from_fn(|k| head[c][k] - sums[c - start][k]);
            for (r, &l) in (c + 1..end).zip(&col[1..]) {
                v = mul_sub::<FMA>(v, l, head[r]);
            }
            head[c] = v.map(|v| v / col[0]);
        }
        end = start;
    }
}

/// The four sums over rows `i` of `columns[t][i] * rows[i]` (the columns
/// as long as `rows`), two rows a step.
#[inline(always)]
fn dots4<const FMA: bool>(columns: [&[f64]; 4], rows: &[Row]) -> [Row; 4] {
    let n = rows.len();
    let columns = columns.map(|c| &c[..n]);
    let (mut even, mut odd) = ([[0.0; 4]; 4], [[0.0; 4]; 4]);
    for i in (0..n - n % 2).step_by(2) {
        for t in 0..4 {
            even[t] = mul_add::<FMA>(even[t], columns[t][i], rows[i]);
            odd[t] = mul_add::<FMA>(odd[t], columns[t][i + 1], rows[i + 1]);
        }
    }
    if n % 2 == 1 {
        for t in 0..4 {
            even[t] = mul_add::<FMA>(even[t], columns[t][n - 1], rows[n - 1]);
        }
    }
    std::array::from_fn(|t| std::array::from_fn(|k| even[t][k] + odd[t][k]))
}

#[cfg(test)]
mod tests {
    use faer::Side;
    use faer::sparse::SymbolicSparseColMatRef;
    use faer::sparse::linalg::SupernodalThreshold;
    use faer::sparse::linalg::cholesky::{
        CholeskySymbolicParams, SymbolicCholeskyRaw, SymmetricOrdering, factorize_symbolic_cholesky,
    };
    use glam::{DVec3, DVec4};

    use super::*;
    use crate::solver::tests::random_system;
    use crate::solver::{Factor, LowerCsc};
    use crate::testing::Rng;

    /// The supernodal factor of a random system of `n` starts (faer would
    /// take a simplicial one for most small systems).
    fn supernodal(n: usize, radius: f64, seed: u64) -> (LowerCsc, Factor) {
        let (_, _, a) = random_system(n, radius, seed);
        let pattern = SymbolicSparseColMatRef::new_checked(a.n, a.n, &a.col_ptr, None, &a.row_idx);
        let params = CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
            ..Default::default()
        };
        let symbolic =
            factorize_symbolic_cholesky(pattern, Side::Lower, SymmetricOrdering::Amd, params)
                .expect("symbolic");
        assert!(
            matches!(symbolic.raw(), SymbolicCholeskyRaw::Supernodal(_)),
            "n {n}"
        );
        let factor = Factor::supernodal(symbolic, &a).expect("SPD");
        (a, factor)
    }

    /// The supernodal factor of a random system: its solve against faer's.
    fn check<T: Rhs>(n: usize, radius: f64, seed: u64, rhs: impl Fn(&mut Rng) -> T) {
        let (_, factor) = supernodal(n, radius, seed);
        let mut rng = Rng::new(seed + 100);
        let b: Vec<T> = (0..n).map(|_| rhs(&mut rng)).collect();
        let (mut ours, mut faer) = (b.clone(), b.clone());
        factor.solve_in_place(&mut ours);
        let Factor::Supernodal { symbolic, values } = &factor else {
            unreachable!("a supernodal factor")
        };
        Factor::solve_in_place_faer(symbolic, values, &mut faer);
        let scale = faer
            .iter()
            .flat_map(|v| (0..T::LANES).map(|k| v.lane(k).abs()))
            .fold(0.0, f64::max);
        for (i, (u, v)) in ours.iter().zip(&faer).enumerate() {
            for k in 0..T::LANES {
                let err = (u.lane(k) - v.lane(k)).abs();
                assert!(
                    err <= 1e-11 * scale,
                    "n {n} row {i} lane {k}: {} vs {}",
                    u.lane(k),
                    v.lane(k)
                );
            }
        }
    }

    #[test]
    fn the_solve_agrees_with_faers_for_one_three_and_four_right_hand_sides() {
        for (n, radius, seed) in [(5, 2.0, 1), (40, 0.6, 2), (300, 0.25, 3), (900, 0.2, 4)] {
            check(n, radius, seed, |r| r.vec3().x - 0.5);
            check(n, radius, seed, |r| r.vec3() - DVec3::splat(0.5));
            check(n, radius, seed, |r| {
                r.vec3().extend(r.vec3().y) - DVec4::splat(0.5)
            });
        }
    }

    /// With and without fused multiply-adds (what a CPU without AVX2 runs):
    /// the same solution to rounding.
    #[test]
    fn the_plain_path_agrees_with_the_fused_one() {
        let (a, factor) = supernodal(600, 0.22, 9);
        let Factor::Supernodal { symbolic, values } = factor else {
            unreachable!("a supernodal factor")
        };
        let SymbolicCholeskyRaw::Supernodal(s) = symbolic.raw() else {
            unreachable!("forced supernodal")
        };
        let mut rng = Rng::new(5);
        let b: Vec<Row> = (0..a.n)
            .map(|_| {
                let v = rng.vec3();
                [v.x, v.y, v.z, 1.0]
            })
            .collect();
        let (mut plain, mut fused) = (b.clone(), b);
        let mut work = Vec::new();
        solve_body::<false>(s, &values, &mut plain, &mut work);
        if let Some(cpu) = Avx2Fma::detect() {
            solve_with(cpu, s, &values, &mut fused, &mut work);
        } else {
            solve_body::<true>(s, &values, &mut fused, &mut work);
        }
        for (p, f) in plain.iter().zip(&fused) {
            for k in 0..4 {
                assert!((p[k] - f[k]).abs() <= 1e-11 * (1.0 + f[k].abs()));
            }
        }
    }
}
