//! A bounding volume hierarchy over triangles, for picking: the closest
//! triangle a ray hits. Built once (median splits along the longest axis of
//! the centroids' box), refitted when the vertices move (same tree, new
//! boxes), queried front to back.
//!
//! ```
//! use csrbf_mesh::{Bvh, Ray};
//! use glam::Vec3;
//!
//! let positions = [Vec3::ZERO, Vec3::X, Vec3::Y];
//! let bvh = Bvh::new(&positions, &[[0, 1, 2]]);
//! let hit = bvh.cast(&positions, &Ray::new(Vec3::new(0.2, 0.2, 1.0), Vec3::NEG_Z)).unwrap();
//! assert_eq!(hit.triangle, 0);
//! assert!((hit.point - Vec3::new(0.2, 0.2, 0.0)).length() < 1e-6);
//! ```

use glam::{DVec3, Vec3};

/// A half-line: `origin + t * dir` for t >= 0.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Where it starts.
    pub origin: Vec3,
    /// Its direction (unit length from [`Ray::new`]).
    pub dir: Vec3,
}

impl Ray {
    /// A ray from `origin` along `dir` (normalised).
    pub fn new(origin: Vec3, dir: Vec3) -> Ray {
        Ray {
            origin,
            dir: dir.normalize_or_zero(),
        }
    }

    /// The point at distance `t` along the ray.
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.dir * t
    }
}

/// Where a ray meets a triangle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Index of the triangle in the list the tree was built on.
    pub triangle: u32,
    /// Distance along the ray.
    pub t: f32,
    /// Barycentric weights of the triangle's three corners.
    pub barycentric: [f32; 3],
    /// The point on the triangle (from the barycentric weights, not the ray).
    pub point: Vec3,
}

impl Hit {
    /// The same point of the surface in other positions of the mesh (its
    /// rest pose, say, when the tree was cast on the deformed one): the
    /// barycentric weights applied to the hit triangle's corners there.
    pub fn point_in(&self, triangles: &[[u32; 3]], positions: &[Vec3]) -> Vec3 {
        let tri = triangles[self.triangle as usize];
        let w = self.barycentric;
        (0..3).map(|k| positions[tri[k] as usize] * w[k]).sum()
    }

    /// The corner of the hit triangle nearest the hit (largest weight).
    pub fn nearest_vertex(&self, triangles: &[[u32; 3]]) -> u32 {
        let tri = triangles[self.triangle as usize];
        let w = self.barycentric;
        (0..3)
            .max_by(|&a, &b| w[a].total_cmp(&w[b]))
            .map_or(tri[0], |k| tri[k])
    }
}

#[derive(Clone, Copy, Debug)]
struct Node {
    lo: Vec3,
    hi: Vec3,
    /// Leaf: first index into `order`; interior: index of the left child
    /// (the right one follows it).
    first: u32,
    /// Leaf: number of triangles; interior: 0.
    count: u32,
}

impl Node {
    /// Interior nodes have no triangles of their own and children after them.
    fn is_leaf(&self) -> bool {
        self.count > 0 || self.first == 0
    }
}

/// The tree. It keeps triangle indices only: the caller passes the same
/// positions and triangles to every call.
#[derive(Clone, Debug)]
pub struct Bvh {
    nodes: Vec<Node>,
    order: Vec<u32>,
    triangles: Vec<[u32; 3]>,
}

const LEAF: usize = 4;

impl Bvh {
    /// Builds the tree over `triangles` (vertex indices into `positions`).
    /// Triangles with an index out of range or a non-finite corner are left
    /// out (they cannot be hit).
    pub fn new(positions: &[Vec3], triangles: &[[u32; 3]]) -> Bvh {
        let valid = |t: &[u32; 3]| {
            t.iter()
                .all(|&i| positions.get(i as usize).is_some_and(|p| p.is_finite()))
        };
        let mut order: Vec<u32> = (0..triangles.len() as u32)
            .filter(|&i| valid(&triangles[i as usize]))
            .collect();
        let centroids: Vec<Vec3> = triangles
            .iter()
            .map(|t| {
                if valid(t) {
                    (positions[t[0] as usize] + positions[t[1] as usize] + positions[t[2] as usize])
                        / 3.0
                } else {
                    Vec3::ZERO
                }
            })
            .collect();
        let mut nodes = Vec::with_capacity(2 * order.len() / LEAF + 1);
        nodes.push(Node {
            lo: Vec3::ZERO,
            hi: Vec3::ZERO,
            first: 0,
            count: order.len() as u32,
        });
        // Split breadth by depth with an explicit stack: children always come
        // after their parent, so a refit walks the nodes backwards.
        let mut stack = vec![0usize];
        while let Some(n) = stack.pop() {
            let (first, count) = (nodes[n].first as usize, nodes[n].count as usize);
            if count <= LEAF {
                continue;
            }
            let slice = &mut order[first..first + count];
            let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
            for &t in slice.iter() {
                lo = lo.min(centroids[t as usize]);
                hi = hi.max(centroids[t as usize]);
            }
            let ext = hi - lo;
            let axis = if ext.x >= ext.y && ext.x >= ext.z {
                0
            } else if ext.y >= ext.z {
                1
            } else {
                2
            };
            let mid = count / 2;
            slice.select_nth_unstable_by(mid, |a, b| {
                centroids[*a as usize][axis].total_cmp(&centroids[*b as usize][axis])
            });
            let left = nodes.len();
            nodes.push(Node {
                lo: Vec3::ZERO,
                hi: Vec3::ZERO,
                first: first as u32,
                count: mid as u32,
            });
            nodes.push(Node {
                lo: Vec3::ZERO,
                hi: Vec3::ZERO,
                first: (first + mid) as u32,
                count: (count - mid) as u32,
            });
            nodes[n].first = left as u32;
            nodes[n].count = 0;
            stack.push(left);
            stack.push(left + 1);
        }
        let mut bvh = Bvh {
            nodes,
            order,
            triangles: triangles.to_vec(),
        };
        bvh.refit(positions);
        bvh
    }

    /// Number of triangles in the tree.
    pub fn len(&self) -> usize {
        self.order.len()
    }

    /// True when no triangle can be hit.
    pub fn is_empty(&self) -> bool {
        self.order.is_empty()
    }

    /// The triangles the tree was built on.
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// New boxes for moved vertices (same topology): linear in the nodes,
    /// much cheaper than a rebuild; picking stays exact, only slower when the
    /// motion is large.
    pub fn refit(&mut self, positions: &[Vec3]) {
        for n in (0..self.nodes.len()).rev() {
            let node = self.nodes[n];
            let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
            if node.is_leaf() {
                let range = node.first as usize..(node.first + node.count) as usize;
                for &t in &self.order[range] {
                    for &v in &self.triangles[t as usize] {
                        let p = positions.get(v as usize).copied().unwrap_or(Vec3::NAN);
                        lo = lo.min(p);
                        hi = hi.max(p);
                    }
                }
            } else {
                for c in [node.first as usize, node.first as usize + 1] {
                    lo = lo.min(self.nodes[c].lo);
                    hi = hi.max(self.nodes[c].hi);
                }
            }
            self.nodes[n].lo = lo;
            self.nodes[n].hi = hi;
        }
    }

    /// The closest triangle hit by the ray (both sides of a triangle count),
    /// or None.
    pub fn cast(&self, positions: &[Vec3], ray: &Ray) -> Option<Hit> {
        if self.order.is_empty() {
            return None;
        }
        let inv = ray.dir.recip();
        let mut best: Option<Hit> = None;
        let mut best_t = f32::INFINITY;
        let mut stack: Vec<(usize, f32)> = Vec::with_capacity(64);
        if let Some(t) = slab(&self.nodes[0], ray.origin, inv, best_t) {
            stack.push((0, t));
        }
        while let Some((n, entry)) = stack.pop() {
            if entry > best_t {
                continue;
            }
            let node = &self.nodes[n];
            if node.is_leaf() {
                let range = node.first as usize..(node.first + node.count) as usize;
                for &t in &self.order[range] {
                    if let Some(h) = triangle_hit(positions, self.triangles[t as usize], ray, t)
                        && h.t < best_t
                    {
                        best_t = h.t;
                        best = Some(h);
                    }
                }
                continue;
            }
            let (a, b) = (node.first as usize, node.first as usize + 1);
            let ta = slab(&self.nodes[a], ray.origin, inv, best_t);
            let tb = slab(&self.nodes[b], ray.origin, inv, best_t);
            // Push the farther child first so the nearer one is popped first.
            match (ta, tb) {
                (Some(x), Some(y)) if x <= y => {
                    stack.push((b, y));
                    stack.push((a, x));
                }
                (Some(x), Some(y)) => {
                    stack.push((a, x));
                    stack.push((b, y));
                }
                (Some(x), None) => stack.push((a, x)),
                (None, Some(y)) => stack.push((b, y)),
                (None, None) => {}
            }
        }
        best
    }
}

/// The point of the surface nearest a query: which triangle, where, and
/// how far.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Nearest {
    /// Index of the triangle (into the triangles the tree was built on).
    pub triangle: u32,
    /// The nearest point.
    pub point: Vec3,
    /// Its distance from the query.
    pub distance: f32,
}

impl Bvh {
    /// The point of the surface nearest `p` (ties: the first found), or
    /// None for an empty tree or a query that is not finite. Nodes are
    /// visited nearest box first and skipped once farther than the best.
    pub fn nearest(&self, positions: &[Vec3], p: Vec3) -> Option<Nearest> {
        if self.order.is_empty() || !p.is_finite() {
            return None;
        }
        let box_d2 = |n: &Node| (n.lo - p).max(p - n.hi).max(Vec3::ZERO).length_squared();
        let mut best: Option<(f32, u32, Vec3)> = None;
        let mut stack: Vec<(usize, f32)> = vec![(0, box_d2(&self.nodes[0]))];
        while let Some((n, d2)) = stack.pop() {
            if best.is_some_and(|b| d2 > b.0) {
                continue;
            }
            let node = &self.nodes[n];
            if node.is_leaf() {
                let range = node.first as usize..(node.first + node.count) as usize;
                for &t in &self.order[range] {
                    let tri = self.triangles[t as usize].map(|v| positions[v as usize]);
                    let q = closest_on_triangle(p, tri);
                    let e2 = q.distance_squared(p);
                    if best.is_none_or(|b| e2 < b.0) {
                        best = Some((e2, t, q));
                    }
                }
                continue;
            }
            let (a, b) = (node.first as usize, node.first as usize + 1);
            let (da, db) = (box_d2(&self.nodes[a]), box_d2(&self.nodes[b]));
            // The nearer child popped first.
            if da <= db {
                stack.push((b, db));
                stack.push((a, da));
            } else {
                stack.push((a, da));
                stack.push((b, db));
            }
        }
        best.map(|(d2, triangle, point)| Nearest {
            triangle,
            point,
            distance: d2.sqrt(),
        })
    }
}

/// The point of triangle `t` nearest `p` (Ericson, Real-Time Collision
/// Detection, 5.1.5: by the Voronoi region of `p`).
pub fn closest_on_triangle(p: Vec3, t: [Vec3; 3]) -> Vec3 {
    let [a, b, c] = t;
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = va + vb + vc;
    if !(denom.abs() > 0.0) {
        // A degenerate triangle: the nearest of its edges' points.
        return [(a, b), (b, c), (c, a)]
            .into_iter()
            .map(|(u, v)| {
                let e = v - u;
                let l2 = e.length_squared();
                let s = if l2 > 0.0 {
                    ((p - u).dot(e) / l2).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                u + e * s
            })
            .min_by(|x, y| x.distance_squared(p).total_cmp(&y.distance_squared(p)))
            .unwrap_or(a);
    }
    let (v, w) = (vb / denom, vc / denom);
    a + ab * v + ac * w
}

impl Bvh {
    /// Calls `f` with the triangles of every leaf whose box overlaps the box
    /// `[lo, hi]` (touching counts): every triangle that can meet that box,
    /// and a few more.
    pub fn for_each_overlap(&self, lo: Vec3, hi: Vec3, mut f: impl FnMut(u32)) {
        if self.order.is_empty() {
            return;
        }
        let overlaps = |n: &Node| n.lo.cmple(hi).all() && n.hi.cmpge(lo).all();
        let mut stack = vec![0usize];
        while let Some(n) = stack.pop() {
            let node = &self.nodes[n];
            if !overlaps(node) {
                continue;
            }
            if node.is_leaf() {
                let range = node.first as usize..(node.first + node.count) as usize;
                for &t in &self.order[range] {
                    f(t);
                }
            } else {
                stack.push(node.first as usize);
                stack.push(node.first as usize + 1);
            }
        }
    }
}

/// Entry distance of the ray into the box, if it enters before `limit`.
fn slab(node: &Node, origin: Vec3, inv: Vec3, limit: f32) -> Option<f32> {
    let t0 = (node.lo - origin) * inv;
    let t1 = (node.hi - origin) * inv;
    // NaN (0 * inf on a box face) is ignored by min/max of the other axes.
    let near = t0.min(t1).max_element().max(0.0);
    let far = t0.max(t1).min_element().min(limit);
    (near <= far).then_some(near)
}

/// Möller-Trumbore in f64 (robust for thin, far triangles), both sides.
fn triangle_hit(positions: &[Vec3], tri: [u32; 3], ray: &Ray, index: u32) -> Option<Hit> {
    let p = |i: u32| positions[i as usize].as_dvec3();
    let (a, b, c) = (p(tri[0]), p(tri[1]), p(tri[2]));
    let (o, d) = (ray.origin.as_dvec3(), ray.dir.as_dvec3());
    let (e1, e2) = (b - a, c - a);
    let h = d.cross(e2);
    let det = e1.dot(h);
    if det.abs() < 1e-300 {
        return None;
    }
    let f = 1.0 / det;
    let s = o - a;
    let u = f * s.dot(h);
    if !(-1e-12..=1.0 + 1e-12).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = f * d.dot(q);
    if v < -1e-12 || u + v > 1.0 + 1e-12 {
        return None;
    }
    let t = f * e2.dot(q);
    if !(t >= 0.0) {
        return None;
    }
    let w = 1.0 - u - v;
    let point: DVec3 = a * w + b * u + c * v;
    Some(Hit {
        triangle: index,
        t: t as f32,
        barycentric: [w as f32, u as f32, v as f32],
        point: point.as_vec3(),
    })
}

/// The closest hit by testing every triangle: the reference the tree is
/// checked against.
pub fn cast_brute_force(positions: &[Vec3], triangles: &[[u32; 3]], ray: &Ray) -> Option<Hit> {
    let mut best: Option<Hit> = None;
    for (i, &t) in triangles.iter().enumerate() {
        if !t
            .iter()
            .all(|&v| positions.get(v as usize).is_some_and(|p| p.is_finite()))
        {
            continue;
        }
        if let Some(h) = triangle_hit(positions, t, ray, i as u32)
            && best.is_none_or(|b| h.t < b.t)
        {
            best = Some(h);
        }
    }
    best
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A seeded generator (xorshift), enough for test inputs.
    pub(crate) struct Rng(pub(crate) u64);
    impl Rng {
        fn next(&mut self) -> f32 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 40) as f32 / (1u64 << 24) as f32
        }
        /// A point in [-1, 1]^3.
        pub(crate) fn v(&mut self) -> Vec3 {
            Vec3::new(self.next(), self.next(), self.next()) * 2.0 - 1.0
        }
    }

    fn soup(rng: &mut Rng, n: usize) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let mut p = Vec::new();
        let mut t = Vec::new();
        for i in 0..n as u32 {
            let c = rng.v() * 3.0;
            p.extend([c + rng.v() * 0.3, c + rng.v() * 0.3, c + rng.v() * 0.3]);
            t.push([3 * i, 3 * i + 1, 3 * i + 2]);
        }
        (p, t)
    }

    #[test]
    fn agrees_with_brute_force_on_random_soups() {
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        for n in [1, 3, 5, 17, 400] {
            let (p, t) = soup(&mut rng, n);
            let bvh = Bvh::new(&p, &t);
            assert_eq!(bvh.len(), n);
            for _ in 0..300 {
                let ray = Ray::new(rng.v() * 6.0, rng.v());
                let a = bvh.cast(&p, &ray);
                let b = cast_brute_force(&p, &t, &ray);
                assert_eq!(a.map(|h| h.triangle), b.map(|h| h.triangle), "{ray:?}");
                if let (Some(a), Some(b)) = (a, b) {
                    assert_eq!(a.t, b.t);
                }
            }
        }
    }

    /// The nearest point of a triangle by dense sampling of it (a plain
    /// reference for `closest_on_triangle`).
    fn sampled_nearest(p: Vec3, t: [Vec3; 3]) -> f32 {
        let n = 200;
        let mut best = f32::INFINITY;
        for i in 0..=n {
            for j in 0..=(n - i) {
                let (u, v) = (i as f32 / n as f32, j as f32 / n as f32);
                let q = t[0] + (t[1] - t[0]) * u + (t[2] - t[0]) * v;
                best = best.min(q.distance(p));
            }
        }
        best
    }

    #[test]
    fn nearest_agrees_with_brute_force_and_sampling() {
        let mut rng = Rng(0x51ed_2701);
        // One triangle against dense samples of it: every Voronoi region.
        for _ in 0..200 {
            let t = [rng.v(), rng.v(), rng.v()];
            let p = rng.v() * 2.0;
            let q = closest_on_triangle(p, t);
            let d = q.distance(p);
            assert!(d <= sampled_nearest(p, t) + 1e-5, "{p:?} {t:?}");
            assert!(d >= sampled_nearest(p, t) - 0.02, "{p:?} {t:?}");
        }
        // A degenerate triangle (a segment) and a point.
        let seg = [Vec3::ZERO, Vec3::X, Vec3::X * 2.0];
        assert!(
            (closest_on_triangle(Vec3::new(1.5, 1.0, 0.0), seg) - Vec3::new(1.5, 0.0, 0.0))
                .length()
                < 1e-6
        );
        // The tree against every triangle.
        for n in [1, 5, 400] {
            let (p, t) = soup(&mut rng, n);
            let bvh = Bvh::new(&p, &t);
            for _ in 0..300 {
                let q = rng.v() * 6.0;
                let got = bvh.nearest(&p, q).expect("a triangle");
                let want = t
                    .iter()
                    .map(|tri| closest_on_triangle(q, tri.map(|v| p[v as usize])).distance(q))
                    .fold(f32::INFINITY, f32::min);
                assert_eq!(got.distance, want, "{q:?}");
                assert!((got.point.distance(q) - got.distance).abs() < 1e-5);
            }
        }
        assert!(Bvh::new(&[], &[]).nearest(&[], Vec3::ZERO).is_none());
    }

    #[test]
    fn refit_follows_moved_vertices() {
        let mut rng = Rng(7);
        let (mut p, t) = soup(&mut rng, 200);
        let mut bvh = Bvh::new(&p, &t);
        for q in &mut p {
            *q = *q * 1.5 + Vec3::new(0.5, -2.0, 0.25);
        }
        bvh.refit(&p);
        for _ in 0..300 {
            let ray = Ray::new(rng.v() * 6.0, rng.v());
            assert_eq!(
                bvh.cast(&p, &ray).map(|h| h.triangle),
                cast_brute_force(&p, &t, &ray).map(|h| h.triangle)
            );
        }
    }

    #[test]
    fn hit_point_lies_on_the_triangle_and_the_ray() {
        let p = [
            Vec3::new(0.0, 0.0, 5.0),
            Vec3::new(4.0, 0.0, 5.0),
            Vec3::new(0.0, 4.0, 5.0),
        ];
        let bvh = Bvh::new(&p, &[[0, 1, 2]]);
        let ray = Ray::new(Vec3::new(1.0, 1.0, 0.0), Vec3::Z);
        let h = bvh.cast(&p, &ray).expect("hit");
        assert!((h.point - Vec3::new(1.0, 1.0, 5.0)).length() < 1e-6);
        assert!((h.t - 5.0).abs() < 1e-6);
        // The same surface point on a moved copy, and the nearest corner.
        let moved: Vec<Vec3> = p.iter().map(|q| *q * 2.0 + Vec3::X).collect();
        let on_moved = h.point_in(&[[0, 1, 2]], &moved);
        assert!((on_moved - (h.point * 2.0 + Vec3::X)).length() < 1e-5);
        assert_eq!(h.nearest_vertex(&[[0, 1, 2]]), 0);
        let near_b = bvh.cast(&p, &Ray::new(Vec3::new(3.5, 0.2, 0.0), Vec3::Z));
        assert_eq!(near_b.map(|h| h.nearest_vertex(&[[0, 1, 2]])), Some(1));
        // Behind the origin or beside the triangle: no hit.
        assert!(
            bvh.cast(&p, &Ray::new(Vec3::new(1.0, 1.0, 9.0), Vec3::Z))
                .is_none()
        );
        assert!(
            bvh.cast(&p, &Ray::new(Vec3::new(3.0, 3.0, 0.0), Vec3::Z))
                .is_none()
        );
    }

    #[test]
    fn bad_triangles_are_left_out() {
        let p = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::NAN];
        let bvh = Bvh::new(&p, &[[0, 1, 2], [0, 1, 3], [0, 1, 9]]);
        assert_eq!(bvh.len(), 1);
        let empty = Bvh::new(&p, &[]);
        assert!(empty.cast(&p, &Ray::new(Vec3::Z, Vec3::NEG_Z)).is_none());
    }
}
