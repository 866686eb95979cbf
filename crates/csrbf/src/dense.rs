//! The dense Cholesky factor of a supernode's diagonal block.
//!
//! faer's factorisation is the faster on one thread at every width, but on
//! the pool it loses to itself on one thread up to about 700 columns and
//! gains little beyond (measured on two threads: 556 against 369 us at 443
//! columns, 2,277 against 2,376 at 882). The top separators of a large
//! system are that wide, and the other thread waits on them. So from
//! [`PANELLED`] columns on, on the pool, the block is factored here in
//! panels of [`PANEL`] columns, right-looking, each step from faer's
//! sequential kernels: the panel's diagonal block factored, the rows under
//! it solved in two halves at once, and the columns right of it updated in
//! two parts of equal work at once (1,584 us at 882 columns, 6,363 at
//! 1,500 against faer's 7,480).

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::{LltError, LltRegularization, cholesky_in_place};
use faer::linalg::matmul::triangular::{self, BlockStructure};
use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::{Accum, MatMut, MatRef, Par};

/// Columns of a panel.
const PANEL: usize = 96;

/// From this many columns on, a block on the pool is factored in panels.
const PANELLED: usize = 448;

/// Factors the lower triangle of the square `a` in place (L with
/// L L^T = A, read from the lower triangle; what lies above the diagonal
/// after is not L's, as after faer's): in panels
/// on the pool (`par`) from [`PANELLED`] columns on, else by faer's
/// factorisation on this thread. `stack`: room for faer's factorisation of
/// `a` on one thread. Fails with the first column whose pivot is not
/// positive.
pub(crate) fn cholesky(
    mut a: MatMut<'_, f64>,
    par: Par,
    stack: &mut MemBuffer,
) -> Result<(), usize> {
    let n = a.nrows();
    if n < PANELLED || !matches!(par, Par::Rayon(_)) {
        return unblocked(a, stack);
    }
    let mut j0 = 0;
    while j0 < n {
        let j1 = (j0 + PANEL).min(n);
        let (panel, right) = a
            .as_mut()
            .submatrix_mut(j0, j0, n - j0, n - j0)
            .split_at_col_mut(j1 - j0);
        let (mut diagonal, mut below) = panel.split_at_row_mut(j1 - j0);
        unblocked(diagonal.as_mut(), stack).map_err(|i| j0 + i)?;
        if j1 == n {
            break;
        }
        // The rows under the panel: B L^-T, in two halves at once.
        let diagonal = diagonal.as_ref();
        let (first, second) = below.as_mut().split_at_row_mut((n - j1) / 2);
        rayon::join(
            || solve_lower_triangular_in_place(diagonal, first.transpose_mut(), Par::Seq),
            || solve_lower_triangular_in_place(diagonal, second.transpose_mut(), Par::Seq),
        );
        // The columns right of the panel, less L21 L21^T: cut where half
        // of their values lie left, each part's on its own thread.
        let below = below.as_ref();
        let trailing = right.subrows_mut(j1 - j0, n - j1);
        let cut = half_of_lower(n - j1, n - j1);
        let (left, rest) = trailing.split_at_col_mut(cut);
        rayon::join(
            || less_product(left, below, 0),
            || less_product(rest, below, cut),
        );
        j0 = j1;
    }
    Ok(())
}

/// faer's factorisation of `a` on this thread.
fn unblocked(a: MatMut<'_, f64>, stack: &mut MemBuffer) -> Result<(), usize> {
    let regularization = LltRegularization {
        dynamic_regularization_delta: 0.0,
        dynamic_regularization_epsilon: 0.0,
    };
    match cholesky_in_place(
        a,
        regularization,
        Par::Seq,
        MemStack::new(stack),
        Default::default(),
    ) {
        Ok(_) => Ok(()),
        Err(LltError::NonPositivePivot { index }) => Err(index),
    }
}

/// The first column of the right part when the `width` columns of a block
/// of `rows` rows, on and below its diagonal (column c holds rows - c
/// values), are cut in two of about equal values.
pub(crate) fn half_of_lower(rows: usize, width: usize) -> usize {
    let total = (rows * width - width * width.saturating_sub(1) / 2) as f64;
    let mut sum = 0.0;
    (0..width)
        .find(|&c| {
            sum += (rows - c) as f64;
            sum >= total * 0.5
        })
        .map_or(width, |c| c + 1)
}

/// Subtracts `l l^T` from the columns `first..first + t.ncols()` of a
/// symmetric block (`t`, those columns' rows from the block's first),
/// on and below the diagonal: `l` is the block's rows of the panel.
fn less_product(t: MatMut<'_, f64>, l: MatRef<'_, f64>, first: usize) {
    let (m, cols) = (t.nrows(), t.ncols());
    if cols == 0 {
        return;
    }
    let (square, rest) = t.subrows_mut(first, m - first).split_at_row_mut(cols);
    let mine = l.subrows(first, cols);
    triangular::matmul(
        square,
        BlockStructure::TriangularLower,
        Accum::Add,
        mine,
        BlockStructure::Rectangular,
        mine.transpose(),
        BlockStructure::Rectangular,
        -1.0,
        Par::Seq,
    );
    if m > first + cols {
        faer::linalg::matmul::matmul(
            rest,
            Accum::Add,
            l.subrows(first + cols, m - first - cols),
            mine.transpose(),
            -1.0,
            Par::Seq,
        );
    }
}

#[cfg(test)]
mod tests {
    use faer::Mat;
    use faer::linalg::cholesky::llt::factor::cholesky_in_place_scratch;

    use super::*;
    use crate::testing::Rng;

    /// A symmetric positive definite matrix as the fit makes them: C2
    /// Wendland values of random points in a unit cube, R half its side,
    /// its upper triangle left out (a value no factor reads).
    fn spd(n: usize, seed: u64) -> Mat<f64> {
        let mut rng = Rng::new(seed);
        let points: Vec<_> = (0..n).map(|_| rng.vec3()).collect();
        Mat::<f64>::from_fn(n, n, |i, j| {
            if i >= j {
                crate::Kernel::C2.eval(points[i].distance(points[j]) / 0.5)
            } else {
                7.25
            }
        })
    }

    /// `cholesky` on a pool of two threads, and faer's on one.
    fn both(a: &Mat<f64>) -> (Result<Mat<f64>, usize>, Result<Mat<f64>, usize>) {
        let n = a.nrows();
        let mut stack = MemBuffer::new(cholesky_in_place_scratch::<f64>(
            n,
            Par::rayon(0),
            Default::default(),
        ));
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .expect("a pool");
        let mut ours = a.clone();
        let made = pool.install(|| cholesky(ours.as_mut(), Par::rayon(0), &mut stack));
        let mut faer = a.clone();
        let theirs = unblocked(faer.as_mut(), &mut stack);
        (made.map(|()| ours), theirs.map(|()| faer))
    }

    #[test]
    fn panels_on_two_threads_give_faers_factor() {
        for (n, seed) in [(40, 1), (PANELLED, 2), (PANELLED + PANEL + 7, 3), (900, 4)] {
            let a = spd(n, seed);
            let (ours, faer) = both(&a);
            let (ours, faer) = (ours.expect("ours"), faer.expect("faer"));
            // Sums in another order: equal to rounding.
            let (mut worst, mut scale) = (0.0f64, 0.0f64);
            for j in 0..n {
                for i in j..n {
                    worst = worst.max((ours[(i, j)] - faer[(i, j)]).abs());
                    scale = scale.max(faer[(i, j)].abs());
                }
            }
            assert!(worst <= 1e-12 * scale, "{n}: {worst:e} of {scale}");
            // And L L^T is A, entry by entry on and below the diagonal.
            let l = Mat::<f64>::from_fn(n, n, |i, j| if i >= j { ours[(i, j)] } else { 0.0 });
            let back = &l * l.transpose();
            for j in (0..n).step_by(7) {
                for i in j..n {
                    assert!(
                        (back[(i, j)] - a[(i, j)]).abs() < 1e-10 * a[(j, j)],
                        "{n}: {i}, {j}"
                    );
                }
            }
        }
    }

    #[test]
    fn a_pivot_that_is_not_positive_is_named_as_faer_names_it() {
        let n = 700;
        for column in [0, 95, 96, 333, 699] {
            let mut a = spd(n, 9);
            // Less the square of that column's pivot and a little more: the
            // columns before it factor as before, and its pivot is -0.5.
            let (first, _) = both(&a);
            let pivot = first.expect("positive definite")[(column, column)];
            a[(column, column)] -= pivot * pivot + 0.5;
            let (ours, faer) = both(&a);
            assert_eq!(ours.err(), Some(column));
            assert_eq!(faer.err(), Some(column));
        }
    }
}
