//! The tree's points bucketed into a uniform grid for box queries of one
//! radius: the cells about R/2 wide, x fastest, so that the points near a
//! box are a few runs of consecutive points, one a row of cells, each
//! tested with no branch. An evaluation asks one such query per cell of
//! points (thousands a frame); the tree's walk to the same points cost a
//! test and a mispredicted branch a node.

use glam::DVec3;

use super::query::append_near;

/// Most cells a grid has, for `n` points: a few per point (the cells' first
/// points are 4 bytes a cell, and a grid is built with each new system's
/// first evaluation: a few dozen starts must not pay for thousands of
/// cells), at most 4M cells (16 MB). Past that the cells grow wider than
/// R/2, and a query tests more points.
fn max_cells(n: usize) -> usize {
    (8 * n).clamp(64, 1 << 22)
}

/// The points of an [`super::Octree`] in a uniform grid, for box queries of
/// radius [`Grid::radius`].
#[derive(Clone, Debug)]
pub(crate) struct Grid {
    radius: f64,
    /// The corner of cell (0, 0, 0).
    lo: DVec3,
    /// The cells' width and its inverse.
    h: f64,
    inv_h: f64,
    /// What a slab's distance from a box is lowered by before it prunes a
    /// row: more than the rounding of the slabs' bounds and of the points'
    /// cells, so a row is never pruned while one of its points is within
    /// R of the box.
    slack: f64,
    dims: [usize; 3],
    /// Cell `c`'s points are `first[c]..first[c + 1]` of the arrays below
    /// (cells x fastest, then y, then z).
    first: Vec<u32>,
    points: Vec<DVec3>,
    ids: Vec<u32>,
}

impl Grid {
    /// The grid of `points` (`ids[k]` the caller's index of `points[k]`)
    /// for queries of `radius`.
    pub(crate) fn new(points: &[DVec3], ids: &[u32], radius: f64) -> Grid {
        let finite = points.iter().filter(|p| p.is_finite());
        let (lo, hi) = finite.fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), p| (lo.min(*p), hi.max(*p)),
        );
        let (lo, extent) = if lo.x <= hi.x {
            (lo, hi - lo)
        } else {
            (DVec3::ZERO, DVec3::ZERO)
        };
        let cap = max_cells(points.len()) as f64;
        // Cells R/2 wide; one cell when that half is not a positive finite
        // width (a radius that underflows), and when the points span more
        // than f64 holds (an infinite width: `dims_of` gives 1, as NaN
        // counts as 0).
        let mut h = 0.5 * radius;
        if !(h > 0.0 && h.is_finite()) {
            h = extent.max_element().max(1.0);
        }
        let dims_of = |h: f64| (extent / h).floor().max(DVec3::ZERO) + 1.0;
        let mut dims = dims_of(h);
        // Each round widens the cells by 1 % at least (or to infinity, one
        // cell), so the loop ends.
        while !(dims.x * dims.y * dims.z <= cap) {
            let grow = ((dims.x * dims.y * dims.z) / cap).cbrt().max(1.01);
            h = if (h * grow).is_finite() {
                h * grow
            } else {
                f64::INFINITY
            };
            dims = dims_of(h);
        }
        let dims = [dims.x as usize, dims.y as usize, dims.z as usize];
        let mut grid = Grid {
            radius,
            lo,
            h,
            inv_h: 1.0 / h,
            slack: 1e-12 * (lo.abs().max_element() + extent.max_element() + h),
            dims,
            first: Vec::new(),
            points: Vec::with_capacity(points.len()),
            ids: Vec::with_capacity(points.len()),
        };
        // A counting sort by cell, each cell's points in the tree's order.
        let keys: Vec<usize> = points.iter().map(|p| grid.key(grid.cell(*p))).collect();
        let mut first = vec![0u32; dims[0] * dims[1] * dims[2] + 1];
        for &k in &keys {
            first[k + 1] += 1;
        }
        for c in 1..first.len() {
            first[c] += first[c - 1];
        }
        let mut next = first.clone();
        let mut order = vec![0usize; points.len()];
        for (k, &key) in keys.iter().enumerate() {
            order[next[key] as usize] = k;
            next[key] += 1;
        }
        grid.points.extend(order.iter().map(|&k| points[k]));
        grid.ids.extend(order.iter().map(|&k| ids[k]));
        grid.first = first;
        grid
    }

    /// The radius the grid answers queries of.
    pub(crate) fn radius(&self) -> f64 {
        self.radius
    }

    /// The cell of `p` by axis, clamped into the grid (NaN to 0).
    fn cell(&self, p: DVec3) -> [usize; 3] {
        let c = (p - self.lo) * self.inv_h;
        std::array::from_fn(|a| {
            // `max` and `min` ignore NaN; `as` saturates.
            c[a].max(0.0).min((self.dims[a] - 1) as f64) as usize
        })
    }

    fn key(&self, [x, y, z]: [usize; 3]) -> usize {
        x + self.dims[0] * (y + self.dims[1] * z)
    }

    /// How far the slab of cells `i` along axis `a` lies from `lo..hi` on
    /// that axis, less the slack (0 when they overlap).
    fn gap(&self, a: usize, i: usize, (lo, hi): (f64, f64)) -> f64 {
        let below = self.lo[a] + i as f64 * self.h;
        let above = below + self.h;
        // `f64::max` ignores NaN: a NaN slab (infinite cells) prunes
        // nothing.
        ((lo - above).max(below - hi) - self.slack).max(0.0)
    }

    /// Appends the index of every point closer than the grid's radius to
    /// the box `[min, max]` to `ids` and its coordinates in `frame` to
    /// `coords`: the rows of cells within reach, cell by cell, each cell's
    /// points in the grid's order, a row's points tested with no branch.
    pub(crate) fn near_box_into(
        &self,
        (min, max): (DVec3, DVec3),
        ids: &mut Vec<u32>,
        coords: &mut [Vec<f32>; 3],
        frame: impl Fn(DVec3) -> [f32; 3],
    ) {
        if self.points.is_empty() {
            return;
        }
        let r = self.radius;
        let r2 = r * r;
        let (a, b) = (self.cell(min - r), self.cell(max + r));
        for z in a[2]..=b[2] {
            let gz = self.gap(2, z, (min.z, max.z));
            if gz * gz >= r2 {
                continue;
            }
            for y in a[1]..=b[1] {
                let gy = self.gap(1, y, (min.y, max.y));
                if gy * gy + gz * gz >= r2 {
                    continue;
                }
                let from = self.first[self.key([a[0], y, z])] as usize;
                let to = self.first[self.key([b[0], y, z]) + 1] as usize;
                if from == to {
                    continue;
                }
                let r = from..to;
                let near = (&self.points[r.clone()], &self.ids[r]);
                append_near(near.0, near.1, (min, max), r2, (ids, coords), &frame);
            }
        }
    }
}
