//! Making a [`Binding`]: the points are sorted into cells about R/2 wide (as
//! the evaluation sorts them), the cells cut into groups of consecutive
//! cells about equal in points (the points copied in cell order first, so a
//! cell reads its own as one run), and each group built whole by one task into
//! arrays of its own: each cell's candidate starts, by index and in lanes,
//! exactly as the evaluation gathers them. One pass, and no copy to join
//! the groups (the product reads each cell from its group).

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use std::ops::Range;

use std::sync::OnceLock;

use super::{Binding, Cell, Group, Rest, Support};
use crate::evaluate::{Blocks, PARALLEL_POINTS, Point, Points};
use crate::lanes::{centre, finite_bounds, gather_candidates, narrow};

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
    // The starts' grid built before the groups ask for it at once.
    support.octree.prepare_box_queries(support.radius);
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
    let make = |(k, (range, g)): (usize, (Range<usize>, Group))| {
        group(support, &rest, &blocks.cells, k, range, g)
    };
    let made: Vec<(Group, Vec<Cell>)> = if parallel {
        ranges
            .into_par_iter()
            .zip(recycled)
            .enumerate()
            .map(make)
            .collect()
    } else {
        ranges
            .into_iter()
            .zip(recycled)
            .enumerate()
            .map(make)
            .collect()
    };
    let mut cells = Vec::with_capacity(blocks.cells.len());
    let mut groups = Vec::with_capacity(made.len());
    for (g, c) in made {
        groups.push(g);
        cells.extend(c);
    }
    let order = (!blocks.identity).then_some(blocks.order);
    Binding {
        kernel: support.kernel,
        radius: support.radius,
        starts: support.starts,
        fingerprint: support.fingerprint,
        octree: support.octree.clone(),
        cells,
        groups,
        rest: kind(rest),
        order,
        pairs: OnceLock::new(),
    }
}

/// Groups a thread's share of the cells is cut into: a few, so that a
/// thread that finishes early takes another's.
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

/// Builds group `k` (the cells `range`) whole: each cell's candidates,
/// by index and in lanes about the cell's centre, after the previous
/// cell's. Returns the group and its cells.
fn group<P: Point>(
    support: &Support<'_>,
    rest: &[P],
    all_cells: &[(usize, usize)],
    k: usize,
    range: Range<usize>,
    mut g: Group,
) -> (Group, Vec<Cell>) {
    // A recycled group's arrays keep their memory.
    g.ids.clear();
    for v in &mut g.xyz {
        v.clear();
    }
    let mut cells = Vec::with_capacity(range.len());
    for &(s, e) in &all_cells[range] {
        // The evaluation's cell, its frame and its candidates
        // (`crate::lanes::displacements`), so that a product gives its
        // values bit for bit.
        let bounds = finite_bounds(rest[s..e].iter().map(|p| p.to_dvec3()));
        let narrow = narrow(bounds, support.radius);
        let id = g.ids.len();
        if narrow {
            gather_candidates(
                support.octree,
                bounds,
                support.radius,
                &mut g.ids,
                &mut g.xyz,
            );
        }
        cells.push(Cell {
            point: s,
            points: e - s,
            group: k,
            id,
            candidates: g.ids.len() - id,
            centre: centre(bounds),
            narrow,
        });
    }
    (g, cells)
}
