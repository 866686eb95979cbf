//! The numeric supernodal Cholesky factorisation on both cores.
//!
//! faer's own numeric factorisation goes supernode by supernode on one
//! thread (its parallel mode splits each dense block and was slower on two
//! cores at every size measured). Its structure says more: the subtrees of
//! the elimination tree under different children of a supernode change
//! only their own columns and read only their own descendants, so they are
//! made at once. The tree is walked on the pool ([`Walk`]): down each
//! subtree's heavy path, the heavy children of a fork as parallel tasks
//! (whichever thread is free takes the next), light subtrees in one go;
//! a wide supernode (the top separators, dense and wide) runs its dense
//! kernels on the pool too.
//!
//! Each supernode is made as faer makes it (left-looking): its columns of
//! A, less the products of every descendant's rows that reach it, then a
//! dense Cholesky of its diagonal block ([`crate::dense`]) and a
//! triangular solve for the rows below. The values land in faer's layout,
//! so faer's symbolic structure and this crate's solves read them
//! unchanged. They are the same on any number of threads to rounding (a
//! block wide enough to be factored in panels sums in another order), and
//! the same bits on the same number.

use faer::dyn_stack::MemBuffer;
use faer::linalg::cholesky::llt::factor::cholesky_in_place_scratch;
use faer::linalg::matmul::triangular::{self, BlockStructure};
use faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky;
use faer::{Accum, MatMut, MatRef, Par};

use std::mem::MaybeUninit;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Mutex, OnceLock, PoisonError};

use crate::symbolic::Permuted;
use crate::triangular::{Tree, of_column};

/// A supernode's columns at least this wide run their updates in two
/// halves and the triangular solve under them on the pool, and their
/// dense Cholesky in panels on it from [`crate::dense`]'s width on (the top
/// separators of a large system).
const WIDE: usize = 192;

/// For each supernode, the earlier supernodes whose rows reach its
/// columns: `(descendant, first, count)`, the descendant's pattern rows
/// `first..first + count` being in the supernode's columns.
struct Updates {
    ptr: Vec<usize>,
    entries: Vec<(u32, u32, u32)>,
    /// Each supernode's multiply-adds: its descendants' products and its
    /// own dense Cholesky and triangular solve.
    work: Vec<f64>,
}

impl Updates {
    fn new(symbolic: &SymbolicSupernodalCholesky<u32>, of_column: &[u32]) -> Updates {
        let count = symbolic.n_supernodes();
        let (begin, end) = (symbolic.supernode_begin(), symbolic.supernode_end());
        let mut lists: Vec<(u32, u32, u32, u32)> = Vec::new();
        let mut work: Vec<f64> = (0..count)
            .map(|k| {
                let width = (end[k] - begin[k]) as f64;
                let below = symbolic.supernode(k).pattern().len() as f64;
                width * width * width / 6.0 + width * width * below * 0.5
            })
            .collect();
        for d in 0..count {
            let pattern = symbolic.supernode(d).pattern();
            let d_width = (end[d] - begin[d]) as f64;
            let mut i = 0;
            while i < pattern.len() {
                let s = of_column[pattern[i] as usize];
                let stop = end[s as usize];
                let mut j = i + 1;
                while j < pattern.len() && pattern[j] < stop {
                    j += 1;
                }
                // The product's square (its lower half) and the rows below.
                let (take, below) = ((j - i) as f64, (pattern.len() - i) as f64);
                work[s as usize] += d_width * take * ((take + 1.0) * 0.5 + below - take);
                lists.push((s, d as u32, i as u32, (j - i) as u32));
                i = j;
            }
        }
        // Stable by supernode: descendants stay ascending.
        lists.sort_by_key(|e| e.0);
        let mut ptr = vec![0usize; count + 1];
        for e in &lists {
            ptr[e.0 as usize + 1] += 1;
        }
        for k in 0..count {
            ptr[k + 1] += ptr[k];
        }
        Updates {
            ptr,
            entries: lists.into_iter().map(|(_, d, i, c)| (d, i, c)).collect(),
            work,
        }
    }

    fn of(&self, s: usize) -> &[(u32, u32, u32)] {
        &self.entries[self.ptr[s]..self.ptr[s + 1]]
    }
}

/// What a thread needs to make supernodes: the row of each column within
/// the supernode being made, the product buffer, dense scratch.
struct Work {
    local: Vec<u32>,
    product: Vec<f64>,
    stack: MemBuffer,
}

impl Work {
    fn new(n: usize, widest: usize) -> Work {
        Work {
            local: vec![u32::MAX; n],
            product: Vec::new(),
            stack: MemBuffer::new(cholesky_in_place_scratch::<f64>(
                widest.max(1),
                Par::rayon(0),
                Default::default(),
            )),
        }
    }
}

/// Factorisations of fewer multiply-adds stay on one thread: below about
/// a millisecond of work, a second thread's wake-up and the tree walk cost
/// more than they save.
const PARALLEL_WORK: f64 = 2e7;

/// A subtree of less work is made by the thread that reaches it, in one
/// go: the tree is walked in parallel only down to parts of about this
/// share of the whole (and of [`LIGHT_WORK`] multiply-adds at least).
const LIGHT_SHARE: f64 = 1.0 / 64.0;

/// See [`LIGHT_SHARE`].
const LIGHT_WORK: f64 = 2e6;

/// A block of values not yet written, zeroed.
fn zeroed(block: &mut [MaybeUninit<f64>]) -> &mut [f64] {
    block.fill(MaybeUninit::new(0.0));
    // SAFETY: every element was just written, and `MaybeUninit<f64>` has
    // the layout of `f64`.
    #[allow(unsafe_code)]
    unsafe {
        &mut *(std::ptr::from_mut::<[MaybeUninit<f64>]>(block) as *mut [f64])
    }
}

/// Each supernode's block of values: to be made (taken once, by the
/// thread that makes it), then made (read by its ancestors' updates).
struct Blocks<'a> {
    todo: Vec<Mutex<Option<&'a mut [MaybeUninit<f64>]>>>,
    made: Vec<OnceLock<&'a [f64]>>,
}

impl<'a> Blocks<'a> {
    fn take(&self, k: usize) -> Option<&'a mut [MaybeUninit<f64>]> {
        self.todo[k]
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .take()
    }

    fn made(&self, k: usize) -> Option<&'a [f64]> {
        self.made[k].get().copied()
    }
}

/// Scratch for the threads: taken by a walk, given back after.
struct Pool {
    spare: Mutex<Vec<Work>>,
    n: usize,
    widest: usize,
}

impl Pool {
    fn take(&self) -> Work {
        let spare = self
            .spare
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .pop();
        spare.unwrap_or_else(|| Work::new(self.n, self.widest))
    }

    fn give(&self, work: Work) {
        self.spare
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .push(work);
    }
}

/// The smaller column of two failed pivots, if any.
fn first_failure(a: Option<usize>, b: Option<usize>) -> Option<usize> {
    match (a, b) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    }
}

/// The shared, read-only parts of a factorisation.
struct Plan<'a> {
    symbolic: &'a SymbolicSupernodalCholesky<u32>,
    a: &'a Permuted,
    updates: Updates,
}

/// Factors A (`a`, its lower triangle in the factor's numbering) into
/// values in faer's layout for `symbolic`. The values are not zeroed
/// before: each supernode's block is, by the thread that makes it (a
/// memset of the whole factor, serial, took 0.4-0.7 ms of the scan's 6 ms,
/// when the allocator handed back used memory). A large
/// factor is made on the pool: its elimination tree's independent
/// subtrees at once, taken by whichever thread is free, and a wide
/// supernode's dense kernels on both threads. Fails with the column
/// (factor numbering) of the first pivot that is not positive: the one a
/// serial factorisation stops at, on any number of threads (a pivot within
/// rounding of zero aside: a block of [`crate::dense`]'s panels sums in
/// another order).
pub(crate) fn factor(
    symbolic: &SymbolicSupernodalCholesky<u32>,
    a: &Permuted,
) -> Result<Vec<f64>, usize> {
    factor_from(symbolic, a, PARALLEL_WORK, LIGHT_WORK).map(|(values, _)| values)
}

/// [`factor`], on the pool from `parallel_work` multiply-adds on, walking
/// down to subtrees of `light_work` at least; and the forks of the walk.
fn factor_from(
    symbolic: &SymbolicSupernodalCholesky<u32>,
    a: &Permuted,
    parallel_work: f64,
    light_work: f64,
) -> Result<(Vec<f64>, usize), usize> {
    let mut values = Box::<[f64]>::new_uninit_slice(symbolic.len_val());
    let forks = factor_into(symbolic, a, &mut values, parallel_work, light_work)?;
    // SAFETY: `factor_into` succeeded, so it made every supernode (it
    // checks), and each one's first step writes its whole block; the
    // blocks tile the values (checked there too).
    #[allow(unsafe_code)]
    let values = unsafe { values.assume_init() };
    Ok((values.into_vec(), forks))
}

/// [`factor_from`] into `values`: every value written when it succeeds.
fn factor_into(
    symbolic: &SymbolicSupernodalCholesky<u32>,
    a: &Permuted,
    values: &mut [MaybeUninit<f64>],
    parallel_work: f64,
    light_work: f64,
) -> Result<usize, usize> {
    let count = symbolic.n_supernodes();
    let (begin, end) = (symbolic.supernode_begin(), symbolic.supernode_end());
    let of_column = of_column(symbolic);
    let plan = Plan {
        symbolic,
        a,
        updates: Updates::new(symbolic, &of_column),
    };
    let ptr = symbolic.col_ptr_for_val();
    let mut todo = Vec::with_capacity(count);
    let mut rest = values;
    for k in 0..count {
        let (block, tail) = rest.split_at_mut((ptr[k + 1] - ptr[k]) as usize);
        todo.push(Mutex::new(Some(block)));
        rest = tail;
    }
    assert!(rest.is_empty(), "the supernodes' blocks tile the values");
    let blocks = Blocks {
        todo,
        made: (0..count).map(|_| OnceLock::new()).collect(),
    };
    let widest = (0..count)
        .map(|k| (end[k] - begin[k]) as usize)
        .max()
        .unwrap_or(0);
    let pool = Pool {
        spare: Mutex::new(Vec::new()),
        n: symbolic.nrows(),
        widest,
    };
    let tree = Tree::new(symbolic, &of_column, &plan.updates.work);
    let total: f64 = tree.roots.iter().map(|&r| tree.subtree[r as usize]).sum();
    let all_made = |blocks: &Blocks<'_>| (0..count).all(|k| blocks.made(k).is_some());
    if total < parallel_work || rayon::current_num_threads() < 2 {
        let mut work = pool.take();
        (0..count).try_for_each(|k| plan.make(k, &blocks, &mut work, Par::Seq))?;
        assert!(all_made(&blocks), "every supernode made");
        return Ok(0);
    }
    let walk = Walk {
        plan: &plan,
        tree: &tree,
        blocks: &blocks,
        pool: &pool,
        light: (total * LIGHT_SHARE).max(light_work),
        forks: AtomicUsize::new(0),
    };
    match walk.all(&tree.roots) {
        Some(column) => Err(column),
        None => {
            assert!(all_made(&blocks), "every supernode made");
            Ok(walk.forks.into_inner())
        }
    }
}

/// A parallel walk of the elimination tree.
struct Walk<'a> {
    plan: &'a Plan<'a>,
    tree: &'a Tree,
    blocks: &'a Blocks<'a>,
    pool: &'a Pool,
    /// Subtrees of less work are made in one go.
    light: f64,
    /// Forks taken (for the tests).
    forks: AtomicUsize,
}

impl Walk<'_> {
    /// Makes the subtrees of `roots`, on the pool (light ones together, in
    /// one go: a forest of many small trees is not a task a tree); the
    /// first failed pivot.
    fn all(&self, roots: &[u32]) -> Option<usize> {
        match roots {
            [] => None,
            [one] => self.subtree(*one),
            _ if roots
                .iter()
                .map(|&r| self.tree.subtree[r as usize])
                .sum::<f64>()
                < self.light =>
            {
                let mut work = self.pool.take();
                let failed = self.in_one_go(roots, &mut work);
                self.pool.give(work);
                failed
            }
            _ => {
                let (a, b) = roots.split_at(roots.len() / 2);
                let (a, b) = rayon::join(|| self.all(a), || self.all(b));
                first_failure(a, b)
            }
        }
    }

    /// Makes the subtrees of `roots` on this thread, each in ascending
    /// order (children first); the first failed pivot of any.
    fn in_one_go(&self, roots: &[u32], work: &mut Work) -> Option<usize> {
        let mut nodes = Vec::new();
        roots.iter().fold(None, |failed, &root| {
            self.tree.ascending(root, &mut nodes);
            let made = nodes
                .iter()
                .try_for_each(|&k| self.plan.make(k as usize, self.blocks, work, Par::Seq));
            first_failure(failed, made.err())
        })
    }

    /// Makes `root`'s subtree: down its path of heavy children (its light
    /// ones made on the way), the heavy children of a fork at once, then
    /// the path back up. A supernode above a failed pivot is not made.
    fn subtree(&self, root: u32) -> Option<usize> {
        let (tree, plan) = (self.tree, self.plan);
        let mut work = self.pool.take();
        // The path, each with the first failure among its light children.
        let mut path: Vec<(u32, Option<usize>)> = Vec::new();
        let mut at = root;
        let below = loop {
            let (light, heavy): (Vec<u32>, Vec<u32>) = tree
                .children(at)
                .iter()
                .partition(|&&c| tree.subtree[c as usize] < self.light);
            path.push((at, self.in_one_go(&light, &mut work)));
            match heavy[..] {
                [] => break None,
                [one] => at = one,
                _ => {
                    self.forks.fetch_add(1, Ordering::Relaxed);
                    self.pool.give(work);
                    let failed = self.all(&heavy);
                    work = self.pool.take();
                    break failed;
                }
            }
        };
        // Nothing above a failure is made (every supernode above is an
        // ancestor of it), but the light children's failures higher up are
        // still gathered: one of them may lie in an earlier column.
        let mut failed = below;
        for &(k, light) in path.iter().rev() {
            failed = first_failure(failed, light);
            if failed.is_some() {
                continue;
            }
            let par = if plan.width(k as usize) >= WIDE {
                Par::rayon(0)
            } else {
                Par::Seq
            };
            failed = plan.make(k as usize, self.blocks, &mut work, par).err();
        }
        self.pool.give(work);
        failed
    }
}

impl Plan<'_> {
    /// Subtracts from `out` (the columns `columns.0..columns.1` of a
    /// supernode of `rows` rows, column-major, its first column at
    /// `columns.0`) every descendant's product that reaches them;
    /// `local[row]` is a row's place in the supernode.
    #[allow(clippy::too_many_arguments)]
    fn update(
        &self,
        descendants: &[(u32, u32, u32)],
        blocks: &Blocks<'_>,
        local: &[u32],
        columns: (usize, usize),
        rows: usize,
        out: &mut [f64],
        product: &mut Vec<f64>,
    ) {
        let symbolic = self.symbolic;
        let (begin, end) = (symbolic.supernode_begin(), symbolic.supernode_end());
        // (first row, first place, length) of each run of a descendant's rows.
        let mut runs: Vec<(usize, u32, u32)> = Vec::new();
        for &(d, first, count) in descendants {
            let d = d as usize;
            let Some(ld) = blocks.made(d) else {
                continue; // cannot happen: a descendant is made first
            };
            let d_width = (end[d] - begin[d]) as usize;
            let d_pattern = symbolic.supernode(d).pattern();
            let d_rows = d_width + d_pattern.len();
            let (first, count) = (first as usize, count as usize);
            // Of its rows in the supernode's columns, those in `columns`.
            let mine = &d_pattern[first..first + count];
            let skip = mine.partition_point(|&c| (c as usize) < columns.0);
            let take = mine.partition_point(|&c| (c as usize) < columns.1) - skip;
            if take == 0 {
                continue;
            }
            let first = first + skip;
            let below = d_pattern.len() - first;
            let lower = MatRef::from_column_major_slice_with_stride(
                &ld[d_width + first..],
                below,
                d_width,
                d_rows,
            );
            let upper = lower.subrows(0, take);
            // Grown, never cleared: every value the scatter reads is written
            // first (a cleared buffer was a memset a descendant).
            if product.len() < below * take {
                product.resize(below * take, 0.0);
            }
            let mut p =
                MatMut::from_column_major_slice_mut(&mut product[..below * take], below, take);
            // The square on top only below its diagonal (the scatter reads
            // no more), the rows under it whole.
            let (square, rest) = p.as_mut().split_at_row_mut(take);
            let (lower_top, lower_rest) = lower.split_at_row(take);
            triangular::matmul(
                square,
                BlockStructure::TriangularLower,
                Accum::Replace,
                lower_top,
                BlockStructure::Rectangular,
                upper.transpose(),
                BlockStructure::Rectangular,
                1.0,
                Par::Seq,
            );
            if below > take {
                faer::linalg::matmul::matmul(
                    rest,
                    Accum::Replace,
                    lower_rest,
                    upper.transpose(),
                    1.0,
                    Par::Seq,
                );
            }
            let rows_at = &d_pattern[first..];
            // The rows' places in the supernode, as runs of consecutive
            // places (a descendant's rows mostly are): each column's part of
            // a run is one slice, subtracted in vector lanes.
            runs.clear();
            for (k, &ri) in rows_at.iter().enumerate() {
                let at = local[ri as usize];
                match runs.last_mut() {
                    Some((k0, at0, len)) if *at0 + *len == at && *k0 + *len as usize == k => {
                        *len += 1
                    }
                    _ => runs.push((k, at, 1)),
                }
            }
            for (jj, &cj) in rows_at[..take].iter().enumerate() {
                let col = (cj as usize - columns.0) * rows;
                let p = &product[jj * below..(jj + 1) * below];
                for &(k0, at0, len) in runs.iter() {
                    let end = k0 + len as usize;
                    if end <= jj {
                        continue;
                    }
                    let k = k0.max(jj);
                    let at = col + (at0 as usize + (k - k0));
                    for (o, v) in out[at..at + (end - k)].iter_mut().zip(&p[k..end]) {
                        *o -= v;
                    }
                }
            }
        }
    }

    /// Supernode `k`'s number of columns.
    fn width(&self, k: usize) -> usize {
        (self.symbolic.supernode_end()[k] - self.symbolic.supernode_begin()[k]) as usize
    }

    /// Makes supernode `s`'s columns of L in its block, from A's and its
    /// descendants' (already made, in `blocks`). `par`: the pool for a
    /// wide supernode's dense kernels.
    fn make(&self, s: usize, blocks: &Blocks<'_>, work: &mut Work, par: Par) -> Result<(), usize> {
        let symbolic = self.symbolic;
        let (begin, end) = (symbolic.supernode_begin(), symbolic.supernode_end());
        let (start, stop) = (begin[s] as usize, end[s] as usize);
        let width = stop - start;
        let pattern = symbolic.supernode(s).pattern();
        let rows = width + pattern.len();
        for (i, &r) in pattern.iter().enumerate() {
            work.local[r as usize] = (width + i) as u32;
        }
        for c in start..stop {
            work.local[c] = (c - start) as u32;
        }
        let Some(block) = blocks.take(s) else {
            return Ok(()); // cannot happen: each supernode is made once
        };
        // Zeroed here, not all at once before: a large factor's fresh pages
        // are first touched by the thread that fills them, both at once.
        let block = zeroed(block);
        // A's columns.
        for c in start..stop {
            let col = (c - start) * rows;
            for k in self.a.col_ptr[c]..self.a.col_ptr[c + 1] {
                let r = self.a.rows[k] as usize;
                block[col + work.local[r] as usize] += self.a.values[k];
            }
        }
        // Less each descendant's product: its rows from the first in these
        // columns down, times its rows in these columns. A wide supernode
        // made on the pool (`par`) has its columns cut in two of about
        // equal work, each half updated by its own task.
        let descendants = self.updates.of(s);
        let local = &work.local[..];
        let half = if width >= WIDE && matches!(par, Par::Rayon(_)) {
            crate::dense::half_of_lower(rows, width)
        } else {
            width
        };
        if half < width {
            let (left, right) = block.split_at_mut(half * rows);
            let (mut p0, mut p1) = (std::mem::take(&mut work.product), Vec::new());
            rayon::join(
                || {
                    self.update(
                        descendants,
                        blocks,
                        local,
                        (start, start + half),
                        rows,
                        left,
                        &mut p0,
                    )
                },
                || {
                    self.update(
                        descendants,
                        blocks,
                        local,
                        (start + half, stop),
                        rows,
                        right,
                        &mut p1,
                    )
                },
            );
            work.product = p0;
        } else {
            self.update(
                descendants,
                blocks,
                local,
                (start, stop),
                rows,
                block,
                &mut work.product,
            );
        }
        for &r in pattern {
            work.local[r as usize] = u32::MAX;
        }
        let dense = if width >= WIDE { par } else { Par::Seq };
        let result = {
            let mut ls = MatMut::from_column_major_slice_mut(&mut *block, rows, width);
            let (mut top, bottom) = ls.as_mut().split_at_row_mut(width);
            match crate::dense::cholesky(top.as_mut(), dense, &mut work.stack) {
                Err(index) => Err(start + index),
                Ok(()) => {
                    faer::linalg::triangular_solve::solve_lower_triangular_in_place(
                        top.as_ref(),
                        bottom.transpose_mut(),
                        dense,
                    );
                    Ok(())
                }
            }
        };
        if result.is_ok() {
            // Read from here on by the ancestors' updates.
            let _ = blocks.made[s].set(block);
        }
        result
    }
}

#[cfg(test)]
mod tests {
    use faer::dyn_stack::{MemBuffer, MemStack};
    use faer::sparse::linalg::SupernodalThreshold;
    use faer::sparse::linalg::cholesky::{
        CholeskySymbolicParams, SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering,
        factorize_symbolic_cholesky,
    };
    use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
    use faer::{Par, Side};

    use super::*;
    use crate::ordering::geometric_dissection;
    use crate::solver::Factor;
    use crate::solver::tests::random_system;
    use crate::symbolic::LowerCsc;
    use crate::testing::Rng;
    use glam::DVec3;

    /// A supernodal structure of `a` (forced: faer takes a simplicial one
    /// for most small systems), under a dissection order or faer's AMD,
    /// relaxed as the fit's.
    fn structure(a: &LowerCsc, order: Option<&[u32]>) -> SymbolicCholesky<u32> {
        let pattern = SymbolicSparseColMatRef::new_checked(a.n, a.n, &a.col_ptr, None, &a.row_idx);
        let inverse;
        let ordering = match order {
            Some(o) => {
                inverse = crate::ordering::inverse(o);
                SymmetricOrdering::Custom(faer::perm::PermRef::new_checked(o, &inverse, a.n))
            }
            None => SymmetricOrdering::Amd,
        };
        let params = CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
            supernodal_params: faer::sparse::linalg::SymbolicSupernodalParams {
                relax: Some(crate::symbolic::RELAX),
            },
            ..Default::default()
        };
        factorize_symbolic_cholesky(pattern, Side::Lower, ordering, params).expect("symbolic")
    }

    /// faer's own numeric factorisation: the reference.
    fn faer_values(symbolic: &SymbolicCholesky<u32>, a: &LowerCsc) -> Result<Vec<f64>, usize> {
        let pattern = SymbolicSparseColMatRef::new_checked(a.n, a.n, &a.col_ptr, None, &a.row_idx);
        let matrix = SparseColMatRef::new(pattern, &a.values);
        let mut values = vec![0.0; symbolic.len_val()];
        let mut mem = MemBuffer::new(
            symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()),
        );
        match symbolic.factorize_numeric_llt(
            &mut values,
            matrix,
            Side::Lower,
            Default::default(),
            Par::Seq,
            MemStack::new(&mut mem),
            Default::default(),
        ) {
            Ok(_) => Ok(values),
            Err(faer::linalg::solvers::LltError::NonPositivePivot { index }) => Err(index),
        }
    }

    /// Ours, serial or walking the tree on the pool however small.
    fn ours(
        symbolic: &SymbolicCholesky<u32>,
        a: &LowerCsc,
        parallel: bool,
    ) -> Result<(Vec<f64>, usize), usize> {
        let SymbolicCholeskyRaw::Supernodal(s) = symbolic.raw() else {
            unreachable!("forced supernodal")
        };
        let identity: Vec<u32>;
        let inverse = match symbolic.perm() {
            Some(p) => p.arrays().1,
            None => {
                identity = (0..a.n as u32).collect();
                &identity
            }
        };
        let from = if parallel { 0.0 } else { f64::INFINITY };
        factor_from(s, &Permuted::new(a, inverse), from, 0.0)
    }

    /// The lower triangle of every supernode's diagonal block and all rows
    /// below it (faer leaves the upper triangle as it finds it).
    fn lower_values(symbolic: &SymbolicCholesky<u32>, values: &[f64]) -> Vec<f64> {
        let SymbolicCholeskyRaw::Supernodal(s) = symbolic.raw() else {
            unreachable!()
        };
        let mut out = Vec::new();
        for k in 0..s.n_supernodes() {
            let width = (s.supernode_end()[k] - s.supernode_begin()[k]) as usize;
            let rows = width + s.supernode(k).pattern().len();
            let at = s.col_ptr_for_val()[k] as usize;
            for c in 0..width {
                out.extend_from_slice(&values[at + c * rows + c..at + (c + 1) * rows]);
            }
        }
        out
    }

    /// A x for the symmetric A whose lower triangle is `a`.
    fn times(a: &LowerCsc, x: &[f64]) -> Vec<f64> {
        let mut y = vec![0.0; a.n];
        for j in 0..a.n {
            for k in a.col_ptr[j] as usize..a.col_ptr[j + 1] as usize {
                let (i, v) = (a.row_idx[k] as usize, a.values[k]);
                y[i] += v * x[j];
                if i != j {
                    y[j] += v * x[i];
                }
            }
        }
        y
    }

    #[test]
    fn the_factor_is_faers_and_solves_a_on_one_thread_or_two() {
        let mut forks_seen = false;
        for (n, radius, seed) in [(300, 0.25, 1), (1500, 0.12, 2), (4000, 0.08, 3)] {
            let (s, g, a) = random_system(n, radius, seed);
            let order = geometric_dissection(&g, &s, radius);
            for order in [Some(&order[..]), None] {
                let symbolic = structure(&a, order);
                let reference = lower_values(&symbolic, &faer_values(&symbolic, &a).expect("SPD"));
                let (plain, _) = ours(&symbolic, &a, false).expect("SPD");
                let (two, forks) = ours(&symbolic, &a, true).expect("SPD");
                forks_seen |= forks > 0;
                let scale = reference.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                for (k, (r, (p, t))) in reference
                    .iter()
                    .zip(
                        lower_values(&symbolic, &plain)
                            .iter()
                            .zip(lower_values(&symbolic, &two)),
                    )
                    .enumerate()
                {
                    assert!(
                        (r - p).abs() <= 1e-12 * scale,
                        "n {n} value {k}: {p} vs faer's {r}"
                    );
                    assert!(
                        (p - t).abs() <= 1e-12 * scale,
                        "n {n} value {k}: cut {t} vs {p}"
                    );
                }
                // And it solves A: the residual of a random right-hand side,
                // through the fit's own structure (the same as faer's).
                let structure = Factor::supernodal_symbolic(&g, order).expect("symbolic");
                let SymbolicCholeskyRaw::Supernodal(theirs) = symbolic.raw() else {
                    unreachable!("forced supernodal")
                };
                assert_eq!(
                    structure.supernodal().col_ptr_for_val(),
                    theirs.col_ptr_for_val()
                );
                assert_eq!(structure.supernodal().row_idx(), theirs.row_idx());
                let factor = Factor::Supernodal {
                    symbolic: std::sync::Arc::new(structure),
                    values: plain,
                    split: None,
                };
                let mut rng = Rng::new(seed);
                let b: Vec<f64> = (0..n).map(|_| rng.f64() - 0.5).collect();
                let mut x = b.clone();
                factor.solve_in_place(&mut x);
                let r = times(&a, &x);
                for (i, (ri, bi)) in r.iter().zip(&b).enumerate() {
                    assert!(
                        (ri - bi).abs() < 1e-9,
                        "n {n} row {i}: A x = {ri}, b = {bi}"
                    );
                }
            }
        }
        assert!(forks_seen, "some system's tree was walked on the pool");
    }

    /// A forest (starts in far-apart clusters: one elimination tree each,
    /// many of them light) walked on the pool gives the serial values, and
    /// a pivot that fails in one tree is the one faer finds.
    #[test]
    fn a_forest_of_trees_is_walked_as_one() {
        let mut rng = Rng::new(77);
        for (clusters, each) in [(2, 900), (40, 60), (150, 16)] {
            let s: Vec<DVec3> = (0..clusters * each)
                .map(|i| rng.vec3() * 0.5 + DVec3::X * (3 * (i / each)) as f64)
                .collect();
            let (g, mut a) = crate::solver::tests::system_of(&s, 0.15);
            let order = geometric_dissection(&g, &s, 0.15);
            let symbolic = structure(&a, Some(&order));
            let reference = lower_values(&symbolic, &faer_values(&symbolic, &a).expect("SPD"));
            let (two, _) = ours(&symbolic, &a, true).expect("SPD");
            let scale = reference.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for (k, (r, t)) in reference
                .iter()
                .zip(lower_values(&symbolic, &two))
                .enumerate()
            {
                assert!(
                    (r - t).abs() <= 1e-12 * scale,
                    "{clusters} trees, value {k}"
                );
            }
            // Coupling too strong in the last cluster only.
            let last = ((clusters - 1) * each) as u32;
            for j in 0..a.n {
                for k in a.col_ptr[j] as usize..a.col_ptr[j + 1] as usize {
                    if j as u32 >= last && a.row_idx[k] as usize != j {
                        a.values[k] *= 3.0;
                    }
                }
            }
            let want = faer_values(&symbolic, &a).expect_err("not positive definite");
            let got = ours(&symbolic, &a, true).expect_err("not positive definite");
            assert_eq!(got, want, "{clusters} trees");
        }
    }

    /// Coupling too strong in a few small balls only: pivots fail in
    /// separate subtrees, some in a light child of a supernode above
    /// another failure. The pool reports the earliest column, as the
    /// serial walk and faer do.
    #[test]
    fn the_earliest_of_failures_in_separate_subtrees_is_reported() {
        for seed in 0..24 {
            let (s, g, mut a) = random_system(1500, 0.12, 40 + seed);
            let mut rng = Rng::new(90 + seed);
            let balls: Vec<DVec3> = (0..8).map(|_| rng.vec3()).collect();
            let strong = |p: DVec3| balls.iter().any(|b| b.distance(p) < 0.1);
            for j in 0..a.n {
                for k in a.col_ptr[j] as usize..a.col_ptr[j + 1] as usize {
                    let i = a.row_idx[k] as usize;
                    if i != j && strong(s[i]) && strong(s[j]) {
                        a.values[k] *= 10.0;
                    }
                }
            }
            let order = geometric_dissection(&g, &s, 0.12);
            let symbolic = structure(&a, Some(&order));
            let want = faer_values(&symbolic, &a).expect_err("not positive definite");
            let SymbolicCholeskyRaw::Supernodal(sn) = symbolic.raw() else {
                unreachable!("forced supernodal")
            };
            let a = Permuted::new(&a, symbolic.perm().expect("ordered").arrays().1);
            // Subtrees light from none to most: the walk's paths and light
            // children differ with each. On a pool of two threads whatever
            // the machine (with one, the factorisation is serial).
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(2)
                .build()
                .expect("a pool");
            for light in [0.0, 1e4, 1e5, 1e6, 1e7] {
                let got = pool
                    .install(|| factor_from(sn, &a, 0.0, light))
                    .expect_err("not positive definite");
                assert_eq!(got, want, "seed {seed}, light from {light}");
            }
        }
    }

    #[test]
    fn a_pivot_that_is_not_positive_is_found_where_faer_finds_it() {
        for seed in 0..3 {
            let (s, g, mut a) = random_system(1200, 0.15, 10 + seed);
            // Coupling too strong for a positive definite matrix.
            for (k, v) in a.values.iter_mut().enumerate() {
                if a.row_idx.get(k).is_some() && *v < 1.0 {
                    *v *= 3.0;
                }
            }
            let order = geometric_dissection(&g, &s, 0.15);
            let symbolic = structure(&a, Some(&order));
            let want = faer_values(&symbolic, &a).expect_err("not positive definite");
            for parallel in [false, true] {
                let got = ours(&symbolic, &a, parallel).expect_err("not positive definite");
                assert_eq!(got, want, "seed {seed}, on the pool: {parallel}");
            }
        }
    }
}
