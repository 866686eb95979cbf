//! Where a surface passes through itself: pairs of triangles that cross,
//! found with the [`Bvh`], and those a deformation made (crossing in the
//! deformed positions, not at rest).
//!
//! Triangles sharing a corner are never a pair (they meet by
//! construction); touching without crossing does not count. The test is
//! exact in its signs for coplanar input given in f32 (a flat sheet folded
//! over itself in its plane is seen) and robust elsewhere: the orientation
//! determinants are evaluated in f64 from f32 coordinates.
//!
//! ```
//! use csrbf_mesh::intersect::{new_self_intersections, self_intersections};
//! use glam::Vec3;
//!
//! // Two triangles apart at rest; one pushed through the other.
//! let rest = [Vec3::ZERO, Vec3::X, Vec3::Y,
//!             Vec3::new(0.2, 0.2, 1.0), Vec3::new(0.3, 0.2, 2.0), Vec3::new(0.2, 0.3, 2.0)];
//! let mut moved = rest;
//! moved[3].z = -1.0;
//! let tris = [[0, 1, 2], [3, 4, 5]];
//! assert!(self_intersections(&rest, &tris).is_empty());
//! assert_eq!(new_self_intersections(&rest, &moved, &tris), vec![[0, 1]]);
//! ```

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use crate::bvh::Bvh;

/// Every pair of triangles `[i, j]` (i < j, ascending) that cross each
/// other and share no corner.
pub fn self_intersections(positions: &[Vec3], triangles: &[[u32; 3]]) -> Vec<[u32; 2]> {
    let all: Vec<u32> = (0..triangles.len() as u32).collect();
    pairs(positions, triangles, &all, &|_, _| true)
}

/// The pairs of triangles that cross in `moved` but not in `rest` (the
/// same triangles over two positions of the vertices), ascending. Only
/// triangles with a moved corner are searched, so a local edit of a large
/// mesh costs little more than the tree.
pub fn new_self_intersections(
    rest: &[Vec3],
    moved: &[Vec3],
    triangles: &[[u32; 3]],
) -> Vec<[u32; 2]> {
    if rest.len() != moved.len() {
        return Vec::new();
    }
    let changed = |t: &[u32; 3]| {
        t.iter()
            .any(|&v| rest.get(v as usize) != moved.get(v as usize))
    };
    let queried: Vec<u32> = (0..triangles.len() as u32)
        .filter(|&i| changed(&triangles[i as usize]))
        .collect();
    pairs(moved, triangles, &queried, &|a, b| {
        !cross(
            corners(rest, &triangles[a as usize]),
            corners(rest, &triangles[b as usize]),
        )
    })
}

/// The crossing pairs that involve a triangle of `queried` (ascending) and
/// that `keep` accepts.
fn pairs(
    positions: &[Vec3],
    triangles: &[[u32; 3]],
    queried: &[u32],
    keep: &(dyn Fn(u32, u32) -> bool + Sync),
) -> Vec<[u32; 2]> {
    if queried.is_empty() {
        return Vec::new();
    }
    // Only triangles that reach the box around the queried ones can cross
    // one: the tree is built on those (a local edit of a large mesh then
    // costs what it touches).
    let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    for &i in queried {
        if let Some(c) = checked_corners(positions, &triangles[i as usize]) {
            lo = lo.min(c[0].min(c[1]).min(c[2]));
            hi = hi.max(c[0].max(c[1]).max(c[2]));
        }
    }
    let near: Vec<u32> = (0..triangles.len() as u32)
        .filter(|&j| {
            checked_corners(positions, &triangles[j as usize]).is_some_and(|c| {
                c[0].min(c[1]).min(c[2]).cmple(hi).all() && c[0].max(c[1]).max(c[2]).cmpge(lo).all()
            })
        })
        .collect();
    let subset: Vec<[u32; 3]> = near.iter().map(|&j| triangles[j as usize]).collect();
    let bvh = Bvh::new(positions, &subset);
    let mut is_queried = vec![false; triangles.len()];
    for &i in queried {
        is_queried[i as usize] = true;
    }
    // The queries in parallel, each chunk its own list.
    let mut out: Vec<[u32; 2]> = queried
        .par_chunks(1024)
        .flat_map_iter(|chunk| {
            let mut found = Vec::new();
            for &i in chunk {
                let ti = triangles[i as usize];
                let Some(ci) = checked_corners(positions, &ti) else {
                    continue;
                };
                let (lo, hi) = (ci[0].min(ci[1]).min(ci[2]), ci[0].max(ci[1]).max(ci[2]));
                bvh.for_each_overlap(lo, hi, |k| {
                    let j = near[k as usize];
                    // Each pair once: by the queried triangle with the smaller index.
                    if j == i || (is_queried[j as usize] && j < i) {
                        return;
                    }
                    let tj = triangles[j as usize];
                    if ti.iter().any(|v| tj.contains(v)) {
                        return;
                    }
                    // A leaf's other triangles: their own boxes first.
                    let Some(cj) = checked_corners(positions, &tj) else {
                        return;
                    };
                    let (jlo, jhi) = (cj[0].min(cj[1]).min(cj[2]), cj[0].max(cj[1]).max(cj[2]));
                    if !(jlo.cmple(hi).all() && jhi.cmpge(lo).all()) {
                        return;
                    }
                    if cross(ci.map(|p| p.as_dvec3()), cj.map(|p| p.as_dvec3())) && keep(i, j) {
                        found.push([i.min(j), i.max(j)]);
                    }
                });
            }
            found
        })
        .collect();
    out.sort_unstable();
    out.dedup();
    out
}

fn checked_corners(p: &[Vec3], t: &[u32; 3]) -> Option<[Vec3; 3]> {
    let c = [
        *p.get(t[0] as usize)?,
        *p.get(t[1] as usize)?,
        *p.get(t[2] as usize)?,
    ];
    c.iter().all(|v| v.is_finite()).then_some(c)
}

fn corners(p: &[Vec3], t: &[u32; 3]) -> [DVec3; 3] {
    t.map(|v| p.get(v as usize).map_or(DVec3::NAN, |x| x.as_dvec3()))
}

/// The signed volume of the tetrahedron (a, b, c, d), times 6.
fn orient(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> f64 {
    (b - a).cross(c - a).dot(d - a)
}

/// Whether two triangles cross: share a point that is not only a touch.
/// Non-coplanar: an edge of one passes through the inside of the other
/// (its ends strictly on both sides of the plane, its line inside the
/// triangle, edges included). Coplanar: their insides overlap in the plane.
pub fn cross(a: [DVec3; 3], b: [DVec3; 3]) -> bool {
    if !a.iter().chain(&b).all(|p| p.is_finite()) {
        return false;
    }
    let sb = b.map(|p| orient(a[0], a[1], a[2], p));
    let sa = a.map(|p| orient(b[0], b[1], b[2], p));
    // All of one on one side of the other's plane: apart.
    let apart = |s: [f64; 3]| s.iter().all(|&x| x > 0.0) || s.iter().all(|&x| x < 0.0);
    if apart(sa) || apart(sb) {
        return false;
    }
    if sb.iter().all(|&x| x == 0.0) {
        return coplanar_overlap(a, b);
    }
    (0..3).any(|k| edge_through(a, b[k], b[(k + 1) % 3], sb[k], sb[(k + 1) % 3]))
        || (0..3).any(|k| edge_through(b, a[k], a[(k + 1) % 3], sa[k], sa[(k + 1) % 3]))
}

/// Whether the segment pq (with signed volumes sp, sq against t's plane)
/// passes strictly through t's plane within t (edges included).
fn edge_through(t: [DVec3; 3], p: DVec3, q: DVec3, sp: f64, sq: f64) -> bool {
    if !(sp * sq < 0.0) {
        return false;
    }
    let o = [
        orient(p, q, t[0], t[1]),
        orient(p, q, t[1], t[2]),
        orient(p, q, t[2], t[0]),
    ];
    (o.iter().all(|&x| x >= 0.0) || o.iter().all(|&x| x <= 0.0)) && o.iter().any(|&x| x != 0.0)
}

/// Two triangles in one plane: do their insides overlap? (Edges crossing
/// properly, or a corner of one strictly inside the other.)
fn coplanar_overlap(a: [DVec3; 3], b: [DVec3; 3]) -> bool {
    let n = (a[1] - a[0]).cross(a[2] - a[0]);
    let na = n.abs();
    // Drop the normal's largest axis.
    let (i, j) = if na.x >= na.y && na.x >= na.z {
        (1, 2)
    } else if na.y >= na.z {
        (2, 0)
    } else {
        (0, 1)
    };
    let a2 = a.map(|p| [p[i], p[j]]);
    let b2 = b.map(|p| [p[i], p[j]]);
    let o2 = |p: [f64; 2], q: [f64; 2], r: [f64; 2]| {
        (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])
    };
    for k in 0..3 {
        for l in 0..3 {
            let (p, q) = (a2[k], a2[(k + 1) % 3]);
            let (r, s) = (b2[l], b2[(l + 1) % 3]);
            if o2(p, q, r) * o2(p, q, s) < 0.0 && o2(r, s, p) * o2(r, s, q) < 0.0 {
                return true;
            }
        }
    }
    let strictly_inside = |t: [[f64; 2]; 3], p: [f64; 2]| {
        let o = [o2(t[0], t[1], p), o2(t[1], t[2], p), o2(t[2], t[0], p)];
        o.iter().all(|&x| x > 0.0) || o.iter().all(|&x| x < 0.0)
    };
    // Identical triangles, or one inside the other.
    let centroid = |t: [[f64; 2]; 3]| {
        [
            (t[0][0] + t[1][0] + t[2][0]) / 3.0,
            (t[0][1] + t[1][1] + t[2][1]) / 3.0,
        ]
    };
    b2.iter().any(|&p| strictly_inside(a2, p))
        || a2.iter().any(|&p| strictly_inside(b2, p))
        || strictly_inside(a2, centroid(b2))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::tests::Rng;
    use crate::bvh::{Ray, cast_brute_force};

    fn soup(rng: &mut Rng, n: usize, size: f32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let mut p = Vec::new();
        let mut t = Vec::new();
        for i in 0..n as u32 {
            let c = rng.v() * 2.0;
            p.extend([c + rng.v() * size, c + rng.v() * size, c + rng.v() * size]);
            t.push([3 * i, 3 * i + 1, 3 * i + 2]);
        }
        (p, t)
    }

    /// Another way to the same answer for triangles in general position:
    /// some edge of one, cast as a ray (Möller-Trumbore), hits the other
    /// within the edge's length.
    fn edge_hits(p: &[Vec3], a: [u32; 3], b: [u32; 3]) -> bool {
        let through = |from: [u32; 3], onto: [u32; 3]| {
            (0..3).any(|k| {
                let (s, e) = (p[from[k] as usize], p[from[(k + 1) % 3] as usize]);
                cast_brute_force(p, &[onto], &Ray::new(s, e - s))
                    .is_some_and(|h| h.t <= (e - s).length())
            })
        };
        through(a, b) || through(b, a)
    }

    #[test]
    fn the_tree_finds_every_pair_brute_force_finds() {
        let mut rng = Rng(0x2545_f491_4f6c_dd1d);
        for (n, size) in [(2, 1.0), (10, 0.8), (60, 0.5), (300, 0.3)] {
            let (p, t) = soup(&mut rng, n, size);
            let mut brute = Vec::new();
            for i in 0..t.len() {
                for j in i + 1..t.len() {
                    let (a, b) = (corners(&p, &t[i]), corners(&p, &t[j]));
                    if cross(a, b) {
                        brute.push([i as u32, j as u32]);
                    }
                    // The predicate against the ray casts.
                    assert_eq!(
                        cross(a, b),
                        edge_hits(&p, t[i], t[j]),
                        "{n}: triangles {i} and {j}"
                    );
                }
            }
            assert_eq!(self_intersections(&p, &t), brute, "{n} triangles");
            if n >= 60 {
                assert!(!brute.is_empty(), "the soup must cross somewhere");
            }
        }
    }

    #[test]
    fn only_pairs_the_motion_made_are_new() {
        let mut rng = Rng(77);
        let (rest, t) = soup(&mut rng, 200, 0.3);
        // Move a third of the triangles.
        let mut moved = rest.clone();
        for v in moved.iter_mut().take(200) {
            *v += Vec3::new(0.4, -0.2, 0.3);
        }
        let before = self_intersections(&rest, &t);
        let after = self_intersections(&moved, &t);
        let want: Vec<[u32; 2]> = after
            .iter()
            .copied()
            .filter(|p| !before.contains(p))
            .collect();
        assert!(!want.is_empty());
        assert_eq!(new_self_intersections(&rest, &moved, &t), want);
        assert!(new_self_intersections(&rest, &rest, &t).is_empty());
    }

    #[test]
    fn neighbours_touches_and_coplanar_overlaps() {
        // A flat strip: neighbours share corners and never count.
        let p = [
            Vec3::ZERO,
            Vec3::X,
            Vec3::Y,
            Vec3::new(1.0, 1.0, 0.0),
            // A coplanar triangle overlapping the first two.
            Vec3::new(0.5, 0.2, 0.0),
            Vec3::new(1.5, 0.2, 0.0),
            Vec3::new(0.5, 1.5, 0.0),
            // One touching the strip's corner from above, not crossing.
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(1.0, 2.0, 1.0),
            Vec3::new(2.0, 1.0, 1.0),
        ];
        let t = [[0, 1, 2], [1, 3, 2], [4, 5, 6], [7, 8, 9]];
        assert_eq!(self_intersections(&p, &t), vec![[0, 2], [1, 2]]);
        // The same triangle twice, and one inside another, overlap.
        let c = |t: [Vec3; 3]| t.map(|v| v.as_dvec3());
        let big = c([Vec3::ZERO, Vec3::X * 4.0, Vec3::Y * 4.0]);
        let small = c([
            Vec3::new(0.5, 0.5, 0.0),
            Vec3::new(1.0, 0.5, 0.0),
            Vec3::new(0.5, 1.0, 0.0),
        ]);
        assert!(cross(big, big) && cross(big, small) && cross(small, big));
        // Non-finite corners never cross.
        let mut bad = big;
        bad[0].x = f64::NAN;
        assert!(!cross(bad, small));
    }
}
