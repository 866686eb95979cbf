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
//!
//! A large factor's elimination tree is cut once ([`Split`]) into two sets
//! of whole subtrees and the supernodes above them, and the two sets are
//! solved at once: at 1m the fill-reducing order's top separators hold a
//! third of L, the two sets a third each. The top's wide supernodes go a
//! panel of [`PANEL`] columns at a time, each panel's rows below it
//! (forward) or its columns' dot products (backward) in two halves at once.

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
/// With a [`Split`] of the factor, its two sets of subtrees are solved at
/// once (on two threads when the pool has them).
pub(crate) fn solve_in_place<T: Rhs>(
    symbolic: &SymbolicSupernodalCholesky<u32>,
    forward: Option<&[u32]>,
    values: &[f64],
    split: Option<&Split>,
    b: &mut [T],
) {
    let n = symbolic.nrows();
    assert_eq!(b.len(), n, "one value per row of the factor");
    let old = |i: usize| forward.map_or(i, |f| f[i] as usize);
    let mut x: Vec<Row> = (0..n).map(|i| row(b[old(i)])).collect();
    let passes = Passes::new(symbolic, values, split);
    match split {
        Some(split) => passes.solve_split(split, &mut x),
        None => passes.solve(&mut x),
    }
    for (i, r) in x.iter().enumerate() {
        set_row(&mut b[old(i)], r);
    }
}

/// The forward half of [`solve_in_place`]: y with L y = b, `b` in the
/// caller's numbering, y in the factor's (`y[i]` for the caller's row
/// `forward[i]`).
pub(crate) fn forward_solve<T: Rhs>(
    symbolic: &SymbolicSupernodalCholesky<u32>,
    forward: &[u32],
    values: &[f64],
    split: Option<&Split>,
    b: &[T],
) -> Vec<T> {
    assert_eq!(b.len(), symbolic.nrows(), "one value per row of the factor");
    let mut x: Vec<Row> = forward.iter().map(|&o| row(b[o as usize])).collect();
    let passes = Passes::new(symbolic, values, split);
    match split {
        Some(split) => passes.forward_split(split, &mut x, &mut Vec::new()),
        None => passes.forward(0..symbolic.n_supernodes(), &mut x, &mut Vec::new()),
    }
    x.iter()
        .map(|r| {
            let mut v = b[0];
            set_row(&mut v, r);
            v
        })
        .collect()
}

/// The backward half of [`solve_in_place`]: x with L^T x = y, `y` in the
/// factor's numbering (as [`forward_solve`] gives it), into `b` in the
/// caller's.
pub(crate) fn backward_solve<T: Rhs>(
    symbolic: &SymbolicSupernodalCholesky<u32>,
    forward: &[u32],
    values: &[f64],
    split: Option<&Split>,
    y: &[T],
    b: &mut [T],
) {
    let n = symbolic.nrows();
    assert!(
        y.len() == n && b.len() == n,
        "one value per row of the factor"
    );
    let mut x: Vec<Row> = y.iter().map(|&v| row(v)).collect();
    let passes = Passes::new(symbolic, values, split);
    match split {
        Some(split) => passes.backward_split(split, &mut x, &mut Vec::new()),
        None => passes.backward((0..symbolic.n_supernodes()).rev(), &mut x, &mut Vec::new()),
    }
    for (r, &o) in x.iter().zip(forward) {
        set_row(&mut b[o as usize], r);
    }
}

/// A value's lanes as a row (the rest zero).
fn row<T: Rhs>(v: T) -> Row {
    assert!(T::LANES <= MAX_LANES, "at most four right-hand sides a row");
    std::array::from_fn(|k| if k < T::LANES { v.lane(k) } else { 0.0 })
}

/// A row's lanes into a value.
fn set_row<T: Rhs>(v: &mut T, r: &Row) {
    for (k, &lane) in r.iter().enumerate().take(T::LANES) {
        v.set_lane(k, lane);
    }
}

/// Values of L below which a factor is solved on one thread: waking a
/// second costs more than half of so small a solve.
const SPLIT_VALUES: usize = 1 << 19;

/// Two sets of subtrees by their roots, each with its work.
type Halves = [(f64, Vec<u32>); 2];

/// Subtrees taken apart at most in search of a cut.
const MAX_CUTS: usize = 64;

/// The most a cut's solve may take, of the serial one's work: less gain
/// is not worth a second thread's start and the copies.
const GAIN: f64 = 0.8;

/// The elimination tree of the supernodes: each one's children (earlier
/// supernodes: a parent holds its child's first row below the diagonal
/// block), the roots, and each subtree's work (the factorisation's
/// multiply-adds, or the solve's values of L).
pub(crate) struct Tree {
    ptr: Vec<usize>,
    children: Vec<u32>,
    pub(crate) roots: Vec<u32>,
    pub(crate) subtree: Vec<f64>,
}

impl Tree {
    /// The tree, each subtree's work the sum of `own` over it.
    pub(crate) fn new(
        symbolic: &SymbolicSupernodalCholesky<u32>,
        of_column: &[u32],
        own: &[f64],
    ) -> Tree {
        let count = symbolic.n_supernodes();
        let parent: Vec<Option<u32>> = (0..count)
            .map(|k| {
                symbolic
                    .supernode(k)
                    .pattern()
                    .first()
                    .map(|&r| of_column[r as usize])
            })
            .collect();
        let mut ptr = vec![0usize; count + 1];
        for p in parent.iter().flatten() {
            ptr[*p as usize + 1] += 1;
        }
        for k in 0..count {
            ptr[k + 1] += ptr[k];
        }
        let mut next = ptr.clone();
        let mut children = vec![0u32; ptr[count]];
        let mut roots = Vec::new();
        let mut subtree = own.to_vec();
        for (k, p) in parent.iter().enumerate() {
            match p {
                Some(p) => {
                    children[next[*p as usize]] = k as u32;
                    next[*p as usize] += 1;
                    subtree[*p as usize] += subtree[k];
                }
                None => roots.push(k as u32),
            }
        }
        Tree {
            ptr,
            children,
            roots,
            subtree,
        }
    }

    pub(crate) fn children(&self, k: u32) -> &[u32] {
        &self.children[self.ptr[k as usize]..self.ptr[k as usize + 1]]
    }

    /// The supernodes of `k`'s subtree, ascending (children first).
    pub(crate) fn ascending(&self, k: u32, out: &mut Vec<u32>) {
        out.clear();
        let mut stack = vec![k];
        while let Some(k) = stack.pop() {
            out.push(k);
            stack.extend_from_slice(self.children(k));
        }
        out.sort_unstable();
    }
}

/// The supernode of each column.
pub(crate) fn of_column(symbolic: &SymbolicSupernodalCholesky<u32>) -> Vec<u32> {
    let (begin, end) = (symbolic.supernode_begin(), symbolic.supernode_end());
    let mut of_column = vec![0u32; symbolic.nrows()];
    for k in 0..symbolic.n_supernodes() {
        of_column[begin[k] as usize..end[k] as usize].fill(k as u32);
    }
    of_column
}

/// The supernodes cut in two for a solve on two threads: two sets of whole
/// subtrees of the elimination tree, about equal in values of L, and the
/// supernodes above them (the top separators). A subtree's supernodes
/// change only rows of the subtree and of the supernodes above it, so the
/// two sets run at once: forward, the first in place and the second in a
/// copy whose rows above start at zero, added after, and the top is solved
/// after them; backward, the top first, then both sets. Found from the factor's structure alone,
/// so a solve gives the same values on any number of threads.
#[derive(Clone, Debug)]
pub(crate) struct Split {
    /// Each set's supernodes, ascending (a child before its parent).
    sets: [Vec<u32>; 2],
    /// The supernodes above both sets, ascending.
    top: Vec<u32>,
}

impl Split {
    /// The cut of a factor with `values` values of L, or `None` when the
    /// factor is too small to gain or its tree has no two halves of about
    /// equal work below a small top.
    pub(crate) fn of(symbolic: &SymbolicSupernodalCholesky<u32>, values: usize) -> Option<Split> {
        if values < SPLIT_VALUES {
            return None;
        }
        Split::cut(symbolic)
    }

    /// The cut of any factor, however small.
    pub(crate) fn cut(symbolic: &SymbolicSupernodalCholesky<u32>) -> Option<Split> {
        let count = symbolic.n_supernodes();
        if count < 3 {
            return None;
        }
        let (begin, end) = (symbolic.supernode_begin(), symbolic.supernode_end());
        let own: Vec<f64> = (0..count)
            .map(|k| {
                let width = (end[k] - begin[k]) as f64;
                (width + symbolic.supernode(k).pattern().len() as f64) * width
            })
            .collect();
        let tree = Tree::new(symbolic, &of_column(symbolic), &own);
        let (subtree, roots) = (&tree.subtree, tree.roots.clone());
        let total: f64 = own.iter().sum();
        // Take the largest subtree apart (its root to the top) while that
        // shortens the solve on two threads (the top's work plus the larger
        // set's), its sets dealt largest first to the lighter one; keep the
        // best cut seen.
        let deal = |below: &mut Vec<u32>| {
            below.sort_by(|a, b| subtree[*b as usize].total_cmp(&subtree[*a as usize]));
            let mut halves: Halves = Default::default();
            for &k in below.iter() {
                let h = usize::from(halves[1].0 < halves[0].0);
                halves[h].0 += subtree[k as usize];
                halves[h].1.push(k);
            }
            halves
        };
        let (mut below, mut top, mut top_work) = (roots, Vec::new(), 0.0);
        // The best cut: its time, its top and its two sets.
        let mut best: Option<(f64, Vec<u32>, Halves)> = None;
        // A chain of supernodes (one child each: a separator made of several
        // supernodes) is walked down without counting as a cut.
        let mut cuts = 0;
        for _ in 0..count {
            if cuts >= MAX_CUTS {
                break;
            }
            let halves = deal(&mut below);
            let time = top_work + halves[0].0.max(halves[1].0);
            if best.as_ref().is_none_or(|b| time < b.0) {
                best = Some((time, top.clone(), halves));
            }
            let largest = below.remove(0);
            if tree.children(largest).is_empty() {
                break;
            }
            top_work += own[largest as usize];
            top.push(largest);
            below.extend(tree.children(largest));
            cuts += usize::from(tree.children(largest).len() > 1);
        }
        let (time, mut top, halves) = best?;
        if time > GAIN * total || halves.iter().any(|h| h.1.is_empty()) {
            return None;
        }
        let sets = halves.map(|(_, roots)| {
            let mut set = Vec::new();
            let mut stack = roots;
            while let Some(k) = stack.pop() {
                set.push(k);
                stack.extend(tree.children(k));
            }
            set.sort_unstable();
            set
        });
        top.sort_unstable();
        Some(Split { sets, top })
    }
}

/// `$avx2` (a function compiled for AVX2 and FMA) when `$passes` holds
/// the CPU's proof, else `$plain`.
macro_rules! on_cpu {
    ($passes:expr, $avx2:expr, $plain:expr) => {{
        #[cfg(target_arch = "x86_64")]
        if $passes.cpu.is_some() {
            // SAFETY: an `Avx2Fma` exists only when the CPU has AVX2 and FMA.
            #[allow(unsafe_code)]
            unsafe {
                $avx2
            };
            return;
        }
        $plain
    }};
}

/// A set of supernodes as indices.
fn nodes(set: &[u32]) -> Vec<usize> {
    set.iter().map(|&k| k as usize).collect()
}

/// The two passes over chosen supernodes, compiled for the CPU found.
#[derive(Clone, Copy)]
struct Passes<'a> {
    symbolic: &'a SymbolicSupernodalCholesky<u32>,
    values: &'a [f64],
    /// The CPU's proof of AVX2 and FMA, read only on x86-64.
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    cpu: Option<Avx2Fma>,
    /// Values from which a supernode goes a panel at a time
    /// ([`WIDE_NODE`] in a split factor's solve, never in another's).
    wide: usize,
}

impl<'a> Passes<'a> {
    /// The passes over this factor. A factor too small to split runs on
    /// this thread alone, its wide nodes too.
    fn new(
        symbolic: &'a SymbolicSupernodalCholesky<u32>,
        values: &'a [f64],
        split: Option<&Split>,
    ) -> Passes<'a> {
        Passes {
            symbolic,
            values,
            cpu: Avx2Fma::detect(),
            wide: if split.is_some() {
                WIDE_NODE
            } else {
                usize::MAX
            },
        }
    }

    /// Forward then backward over every supernode.
    fn solve(self, x: &mut [Row]) {
        let mut work = Vec::new();
        let count = self.symbolic.n_supernodes();
        self.forward(0..count, x, &mut work);
        self.backward((0..count).rev(), x, &mut work);
    }

    /// [`Passes::solve`] with the two sets of `split` at once: the forward
    /// pass's copy serves the backward one (its top rows made again).
    fn solve_split(self, split: &Split, x: &mut [Row]) {
        let mut copy = Vec::new();
        self.forward_split(split, x, &mut copy);
        self.backward_split(split, x, &mut copy);
    }

    /// The forward pass with the two sets of `split` at once. The second
    /// set works in a copy of `x` (made in `copy`) whose top rows start at
    /// zero (they gather its updates, added after); its rows are copied
    /// back at the end.
    fn forward_split(self, split: &Split, x: &mut [Row], copy: &mut Vec<Row>) {
        let rows = self.rows();
        let [first, second] = split.sets.each_ref().map(|s| nodes(s));
        copy.clear();
        copy.extend_from_slice(x);
        for &k in &split.top {
            copy[rows(k)].fill([0.0; 4]);
        }
        let (mut work, mut work2) = (Vec::new(), Vec::new());
        rayon::join(
            || self.forward(first.iter().copied(), x, &mut work),
            || self.forward(second.iter().copied(), copy, &mut work2),
        );
        for &k in &split.top {
            for (a, b) in x[rows(k)].iter_mut().zip(&copy[rows(k)]) {
                *a = std::array::from_fn(|l| a[l] + b[l]);
            }
        }
        self.forward(nodes(&split.top).into_iter(), x, &mut work);
        for &k in &split.sets[1] {
            x[rows(k)].copy_from_slice(&copy[rows(k)]);
        }
    }

    /// The backward pass with the two sets of `split` at once: the top
    /// first, then each set on its own copy of `x`, the second's rows
    /// copied back. `copy`: the forward pass's (the second set's rows as in
    /// `x`: only the top's are made again), or empty.
    fn backward_split(self, split: &Split, x: &mut [Row], copy: &mut Vec<Row>) {
        let rows = self.rows();
        let [first, second] = split.sets.each_ref().map(|s| nodes(s));
        let mut work = Vec::new();
        self.backward(nodes(&split.top).into_iter().rev(), x, &mut work);
        if copy.len() == x.len() {
            for &k in &split.top {
                copy[rows(k)].copy_from_slice(&x[rows(k)]);
            }
        } else {
            copy.clear();
            copy.extend_from_slice(x);
        }
        let mut work2 = Vec::new();
        rayon::join(
            || self.backward(first.iter().rev().copied(), x, &mut work),
            || self.backward(second.iter().rev().copied(), copy, &mut work2),
        );
        for &k in &split.sets[1] {
            x[rows(k)].copy_from_slice(&copy[rows(k)]);
        }
    }

    /// The rows of supernode `k`.
    fn rows(self) -> impl Fn(u32) -> std::ops::Range<usize> + use<'a> {
        let (begin, end) = (
            self.symbolic.supernode_begin(),
            self.symbolic.supernode_end(),
        );
        move |k| begin[k as usize] as usize..end[k as usize] as usize
    }

    fn forward(self, nodes: impl Iterator<Item = usize>, x: &mut [Row], work: &mut Vec<Row>) {
        self.pass(Way::Forward, nodes, x, work)
    }

    fn backward(self, nodes: impl Iterator<Item = usize>, x: &mut [Row], work: &mut Vec<Row>) {
        self.pass(Way::Backward, nodes, x, work)
    }

    /// [`pass`] for the CPU.
    fn pass(
        self,
        way: Way,
        nodes: impl Iterator<Item = usize>,
        x: &mut [Row],
        work: &mut Vec<Row>,
    ) {
        on_cpu!(
            self,
            pass_avx2(self, way, nodes, x, work),
            pass::<false>(self, way, nodes, x, work)
        )
    }

    /// [`take_columns`] for the CPU.
    fn take_columns(
        self,
        node: &Node<'_>,
        columns: std::ops::Range<usize>,
        xs: &[Row],
        rows: &mut [Row],
        from: usize,
    ) {
        on_cpu!(
            self,
            take_columns_avx2(node, columns, xs, rows, from),
            take_columns::<false>(node, columns, xs, rows, from)
        )
    }

    /// [`dots_below`] for the CPU.
    fn dots_below(
        self,
        node: &Node<'_>,
        columns: std::ops::Range<usize>,
        from: usize,
        rows: &[Row],
        out: &mut [Row],
    ) {
        on_cpu!(
            self,
            dots_below_avx2(node, columns, from, rows, out),
            dots_below::<false>(node, columns, from, rows, out)
        )
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn take_columns_avx2(
    node: &Node<'_>,
    columns: std::ops::Range<usize>,
    xs: &[Row],
    rows: &mut [Row],
    from: usize,
) {
    take_columns::<true>(node, columns, xs, rows, from)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn dots_below_avx2(
    node: &Node<'_>,
    columns: std::ops::Range<usize>,
    from: usize,
    rows: &[Row],
    out: &mut [Row],
) {
    dots_below::<true>(node, columns, from, rows, out)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn pass_avx2(
    passes: Passes<'_>,
    way: Way,
    nodes: impl Iterator<Item = usize>,
    x: &mut [Row],
    work: &mut Vec<Row>,
) {
    pass::<true>(passes, way, nodes, x, work)
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

/// Which triangular solve a pass makes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Way {
    /// L y = b over supernodes ascending (a child before its parent), each
    /// solving its own rows and updating those below it.
    Forward,
    /// L^T x = y over supernodes descending (a parent before its
    /// children), the rows below each already solved.
    Backward,
}

/// One solve `way` over `nodes`: each supernode's rows gathered, solved,
/// and put back (forward, the rows below it too).
#[inline(always)]
fn pass<const FMA: bool>(
    passes: Passes<'_>,
    way: Way,
    nodes: impl Iterator<Item = usize>,
    x: &mut [Row],
    work: &mut Vec<Row>,
) {
    for s in nodes {
        let node = node(passes.symbolic, passes.values, s);
        node.gather(x, work);
        match way {
            Way::Forward => forward_node::<FMA>(passes, &node, work),
            Way::Backward => backward_node::<FMA>(passes, &node, work),
        }
        x[node.start..node.start + node.width].copy_from_slice(&work[..node.width]);
        if way == Way::Forward {
            for (&r, v) in node.below.iter().zip(&work[node.width..]) {
                x[r as usize] = *v;
            }
        }
    }
}

/// Columns a panel of a wide supernode holds (a multiple of four, so that
/// its groups of four columns are those of the whole node).
const PANEL: usize = 64;

/// Values from which a supernode's rows are split between two threads a
/// panel at a time (at 1m the top separator's supernodes hold a third of
/// L, and would run on one thread after the two sets).
const WIDE_NODE: usize = 1 << 16;

/// Whether `node` is solved a panel at a time, its rows (forward) or its
/// columns (backward) in two halves at once.
fn is_wide(node: &Node<'_>, wide: usize) -> bool {
    node.values.len() >= wide && node.width >= 2 * PANEL
}

/// One supernode's part of L y = b on its gathered rows: its diagonal
/// block's rows solved, the rows below updated, four columns at a time
/// (their 4 x 4 triangle column by column, then the rows below it take the
/// four columns' terms in one pass: a row loaded and stored once for four
/// multiply-adds). A wide node goes a panel of columns at a time: the
/// panel's own rows first, then the rows below the panel in two halves at
/// once; each row takes the same terms in the same order either way.
#[inline(always)]
fn forward_node<const FMA: bool>(passes: Passes<'_>, node: &Node<'_>, work: &mut [Row]) {
    if !is_wide(node, passes.wide) {
        forward_panel::<FMA>(node, work, 0..node.width, work.len());
        return;
    }
    for p in (0..node.width).step_by(PANEL) {
        let q = (p + PANEL).min(node.width);
        forward_panel::<FMA>(node, work, p..q, q);
        let (done, rest) = work.split_at_mut(q);
        let xs = &done[p..q];
        let (a, b) = rest.split_at_mut(rest.len() / 2);
        let b_from = q + a.len();
        // rayon's closures do not inherit this function's target
        // features: each half is compiled for the CPU anew.
        rayon::join(
            || passes.take_columns(node, p..q, xs, a, q),
            || passes.take_columns(node, p..q, xs, b, b_from),
        );
    }
}

/// Solves the rows of `columns` and updates the rows after them up to
/// `until` (node rows), four columns at a time.
#[inline(always)]
fn forward_panel<const FMA: bool>(
    node: &Node<'_>,
    work: &mut [Row],
    columns: std::ops::Range<usize>,
    until: usize,
) {
    let mut j = columns.start;
    while j < columns.end {
        let k = (columns.end - j).min(4);
        for c in j..j + k {
            let col = node.column(c);
            let xc = work[c].map(|v| v / col[0]);
            work[c] = xc;
            for (i, &l) in (c + 1..j + k).zip(&col[1..]) {
                work[i] = mul_sub::<FMA>(work[i], l, xc);
            }
        }
        let (done, rest) = work[..until].split_at_mut(j + k);
        take_columns::<FMA>(node, j..j + k, &done[j..j + k], rest, j + k);
        j += k;
    }
}

/// `rows` (node rows from `from`) take the terms of the solved `columns`
/// (values `xs`), four columns at a time in column order.
#[inline(always)]
fn take_columns<const FMA: bool>(
    node: &Node<'_>,
    columns: std::ops::Range<usize>,
    xs: &[Row],
    rows: &mut [Row],
    from: usize,
) {
    let n = rows.len();
    let of = |c: usize| &node.column(c)[from - c..from - c + n];
    let mut j = columns.start;
    while j < columns.end {
        let k = (columns.end - j).min(4);
        let x = &xs[j - columns.start..];
        if k == 4 {
            let cols = [0, 1, 2, 3].map(|t| of(j + t));
            let xs = [x[0], x[1], x[2], x[3]];
            // Two rows a step.
            for i in (0..n - n % 2).step_by(2) {
                let (mut a, mut b) = (rows[i], rows[i + 1]);
                for t in 0..4 {
                    a = mul_sub::<FMA>(a, cols[t][i], xs[t]);
                    b = mul_sub::<FMA>(b, cols[t][i + 1], xs[t]);
                }
                (rows[i], rows[i + 1]) = (a, b);
            }
            if n % 2 == 1 {
                let mut a = rows[n - 1];
                for t in 0..4 {
                    a = mul_sub::<FMA>(a, cols[t][n - 1], xs[t]);
                }
                rows[n - 1] = a;
            }
        } else {
            for (t, &xc) in x[..k].iter().enumerate() {
                for (d, &l) in rows.iter_mut().zip(of(j + t)) {
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
/// wait on each other), then their 4 x 4 triangle. A wide node goes a
/// panel at a time from the last: the dot products of the panel's columns
/// with the rows after the panel first, its columns in two halves at once,
/// then the panel as a node of its own.
#[inline(always)]
fn backward_node<const FMA: bool>(passes: Passes<'_>, node: &Node<'_>, work: &mut [Row]) {
    if !is_wide(node, passes.wide) {
        backward_panel::<FMA>(node, work, 0..node.width, None);
        return;
    }
    let mut sums = Vec::with_capacity(PANEL);
    let mut q = node.width;
    while q > 0 {
        let p = q.saturating_sub(PANEL);
        let (head, solved) = work.split_at_mut(q);
        sums.clear();
        sums.resize(q - p, [0.0; 4]);
        let mid = p + (q - p) / 2;
        let (a, b) = sums.split_at_mut(mid - p);
        // As in `forward_node`.
        rayon::join(
            || passes.dots_below(node, p..mid, q, solved, a),
            || passes.dots_below(node, mid..q, q, solved, b),
        );
        backward_panel::<FMA>(node, head, p..q, Some(&sums));
        q = p;
    }
}

/// The dot products of `columns` with the solved `rows` (node rows from
/// `from`), into `out`, four columns a pass.
#[inline(always)]
fn dots_below<const FMA: bool>(
    node: &Node<'_>,
    columns: std::ops::Range<usize>,
    from: usize,
    rows: &[Row],
    out: &mut [Row],
) {
    let below = |c: usize| &node.column(c)[from - c..];
    for (j, out) in columns.clone().step_by(4).zip(out.chunks_mut(4)) {
        let k = out.len();
        if k == 4 {
            out.copy_from_slice(&dots4::<FMA>([0, 1, 2, 3].map(|t| below(j + t)), rows));
        } else {
            for (t, o) in out.iter_mut().enumerate() {
                *o = dots4::<FMA>([below(j + t); 4], rows)[0];
            }
        }
    }
}

/// The backward step of `columns` on `work` (the node's rows from its
/// first, the rows after `columns` solved), last four first; `after`: the
/// columns' dot products with rows past the end of `work` (a wide node's
/// panel is given the rows up to its end), to add.
#[inline(always)]
fn backward_panel<const FMA: bool>(
    node: &Node<'_>,
    work: &mut [Row],
    columns: std::ops::Range<usize>,
    after: Option<&[Row]>,
) {
    let mut end = columns.end;
    while end > columns.start {
        let start = end.saturating_sub(4).max(columns.start);
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
        if let Some(after) = after {
            for c in start..end {
                let a = after[c - columns.start];
                sums[c - start] = std::array::from_fn(|k| sums[c - start][k] + a[k]);
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
    use glam::{DVec3, DVec4};

    use super::*;
    use crate::solver::Factor;
    use crate::solver::tests::{random_system, solve_with_faer, supernodal_of};
    use crate::symbolic::LowerCsc;
    use crate::testing::Rng;

    /// The supernodal factor of a random system of `n` starts, in faer's
    /// minimum degree order.
    fn supernodal(n: usize, radius: f64, seed: u64) -> (LowerCsc, Factor) {
        let (_, g, a) = random_system(n, radius, seed);
        let symbolic = Factor::supernodal_symbolic(&g, None).expect("symbolic");
        let factor = supernodal_of(symbolic, &a).expect("SPD");
        (a, factor)
    }

    /// The supernodal factor of a random system: its solve against faer's.
    /// With `split`, the factor is solved through a cut of its tree (and
    /// its wide nodes by panels) whatever its size, when it has one.
    fn check<T: Rhs>(n: usize, radius: f64, seed: u64, split: bool, rhs: impl Fn(&mut Rng) -> T) {
        let (_, factor) = supernodal(n, radius, seed);
        let Factor::Supernodal {
            symbolic, values, ..
        } = factor
        else {
            unreachable!("a supernodal factor")
        };
        let s = symbolic.supernodal();
        let cut = if split { Split::cut(s) } else { None };
        if split && cut.is_none() {
            return;
        }
        let factor = Factor::Supernodal {
            split: cut.map(std::sync::Arc::new),
            symbolic,
            values,
        };
        let mut rng = Rng::new(seed + 100);
        let b: Vec<T> = (0..n).map(|_| rhs(&mut rng)).collect();
        let (mut ours, mut faer) = (b.clone(), b.clone());
        factor.solve_in_place(&mut ours);
        let Factor::Supernodal {
            symbolic, values, ..
        } = &factor
        else {
            unreachable!("a supernodal factor")
        };
        solve_with_faer(symbolic, values, &mut faer);
        let scale = faer
            .iter()
            .flat_map(|v| (0..T::LANES).map(|k| v.lane(k).abs()))
            .fold(0.0, f64::max);
        for (i, (u, v)) in ours.iter().zip(&faer).enumerate() {
            for k in 0..T::LANES {
                let err = (u.lane(k) - v.lane(k)).abs();
                assert!(
                    err <= 1e-11 * scale,
                    "n {n} row {i} lane {k} (split {split}): {} vs {}",
                    u.lane(k),
                    v.lane(k)
                );
            }
        }
    }

    #[test]
    fn the_solve_agrees_with_faers_for_one_three_and_four_right_hand_sides_split_or_not() {
        let cases = [
            (5, 2.0, 1),
            (40, 0.6, 2),
            (300, 0.25, 3),
            (900, 0.2, 4),
            (2000, 0.1, 4),
        ];
        for (n, radius, seed) in cases {
            for split in [false, true] {
                check(n, radius, seed, split, |r| r.vec3().x - 0.5);
                check(n, radius, seed, split, |r| r.vec3() - DVec3::splat(0.5));
                check(n, radius, seed, split, |r| {
                    r.vec3().extend(r.vec3().y) - DVec4::splat(0.5)
                });
            }
        }
    }

    /// With and without fused multiply-adds (what a CPU without AVX2 runs):
    /// the same solution to rounding.
    #[test]
    fn the_plain_path_agrees_with_the_fused_one() {
        let (a, factor) = supernodal(600, 0.22, 9);
        let Factor::Supernodal {
            symbolic, values, ..
        } = factor
        else {
            unreachable!("a supernodal factor")
        };
        let s = symbolic.supernodal();
        let mut rng = Rng::new(5);
        let b: Vec<Row> = (0..a.n)
            .map(|_| {
                let v = rng.vec3();
                [v.x, v.y, v.z, 1.0]
            })
            .collect();
        let (mut plain, mut fused) = (b.clone(), b);
        let passes = |cpu| Passes {
            symbolic: s,
            values: &values,
            cpu,
            wide: WIDE_NODE,
        };
        passes(None).solve(&mut plain);
        match Avx2Fma::detect() {
            Some(cpu) => passes(Some(cpu)).solve(&mut fused),
            // Fused multiply-adds in software.
            None => {
                let count = s.n_supernodes();
                let work = &mut Vec::new();
                pass::<true>(passes(None), Way::Forward, 0..count, &mut fused, work);
                pass::<true>(
                    passes(None),
                    Way::Backward,
                    (0..count).rev(),
                    &mut fused,
                    work,
                );
            }
        }
        for (p, f) in plain.iter().zip(&fused) {
            for k in 0..4 {
                assert!((p[k] - f[k]).abs() <= 1e-11 * (1.0 + f[k].abs()));
            }
        }
    }

    /// A random system's supernodal factor, its structure and its cut.
    fn cut_of(n: usize, radius: f64, seed: u64) -> (Factor, Split) {
        let (_, factor) = supernodal(n, radius, seed);
        let Factor::Supernodal { symbolic, .. } = &factor else {
            unreachable!("a supernodal factor")
        };
        let s = symbolic.supernodal();
        let split = Split::cut(s).unwrap_or_else(|| panic!("n {n}: no cut"));
        (factor, split)
    }

    /// The forward and backward halves, on their own (the polynomial block
    /// and a solve with it use them): backward(forward(b)) is the whole
    /// solve, and forward's y has y . y' = b . A^-1 b' (the block's S =
    /// V^T V). On a factor cut in two and on the same factor uncut.
    #[test]
    fn the_halves_of_a_solve_make_the_solve() {
        let (n, radius, seed) = (2000, 0.1, 4);
        let (factor, split) = cut_of(n, radius, seed);
        let Factor::Supernodal {
            symbolic, values, ..
        } = factor
        else {
            unreachable!()
        };
        let mut rng = Rng::new(seed + 7);
        let b: Vec<DVec4> = (0..n)
            .map(|_| DVec4::new(rng.f64(), rng.f64(), rng.f64(), rng.f64()) - 0.5)
            .collect();
        let c: Vec<DVec4> = (0..n)
            .map(|_| DVec4::new(rng.f64(), rng.f64(), rng.f64(), rng.f64()) - 0.5)
            .collect();
        for split in [Some(std::sync::Arc::new(split)), None] {
            let cut = split.is_some();
            let factor = Factor::Supernodal {
                symbolic: symbolic.clone(),
                values: values.clone(),
                split,
            };
            let mut whole = b.clone();
            factor.solve_in_place(&mut whole);
            let y = factor.forward(&b);
            let mut halves = vec![DVec4::ZERO; n];
            factor.backward(y.clone(), &mut halves);
            let scale = whole
                .iter()
                .map(|v| v.abs().max_element())
                .fold(0.0, f64::max);
            for (i, (u, v)) in halves.iter().zip(&whole).enumerate() {
                assert!(
                    (*u - *v).abs().max_element() <= 1e-12 * scale,
                    "cut {cut} row {i}: {u} vs {v}"
                );
            }
            // y . y' against b . A^-1 c, lane by lane.
            let y2 = factor.forward(&c);
            let mut x = c.clone();
            factor.solve_in_place(&mut x);
            for k in 0..4 {
                let ours: f64 = y.iter().zip(&y2).map(|(u, v)| u[k] * v[k]).sum();
                let want: f64 = b.iter().zip(&x).map(|(u, v)| u[k] * v[k]).sum();
                assert!(
                    (ours - want).abs() <= 1e-10 * want.abs().max(1.0),
                    "cut {cut} lane {k}: {ours} vs {want}"
                );
            }
        }
    }

    /// The cut takes every supernode once, each set whole subtrees (every
    /// row a supernode changes lies in its own set or in the top, so the
    /// sets never touch each other's rows), and two threads' share of the
    /// work (the top's and the larger set's) is at most [`GAIN`] of it all.
    #[test]
    fn a_cut_takes_whole_subtrees_into_two_sets() {
        for (n, radius, seed) in [(2000, 0.1, 4), (5000, 0.07, 7)] {
            let (factor, split) = cut_of(n, radius, seed);
            let Factor::Supernodal { symbolic, .. } = &factor else {
                unreachable!()
            };
            let s = symbolic.supernodal();
            let count = s.n_supernodes();
            let (begin, end) = (s.supernode_begin(), s.supernode_end());
            let mut set_of = vec![None; count];
            for (k, set) in split.sets.iter().chain([&split.top]).enumerate() {
                assert!(set.windows(2).all(|w| w[0] < w[1]), "n {n}: ascending");
                for &node in set {
                    assert_eq!(set_of[node as usize], None, "n {n}: node {node} twice");
                    set_of[node as usize] = Some(k);
                }
            }
            assert!(set_of.iter().all(Option::is_some), "n {n}: a node left out");
            assert!(
                split.sets.iter().all(|s| !s.is_empty()),
                "n {n}: an empty set"
            );
            let node_of_row = |row: u32| (0..count).find(|&p| (begin[p]..end[p]).contains(&row));
            let mut work = [0.0; 3];
            for node in 0..count {
                let mine = set_of[node].unwrap();
                let width = (end[node] - begin[node]) as usize;
                work[mine] += ((width + s.supernode(node).pattern().len()) * width) as f64;
                for &row in s.supernode(node).pattern() {
                    let theirs = set_of[node_of_row(row).expect("a row's node")].unwrap();
                    assert!(
                        theirs == mine || theirs == 2,
                        "n {n}: node {node} in set {mine} changes row {row} of set {theirs}"
                    );
                }
            }
            let all: f64 = work.iter().sum();
            assert!(
                work[2] + work[0].max(work[1]) <= GAIN * all,
                "n {n}: the work by set {work:?}"
            );
        }
    }

    /// The two sets at once (on one thread or two) give the serial solve's
    /// solution to rounding, and the same values on any number of threads.
    #[test]
    fn a_split_solve_agrees_with_the_serial_one_on_any_number_of_threads() {
        for (n, radius, seed) in [(2000, 0.1, 4), (5000, 0.07, 7)] {
            let (factor, split) = cut_of(n, radius, seed);
            let Factor::Supernodal {
                symbolic, values, ..
            } = &factor
            else {
                unreachable!()
            };
            let s = symbolic.supernodal();
            let mut rng = Rng::new(seed + 1);
            let b: Vec<Row> = (0..n)
                .map(|_| {
                    let v = rng.vec3() - DVec3::splat(0.5);
                    [v.x, v.y, v.z, rng.vec3().x]
                })
                .collect();
            let passes = Passes {
                symbolic: s,
                values,
                cpu: Avx2Fma::detect(),
                wide: WIDE_NODE,
            };
            let mut serial = b.clone();
            passes.solve(&mut serial);
            let on = |threads: usize| {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .expect("a pool");
                let mut x = b.clone();
                pool.install(|| passes.solve_split(&split, &mut x));
                x
            };
            let (one, two) = (on(1), on(2));
            assert_eq!(one, two, "n {n}: the thread count changed the values");
            let scale = serial.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
            for (i, (u, v)) in two.iter().zip(&serial).enumerate() {
                for k in 0..4 {
                    assert!(
                        (u[k] - v[k]).abs() <= 1e-11 * scale,
                        "n {n} row {i} lane {k}: {} vs {}",
                        u[k],
                        v[k]
                    );
                }
            }
        }
    }

    /// A wide supernode a panel at a time, its halves at once: forward the
    /// same values bit for bit as the whole node, backward the same to
    /// rounding, and the same values on any number of threads; with and
    /// without AVX2. The node's last panel is short and ends in fewer than
    /// four columns.
    #[test]
    fn a_wide_node_by_panels_agrees_with_the_whole_node() {
        // The first system whose widest node ends in a short panel and a
        // group of fewer than four columns.
        let (a, factor, widest) = (4..40)
            .find_map(|seed| {
                let (a, factor) = supernodal(900, 0.2, seed);
                let Factor::Supernodal { symbolic, .. } = &factor else {
                    unreachable!()
                };
                let s = symbolic.supernodal();
                let widest = (0..s.n_supernodes())
                    .map(|k| (s.supernode_end()[k] - s.supernode_begin()[k]) as usize)
                    .max()
                    .unwrap_or(0);
                (widest >= 2 * PANEL && widest % PANEL != 0 && widest % 4 != 0)
                    .then_some((a, factor, widest))
            })
            .expect("a system with such a node");
        let Factor::Supernodal {
            symbolic, values, ..
        } = &factor
        else {
            unreachable!()
        };
        let s = symbolic.supernodal();
        let mut rng = Rng::new(11);
        let b: Vec<Row> = (0..a.n)
            .map(|_| {
                let v = rng.vec3() - DVec3::splat(0.5);
                [v.x, v.y, v.z, 0.25]
            })
            .collect();
        let count = s.n_supernodes();
        for cpu in [None, Avx2Fma::detect()] {
            let passes = |wide| Passes {
                symbolic: s,
                values,
                cpu,
                wide,
            };
            let forward = |wide| {
                let mut x = b.clone();
                passes(wide).forward(0..count, &mut x, &mut Vec::new());
                x
            };
            let cpu = cpu.is_some();
            assert_eq!(
                forward(usize::MAX),
                forward(0),
                "forward by panels (AVX2 {cpu}, {widest} columns)"
            );
            let solve = |wide, threads| {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .expect("a pool");
                let mut x = b.clone();
                pool.install(|| passes(wide).solve(&mut x));
                x
            };
            let whole = solve(usize::MAX, 2);
            let (one, two) = (solve(0, 1), solve(0, 2));
            assert_eq!(one, two, "the thread count changed the values (AVX2 {cpu})");
            let scale = whole.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
            for (i, (u, v)) in two.iter().zip(&whole).enumerate() {
                for k in 0..4 {
                    assert!(
                        (u[k] - v[k]).abs() <= 1e-11 * scale,
                        "row {i} lane {k} (AVX2 {cpu}): {} vs {}",
                        u[k],
                        v[k]
                    );
                }
            }
        }
    }
}
