//! The supernodal factor's structure: A's pattern in a fill-reducing
//! numbering, its elimination tree, the column counts of L, and faer's
//! supernodes made from them.
//!
//! faer's own analysis (`factorize_symbolic_cholesky`) permutes A's
//! pattern, then counts L's columns by walking every row's subtree of the
//! elimination tree: time in proportion to L's entries, about 1.8 of its
//! 2.8 ms on a 4,000-start scan (a million entries of L from 120,000 of
//! A). Here the permuted pattern is made in one pass with no branch to
//! mispredict, the tree by Liu's algorithm with path compression, and the
//! counts from A's entries alone (Gilbert, Ng and Peyton's row skeletons
//! and least common ancestors, as CSparse's `cs_counts`); faer then makes
//! the supernodes from them (`factorize_supernodal_symbolic_cholesky`,
//! with [`RELAX`]), the structure its own analysis gives.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::SymbolicSparseColMatRef;
use faer::sparse::linalg::cholesky::simplicial::EliminationTreeRef;
use faer::sparse::linalg::cholesky::supernodal::{
    SymbolicSupernodalCholesky, factorize_supernodal_symbolic_cholesky,
    factorize_supernodal_symbolic_cholesky_scratch,
};

use crate::error::FitError;
use crate::ordering::Graph;

/// When two supernodes, a child and its parent, are merged into one: up to
/// `n` columns together, when no more than this share of the merged block
/// would be zeros (faer's and CHOLMOD's default: 4 / 1.0, 16 / 0.8,
/// 48 / 0.1, then 0.05). Looser than the default: a neighbour graph's
/// supernodes are small (23 columns on average on a 4,000-start scan),
/// and a descendant's update is a product and then a scatter of its rows
/// into the ancestor, the scatter as costly as the product when the
/// descendant is narrow. Measured on the scan (interleaved fit loops):
/// 7 % more multiply-adds, the numeric phase 3.5 -> 3.4 ms; on 10,000
/// and 100,000 starts 1-3 % faster.
pub(crate) const RELAX: &[(usize, f64)] = &[(8, 1.0), (32, 0.8), (64, 0.2), (usize::MAX, 0.1)];

/// The lower triangle of A by columns: `col_ptr`, sorted `row_idx` (each
/// column starting with its diagonal) and `values`.
#[cfg(test)]
pub(crate) struct LowerCsc {
    pub(crate) n: usize,
    pub(crate) col_ptr: Vec<u32>,
    pub(crate) row_idx: Vec<u32>,
    pub(crate) values: Vec<f64>,
}

/// A's lower triangle in the factor's numbering, by columns: each
/// column's rows on and below the diagonal (in no particular order) and
/// their values. What each supernode's columns start from.
#[derive(Debug)]
pub(crate) struct Permuted {
    pub(crate) col_ptr: Vec<usize>,
    pub(crate) rows: Vec<u32>,
    pub(crate) values: Vec<f64>,
}

/// Columns one task of [`Permuted::of_graph`] makes.
const PERMUTED_COLUMNS: usize = 512;

impl Permuted {
    /// A made from the starts' neighbour graph and its kernel values
    /// (`phi(old, old)`, `diag` on the diagonal), in the numbering `order`
    /// (`inverse` its inverse). Counted, then made in chunks of columns on
    /// the pool, each new column from its start's neighbours in one pass:
    /// the values straight into the factor's numbering, where permuting
    /// A's columns after took 0.6 ms of the scan's fit, serial.
    pub(crate) fn of_graph(
        graph: &Graph,
        order: &[u32],
        inverse: &[u32],
        phi: &(impl Fn(usize, usize) -> f64 + Sync),
        diag: f64,
    ) -> Permuted {
        use rayon::prelude::*;
        let n = order.len();
        let mut col_ptr = vec![0usize; n + 1];
        for (k, &old) in order.iter().enumerate() {
            let below = graph
                .neighbours(old as usize)
                .iter()
                .map(|&j| usize::from(inverse[j as usize] as usize > k))
                .sum::<usize>();
            col_ptr[k + 1] = col_ptr[k] + 1 + below;
        }
        let entries = col_ptr[n];
        let mut rows = vec![0u32; entries];
        let mut values = vec![0.0; entries];
        // The chunks of columns, each with its own part of rows and values.
        let mut chunks = Vec::with_capacity(n.div_ceil(PERMUTED_COLUMNS));
        let (mut rows_left, mut values_left) = (&mut rows[..], &mut values[..]);
        for first in (0..n).step_by(PERMUTED_COLUMNS) {
            let last = (first + PERMUTED_COLUMNS).min(n);
            let len = col_ptr[last] - col_ptr[first];
            let (r, rest_rows) = rows_left.split_at_mut(len);
            let (v, rest_values) = values_left.split_at_mut(len);
            chunks.push((first, last, r, v));
            rows_left = rest_rows;
            values_left = rest_values;
        }
        chunks
            .into_par_iter()
            .for_each(|(first, last, rows, values)| {
                let base = col_ptr[first];
                for k in first..last {
                    let (start, stop) = (col_ptr[k] - base, col_ptr[k + 1] - base);
                    let old = order[k] as usize;
                    rows[start] = k as u32;
                    values[start] = diag;
                    // Each neighbour written at the cursor, kept when below the
                    // diagonal (no branch to mispredict); the last column's
                    // discarded write past its end is not made.
                    let mut at = start + 1;
                    for &j in graph.neighbours(old) {
                        let i = inverse[j as usize];
                        if at < rows.len() {
                            rows[at] = i;
                        }
                        at += usize::from(i as usize > k);
                    }
                    debug_assert_eq!(at, stop);
                    for at in start + 1..stop {
                        values[at] = phi(order[rows[at] as usize] as usize, old);
                    }
                }
            });
        Permuted {
            col_ptr,
            rows,
            values,
        }
    }

    /// A from its lower triangle in the caller's numbering (`inverse[old]
    /// = new`).
    #[cfg(test)]
    pub(crate) fn new(a: &LowerCsc, inverse: &[u32]) -> Permuted {
        let mut col_ptr = vec![0usize; a.n + 1];
        let entries = || {
            (0..a.n).flat_map(move |j| {
                (a.col_ptr[j] as usize..a.col_ptr[j + 1] as usize).map(move |k| {
                    let (r, c) = (inverse[a.row_idx[k] as usize], inverse[j]);
                    (r.min(c) as usize, r.max(c), a.values[k])
                })
            })
        };
        for (c, _, _) in entries() {
            col_ptr[c + 1] += 1;
        }
        for j in 0..a.n {
            col_ptr[j + 1] += col_ptr[j];
        }
        let mut next = col_ptr.clone();
        let mut rows = vec![0u32; col_ptr[a.n]];
        let mut values = vec![0.0; col_ptr[a.n]];
        for (c, r, v) in entries() {
            rows[next[c]] = r;
            values[next[c]] = v;
            next[c] += 1;
        }
        Permuted {
            col_ptr,
            rows,
            values,
        }
    }
}

/// The structure of a supernodal factor of A in a fill-reducing numbering.
#[derive(Debug)]
pub(crate) struct Structure {
    /// `order[new] = old`.
    order: Vec<u32>,
    /// `inverse[old] = new`.
    inverse: Vec<u32>,
    supernodal: SymbolicSupernodalCholesky<u32>,
}

impl Structure {
    /// The structure of the factor of A, whose pattern is `graph` and the
    /// diagonal, in the numbering `order` (`order[new] = old`, a
    /// permutation of the graph's nodes).
    pub(crate) fn new(graph: &Graph, order: Vec<u32>) -> Result<Structure, FitError> {
        let n = graph.len();
        if order.len() != n {
            return Err(FitError::Solver(format!(
                "an order of {} rows for a system of {n}",
                order.len(),
            )));
        }
        let mut seen = vec![false; n];
        for (at, &old) in order.iter().enumerate() {
            if (old as usize) >= n || std::mem::replace(&mut seen[old as usize], true) {
                return Err(FitError::Solver(format!(
                    "an order that is not a permutation of 0..{n}: {old} at {at}"
                )));
            }
        }
        let inverse = crate::ordering::inverse(&order);
        let patterns = Patterns::new(graph, &order, &inverse);
        let parent = elimination_tree(&patterns);
        let counts = column_counts(&patterns, &parent);
        let upper = SymbolicSparseColMatRef::new_unsorted_checked(
            n,
            n,
            &patterns.upper_ptr[..],
            None,
            &patterns.upper_rows[..],
        );
        // Every parent is a later column or none: what faer's own tree
        // guarantees, and what its supernodal pass indexes by.
        let valid = parent
            .iter()
            .enumerate()
            .all(|(j, &p)| p == NONE || (p as usize > j && (p as usize) < n));
        assert!(valid, "an elimination tree's parent follows its child");
        // SAFETY: faer documents the tree as one its
        // `prefactorize_symbolic_cholesky` made; what its supernodal pass
        // relies on unchecked is that every parent is -1 or an index below
        // n, with no cycle: every entry here is -1 or in `j + 1..n`
        // (checked above). And it is the same tree: `parent` is the
        // elimination tree of `upper`, which the tests check equals faer's.
        #[allow(unsafe_code)]
        let etree = unsafe { EliminationTreeRef::<u32>::from_inner(&parent) };
        let mut mem = MemBuffer::try_new(factorize_supernodal_symbolic_cholesky_scratch::<u32>(n))
            .map_err(|e| FitError::Solver(format!("{e:?}")))?;
        let supernodal = factorize_supernodal_symbolic_cholesky(
            upper,
            etree,
            &counts,
            MemStack::new(&mut mem),
            faer::sparse::linalg::SymbolicSupernodalParams { relax: Some(RELAX) },
        )
        .map_err(|e| FitError::Solver(format!("{e:?}")))?;
        Ok(Structure {
            order,
            inverse,
            supernodal,
        })
    }

    /// The structure in faer's approximate minimum degree order.
    pub(crate) fn amd(graph: &Graph) -> Result<Structure, FitError> {
        Structure::new(graph, amd_order(graph)?)
    }

    /// faer's supernodes, in the numbering [`Structure::order`].
    pub(crate) fn supernodal(&self) -> &SymbolicSupernodalCholesky<u32> {
        &self.supernodal
    }

    /// `order[new] = old`.
    pub(crate) fn order(&self) -> &[u32] {
        &self.order
    }

    /// `inverse[old] = new`.
    pub(crate) fn inverse(&self) -> &[u32] {
        &self.inverse
    }

    /// Values of L (faer's supernodal layout).
    pub(crate) fn len_val(&self) -> usize {
        self.supernodal.len_val()
    }
}

/// faer's approximate minimum degree order of the graph.
pub(crate) fn amd_order(graph: &Graph) -> Result<Vec<u32>, FitError> {
    use faer::sparse::linalg::amd;
    let n = graph.len();
    let mut col_ptr = Vec::with_capacity(n + 1);
    let mut row_idx = Vec::with_capacity(graph.edge_entries());
    col_ptr.push(0u32);
    for j in 0..n {
        row_idx.extend_from_slice(graph.neighbours(j));
        col_ptr.push(row_idx.len() as u32);
    }
    let pattern =
        SymbolicSparseColMatRef::new_unsorted_checked(n, n, &col_ptr[..], None, &row_idx[..]);
    let (mut order, mut inverse) = (vec![0u32; n], vec![0u32; n]);
    let mut mem = MemBuffer::try_new(amd::order_maybe_unsorted_scratch::<u32>(n, row_idx.len()))
        .map_err(|e| FitError::Solver(format!("{e:?}")))?;
    amd::order_maybe_unsorted(
        &mut order,
        &mut inverse,
        pattern,
        Default::default(),
        MemStack::new(&mut mem),
    )
    .map_err(|e| FitError::Solver(format!("{e:?}")))?;
    Ok(order)
}

/// A's pattern in the new numbering, by columns: each column's rows above
/// the diagonal and the diagonal (`upper`: what faer's supernodal pass and
/// the elimination tree read) and its rows below the diagonal (`lower`:
/// what the column counts read). Rows are in no particular order.
struct Patterns {
    upper_ptr: Vec<u32>,
    upper_rows: Vec<u32>,
    lower_ptr: Vec<u32>,
    lower_rows: Vec<u32>,
}

impl Patterns {
    /// From the neighbours of each node (old numbering) and the order:
    /// new column `k` reads node `order[k]`'s neighbours once, each one
    /// written to both sides and counted on the side of the diagonal it
    /// falls (no branch to mispredict on a coin toss).
    fn new(graph: &Graph, order: &[u32], inverse: &[u32]) -> Patterns {
        let n = order.len();
        let entries = graph.edge_entries();
        // Room for every entry on either side (and one more to write the
        // entry not counted), whatever the graph's symmetry.
        let mut upper_rows = vec![0u32; entries + n + 1];
        let mut lower_rows = vec![0u32; entries + 1];
        let mut upper_ptr = Vec::with_capacity(n + 1);
        let mut lower_ptr = Vec::with_capacity(n + 1);
        upper_ptr.push(0u32);
        lower_ptr.push(0u32);
        let (mut up, mut down) = (0usize, 0usize);
        for (k, &old) in order.iter().enumerate() {
            let k = k as u32;
            for &j in graph.neighbours(old as usize) {
                let i = inverse[j as usize];
                upper_rows[up] = i;
                lower_rows[down] = i;
                // A self loop (none in a neighbour graph) on neither side.
                up += usize::from(i < k);
                down += usize::from(i > k);
            }
            upper_rows[up] = k;
            up += 1;
            upper_ptr.push(up as u32);
            lower_ptr.push(down as u32);
        }
        upper_rows.truncate(up);
        lower_rows.truncate(down);
        Patterns {
            upper_ptr,
            upper_rows,
            lower_ptr,
            lower_rows,
        }
    }

    fn above(&self, k: usize) -> &[u32] {
        &self.upper_rows[self.upper_ptr[k] as usize..self.upper_ptr[k + 1] as usize]
    }

    fn below(&self, j: usize) -> &[u32] {
        &self.lower_rows[self.lower_ptr[j] as usize..self.lower_ptr[j + 1] as usize]
    }

    fn len(&self) -> usize {
        self.upper_ptr.len() - 1
    }
}

/// No parent: a root of the elimination tree (faer's convention).
const NONE: i32 = -1;

/// The elimination tree of the pattern: `parent[k]` (a later column) or
/// [`NONE`] for a root. Liu's algorithm: each entry above the diagonal
/// joins its row's tree, whose root is found with path compression.
fn elimination_tree(p: &Patterns) -> Vec<i32> {
    let n = p.len();
    let mut parent = vec![NONE; n];
    let mut ancestor = vec![NONE; n];
    for k in 0..n {
        for &i in p.above(k) {
            let mut i = i as i32;
            while i != NONE && (i as usize) < k {
                let next = ancestor[i as usize];
                ancestor[i as usize] = k as i32;
                if next == NONE {
                    parent[i as usize] = k as i32;
                }
                i = next;
            }
        }
    }
    parent
}

/// A postorder of the forest `parent`: each subtree's nodes together, a
/// node after its children.
fn postorder(parent: &[i32]) -> Vec<u32> {
    let n = parent.len();
    // Children lists, kept in ascending order.
    let mut head = vec![NONE; n];
    let mut next = vec![NONE; n];
    for j in (0..n).rev() {
        if parent[j] != NONE {
            let p = parent[j] as usize;
            next[j] = head[p];
            head[p] = j as i32;
        }
    }
    let mut post = Vec::with_capacity(n);
    let mut stack: Vec<u32> = Vec::new();
    for root in (0..n).filter(|&j| parent[j] == NONE) {
        stack.push(root as u32);
        while let Some(&top) = stack.last() {
            let child = head[top as usize];
            if child == NONE {
                stack.pop();
                post.push(top);
            } else {
                head[top as usize] = next[child as usize];
                stack.push(child as u32);
            }
        }
    }
    post
}

/// The entries of each column of L, its diagonal included, from A's
/// entries alone: row `i`'s subtree of the elimination tree has a leaf at
/// each column `j` whose A(i, j) is the first of `i` met in `j`'s subtree
/// (the skeleton); each leaf adds one, each least common ancestor of two
/// leaves of the same row takes one away.
fn column_counts(p: &Patterns, parent: &[i32]) -> Vec<u32> {
    let n = p.len();
    let post = postorder(parent);
    let mut first = vec![NONE; n];
    let mut delta = vec![0i64; n];
    for (k, &j) in post.iter().enumerate() {
        let mut j = j as i32;
        delta[j as usize] = i64::from(first[j as usize] == NONE);
        while j != NONE && first[j as usize] == NONE {
            first[j as usize] = k as i32;
            j = parent[j as usize];
        }
    }
    let mut max_first = vec![NONE; n];
    let mut prev_leaf = vec![NONE; n];
    let mut ancestor: Vec<i32> = (0..n as i32).collect();
    for &j in &post {
        let j = j as usize;
        if parent[j] != NONE {
            delta[parent[j] as usize] -= 1;
        }
        for &i in p.below(j) {
            let i = i as usize;
            // Is j a leaf of row i's subtree?
            if first[j] <= max_first[i] {
                continue;
            }
            max_first[i] = first[j];
            let previous = prev_leaf[i];
            prev_leaf[i] = j as i32;
            delta[j] += 1;
            if previous != NONE {
                // The least common ancestor of this leaf and the last.
                let mut q = previous;
                while q != ancestor[q as usize] {
                    q = ancestor[q as usize];
                }
                let mut s = previous;
                while s != q {
                    let up = ancestor[s as usize];
                    ancestor[s as usize] = q;
                    s = up;
                }
                delta[q as usize] -= 1;
            }
        }
        if parent[j] != NONE {
            ancestor[j] = parent[j];
        }
    }
    // A parent comes after its children: sum each subtree's deltas upwards.
    for j in 0..n {
        if parent[j] != NONE {
            delta[parent[j] as usize] += delta[j];
        }
    }
    delta.into_iter().map(|d| d as u32).collect()
}

#[cfg(test)]
mod tests {
    use faer::Side;
    use faer::dyn_stack::{MemBuffer, MemStack};
    use faer::perm::PermRef;
    use faer::sparse::SymbolicSparseColMatRef;
    use faer::sparse::linalg::SupernodalThreshold;
    use faer::sparse::linalg::cholesky::{
        CholeskySymbolicParams, SymbolicCholeskyRaw, SymmetricOrdering,
        factorize_symbolic_cholesky, simplicial,
    };

    use super::*;
    use crate::ordering::{geometric_dissection, inverse, reverse_cuthill_mckee};
    use crate::solver::tests::random_system;

    /// The numberings each system is analysed in: the caller's, a band
    /// ordering and a dissection.
    fn orders(n: usize, radius: f64, seed: u64) -> (Graph, LowerCsc, Vec<Vec<u32>>) {
        let (s, g, a) = random_system(n, radius, seed);
        let identity: Vec<u32> = (0..n as u32).collect();
        let orders = vec![
            identity,
            reverse_cuthill_mckee(&g),
            geometric_dissection(&g, &s, radius),
        ];
        (g, a, orders)
    }

    /// The elimination tree and column counts are faer's own (which walks
    /// every row's subtree), for random systems under three numberings.
    #[test]
    fn the_tree_and_counts_are_faers() {
        for (n, radius, seed) in [(1, 0.1, 1), (2, 0.9, 1), (300, 0.25, 1), (2000, 0.1, 2)] {
            let (g, _, orders) = orders(n, radius, seed);
            for order in orders {
                let p = Patterns::new(&g, &order, &inverse(&order));
                let parent = elimination_tree(&p);
                let counts = column_counts(&p, &parent);
                let pattern = SymbolicSparseColMatRef::new_unsorted_checked(
                    n,
                    n,
                    &p.upper_ptr[..],
                    None,
                    &p.upper_rows[..],
                );
                let mut etree = vec![0i32; n];
                let mut want = vec![0u32; n];
                let mut mem = MemBuffer::new(simplicial::prefactorize_symbolic_cholesky_scratch::<
                    u32,
                >(n, p.upper_rows.len()));
                simplicial::prefactorize_symbolic_cholesky(
                    &mut etree,
                    &mut want,
                    pattern,
                    MemStack::new(&mut mem),
                );
                assert_eq!(parent, etree, "n {n}: the elimination tree");
                assert_eq!(counts, want, "n {n}: the column counts");
            }
        }
    }

    /// The permuted pattern holds each of A's entries once, on the side
    /// of the diagonal each half reads, and every diagonal.
    #[test]
    fn the_permuted_pattern_is_a_s() {
        let (g, a, orders) = orders(400, 0.2, 5);
        for order in orders {
            let inv = inverse(&order);
            let p = Patterns::new(&g, &order, &inv);
            let mut want: Vec<(u32, u32)> = Vec::new();
            for c in 0..a.n {
                for &r in &a.row_idx[a.col_ptr[c] as usize..a.col_ptr[c + 1] as usize] {
                    let (i, j) = (inv[r as usize], inv[c]);
                    want.push((i.min(j), i.max(j)));
                }
            }
            want.sort_unstable();
            let mut upper: Vec<(u32, u32)> = (0..a.n)
                .flat_map(|k| p.above(k).iter().map(move |&i| (i, k as u32)))
                .collect();
            upper.sort_unstable();
            assert_eq!(upper, want, "upper rows and diagonals");
            let mut lower: Vec<(u32, u32)> = (0..a.n)
                .flat_map(|j| p.below(j).iter().map(move |&i| (j as u32, i)))
                .collect();
            lower.sort_unstable();
            want.retain(|&(i, j)| i != j);
            assert_eq!(lower, want, "lower rows");
        }
    }

    /// The supernodes are the ones faer's whole analysis makes in the same
    /// numbering: the same columns, rows and layout of values.
    #[test]
    fn the_supernodes_are_faers() {
        for (n, radius, seed) in [(1, 0.1, 3), (60, 0.4, 3), (700, 0.2, 4), (3000, 0.08, 6)] {
            let (g, a, orders) = orders(n, radius, seed);
            for order in orders {
                let ours = Structure::new(&g, order.clone()).unwrap();
                let inv = inverse(&order);
                let pattern =
                    SymbolicSparseColMatRef::new_checked(n, n, &a.col_ptr, None, &a.row_idx);
                let params = CholeskySymbolicParams {
                    supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
                    supernodal_params: faer::sparse::linalg::SymbolicSupernodalParams {
                        relax: Some(RELAX),
                    },
                    ..Default::default()
                };
                let theirs = factorize_symbolic_cholesky(
                    pattern,
                    Side::Lower,
                    SymmetricOrdering::Custom(PermRef::new_checked(&order, &inv, n)),
                    params,
                )
                .unwrap();
                let SymbolicCholeskyRaw::Supernodal(t) = theirs.raw() else {
                    unreachable!("forced supernodal")
                };
                let s = ours.supernodal();
                assert_eq!(s.n_supernodes(), t.n_supernodes(), "n {n}");
                assert_eq!(s.supernode_begin(), t.supernode_begin(), "n {n}");
                assert_eq!(s.supernode_end(), t.supernode_end(), "n {n}");
                assert_eq!(s.col_ptr_for_row_idx(), t.col_ptr_for_row_idx(), "n {n}");
                assert_eq!(s.col_ptr_for_val(), t.col_ptr_for_val(), "n {n}");
                assert_eq!(s.row_idx(), t.row_idx(), "n {n}");
                assert_eq!(ours.order(), &order[..]);
                assert_eq!(ours.inverse(), &inv[..]);
            }
        }
    }

    /// A made from the graph in chunks of columns on the pool holds, column
    /// by column, the entries and values of A's lower triangle permuted.
    #[test]
    fn a_made_from_the_graph_is_a_permuted() {
        use crate::kernel::Kernel;
        for (n, radius, seed) in [(1, 0.1, 1), (90, 0.3, 2), (2000, 0.1, 3)] {
            let (s, g, a) = random_system(n, radius, seed);
            let phi = |i: usize, j: usize| Kernel::C2.eval(s[i].distance(s[j]) / radius);
            let (_, _, orders) = orders(n, radius, seed);
            for order in orders {
                let inv = inverse(&order);
                let ours = Permuted::of_graph(&g, &order, &inv, &phi, Kernel::C2.eval(0.0));
                let want = Permuted::new(&a, &inv);
                assert_eq!(ours.col_ptr, want.col_ptr, "n {n}");
                let column = |p: &Permuted, k: usize| {
                    let mut c: Vec<(u32, u64)> = (p.col_ptr[k]..p.col_ptr[k + 1])
                        .map(|e| (p.rows[e], p.values[e].to_bits()))
                        .collect();
                    c.sort_unstable();
                    c
                };
                for k in 0..n {
                    assert_eq!(column(&ours, k), column(&want, k), "n {n} column {k}");
                }
            }
        }
    }

    #[test]
    fn an_order_not_a_permutation_is_refused() {
        let (g, _, _) = orders(10, 0.5, 1);
        let err = Structure::new(&g, vec![0, 1, 2]).unwrap_err();
        assert!(
            format!("{err}").contains("3 rows for a system of 10"),
            "{err}"
        );
        for (order, says) in [
            (vec![0, 1, 2, 3, 4, 5, 6, 7, 8, 8], "8 at 9"),
            (vec![0, 1, 2, 3, 4, 5, 6, 7, 8, 10], "10 at 9"),
        ] {
            let err = Structure::new(&g, order).unwrap_err();
            assert!(format!("{err}").contains(says), "{err}");
        }
    }
}
