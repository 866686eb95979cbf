//! Making a [`Binding`]: the points are sorted into cells about R/2 wide (as
//! the evaluation sorts them), the cells cut into groups of consecutive
//! cells about equal in points (the points copied in cell order first, so a
//! cell reads its own as one run), and each group built whole by one task into
//! arrays of its own: each cell gathers its candidate starts once, and each
//! point's mask and weights follow the previous point's. One pass, and no
//! copy of the weights to join the groups (the product reads each cell from
//! its group).

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use std::ops::Range;

use super::weights::{Lanes, fill_cell};
use super::{BLOCK, Binding, Cell, Group, LEVEL_BYTES, LEVEL_TAIL, Rest, Support};
use crate::evaluate::{Blocks, Candidates, PARALLEL_POINTS, Point, Points};
use crate::simd::{Avx2Fma, Avx512};

/// Marks a padding candidate in `ids` (no start has this index).
pub(super) const PADDING: u32 = u32::MAX;

/// Builds a binding; `recycled` are groups of an earlier binding whose
/// arrays (already in memory, their pages touched) the new groups reuse.
pub(super) fn dispatch<P: Point>(
    support: &Support<'_>,
    points: &[P],
    recycled: Vec<Group>,
) -> Binding {
    match P::slice(points) {
        Points::F32(p) => of_f32(support, p, recycled),
        Points::F64(p) => of_f64(support, p, recycled),
    }
}

// The hot loops, compiled here (not in the caller's crate) for each kind.
#[inline(never)]
fn of_f32(support: &Support<'_>, points: &[Vec3], recycled: Vec<Group>) -> Binding {
    build(support, points, Rest::F32, recycled)
}

#[inline(never)]
fn of_f64(support: &Support<'_>, points: &[DVec3], recycled: Vec<Group>) -> Binding {
    build(support, points, Rest::F64, recycled)
}

fn build<P: Point>(
    support: &Support<'_>,
    points: &[P],
    kind: impl FnOnce(Vec<P>) -> Rest,
    mut recycled: Vec<Group>,
) -> Binding {
    let blocks = Blocks::for_starts(points, support.radius, support.starts);
    let parallel = points.len() >= PARALLEL_POINTS;
    let tasks = if parallel {
        GROUPS_PER_THREAD * rayon::current_num_threads()
    } else {
        1
    };
    // The points in cell order first (in parallel: a gather of 1M points
    // in cell order took 7 ms on one thread): each cell then reads its
    // points as one run.
    let rest: Vec<P> = if blocks.identity {
        points.to_vec()
    } else if parallel {
        blocks
            .order
            .par_iter()
            .map(|&i| points[i as usize])
            .collect()
    } else {
        blocks.order.iter().map(|&i| points[i as usize]).collect()
    };
    let ranges = group_ranges(&blocks.cells, tasks);
    recycled.resize_with(ranges.len(), Group::default);
    let make = |scratch: &mut Scratch, (k, (range, g)): (usize, (Range<usize>, Group))| {
        group(support, &rest, &blocks.cells, k, range, g, scratch)
    };
    let made: Vec<(Group, Vec<Cell>, usize)> = if parallel {
        ranges
            .into_par_iter()
            .zip(recycled)
            .enumerate()
            .map_init(Default::default, make)
            .collect()
    } else {
        let mut scratch = Default::default();
        ranges
            .into_iter()
            .zip(recycled)
            .enumerate()
            .map(|r| make(&mut scratch, r))
            .collect()
    };
    let mut cells = Vec::with_capacity(blocks.cells.len());
    let mut groups = Vec::with_capacity(made.len());
    let mut pairs = 0;
    for (g, c, hits) in made {
        groups.push(g);
        cells.extend(c);
        pairs += hits;
    }
    let order = (!blocks.identity).then_some(blocks.order);
    let place_if_nonfinite = |(k, p): (usize, &P)| (!p.to_dvec3().is_finite()).then_some(k as u32);
    let nonfinite = if parallel {
        rest.par_iter()
            .enumerate()
            .filter_map(place_if_nonfinite)
            .collect()
    } else {
        rest.iter()
            .enumerate()
            .filter_map(place_if_nonfinite)
            .collect()
    };
    Binding {
        kernel: support.kernel,
        radius: support.radius,
        starts: support.starts,
        fingerprint: support.fingerprint,
        cells,
        groups,
        rest: kind(rest),
        order,
        nonfinite,
        pairs,
    }
}

/// Groups a thread's share of the cells is cut into. Few and large: at 1M
/// points a group's levels (about 33 MB) stay above glibc's largest mmap
/// threshold (32 MB), so a dropped binding's memory goes back to the
/// system; with eight a thread (11 MB each) glibc kept them in its arenas
/// and `bench --scene 1m`, which holds two bindings at once, peaked 70 MB
/// higher. Two a thread bind as fast (measured: 115-120 ms either way).
const GROUPS_PER_THREAD: usize = 2;

/// Consecutive runs of cells, about `tasks` of them, about equal in points.
fn group_ranges(cells: &[(usize, usize)], tasks: usize) -> Vec<Range<usize>> {
    let total = cells.last().map_or(0, |c| c.1) - cells.first().map_or(0, |c| c.0);
    let share = total.div_ceil(tasks.max(1)).max(1);
    let mut out = Vec::with_capacity(tasks + 1);
    let (mut from, mut points) = (0, 0);
    for (k, &(s, e)) in cells.iter().enumerate() {
        points += e - s;
        if points >= share {
            out.push(from..k + 1);
            (from, points) = (k + 1, 0);
        }
    }
    if from < cells.len() {
        out.push(from..cells.len());
    }
    out
}

/// Builds group `k` (the cells `range`) whole: each cell's candidates
/// gathered once, each point's mask and weights written straight after
/// the previous point's. Returns the group, its cells and its hits.
fn group<P: Point>(
    support: &Support<'_>,
    rest: &[P],
    all_cells: &[(usize, usize)],
    k: usize,
    range: Range<usize>,
    mut g: Group,
    (cand, lanes, xs): &mut Scratch,
) -> (Group, Vec<Cell>, usize) {
    let cpu = (Avx2Fma::detect(), Avx512::detect());
    let cell_points = |(s, e): (usize, usize)| rest[s..e].iter().map(|p| p.to_dvec3());
    // A recycled group's arrays keep their memory.
    g.ids.clear();
    g.masks.clear();
    g.levels.clear();
    let mut cells = Vec::with_capacity(range.len());
    let mut hits = 0;
    let group_points: usize = all_cells[range.clone()].iter().map(|c| c.1 - c.0).sum();
    for (n, &(s, e)) in all_cells[range].iter().enumerate() {
        gather(support, cand, cell_points((s, e)));
        lanes.pad(cand);
        let nb = cand.len().div_ceil(BLOCK);
        let cell = Cell {
            point: s,
            points: e - s,
            group: k,
            id: g.ids.len(),
            blocks: nb,
            mask: g.masks.len(),
            level: g.levels.len(),
        };
        g.ids.extend_from_slice(cand.ids());
        g.ids.resize(cell.id + nb * BLOCK, PADDING);
        g.masks.resize(cell.mask + cell.points * nb, 0);
        // Room for every candidate of every point (and the vector stores'
        // tail), written without zeroing first.
        let room = LEVEL_BYTES * cell.points * nb * BLOCK + LEVEL_TAIL;
        if n == 0 {
            // The first cell as the group's guess: one allocation for the
            // group's arrays, most of the time (a copy when they grow).
            g.masks.reserve(group_points * nb * 5 / 4);
            g.levels
                .reserve(LEVEL_BYTES * group_points * nb * BLOCK * 3 / 4 + room);
        }
        g.levels.reserve(room);
        let spare = &mut g.levels.spare_capacity_mut()[..room];
        xs.clear();
        xs.extend(cell_points((s, e)));
        let rows = &mut g.masks[cell.mask..];
        let (kernel, radius) = (support.kernel, support.radius);
        let w = fill_cell(cpu, lanes, xs, kernel, radius, rows, spare);
        // SAFETY: `fill_cell` initialised the hits' levels, point after
        // point: the first `3 w` bytes of the spare capacity (and
        // `3 w <= room`, the capacity reserved).
        #[allow(unsafe_code)]
        unsafe {
            g.levels.set_len(cell.level + LEVEL_BYTES * w)
        };
        hits += w;
        cells.push(cell);
    }
    // The product's loads reach up to eight levels for every byte of a
    // row, and the tail, past the row's first level: zeros after the last.
    let longest = cells.iter().map(|c| c.blocks).max().unwrap_or(0);
    let end = g.levels.len();
    g.levels
        .resize(end + LEVEL_BYTES * BLOCK * longest + LEVEL_TAIL, 0);
    g.levels.shrink_to_fit();
    g.masks.shrink_to_fit();
    g.ids.shrink_to_fit();
    (g, cells, hits)
}

/// A task's scratch: a cell's candidates, their coordinates in lanes, and
/// its points.
type Scratch = (Candidates, Lanes, Vec<DVec3>);

/// The starts within R of the finite ones of a cell's points.
fn gather(support: &Support<'_>, cand: &mut Candidates, points: impl Iterator<Item = DVec3>) {
    let finite = points.filter(|x| x.is_finite());
    cand.gather(support.octree, finite, support.radius);
}
