//! Band-reducing renumberings of the start points: the papers' breadth-first
//! sweep (their figure 3) and reverse Cuthill-McKee; and for the supernodal
//! solver a fill-reducing one, nested dissection by coordinates.
//!
//! A permutation here is `perm[new] = old`: the start that takes position
//! `new` in the system.

use std::collections::VecDeque;

/// The neighbour graph of the start points in compressed rows: `j` is a
/// neighbour of `i` when |s_i - s_j| < R, so A_ij != 0. No self loops.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Graph {
    offsets: Vec<usize>,
    neighbours: Vec<u32>,
}

impl Graph {
    /// A graph from each node's neighbour list. The lists must be symmetric.
    pub fn from_lists(lists: &[Vec<u32>]) -> Graph {
        let mut offsets = Vec::with_capacity(lists.len() + 1);
        offsets.push(0);
        let mut neighbours = Vec::with_capacity(lists.iter().map(Vec::len).sum());
        for l in lists {
            neighbours.extend_from_slice(l);
            offsets.push(neighbours.len());
        }
        Graph {
            offsets,
            neighbours,
        }
    }

    /// A graph from compressed rows.
    pub(crate) fn from_parts(offsets: Vec<usize>, neighbours: Vec<u32>) -> Graph {
        Graph {
            offsets,
            neighbours,
        }
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// Whether the graph has no node.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The neighbours of node `i`.
    pub fn neighbours(&self, i: usize) -> &[u32] {
        &self.neighbours[self.offsets[i]..self.offsets[i + 1]]
    }

    /// Number of neighbours of node `i`.
    pub fn degree(&self, i: usize) -> usize {
        self.offsets[i + 1] - self.offsets[i]
    }

    /// Number of edges counted both ways (the off-diagonal non-zeros of A).
    pub fn edge_entries(&self) -> usize {
        self.neighbours.len()
    }
}

/// Which renumbering to use before building the profile.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[non_exhaustive]
pub enum Ordering {
    /// Keep the caller's order.
    Identity,
    /// The papers' breadth-first sweep from the first start.
    BreadthFirst,
    /// Reverse Cuthill-McKee from a pseudo-peripheral start.
    ReverseCuthillMcKee,
    /// Whichever of the three gives the smallest envelope (default).
    #[default]
    Auto,
}

impl Ordering {
    /// Every choice.
    pub const ALL: [Ordering; 4] = [
        Ordering::Auto,
        Ordering::ReverseCuthillMcKee,
        Ordering::BreadthFirst,
        Ordering::Identity,
    ];

    /// The lower-case name used in control files and reports.
    pub fn name(self) -> &'static str {
        match self {
            Ordering::Identity => "identity",
            Ordering::BreadthFirst => "breadth-first",
            Ordering::ReverseCuthillMcKee => "rcm",
            Ordering::Auto => "auto",
        }
    }
}

impl std::fmt::Display for Ordering {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Ordering {
    type Err = crate::NameError;
    fn from_str(s: &str) -> Result<Self, crate::NameError> {
        Ordering::ALL
            .into_iter()
            .find(|o| o.name().eq_ignore_ascii_case(s))
            .ok_or_else(|| crate::NameError::UnknownOrdering(s.to_owned()))
    }
}

/// Band measures of the matrix under a numbering.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Band {
    /// Largest distance of a non-zero from the diagonal.
    pub bandwidth: usize,
    /// Entries strictly below the diagonal inside the profile.
    pub envelope: usize,
}

/// The papers' renumbering: a breadth-first sweep over the neighbour graph
/// from start 0 (then from the first unvisited start of each further component).
pub fn breadth_first(graph: &Graph) -> Vec<u32> {
    sweep(graph, |_| 0, false)
}

/// Reverse Cuthill-McKee: a breadth-first sweep from a pseudo-peripheral
/// start, neighbours taken by increasing degree, then reversed.
pub fn reverse_cuthill_mckee(graph: &Graph) -> Vec<u32> {
    let mut perm = sweep(graph, |c| pseudo_peripheral(graph, c), true);
    perm.reverse();
    perm
}

/// A numbering chosen by [`order`], with the band of every candidate tried.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Chosen {
    /// `perm[new] = old`.
    pub perm: Vec<u32>,
    /// Its band.
    pub band: Band,
    /// Which ordering it is.
    pub ordering: Ordering,
    /// Every ordering tried, with its band (one entry unless `Auto`).
    pub tried: Vec<(Ordering, Band)>,
}

/// The numbering `ordering` asks for, and its band. `Auto` takes the smallest
/// envelope of the candidates, so it never widens the caller's order (up to
/// 20,000 starts; beyond, reverse Cuthill-McKee's).
pub fn order(graph: &Graph, ordering: Ordering) -> Chosen {
    order_knowing(graph, ordering, None)
}

/// [`order`], given the band of the caller's order if it is known (the
/// fit reports it anyway): not measured again.
pub(crate) fn order_knowing(graph: &Graph, ordering: Ordering, identity: Option<Band>) -> Chosen {
    let mut best = Chosen::default();
    for (k, &o) in candidates(graph.len(), ordering).iter().enumerate() {
        let known = identity.filter(|_| o == Ordering::Identity);
        let (perm, b) = match known {
            // Its numbering is made only if it is taken.
            Some(b) => (None, b),
            None => {
                let perm = numbering(graph, o);
                let b = band(graph, &perm);
                (Some(perm), b)
            }
        };
        best.tried.push((o, b));
        if k == 0 || b.envelope < best.band.envelope {
            best.perm = perm.unwrap_or_else(|| numbering(graph, o));
            (best.band, best.ordering) = (b, o);
        }
    }
    best
}

/// The numbering of one ordering (`Auto`, never a candidate, as the
/// caller's order).
fn numbering(graph: &Graph, o: Ordering) -> Vec<u32> {
    match o {
        Ordering::BreadthFirst => breadth_first(graph),
        Ordering::ReverseCuthillMcKee => reverse_cuthill_mckee(graph),
        Ordering::Identity | Ordering::Auto => (0..graph.len() as u32).collect(),
    }
}

/// The orderings [`order`] tries, the first first.
fn candidates(n: usize, ordering: Ordering) -> &'static [Ordering] {
    match ordering {
        // A system this big goes to the supernodal solver unless its band
        // is narrow, which reverse Cuthill-McKee finds alone: the two
        // other tries would cost two passes more for nothing.
        Ordering::Auto if n > AUTO_ONE_ORDERING => &[Ordering::ReverseCuthillMcKee],
        Ordering::Auto => &[
            Ordering::ReverseCuthillMcKee,
            Ordering::BreadthFirst,
            Ordering::Identity,
        ],
        Ordering::BreadthFirst => &[Ordering::BreadthFirst],
        Ordering::ReverseCuthillMcKee => &[Ordering::ReverseCuthillMcKee],
        Ordering::Identity => &[Ordering::Identity],
    }
}

/// Above this many starts `Auto` tries reverse Cuthill-McKee only.
const AUTO_ONE_ORDERING: usize = 20_000;

/// Bandwidth and envelope of the matrix with pattern `graph` under `perm`.
pub fn band(graph: &Graph, perm: &[u32]) -> Band {
    let mut out = Band::default();
    if perm.iter().enumerate().all(|(i, &p)| p as usize == i) {
        // The caller's own order: each row's first column is its least
        // neighbour, a plain minimum (no gather through an inverse).
        for new in 0..graph.len() {
            let least = graph.neighbours(new).iter().copied().min();
            let first = least.map_or(new, |j| (j as usize).min(new));
            out.bandwidth = out.bandwidth.max(new - first);
            out.envelope += new - first;
        }
        return out;
    }
    let inv = inverse(perm);
    for (new, &old) in perm.iter().enumerate() {
        let first = graph
            .neighbours(old as usize)
            .iter()
            .map(|&j| inv[j as usize] as usize)
            .min()
            .unwrap_or(new)
            .min(new);
        out.bandwidth = out.bandwidth.max(new - first);
        out.envelope += new - first;
    }
    out
}

/// The inverse permutation: `inv[old] = new`.
pub fn inverse(perm: &[u32]) -> Vec<u32> {
    let mut inv = vec![0u32; perm.len()];
    for (new, &old) in perm.iter().enumerate() {
        inv[old as usize] = new as u32;
    }
    inv
}

/// Coordinates sampled to estimate a part's median along an axis.
const SAMPLE: usize = 255;

/// Parts of at most this many starts are not split further by
/// [`geometric_dissection`]: they keep the order the splits left them in.
const DISSECTION_LEAF: usize = 32;

/// Nested dissection by coordinates, a fill-reducing ordering for the
/// supernodal factor: split the starts at the median of their widest axis,
/// take as separator the starts of one side (the one with fewer) that have a
/// neighbour on the other, number the two halves (recursively) and the
/// separator last. The halves then share no entry, so no fill joins them.
///
/// `reach`: no edge of `graph` is longer (the radius of support): only the
/// starts within it of a cut are looked at for the separator. A longer edge
/// costs fill, never correctness.
pub(crate) fn geometric_dissection(graph: &Graph, points: &[glam::DVec3], reach: f64) -> Vec<u32> {
    dissection(graph, points, reach).0
}

/// [`geometric_dissection`] and its splits: `(begin, middle, separator)`,
/// positions in the numbering where a split's first half, second half and
/// separator start (the separator runs to the end of the enclosing part).
fn dissection(graph: &Graph, points: &[glam::DVec3], reach: f64) -> (Vec<u32>, Vec<[usize; 3]>) {
    let n = graph.len().min(points.len());
    let mut ids: Vec<u32> = (0..n as u32).collect();
    let mut d = Dissection {
        graph,
        points,
        reach,
        perm: Vec::with_capacity(n),
        mark: vec![0; n],
        token: 0,
        splits: Vec::new(),
    };
    d.dissect(&mut ids);
    (d.perm, d.splits)
}

/// The state of a nested dissection: `mark[i]` tells which part of the
/// current split start `i` is in (each split takes two fresh tokens).
struct Dissection<'a> {
    graph: &'a Graph,
    points: &'a [glam::DVec3],
    reach: f64,
    perm: Vec<u32>,
    mark: Vec<u32>,
    token: u32,
    splits: Vec<[usize; 3]>,
}

impl Dissection<'_> {
    /// Numbers `ids` next: both halves, then their separator.
    fn dissect(&mut self, ids: &mut [u32]) {
        let (graph, points) = (self.graph, self.points);
        if ids.len() <= DISSECTION_LEAF {
            self.perm.extend_from_slice(ids);
            return;
        }
        // Of the three axes' median cuts, the one with the fewest starts
        // within reach of it (the separator's candidates: on a surface, a
        // cut across the widest axis may run along it). Each axis's median
        // is estimated from a sample; the cut made is exact.
        let m = ids.len() / 2;
        let mut best = (usize::MAX, 0);
        #[allow(clippy::needless_range_loop)] // `axis` indexes each point's coordinates
        for axis in 0..3 {
            let step = (ids.len() / SAMPLE).max(1);
            let mut sample: Vec<f64> = ids
                .iter()
                .step_by(step)
                .map(|&i| points[i as usize][axis])
                .collect();
            let half = sample.len() / 2;
            let (_, &mut cut, _) = sample.select_nth_unstable_by(half, f64::total_cmp);
            let slab = ids
                .iter()
                .filter(|&&i| (points[i as usize][axis] - cut).abs() <= self.reach)
                .count();
            if slab < best.0 {
                best = (slab, axis);
            }
        }
        self.split_at_median(ids, best.1);
        let (on_left, on_right) = self.boundaries(ids, m, best.1);
        let (left, right) = (self.token - 1, self.token);
        let (mark, reach) = (&self.mark, self.reach);
        let cut = points[ids[m] as usize][best.1];
        let touches = |i: u32, other: u32| {
            (points[i as usize][best.1] - cut).abs() <= reach
                && graph
                    .neighbours(i as usize)
                    .iter()
                    .any(|&j| mark[j as usize] == other)
        };
        let (mut a, mut b, mut sep) = (Vec::new(), Vec::new(), Vec::new());
        if on_left <= on_right {
            for &i in &ids[..m] {
                if touches(i, right) { &mut sep } else { &mut a }.push(i);
            }
            b.extend_from_slice(&ids[m..]);
        } else {
            a.extend_from_slice(&ids[..m]);
            for &i in &ids[m..] {
                if touches(i, left) { &mut sep } else { &mut b }.push(i);
            }
        }
        let begin = self.perm.len();
        self.dissect(&mut a);
        let middle = self.perm.len();
        self.dissect(&mut b);
        self.splits.push([begin, middle, self.perm.len()]);
        z_order(points, &mut sep);
        self.perm.extend_from_slice(&sep);
    }
}

/// Sorts `ids` along a Z-order (Morton) curve over their bounding box.
///
/// A separator's starts in this order: each subtree below touches a patch
/// of the separator, and a patch's starts come out mostly together, so a
/// descendant's rows fall into few runs of consecutive rows of the
/// supernodes above it, the runs the factorisation's scatter adds as
/// slices. On a scan's surface this about halves the runs; left in the
/// order the median split left them, the runs are single rows.
fn z_order(points: &[glam::DVec3], ids: &mut [u32]) {
    /// Bits of each coordinate in the key (three of them in a `u64`).
    const BITS: u32 = 21;
    if ids.len() < 3 {
        return;
    }
    let (mut lo, mut hi) = (glam::DVec3::INFINITY, glam::DVec3::NEG_INFINITY);
    for &i in ids.iter() {
        lo = lo.min(points[i as usize]);
        hi = hi.max(points[i as usize]);
    }
    let cells = f64::from((1u32 << BITS) - 1);
    let extent = (hi - lo).max_element();
    let scale = if extent > 0.0 { cells / extent } else { 0.0 };
    // Spreads the low 21 bits of `x` three apart.
    let spread = |x: u64| {
        let mut x = x & 0x1f_ffff;
        x = (x | (x << 32)) & 0x1f_0000_0000_ffff;
        x = (x | (x << 16)) & 0x1f_0000_ff00_00ff;
        x = (x | (x << 8)) & 0x100f_00f0_0f00_f00f;
        x = (x | (x << 4)) & 0x10c3_0c30_c30c_30c3;
        (x | (x << 2)) & 0x1249_2492_4924_9249
    };
    ids.sort_by_cached_key(|&i| {
        // In 0..=cells: the float-to-int cast saturates, and NaN (none in
        // validated starts) would be 0.
        let q = (points[i as usize] - lo) * scale;
        spread(q.x as u64) | (spread(q.y as u64) << 1) | (spread(q.z as u64) << 2)
    });
}

impl Dissection<'_> {
    /// Puts the half of `ids` lower along `axis` first.
    fn split_at_median(&self, ids: &mut [u32], axis: usize) {
        let points = self.points;
        ids.select_nth_unstable_by(ids.len() / 2, |&a, &b| {
            points[a as usize][axis].total_cmp(&points[b as usize][axis])
        });
    }

    /// Marks `ids[..m]` and `ids[m..]` (split at the median along `axis`)
    /// with two fresh tokens and counts the starts of each side with a
    /// neighbour on the other: of those within `reach` of the cut, the
    /// others having none.
    fn boundaries(&mut self, ids: &[u32], m: usize, axis: usize) -> (usize, usize) {
        self.token += 2;
        let (left, right) = (self.token - 1, self.token);
        for &i in &ids[..m] {
            self.mark[i as usize] = left;
        }
        for &i in &ids[m..] {
            self.mark[i as usize] = right;
        }
        let (graph, mark, points) = (self.graph, &self.mark, self.points);
        let cut = ids.get(m).map_or(0.0, |&i| points[i as usize][axis]);
        let near = |i: u32| (points[i as usize][axis] - cut).abs() <= self.reach;
        let touches = |i: u32, other: u32| {
            graph
                .neighbours(i as usize)
                .iter()
                .any(|&j| mark[j as usize] == other)
        };
        (
            ids[..m]
                .iter()
                .filter(|&&i| near(i) && touches(i, right))
                .count(),
            ids[m..]
                .iter()
                .filter(|&&i| near(i) && touches(i, left))
                .count(),
        )
    }
}

/// Breadth-first numbering of every component; `root(c)` picks the root of
/// the component containing node `c` (the first unvisited node).
fn sweep(graph: &Graph, root: impl Fn(usize) -> usize, by_degree: bool) -> Vec<u32> {
    let n = graph.len();
    let mut seen = vec![false; n];
    let mut perm = Vec::with_capacity(n);
    let mut queue = VecDeque::new();
    let mut buf: Vec<u32> = Vec::new();
    for c in 0..n {
        if seen[c] {
            continue;
        }
        let r = root(c);
        let r = if seen[r] { c } else { r };
        seen[r] = true;
        queue.push_back(r as u32);
        while let Some(i) = queue.pop_front() {
            perm.push(i);
            buf.clear();
            buf.extend(
                graph
                    .neighbours(i as usize)
                    .iter()
                    .filter(|&&j| !seen[j as usize]),
            );
            if by_degree {
                buf.sort_by_key(|&j| (graph.degree(j as usize), j));
            }
            for &j in &buf {
                seen[j as usize] = true;
                queue.push_back(j);
            }
        }
    }
    perm
}

/// A pseudo-peripheral node of the component of `start` (George & Liu):
/// repeat a breadth-first sweep from the farthest, lowest-degree node of the
/// last level while the eccentricity grows.
fn pseudo_peripheral(graph: &Graph, start: usize) -> usize {
    let mut level = vec![u32::MAX; graph.len()];
    let mut touched = Vec::new();
    let mut node = start;
    let mut ecc = 0;
    for _ in 0..8 {
        for &t in &touched {
            level[t] = u32::MAX;
        }
        touched.clear();
        let mut queue = VecDeque::from([node]);
        level[node] = 0;
        touched.push(node);
        let mut last = node;
        while let Some(i) = queue.pop_front() {
            last = i;
            for &j in graph.neighbours(i) {
                let j = j as usize;
                if level[j] == u32::MAX {
                    level[j] = level[i] + 1;
                    touched.push(j);
                    queue.push_back(j);
                }
            }
        }
        let depth = level[last];
        let candidate = touched
            .iter()
            .copied()
            .filter(|&i| level[i] == depth)
            .min_by_key(|&i| (graph.degree(i), i))
            .unwrap_or(last);
        if depth <= ecc && node != start {
            break;
        }
        ecc = depth;
        node = candidate;
    }
    node
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::Rng;

    /// A k x k grid graph with its nodes shuffled.
    fn shuffled_grid(k: usize, seed: u64) -> Graph {
        let n = k * k;
        let mut rng = Rng::new(seed);
        let mut label: Vec<u32> = (0..n as u32).collect();
        for i in (1..n).rev() {
            label.swap(i, rng.below(i + 1));
        }
        let mut lists = vec![Vec::new(); n];
        for y in 0..k {
            for x in 0..k {
                let a = label[y * k + x];
                for (dx, dy) in [(1, 0), (0, 1), (1, 1)] {
                    if x + dx < k && y + dy < k {
                        let b = label[(y + dy) * k + x + dx];
                        lists[a as usize].push(b);
                        lists[b as usize].push(a);
                    }
                }
            }
        }
        Graph::from_lists(&lists)
    }

    fn is_permutation(p: &[u32], n: usize) -> bool {
        let mut seen = vec![false; n];
        p.len() == n
            && p.iter()
                .all(|&i| !std::mem::replace(&mut seen[i as usize], true))
    }

    #[test]
    fn orderings_are_permutations_and_narrow_a_shuffled_grid() {
        for seed in 0..5 {
            let g = shuffled_grid(30, seed);
            let ident = band(&g, &(0..g.len() as u32).collect::<Vec<_>>());
            for p in [breadth_first(&g), reverse_cuthill_mckee(&g)] {
                assert!(is_permutation(&p, g.len()));
                let b = band(&g, &p);
                // A 30 x 30 grid with diagonals has a band of about 31-62.
                assert!(b.bandwidth <= 64, "{b:?}");
                assert!(b.envelope * 5 < ident.envelope, "{b:?} vs {ident:?}");
            }
        }
    }

    /// The band of the caller's order (its own fast path) and of any other
    /// against a plain count over every entry.
    #[test]
    fn band_counts_each_rows_first_column() {
        let plain = |g: &Graph, perm: &[u32]| {
            let inv = inverse(perm);
            let mut b = Band::default();
            for i in 0..g.len() {
                let mut first = inv[i] as usize;
                for &j in g.neighbours(i) {
                    first = first.min(inv[j as usize] as usize);
                }
                b.bandwidth = b.bandwidth.max(inv[i] as usize - first);
                b.envelope += inv[i] as usize - first;
            }
            b
        };
        for seed in 0..4 {
            let g = shuffled_grid(12, seed);
            let identity: Vec<u32> = (0..g.len() as u32).collect();
            let reversed: Vec<u32> = identity.iter().rev().copied().collect();
            for perm in [identity, reversed, reverse_cuthill_mckee(&g)] {
                assert_eq!(band(&g, &perm), plain(&g, &perm), "seed {seed}");
            }
        }
        let lonely = Graph::from_lists(&[vec![], vec![2], vec![1]]);
        assert_eq!(
            band(&lonely, &[0, 1, 2]),
            Band {
                bandwidth: 1,
                envelope: 1
            }
        );
    }

    #[test]
    fn auto_never_widens_the_callers_order() {
        for seed in 0..20 {
            let mut rng = Rng::new(seed);
            let n = 1 + rng.below(60);
            let mut lists = vec![Vec::new(); n];
            for _ in 0..rng.below(3 * n) {
                let (a, b) = (rng.below(n), rng.below(n));
                if a != b && !lists[a].contains(&(b as u32)) {
                    lists[a].push(b as u32);
                    lists[b].push(a as u32);
                }
            }
            let g = Graph::from_lists(&lists);
            let ident = band(&g, &(0..n as u32).collect::<Vec<_>>());
            let c = order(&g, Ordering::Auto);
            assert!(is_permutation(&c.perm, n));
            assert_eq!(c.band, band(&g, &c.perm));
            assert!(c.band.envelope <= ident.envelope);
            assert_eq!(c.tried.len(), 3);
            assert!(c.tried.iter().all(|(_, b)| c.band.envelope <= b.envelope));
            // The caller's band given, not measured again: the same choice.
            assert_eq!(order_knowing(&g, Ordering::Auto, Some(ident)), c);
        }
    }

    /// Random points in a slab and their neighbour graph within `r`.
    fn points_and_graph(n: usize, r: f64, seed: u64) -> (Vec<glam::DVec3>, Graph) {
        let mut rng = Rng::new(seed);
        let p: Vec<glam::DVec3> = (0..n)
            .map(|_| rng.vec3() * glam::DVec3::new(1.0, 1.0, 0.2))
            .collect();
        let lists: Vec<Vec<u32>> = (0..n)
            .map(|i| {
                (0..n)
                    .filter(|&j| j != i && p[i].distance(p[j]) < r)
                    .map(|j| j as u32)
                    .collect()
            })
            .collect();
        (p, Graph::from_lists(&lists))
    }

    #[test]
    fn geometric_dissection_is_a_permutation_whose_separators_separate() {
        for seed in 0..4 {
            let (p, g) = points_and_graph(700 + 300 * seed as usize, 0.08, seed);
            let (perm, splits) = dissection(&g, &p, 0.08);
            assert!(is_permutation(&perm, g.len()));
            assert_eq!(perm, geometric_dissection(&g, &p, 0.08));
            assert!(splits.len() >= 8, "{} splits", splits.len());
            let inv = inverse(&perm);
            for &[begin, middle, sep] in &splits {
                // No edge joins the first half to the second.
                for &i in &perm[begin..middle] {
                    for &j in g.neighbours(i as usize) {
                        let kj = inv[j as usize] as usize;
                        assert!(
                            !(middle..sep).contains(&kj),
                            "edge across split {begin}..{sep}"
                        );
                    }
                }
            }
            // The top separator is small against the halves (a slab's cut).
            let top = splits.last().copied().unwrap_or_default();
            assert!(g.len() - top[2] < g.len() / 5, "{top:?} of {}", g.len());
        }
    }

    /// Runs of consecutive places that `members` fill in `order`.
    fn runs_in(order: &[u32], members: &[bool]) -> usize {
        let mut runs = 0;
        let mut inside = false;
        for &i in order {
            let m = members[i as usize];
            runs += usize::from(m && !inside);
            inside = m;
        }
        runs
    }

    #[test]
    fn a_z_order_keeps_a_patch_of_a_separator_together() {
        // A shuffled 64 x 64 grid on a tilted plane (a separator's slab).
        let mut rng = Rng::new(5);
        let mut points = Vec::new();
        for i in 0..64 {
            for j in 0..64 {
                let (x, y) = (f64::from(i), f64::from(j));
                points.push(glam::DVec3::new(
                    x,
                    y,
                    0.3 * x - 0.2 * y + 0.2 * rng.f64() - 0.1,
                ));
            }
        }
        let mut ids: Vec<u32> = (0..points.len() as u32).collect();
        for k in (1..ids.len()).rev() {
            ids.swap(k, rng.below(k + 1));
        }
        let shuffled = ids.clone();
        z_order(&points, &mut ids);
        let mut sorted = ids.clone();
        sorted.sort_unstable();
        assert!(sorted.iter().enumerate().all(|(k, &i)| i as usize == k));
        // Discs of about 80 starts: in runs of several starts on average.
        for _ in 0..16 {
            let c = glam::DVec2::new(8.0 + 48.0 * rng.f64(), 8.0 + 48.0 * rng.f64());
            let members: Vec<bool> = points
                .iter()
                .map(|p| p.truncate().distance(c) < 5.0)
                .collect();
            let count = members.iter().filter(|&&m| m).count();
            let (z, before) = (runs_in(&ids, &members), runs_in(&shuffled, &members));
            // A Z-order's jumps cut a disc in a dozen or more runs (measured
            // 12-19 here); left shuffled, nearly every start is a run.
            assert!(
                3 * z < count && 2 * before > count,
                "{count} starts: {z} runs, {before} shuffled"
            );
        }
    }

    #[test]
    fn disconnected_and_empty_graphs() {
        let g = Graph::from_lists(&[vec![1], vec![0], vec![], vec![4], vec![3]]);
        assert!(is_permutation(&reverse_cuthill_mckee(&g), 5));
        assert!(is_permutation(&breadth_first(&g), 5));
        assert!(
            order(&Graph::from_lists(&[]), Ordering::Auto)
                .perm
                .is_empty()
        );
    }
}
