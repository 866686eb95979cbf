//! Making a [`Binding`]: the points are sorted into cells about R/2 wide (as
//! the evaluation sorts them) and each cell gathers its candidate starts
//! once. A first parallel pass counts every cell's candidates and hits; the
//! arrays are then allocated whole, and a second pass fills each cell's own
//! slices of them (no per-cell vectors to join).

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use super::weights::{Lanes, count_row, fill_row};
use super::{BLOCK, Binding, Cell, Rest, Support};
use crate::evaluate::{Blocks, Candidates, PARALLEL_POINTS, Point, Points};
use crate::simd::Avx2Fma;

/// Marks a padding candidate in `ids` (no start has this index).
pub(super) const PADDING: u32 = u32::MAX;

pub(super) fn dispatch<P: Point>(support: &Support<'_>, points: &[P]) -> Binding {
    match P::slice(points) {
        Points::F32(p) => of_f32(support, p),
        Points::F64(p) => of_f64(support, p),
    }
}

// The hot loops, compiled here (not in the caller's crate) for each kind.
#[inline(never)]
fn of_f32(support: &Support<'_>, points: &[Vec3]) -> Binding {
    build(support, points, Rest::F32)
}

#[inline(never)]
fn of_f64(support: &Support<'_>, points: &[DVec3]) -> Binding {
    build(support, points, Rest::F64)
}

/// One cell's slices of the binding's arrays, filled by the second pass.
struct Slices<'a> {
    cell: Cell,
    ids: &'a mut [u32],
    masks: &'a mut [u8],
    weights: &'a mut [f32],
}

fn build<P: Point>(
    support: &Support<'_>,
    points: &[P],
    kind: impl FnOnce(Vec<P>) -> Rest,
) -> Binding {
    let blocks = Blocks::for_starts(points, support.radius, support.starts);
    let parallel = points.len() >= PARALLEL_POINTS;
    let radius = support.radius;
    let cpu = Avx2Fma::detect();
    let cell_points = |(s, e): (usize, usize)| {
        blocks.order[s..e]
            .iter()
            .map(|&i| points[i as usize].to_dvec3())
    };
    // First pass: each cell's candidates and hits.
    let count = |(cand, lanes): &mut (Candidates, Lanes), &(s, e): &(usize, usize)| {
        gather(support, cand, cell_points((s, e)));
        lanes.pad(cand);
        let hits: usize = cell_points((s, e))
            .filter(|x| x.is_finite())
            .map(|x| count_row(cpu, lanes, x, radius))
            .sum();
        (cand.len(), hits)
    };
    let counts: Vec<(usize, usize)> = if parallel {
        blocks
            .cells
            .par_iter()
            .with_min_len(2)
            .map_init(Default::default, count)
            .collect()
    } else {
        let mut scratch = Default::default();
        blocks
            .cells
            .iter()
            .map(|c| count(&mut scratch, c))
            .collect()
    };
    let cells = layout(&blocks.cells, &counts);
    let last = cells.last().copied().unwrap_or_default();
    let mut ids = vec![PADDING; last.id + last.blocks * BLOCK];
    let mut masks = vec![0u8; last.mask + last.points * last.blocks];
    let total: usize = counts.iter().map(|c| c.1).sum();
    let longest = cells.iter().map(|c| c.blocks).max().unwrap_or(0);
    let mut weights = vec![0.0f32; total + BLOCK * (longest + 1)];
    // Second pass: the same candidates again, each cell into its slices.
    let fill = |(cand, lanes): &mut (Candidates, Lanes), s: Slices<'_>| {
        let c = s.cell;
        gather(support, cand, cell_points((c.point, c.point + c.points)));
        s.ids[..cand.len()].copy_from_slice(cand.ids());
        lanes.pad(cand);
        let mut w = 0;
        let rows = s.masks.chunks_exact_mut(c.blocks.max(1));
        for (x, row) in cell_points((c.point, c.point + c.points)).zip(rows) {
            if x.is_finite() {
                w += fill_row(
                    cpu,
                    lanes,
                    x,
                    support.kernel,
                    radius,
                    row,
                    &mut s.weights[w..],
                );
            }
        }
    };
    let slices = split(&cells, &mut ids, &mut masks, &mut weights[..total]);
    if parallel {
        slices
            .into_par_iter()
            .with_min_len(2)
            .for_each_init(Default::default, fill);
    } else {
        let mut scratch = Default::default();
        slices.into_iter().for_each(|s| fill(&mut scratch, s));
    }
    let (rest, slot) = if blocks.identity {
        (points.to_vec(), None)
    } else {
        let mut slot = vec![0u32; points.len()];
        for (k, &i) in blocks.order.iter().enumerate() {
            slot[i as usize] = k as u32;
        }
        let rest = blocks.order.iter().map(|&i| points[i as usize]).collect();
        (rest, Some(slot))
    };
    Binding {
        kernel: support.kernel,
        radius,
        starts: support.starts,
        fingerprint: support.fingerprint,
        cells,
        ids,
        rest: kind(rest),
        slot,
        masks,
        weights,
        pairs: total,
    }
}

/// The starts within R of the finite ones of a cell's points.
fn gather(support: &Support<'_>, cand: &mut Candidates, points: impl Iterator<Item = DVec3>) {
    let finite = points.filter(|x| x.is_finite());
    cand.gather(support.octree, finite, support.radius);
}

/// Where each cell's rows start, from its (candidates, hits).
fn layout(cells: &[(usize, usize)], counts: &[(usize, usize)]) -> Vec<Cell> {
    let (mut id, mut mask, mut weight) = (0, 0, 0);
    cells
        .iter()
        .zip(counts)
        .map(|(&(s, e), &(candidates, hits))| {
            let blocks = candidates.div_ceil(BLOCK);
            let cell = Cell {
                point: s,
                points: e - s,
                id,
                blocks,
                mask,
                weight,
            };
            id += blocks * BLOCK;
            mask += (e - s) * blocks;
            weight += hits;
            cell
        })
        .collect()
}

/// Cuts the arrays into each cell's slices.
fn split<'a>(
    cells: &[Cell],
    mut ids: &'a mut [u32],
    mut masks: &'a mut [u8],
    mut weights: &'a mut [f32],
) -> Vec<Slices<'a>> {
    let mut out = Vec::with_capacity(cells.len());
    for (k, c) in cells.iter().enumerate() {
        let hits = cells
            .get(k + 1)
            .map_or(weights.len(), |n| n.weight - c.weight);
        let (i, rest) = std::mem::take(&mut ids).split_at_mut(c.blocks * BLOCK);
        let (m, rest_m) = std::mem::take(&mut masks).split_at_mut(c.points * c.blocks);
        let (w, rest_w) = std::mem::take(&mut weights).split_at_mut(hits);
        (ids, masks, weights) = (rest, rest_m, rest_w);
        out.push(Slices {
            cell: *c,
            ids: i,
            masks: m,
            weights: w,
        });
    }
    out
}
