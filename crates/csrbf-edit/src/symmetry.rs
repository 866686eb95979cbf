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

use glam::Vec3;

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
    let finite: Vec<Vec3> = positions
        .iter()
        .copied()
        .filter(|p| p.is_finite())
        .collect();
    if finite.is_empty() || axis > 2 {
        return None;
    }
    let (lo, hi) = finite
        .iter()
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), p| {
            (a.min(*p), b.max(*p))
        });
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
