use glam::DVec3;

use super::Octree;

impl Octree {
    /// Calls `f(index, distance²)` for every point closer than `radius` to `q`
    /// (strictly: points at exactly `radius` get a zero kernel weight anyway).
    pub fn for_each_within(&self, q: DVec3, radius: f64, mut f: impl FnMut(u32, f64)) {
        let r2 = radius * radius;
        self.visit(
            |min, max| box_distance2(q, min, max) < r2,
            |p, id| {
                let d2 = p.distance_squared(q);
                if d2 < r2 {
                    f(id, d2);
                }
            },
        );
    }

    /// The point nearest `q` and its distance², None for an empty tree
    /// (ties go to the one met first).
    pub fn nearest(&self, q: DVec3) -> Option<(u32, f64)> {
        let best = std::cell::Cell::new((u32::MAX, f64::INFINITY));
        self.visit(
            |min, max| box_distance2(q, min, max) < best.get().1,
            |p, id| {
                let d2 = p.distance_squared(q);
                if d2 < best.get().1 {
                    best.set((id, d2));
                }
            },
        );
        let (id, d2) = best.get();
        (id != u32::MAX).then_some((id, d2))
    }

    /// The indices of every point closer than `radius` to `q`, in no set order.
    #[cfg(test)]
    pub fn within(&self, q: DVec3, radius: f64) -> Vec<u32> {
        let mut out = Vec::new();
        self.for_each_within(q, radius, |i, _| out.push(i));
        out
    }

    /// Calls `f(index, point)` for every point closer than `radius` to the box
    /// `[min, max]`: the candidates for any query point inside that box.
    pub fn for_each_near_box(
        &self,
        min: DVec3,
        max: DVec3,
        radius: f64,
        mut f: impl FnMut(u32, DVec3),
    ) {
        let r2 = radius * radius;
        self.for_each_leaf_near_box(min, max, radius, |points, ids| {
            for (&p, &id) in points.iter().zip(ids) {
                if box_distance2(p, min, max) < r2 {
                    f(id, p);
                }
            }
        });
    }

    /// Appends the index of every point closer than `radius` to the box
    /// `[min, max]` to `ids` and its coordinates in `frame` to `coords`:
    /// from the tree's grid ([`Octree::grid`]) when the tree holds
    /// [`GRID_POINTS`] points or more and its grid is for `radius`, else
    /// from its walk, leaf by leaf. Either way each point of a run is
    /// written and kept or not with no branch. The order depends on which
    /// answers, and that on the tree and the radius alone (so two callers
    /// with the same tree and radius agree).
    pub(crate) fn near_box_into(
        &self,
        (min, max): (DVec3, DVec3),
        radius: f64,
        ids: &mut Vec<u32>,
        coords: &mut [Vec<f32>; 3],
        frame: impl Fn(DVec3) -> [f32; 3],
    ) {
        if self.points.len() >= GRID_POINTS
            && let Some(grid) = self.grid(radius)
        {
            grid.near_box_into((min, max), ids, coords, frame);
            return;
        }
        let r2 = radius * radius;
        self.for_each_leaf_near_box(min, max, radius, |points, leaf_ids| {
            append_near(points, leaf_ids, (min, max), r2, (ids, coords), &frame);
        });
    }

    /// Builds what [`Octree::near_box_into`] will ask for at `radius` (the
    /// grid, when the tree has one), before many threads ask at once.
    pub(crate) fn prepare_box_queries(&self, radius: f64) {
        if self.points.len() >= GRID_POINTS {
            self.grid(radius);
        }
    }

    /// Calls `leaf(points, indices)` for every leaf whose bounds are closer
    /// than `radius` to the box `[min, max]` (its points may be farther:
    /// the caller tests each, [`box_distance2`]), in the order
    /// [`Octree::for_each_near_box`] meets them.
    pub(crate) fn for_each_leaf_near_box(
        &self,
        min: DVec3,
        max: DVec3,
        radius: f64,
        mut leaf: impl FnMut(&[DVec3], &[u32]),
    ) {
        let r2 = radius * radius;
        let Some(root) = self.nodes.first() else {
            return;
        };
        let near = |n: &super::Node| box_box_distance2(min, max, n.min, n.max) < r2;
        if !near(root) {
            return;
        }
        // Depth first, as `visit`; a child is tested when its parent is
        // opened and pushed only when near, with no branch (the test fails
        // about as often as it passes, which a branch would mispredict).
        let mut stack = [0u32; 8 * (Self::MAX_DEPTH as usize + 1)];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let node = self.nodes[stack[top] as usize];
            if node.children == 0 {
                let r = node.start as usize..node.end as usize;
                leaf(&self.points[r.clone()], &self.ids[r]);
                continue;
            }
            for c in 0..node.children {
                let child = node.first_child + c;
                stack[top] = child;
                top += usize::from(near(&self.nodes[child as usize]));
            }
        }
    }

    /// Every leaf: its points' indices, the points, and its tight bounds.
    /// Together the leaves hold each point once.
    pub(crate) fn leaves(&self) -> impl Iterator<Item = (&[u32], &[DVec3], DVec3, DVec3)> {
        self.nodes.iter().filter(|n| n.children == 0).map(|n| {
            let r = n.start as usize..n.end as usize;
            (&self.ids[r.clone()], &self.points[r], n.min, n.max)
        })
    }

    /// Depth-first walk: descends into nodes whose bounds pass `keep`, and
    /// hands every point of a kept leaf to `point`.
    #[inline]
    fn visit(&self, keep: impl Fn(DVec3, DVec3) -> bool, mut point: impl FnMut(DVec3, u32)) {
        if self.nodes.is_empty() {
            return;
        }
        let mut stack = [0u32; 8 * (Self::MAX_DEPTH as usize + 1)];
        let mut top = 1;
        stack[0] = 0;
        while top > 0 {
            top -= 1;
            let node = self.nodes[stack[top] as usize];
            if !keep(node.min, node.max) {
                continue;
            }
            if node.children == 0 {
                let (s, e) = (node.start as usize, node.end as usize);
                for (p, id) in self.points[s..e].iter().zip(&self.ids[s..e]) {
                    point(*p, *id);
                }
            } else {
                for c in 0..node.children {
                    stack[top] = node.first_child + c;
                    top += 1;
                }
            }
        }
    }
}

/// Trees with fewer points answer box queries by their walk: a grid costs
/// more to build than it saves (it is built with each new system's first
/// evaluation). At 1,000 starts both answer as fast, at 10,000 the grid
/// 0.5 ms faster an evaluation of 1M points; at 92 (the papers' fish) the
/// walk 0.015 ms faster.
pub(crate) const GRID_POINTS: usize = 2048;

/// Appends each of `points` (with its index in `point_ids`) closer than
/// sqrt(r2) to the box `[min, max]`: every point written at the end, and
/// the end advanced past the near ones (room for all first, the rest cut
/// after), so no branch decides.
#[inline]
pub(super) fn append_near(
    points: &[DVec3],
    point_ids: &[u32],
    (min, max): (DVec3, DVec3),
    r2: f64,
    (ids, coords): (&mut Vec<u32>, &mut [Vec<f32>; 3]),
    frame: &impl Fn(DVec3) -> [f32; 3],
) {
    let mut end = ids.len();
    let room = end + points.len();
    ids.resize(room, 0);
    for v in coords.iter_mut() {
        v.resize(room, 0.0);
    }
    for (&p, &id) in points.iter().zip(point_ids) {
        let u = frame(p);
        ids[end] = id;
        for (v, u) in coords.iter_mut().zip(u) {
            v[end] = u;
        }
        end += usize::from(box_distance2(p, min, max) < r2);
    }
    ids.truncate(end);
    for v in coords.iter_mut() {
        v.truncate(end);
    }
}

/// Squared distance from a point to a box (0 inside).
#[inline]
pub(crate) fn box_distance2(p: DVec3, min: DVec3, max: DVec3) -> f64 {
    let d = (min - p).max(p - max).max(DVec3::ZERO);
    d.length_squared()
}

/// Squared distance between two boxes (0 when they overlap).
#[inline]
fn box_box_distance2(amin: DVec3, amax: DVec3, bmin: DVec3, bmax: DVec3) -> f64 {
    let d = (amin - bmax).max(bmin - amax).max(DVec3::ZERO);
    d.length_squared()
}
