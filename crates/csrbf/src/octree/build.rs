use glam::DVec3;

use super::{Node, Octree};

impl Octree {
    /// Builds the tree over `points`; `points[i]` is reported as index `i`.
    ///
    /// Non-finite points are the caller's to reject; they end in one leaf.
    pub fn new(points: &[DVec3]) -> Octree {
        let mut tree = Octree {
            points: points.to_vec(),
            ids: (0..points.len() as u32).collect(),
            nodes: Vec::with_capacity(points.len() / 4 + 1),
            grid: std::sync::OnceLock::new(),
        };
        if points.is_empty() {
            return tree;
        }
        let (min, max) = bounds(&tree.points);
        let half = (max - min).max_element() * 0.5;
        let center = (min + max) * 0.5;
        tree.nodes.push(Node {
            min,
            max,
            start: 0,
            end: points.len() as u32,
            first_child: 0,
            children: 0,
        });
        let mut scratch_p = Vec::new();
        let mut scratch_i = Vec::new();
        tree.split(0, center, half, 0, &mut scratch_p, &mut scratch_i);
        tree
    }

    /// Splits node `n` (a cube of the given centre and half-width) into
    /// octants, recursively.
    fn split(
        &mut self,
        n: usize,
        center: DVec3,
        half: f64,
        depth: u32,
        scratch_p: &mut Vec<DVec3>,
        scratch_i: &mut Vec<u32>,
    ) {
        let node = self.nodes[n];
        let (s, e) = (node.start as usize, node.end as usize);
        if e - s <= Self::LEAF_SIZE
            || depth >= Self::MAX_DEPTH
            || node.min == node.max
            || !(half > 0.0)
        {
            return;
        }
        // Counting sort of the node's points by octant.
        let octant = |p: DVec3| -> usize {
            (p.x >= center.x) as usize
                | ((p.y >= center.y) as usize) << 1
                | ((p.z >= center.z) as usize) << 2
        };
        let mut counts = [0usize; 8];
        for p in &self.points[s..e] {
            counts[octant(*p)] += 1;
        }
        let mut offsets = [0usize; 9];
        for o in 0..8 {
            offsets[o + 1] = offsets[o] + counts[o];
        }
        scratch_p.clear();
        scratch_p.resize(e - s, DVec3::ZERO);
        scratch_i.clear();
        scratch_i.resize(e - s, 0);
        let mut next = offsets;
        for k in s..e {
            let o = octant(self.points[k]);
            scratch_p[next[o]] = self.points[k];
            scratch_i[next[o]] = self.ids[k];
            next[o] += 1;
        }
        self.points[s..e].copy_from_slice(scratch_p);
        self.ids[s..e].copy_from_slice(scratch_i);

        let first_child = self.nodes.len();
        let mut children = Vec::with_capacity(8);
        for o in 0..8 {
            if counts[o] == 0 {
                continue;
            }
            let cs = s + offsets[o];
            let ce = s + offsets[o + 1];
            let (min, max) = bounds(&self.points[cs..ce]);
            let h = half * 0.5;
            let c = center
                + DVec3::new(
                    if o & 1 != 0 { h } else { -h },
                    if o & 2 != 0 { h } else { -h },
                    if o & 4 != 0 { h } else { -h },
                );
            children.push((c, h));
            self.nodes.push(Node {
                min,
                max,
                start: cs as u32,
                end: ce as u32,
                first_child: 0,
                children: 0,
            });
        }
        self.nodes[n].first_child = first_child as u32;
        self.nodes[n].children = children.len() as u32;
        for (k, (c, h)) in children.into_iter().enumerate() {
            self.split(first_child + k, c, h, depth + 1, scratch_p, scratch_i);
        }
    }
}

/// Tight bounds of a non-empty slice of points.
pub(crate) fn bounds(points: &[DVec3]) -> (DVec3, DVec3) {
    points.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    )
}
