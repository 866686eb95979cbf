//! A variable-depth octree over points, answering "all points within R of q".
//!
//! Nodes keep the tight bounding box of their points, so a query prunes any
//! node whose box is farther than R from the query. Leaves hold at most
//! [`Octree::LEAF_SIZE`] points, except where points coincide or the depth limit
//! is reached.

mod build;
mod grid;
mod query;

use std::sync::OnceLock;

use glam::DVec3;

pub(crate) use grid::Grid;
#[cfg(test)]
pub(crate) use query::GRID_POINTS;

/// An octree over a fixed set of points. Points are referred to by their index
/// in the slice the tree was built from.
#[derive(Clone, Debug, Default)]
pub struct Octree {
    /// Points in leaf order.
    points: Vec<DVec3>,
    /// `ids[i]` is the caller's index of `points[i]`.
    ids: Vec<u32>,
    nodes: Vec<Node>,
    /// The points in a grid for box queries of one radius, built when
    /// first asked ([`Octree::grid`]).
    grid: OnceLock<Grid>,
}

#[derive(Clone, Copy, Debug)]
struct Node {
    /// Tight bounds of the node's points.
    min: DVec3,
    max: DVec3,
    /// Range of the node's points in `Octree::points`.
    start: u32,
    end: u32,
    /// Index of the first child in `Octree::nodes`; children are contiguous.
    first_child: u32,
    /// Number of children; 0 for a leaf.
    children: u32,
}

impl Octree {
    /// Most points in a leaf that can still be split.
    pub const LEAF_SIZE: usize = 12;
    /// Deepest level; below it points are left in one leaf.
    pub const MAX_DEPTH: u32 = 24;

    /// The points in a grid for box queries of `radius`: built on the first
    /// call, for its radius, and kept. `None` for any other radius: a tree
    /// serves one radius (its system's, and its bindings', which share it),
    /// and a caller asking for another walks the tree rather than build a
    /// grid a query.
    pub(crate) fn grid(&self, radius: f64) -> Option<&Grid> {
        let grid = self
            .grid
            .get_or_init(|| Grid::new(&self.points, &self.ids, radius));
        (grid.radius() == radius).then_some(grid)
    }

    /// Depth of the deepest leaf (the root has depth 0).
    #[cfg(test)]
    pub fn depth(&self) -> u32 {
        fn walk(t: &Octree, n: usize, d: u32) -> u32 {
            let node = t.nodes[n];
            (0..node.children)
                .map(|c| walk(t, (node.first_child + c) as usize, d + 1))
                .max()
                .unwrap_or(d)
        }
        if self.nodes.is_empty() {
            0
        } else {
            walk(self, 0, 0)
        }
    }
}

#[cfg(test)]
mod tests;
