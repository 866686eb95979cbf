//! The plane a model is most nearly mirror-symmetric about, normal to an
//! axis: where a mirror puts the images of control vectors (the studio's
//! Mirror, Python's `csrbf.symmetry_plane`, Blender's Mirror Controls). The bounding
//! box's centre is not that plane for a scan with more hair on one side or a
//! shoulder in the frame (the second mouth corner of a face scan landed on
//! the cheek); the plane is fitted instead, as the reflection-only case of
//! ICP: each sampled vertex is mirrored, paired with the vertex nearest its
//! image, and the plane moved to the median of the pairs' midpoints, until
//! it settles.

use std::collections::HashMap;

use glam::{DVec3, Vec3};

/// Most vertices sampled for the pairs (spread evenly over the array).
const SAMPLES: usize = 4000;
/// Most vertices in the grid the nearest images are looked up in.
const GRID_VERTICES: usize = 400_000;
/// Cells along the bounding box's diagonal.
const CELLS: f32 = 64.0;
/// Planes tried across the box before the rounds.
const CANDIDATES: usize = 48;
/// Rounds of pairing and moving the plane.
const ROUNDS: usize = 30;

/// The offset `c` of the plane `p[axis] = c` about which `positions` are
/// most nearly symmetric (None for no finite position or `axis` > 2). It
/// starts at the vertices' mean, so a model that is symmetric about some
/// plane normal to `axis` gives that plane even when extra parts (a tail, a
/// prop) move its box and its mean off it.
pub fn symmetry_plane(positions: &[Vec3], axis: usize) -> Option<f64> {
    if axis > 2 {
        return None;
    }
    let (finite, lo, hi) = finite_points(positions)?;
    let diagonal = (hi - lo).length();
    let mean = finite.iter().map(|p| p[axis] as f64).sum::<f64>() / finite.len() as f64;
    if diagonal <= 0.0 || hi[axis] <= lo[axis] {
        return Some(mean);
    }
    let grid = Grid::new(&finite, diagonal / CELLS);
    let stride = finite.len().div_ceil(SAMPLES).max(1);
    let samples: Vec<Vec3> = finite.iter().step_by(stride).copied().collect();
    // Pairs farther apart than this are not images of each other.
    let reach = 2.0 * grid.cell;
    // Where to start: of planes across the box, the one whose images land
    // nearest the model (a few samples each); ICP alone, from the mean,
    // settles on a wrong plane when extra parts pull the mean off.
    let few: Vec<Vec3> = samples.iter().step_by(8).copied().collect();
    let cost = |c: f64| -> f64 {
        few.iter()
            .map(|v| {
                let mut image = *v;
                image[axis] = (2.0 * c - v[axis] as f64) as f32;
                grid.nearest(image, reach)
                    .map_or(reach, |w| w.distance(image)) as f64
            })
            .sum()
    };
    let (a, b) = (lo[axis] as f64, hi[axis] as f64);
    let mut c = (0..CANDIDATES)
        .map(|i| a + (b - a) * (i as f64 + 0.5) / CANDIDATES as f64)
        .chain([mean])
        .map(|c| (cost(c), c))
        .min_by(|x, y| x.0.total_cmp(&y.0))
        .map_or(mean, |(_, c)| c);
    for _ in 0..ROUNDS {
        let mut mids: Vec<f64> = samples
            .iter()
            .filter_map(|v| {
                let mut image = *v;
                image[axis] = (2.0 * c - v[axis] as f64) as f32;
                let w = grid.nearest(image, reach)?;
                Some((v[axis] as f64 + w[axis] as f64) * 0.5)
            })
            .collect();
        if mids.is_empty() {
            break;
        }
        let mid = mids.len() / 2;
        let (_, &mut median, _) = mids.select_nth_unstable_by(mid, f64::total_cmp);
        let moved = (median - c).abs();
        c = median;
        if moved < 1e-7 * diagonal as f64 {
            break;
        }
    }
    Some(c)
}

/// A plane of symmetry: a point on it and its unit normal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    /// A point of the plane.
    pub point: DVec3,
    /// Its normal, of unit length.
    pub normal: DVec3,
}

impl Plane {
    /// The plane through `point` normal to `normal` (any length but zero);
    /// None when either is not finite or the normal is zero.
    pub fn new(point: DVec3, normal: DVec3) -> Option<Plane> {
        let n = normal.try_normalize()?;
        (point.is_finite() && n.is_finite()).then_some(Plane { point, normal: n })
    }

    /// The plane `p[axis] = offset` (axis 0 X, 1 Y, 2 Z).
    pub fn axis(axis: usize, offset: f64) -> Option<Plane> {
        let mut n = DVec3::ZERO;
        *n.as_mut().get_mut(axis)? = 1.0;
        Plane::new(n * offset, n)
    }

    /// The plane through three points; None when they are (nearly) on one
    /// line.
    pub fn through(a: DVec3, b: DVec3, c: DVec3) -> Option<Plane> {
        let n = (b - a).cross(c - a);
        let scale = (b - a).length().max((c - a).length()).max((c - b).length());
        if !(n.length() > 1e-9 * scale * scale) {
            return None;
        }
        Plane::new(a, n)
    }

    /// The signed distance of `p` from the plane (positive on the normal's
    /// side).
    pub fn distance(&self, p: DVec3) -> f64 {
        (p - self.point).dot(self.normal)
    }

    /// The mirror image of a point.
    pub fn reflect(&self, p: DVec3) -> DVec3 {
        p - 2.0 * self.distance(p) * self.normal
    }

    /// The mirror image of a direction (a control's move).
    pub fn reflect_vector(&self, v: DVec3) -> DVec3 {
        v - 2.0 * v.dot(self.normal) * self.normal
    }

    /// The angle between two planes' normals, in degrees (0 to 90: a
    /// plane's normal may point either way).
    pub fn angle_deg(&self, other: &Plane) -> f64 {
        self.normal
            .dot(other.normal)
            .abs()
            .min(1.0)
            .acos()
            .to_degrees()
    }
}

/// The plane of any orientation that `positions` are most nearly
/// mirror-symmetric about (None for no finite position): of the planes
/// normal to X, Y, Z and to the points' principal axes (a scan turned in
/// its frame is symmetric about one of those), each at the best of 48
/// offsets, the one whose images land nearest the model; then refined by
/// reflection-only ICP that turns the plane too: each sampled vertex
/// mirrored, paired with the vertex nearest its image, the normal moved to
/// the main direction of the pairs' differences and the plane through the
/// median of their midpoints, until it settles.
pub fn find_plane(positions: &[Vec3]) -> Option<Plane> {
    let (finite, lo, hi) = finite_points(positions)?;
    let diagonal = (hi - lo).length();
    let mean = finite.iter().map(|p| p.as_dvec3()).sum::<DVec3>() / finite.len() as f64;
    if !(diagonal > 0.0) {
        return Plane::new(mean, DVec3::X);
    }
    let grid = Grid::new(&finite, diagonal / CELLS);
    let stride = finite.len().div_ceil(SAMPLES).max(1);
    let samples: Vec<DVec3> = finite
        .iter()
        .step_by(stride)
        .map(|p| p.as_dvec3())
        .collect();
    let few: Vec<DVec3> = samples.iter().step_by(8).copied().collect();
    let reach = 2.0 * grid.cell;
    let cost = |plane: &Plane, pts: &[DVec3]| -> f64 {
        pts.iter()
            .map(|v| {
                let image = plane.reflect(*v).as_vec3();
                grid.nearest(image, reach)
                    .map_or(reach, |w| w.distance(image)) as f64
            })
            .sum::<f64>()
            / pts.len().max(1) as f64
    };
    let mut normals = vec![DVec3::X, DVec3::Y, DVec3::Z];
    normals.extend(principal_axes(&samples, mean));
    let mut best: Option<(f64, Plane)> = None;
    for n in normals {
        let (a, b) = samples
            .iter()
            .map(|p| p.dot(n))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
                (a.min(x), b.max(x))
            });
        let offsets = (0..CANDIDATES)
            .map(|i| a + (b - a) * (i as f64 + 0.5) / CANDIDATES as f64)
            .chain([mean.dot(n)]);
        for c in offsets {
            let Some(plane) = Plane::new(n * c, n) else {
                continue;
            };
            let k = cost(&plane, &few);
            if best.is_none_or(|(b, _)| k < b) {
                best = Some((k, plane));
            }
        }
    }
    let (_, mut plane) = best?;
    let mut now = cost(&plane, &samples);
    for _ in 0..ROUNDS {
        let pairs: Vec<(DVec3, DVec3)> = samples
            .iter()
            .filter_map(|v| {
                let w = grid.nearest(plane.reflect(*v).as_vec3(), reach)?.as_dvec3();
                Some((*v, w))
            })
            .collect();
        if pairs.len() < 3 {
            break;
        }
        // The differences of true pairs all lie along the normal: the main
        // direction of their outer products, turned to the old normal's side.
        let mut m = [[0.0f64; 3]; 3];
        for (v, w) in &pairs {
            let d = *v - *w;
            for (i, row) in m.iter_mut().enumerate() {
                for (j, x) in row.iter_mut().enumerate() {
                    *x += d[i] * d[j];
                }
            }
        }
        let mut n = main_axis(m).unwrap_or(plane.normal);
        if n.dot(plane.normal) < 0.0 {
            n = -n;
        }
        let mut along: Vec<f64> = pairs
            .iter()
            .map(|(v, w)| ((*v + *w) * 0.5).dot(n))
            .collect();
        let mid = along.len() / 2;
        let (_, &mut c, _) = along.select_nth_unstable_by(mid, f64::total_cmp);
        let Some(next) = Plane::new(n * c, n) else {
            break;
        };
        let settled = next.angle_deg(&plane) < 1e-6
            && (next.distance(plane.point)).abs() < 1e-7 * diagonal as f64;
        // Kept only while the images land nearer.
        let then = cost(&next, &samples);
        if then > now {
            break;
        }
        (plane, now) = (next, then);
        if settled {
            break;
        }
    }
    Some(plane)
}

/// The eigenvectors of the points' covariance about `mean`.
fn principal_axes(points: &[DVec3], mean: DVec3) -> Vec<DVec3> {
    let mut m = [[0.0f64; 3]; 3];
    for p in points {
        let d = *p - mean;
        for (i, row) in m.iter_mut().enumerate() {
            for (j, x) in row.iter_mut().enumerate() {
                *x += d[i] * d[j];
            }
        }
    }
    let (_, vectors) = jacobi(m);
    vectors
        .into_iter()
        .filter_map(|v| v.try_normalize())
        .collect()
}

/// The eigenvector of the largest eigenvalue of a symmetric matrix.
fn main_axis(m: [[f64; 3]; 3]) -> Option<DVec3> {
    let (values, vectors) = jacobi(m);
    let k = (0..3).max_by(|&a, &b| values[a].total_cmp(&values[b]))?;
    vectors[k].try_normalize()
}

/// Eigenvalues and eigenvectors of a symmetric 3x3 matrix (cyclic Jacobi
/// rotations until the off-diagonal vanishes).
fn jacobi(mut a: [[f64; 3]; 3]) -> ([f64; 3], [DVec3; 3]) {
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _ in 0..50 {
        let off = a[0][1].abs() + a[0][2].abs() + a[1][2].abs();
        let scale = a[0][0].abs() + a[1][1].abs() + a[2][2].abs();
        if !(off > 1e-15 * scale) {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if a[p][q] == 0.0 {
                continue;
            }
            let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            for row in a.iter_mut() {
                let (akp, akq) = (row[p], row[q]);
                row[p] = c * akp - s * akq;
                row[q] = s * akp + c * akq;
            }
            let (rp, rq) = (a[p], a[q]);
            for k in 0..3 {
                a[p][k] = c * rp[k] - s * rq[k];
                a[q][k] = s * rp[k] + c * rq[k];
            }
            for row in v.iter_mut() {
                let (vkp, vkq) = (row[p], row[q]);
                row[p] = c * vkp - s * vkq;
                row[q] = s * vkp + c * vkq;
            }
        }
    }
    let col = |j: usize| DVec3::new(v[0][j], v[1][j], v[2][j]);
    ([a[0][0], a[1][1], a[2][2]], [col(0), col(1), col(2)])
}

/// Where a start mirrored across `plane` lands on a surface: the surface's
/// point nearest its exact image, and how far that is from the image (more
/// than a few percent of R says the model is not symmetric there).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Image {
    /// The exact mirror image.
    pub exact: DVec3,
    /// The surface's point nearest it.
    pub on_surface: DVec3,
    /// Their distance.
    pub gap: f64,
}

/// The images of `points` across `plane`, each put on the surface of
/// `positions` and `triangles` (its nearest point); None for a point with
/// no surface (no triangle) or not finite.
pub fn mirror_onto(
    positions: &[Vec3],
    triangles: &[[u32; 3]],
    plane: &Plane,
    points: &[DVec3],
) -> Vec<Option<Image>> {
    let bvh = csrbf_mesh::Bvh::new(positions, triangles);
    points
        .iter()
        .map(|p| {
            let exact = plane.reflect(*p);
            let hit = bvh.nearest(positions, exact.as_vec3())?;
            let on_surface = hit.point.as_dvec3();
            Some(Image {
                exact,
                on_surface,
                gap: on_surface.distance(exact),
            })
        })
        .collect()
}

/// The finite points and their bounding box; None when there is none.
fn finite_points(positions: &[Vec3]) -> Option<(Vec<Vec3>, Vec3, Vec3)> {
    let finite: Vec<Vec3> = positions
        .iter()
        .copied()
        .filter(|p| p.is_finite())
        .collect();
    if finite.is_empty() {
        return None;
    }
    let (lo, hi) = finite
        .iter()
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), p| {
            (a.min(*p), b.max(*p))
        });
    Some((finite, lo, hi))
}

/// Vertices in cubic cells, for the nearest one to a point.
struct Grid {
    cell: f32,
    cells: HashMap<[i32; 3], Vec<Vec3>>,
}

impl Grid {
    fn new(positions: &[Vec3], cell: f32) -> Grid {
        let stride = positions.len().div_ceil(GRID_VERTICES).max(1);
        let mut cells: HashMap<[i32; 3], Vec<Vec3>> = HashMap::new();
        for p in positions.iter().step_by(stride) {
            cells.entry(key(*p, cell)).or_default().push(*p);
        }
        Grid { cell, cells }
    }

    /// The vertex nearest `p` within `reach` (looked up in the cells
    /// around `p`'s).
    fn nearest(&self, p: Vec3, reach: f32) -> Option<Vec3> {
        let k = key(p, self.cell);
        let r = (reach / self.cell).ceil() as i32;
        let mut best: Option<(f32, Vec3)> = None;
        for dx in -r..=r {
            for dy in -r..=r {
                for dz in -r..=r {
                    let Some(vs) = self.cells.get(&[k[0] + dx, k[1] + dy, k[2] + dz]) else {
                        continue;
                    };
                    for v in vs {
                        let d = v.distance_squared(p);
                        if d <= reach * reach && best.is_none_or(|(b, _)| d < b) {
                            best = Some((d, *v));
                        }
                    }
                }
            }
        }
        best.map(|(_, v)| v)
    }
}

fn key(p: Vec3, cell: f32) -> [i32; 3] {
    let q = (p / cell).floor();
    [q.x as i32, q.y as i32, q.z as i32]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sphere about x = 0.3 with a tail sticking out along +X: its box's
    /// centre and its mean are off the plane of symmetry.
    fn sphere_with_tail() -> Vec<Vec3> {
        let mesh = csrbf_mesh::shapes::uv_sphere(1.0, 24, 48);
        let mut p: Vec<Vec3> = (mesh.positions.iter())
            .map(|v| *v + Vec3::new(0.3, -0.2, 0.1))
            .collect();
        p.extend((0..200).map(|k| Vec3::new(1.3 + k as f32 * 0.01, -0.2, 0.1)));
        p
    }

    #[test]
    fn the_plane_of_a_symmetric_model_with_a_tail_is_found() {
        let p = sphere_with_tail();
        let (lo, hi) = p
            .iter()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), v| {
                (a.min(*v), b.max(*v))
            });
        let centre = ((lo + hi) * 0.5).x as f64;
        assert!((centre - 0.3).abs() > 0.4, "the box is off: {centre}");
        let c = symmetry_plane(&p, 0).expect("a plane");
        assert!((c - 0.3).abs() < 2e-3, "x = {c}");
        // About the other axes too (the sphere's centre there).
        let y = symmetry_plane(&p, 1).expect("a plane");
        assert!((y + 0.2).abs() < 2e-3, "y = {y}");
    }

    /// An egg (an ellipsoid with a bump up and forward) symmetric about
    /// x = 0 alone, turned by `turn` and moved by `shift`.
    fn turned_egg(turn: glam::DQuat, shift: DVec3) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let mesh = csrbf_mesh::shapes::uv_sphere(1.0, 48, 96);
        let bump = DVec3::new(0.0, 0.6, 0.8);
        let p = mesh
            .positions
            .iter()
            .map(|v| {
                let d = v.as_dvec3();
                let out = 1.0 + 0.4 * (d.dot(bump) - 0.6).max(0.0);
                let q = DVec3::new(d.x * 1.0, d.y * 0.7, d.z * 0.5) * out;
                (turn * q + shift).as_vec3()
            })
            .collect();
        (p, mesh.faces.triangles())
    }

    #[test]
    fn a_plane_of_any_orientation_is_found_and_starts_mirror_onto_the_surface() {
        // Issue 42: a model symmetric about a plane turned 12 and 17 degrees
        // about two axes.
        let turn = glam::DQuat::from_axis_angle(DVec3::Y, 12f64.to_radians())
            * glam::DQuat::from_axis_angle(DVec3::Z, 17f64.to_radians());
        let shift = DVec3::new(0.3, -0.2, 0.5);
        let (p, t) = turned_egg(turn, shift);
        let truth = Plane::new(shift, turn * DVec3::X).expect("plane");
        let found = find_plane(&p).expect("a plane");
        assert!(found.angle_deg(&truth) < 1.0, "{found:?} against {truth:?}");
        let diagonal = {
            let (lo, hi) = p
                .iter()
                .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), v| {
                    (a.min(*v), b.max(*v))
                });
            (hi - lo).length() as f64
        };
        assert!(
            found.distance(truth.point).abs() < 1e-3 * diagonal,
            "{found:?}"
        );
        // Starts on one side, mirrored onto the surface: each within 1e-4 of
        // the diagonal of the surface, and near the exact image.
        let starts: Vec<DVec3> = (p.iter())
            .map(|v| v.as_dvec3())
            .filter(|v| truth.distance(*v) > 0.2)
            .step_by(97)
            .collect();
        assert!(starts.len() > 10);
        let bvh = csrbf_mesh::Bvh::new(&p, &t);
        for (s, image) in starts.iter().zip(mirror_onto(&p, &t, &found, &starts)) {
            let image = image.expect("a surface");
            let off = bvh
                .nearest(&p, image.on_surface.as_vec3())
                .expect("near")
                .distance;
            assert!((off as f64) < 1e-4 * diagonal, "{s} -> {image:?}");
            assert!(image.gap < 5e-3 * diagonal, "{s} -> {image:?}");
            assert!((found.distance(image.exact) + found.distance(*s)).abs() < 1e-9);
        }
        // The axis-aligned planes of an unturned model are kept as they are.
        let (q, _) = turned_egg(glam::DQuat::IDENTITY, DVec3::ZERO);
        let plain = find_plane(&q).expect("a plane");
        assert!(
            plain.angle_deg(&Plane::axis(0, 0.0).expect("x")) < 0.05,
            "{plain:?}"
        );
    }

    #[test]
    fn planes_from_points_and_normals() {
        let p = Plane::through(DVec3::ZERO, DVec3::Y, DVec3::Z).expect("the plane x = 0");
        assert!(p.angle_deg(&Plane::axis(0, 0.0).expect("x")) < 1e-9);
        assert_eq!(
            p.reflect(DVec3::new(2.0, 1.0, 3.0)),
            DVec3::new(-2.0, 1.0, 3.0)
        );
        assert_eq!(
            p.reflect_vector(DVec3::new(1.0, 1.0, 0.0)),
            DVec3::new(-1.0, 1.0, 0.0)
        );
        assert_eq!(Plane::through(DVec3::ZERO, DVec3::X, DVec3::X * 2.0), None);
        assert_eq!(Plane::new(DVec3::ZERO, DVec3::ZERO), None);
        assert_eq!(Plane::new(DVec3::NAN, DVec3::X), None);
        assert_eq!(Plane::axis(3, 0.0), None);
        let q = Plane::axis(2, 1.5).expect("z = 1.5");
        assert_eq!(q.distance(DVec3::new(4.0, 4.0, 2.0)), 0.5);
        assert_eq!(find_plane(&[]), None);
        // Jacobi against a known decomposition.
        let (values, vectors) = jacobi([[2.0, 1.0, 0.0], [1.0, 2.0, 0.0], [0.0, 0.0, 5.0]]);
        let mut pairs: Vec<(f64, DVec3)> = values.into_iter().zip(vectors).collect();
        pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
        assert!((pairs[0].0 - 1.0).abs() < 1e-12 && (pairs[1].0 - 3.0).abs() < 1e-12);
        assert!((pairs[2].0 - 5.0).abs() < 1e-12);
        assert!(pairs[1].1.dot(DVec3::new(1.0, 1.0, 0.0).normalize()).abs() > 1.0 - 1e-12);
    }

    #[test]
    fn a_point_and_nothing_and_a_bad_axis() {
        assert_eq!(symmetry_plane(&[], 0), None);
        assert_eq!(symmetry_plane(&[Vec3::ONE], 3), None);
        assert_eq!(symmetry_plane(&[Vec3::splat(2.0); 3], 1), Some(2.0));
        assert_eq!(symmetry_plane(&[Vec3::NAN], 0), None);
    }

    /// The mean distance from the mirror images of every tenth vertex to
    /// the nearest vertex, by brute force: what the plane should make least.
    fn image_distance(p: &[Vec3], axis: usize, c: f64) -> f64 {
        let samples: Vec<Vec3> = p.iter().step_by(10).copied().collect();
        let sum: f32 = (samples.iter())
            .map(|v| {
                let mut q = *v;
                q[axis] = (2.0 * c - v[axis] as f64) as f32;
                p.iter()
                    .map(|w| w.distance(q))
                    .fold(f32::INFINITY, f32::min)
            })
            .sum();
        sum as f64 / samples.len() as f64
    }

    #[test]
    fn suzannes_plane_is_where_her_images_land_nearest_even_beside_a_prop() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../assets/models/assimp_Suzanne_248.obj");
        let mesh = csrbf_mesh::read(&path).expect("the bundled Suzanne");
        let diagonal = mesh.diagonal() as f64;
        let x = symmetry_plane(&mesh.positions, 0).expect("a plane");
        // The brute-force best plane among 81 near x = 0 (this Suzanne is
        // not exactly symmetric: it is near x = 0.006, not at 0).
        let best = (0..=80)
            .map(|i| -0.02 + 0.0005 * i as f64)
            .min_by(|a, b| {
                let (ca, cb) = (
                    image_distance(&mesh.positions, 0, *a),
                    image_distance(&mesh.positions, 0, *b),
                );
                ca.total_cmp(&cb)
            })
            .expect("planes");
        let (ours, least) = (
            image_distance(&mesh.positions, 0, x),
            image_distance(&mesh.positions, 0, best),
        );
        assert!(
            ours <= least * 1.01,
            "x = {x}: {ours} against {least} at {best}"
        );
        // A ball standing beside her moves the bounding box's centre by
        // a third of her width; the plane stays.
        let mut p = mesh.positions.clone();
        let ball = csrbf_mesh::shapes::uv_sphere(0.3, 8, 16);
        p.extend(ball.positions.iter().map(|v| *v + Vec3::new(2.2, 0.0, 0.0)));
        let beside = symmetry_plane(&p, 0).expect("a plane");
        let (lo, hi) = p
            .iter()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), v| {
                (a.min(*v), b.max(*v))
            });
        let centre = ((lo + hi) * 0.5).x as f64;
        assert!(centre > 0.3, "the box's centre moved: {centre}");
        // Her images land about as near at any plane within 0.01 of x = 0
        // (she is not exactly symmetric): within half a percent of her size.
        assert!(
            (beside - x).abs() < 5e-3 * diagonal,
            "x = {beside} beside the ball"
        );
    }
}
