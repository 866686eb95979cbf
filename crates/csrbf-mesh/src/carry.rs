//! Normals carried through a deformation.
//!
//! Meshes from other tools (Blender's glTF export, most game assets) arrive
//! with their vertices split where UVs have seams, every copy of a seam
//! vertex carrying the same normal, and with hard edges made the same way
//! but with different normals per copy. Recomputing normals per split vertex
//! after a deformation sees only the faces on one side of a seam, so the
//! copies disagree (by degrees on a sphere, by far more on Blender's monkey)
//! and the seam shows in any reader that keeps the file's normals.
//!
//! The rule here: the copies of a vertex are welded into one *smooth group*
//! when they sit at the same position with the same input normal (within
//! [`SAME_NORMAL_COS`]); copies with different normals at one position (a
//! cube's corner) stay apart, so hard edges stay hard. Each group's
//! area-weighted normal is taken over all its copies' faces before and
//! after the move, and every output normal is the input normal rotated by
//! the shortest arc from the first to the second. Where nothing moves the
//! rotation is the identity and the file's normals come back unchanged (the
//! tool's own weighting is kept); copies that agreed still agree; a flat
//! face's group (its own corners) follows the face exactly.

use std::collections::HashMap;

use glam::{Quat, Vec3};

use crate::{Faces, Mesh};

/// Two copies of a vertex at one position belong to the same smooth
/// surface when their input normals' cosine exceeds this (about 1.8
/// degrees: exporters round normals, hard edges differ by far more).
pub const SAME_NORMAL_COS: f32 = 0.9995;

impl Mesh {
    /// Moves the vertices to `moved` and, where the mesh has normals,
    /// carries them through the move (see the module's docs): nothing moves,
    /// the normals stay; a smooth surface split at UV seams keeps equal
    /// normals on its copies; hard edges stay hard. A mesh without normals
    /// (or with a count that does not match) gets them recomputed.
    pub fn move_vertices(&mut self, moved: Vec<Vec3>) {
        let carried = match &self.normals {
            Some(n) if n.len() == self.positions.len() && moved.len() == n.len() => {
                Some(carry_normals(&self.positions, &moved, &self.faces, n))
            }
            _ => None,
        };
        let corners = match (&self.corner_normals, &carried) {
            (Some(c), Some(_)) => carry_corner_normals(&self.positions, &moved, &self.faces, c),
            _ => None,
        };
        self.positions = moved;
        match carried {
            Some(n) => {
                self.normals = Some(n);
                self.corner_normals = corners;
            }
            None => self.recompute_normals(),
        }
    }
}

/// Per-corner normals carried as [`carry_normals`] carries per-vertex ones,
/// over the mesh split where a vertex's corners differ (each vertex and
/// normal its own vertex: the hard edges `smooth_groups` keeps apart).
/// `None` unless `corners` has one normal per face corner and every corner's
/// vertex is in `before` and `after`.
fn carry_corner_normals(
    before: &[Vec3],
    after: &[Vec3],
    faces: &Faces,
    corners: &[Vec3],
) -> Option<Vec<Vec3>> {
    let n = before.len().min(after.len());
    if corners.len() != faces.indices.len() || faces.indices.iter().any(|&v| v as usize >= n) {
        return None;
    }
    let mut split: HashMap<(u32, [u32; 3]), u32> = HashMap::new();
    let (mut b, mut a, mut normals) = (Vec::new(), Vec::new(), Vec::new());
    let mut indices = Vec::with_capacity(corners.len());
    for (&v, &c) in faces.indices.iter().zip(corners) {
        let key = (v, (c + Vec3::ZERO).to_array().map(f32::to_bits));
        let at = *split.entry(key).or_insert_with(|| {
            b.push(before[v as usize]);
            a.push(after[v as usize]);
            normals.push(c);
            (normals.len() - 1) as u32
        });
        indices.push(at);
    }
    let split_faces = Faces {
        offsets: faces.offsets.clone(),
        indices,
    };
    let carried = carry_normals(&b, &a, &split_faces, &normals);
    Some(
        split_faces
            .indices
            .iter()
            .map(|&i| carried[i as usize])
            .collect(),
    )
}

/// Per-vertex and, where needed, per-corner normals from each face corner's
/// normal (`None`: the corner has none): a vertex whose corners agree gets
/// their normal, one whose corners differ the normalised mean of theirs, one
/// with none `base`'s. The per-corner normals (a corner without one takes
/// its vertex's) are `Some` only when some vertex's corners differ.
pub(crate) fn normals_from_corners(
    base: Vec<Vec3>,
    faces: &Faces,
    corners: &[Option<Vec3>],
) -> (Vec<Vec3>, Option<Vec<Vec3>>) {
    let n = base.len();
    let mut first: Vec<Option<Vec3>> = vec![None; n];
    let mut sum = vec![Vec3::ZERO; n];
    let mut differs = vec![false; n];
    for (&v, c) in faces.indices.iter().zip(corners) {
        let (Some(c), Some(slot)) = (*c, first.get_mut(v as usize)) else {
            continue;
        };
        match slot {
            Some(f) if *f != c => differs[v as usize] = true,
            Some(_) => {}
            None => *slot = Some(c),
        }
        sum[v as usize] += c.normalize_or_zero();
    }
    let per_vertex: Vec<Vec3> = base
        .into_iter()
        .enumerate()
        .map(|(v, b)| match first[v] {
            Some(f) if !differs[v] => f,
            Some(f) => sum[v].normalize_or(f),
            None => b,
        })
        .collect();
    let split = differs.iter().any(|&d| d) && corners.len() == faces.indices.len();
    let per_corner = split.then(|| {
        faces
            .indices
            .iter()
            .zip(corners)
            .map(|(&v, c)| {
                c.unwrap_or_else(|| per_vertex.get(v as usize).copied().unwrap_or(Vec3::Z))
            })
            .collect()
    });
    (per_vertex, per_corner)
}

/// The smooth group of every vertex: vertices at the same position (bit for
/// bit: exporters write a seam's copies from one value) whose normals agree
/// within [`SAME_NORMAL_COS`] share a group (a vertex without a normal in
/// `normals` is a group of its own).
pub fn smooth_groups(positions: &[Vec3], normals: &[Vec3]) -> Vec<u32> {
    let mut at: HashMap<[u32; 3], Vec<u32>> = HashMap::new();
    let mut group = vec![0u32; positions.len()];
    let mut next = 0u32;
    for (v, p) in positions.iter().enumerate() {
        // -0.0 and 0.0 are one position.
        let key = (*p + Vec3::ZERO).to_array().map(f32::to_bits);
        let firsts = at.entry(key).or_default();
        let n = normals
            .get(v)
            .copied()
            .unwrap_or(Vec3::ZERO)
            .normalize_or_zero();
        let same = firsts.iter().copied().find(|&f| {
            let m = normals
                .get(f as usize)
                .copied()
                .unwrap_or(Vec3::ZERO)
                .normalize_or_zero();
            n.dot(m) > SAME_NORMAL_COS
        });
        group[v] = match same {
            Some(f) => group[f as usize],
            None => {
                firsts.push(v as u32);
                next += 1;
                next - 1
            }
        };
    }
    group
}

/// `normals` (one per vertex of `before`) carried to the moved positions
/// `after`: each rotated by the turn of its smooth group's area-weighted
/// normal (module docs). Unless `before`, `after` and `normals` have one
/// entry per vertex each, `normals` are returned as they are.
pub fn carry_normals(
    before: &[Vec3],
    after: &[Vec3],
    faces: &Faces,
    normals: &[Vec3],
) -> Vec<Vec3> {
    if before.len() != after.len() || before.len() != normals.len() {
        return normals.to_vec();
    }
    let group = smooth_groups(before, normals);
    let groups = group.iter().map(|&g| g as usize + 1).max().unwrap_or(0);
    let (mut n0, mut n1) = (vec![Vec3::ZERO; groups], vec![Vec3::ZERO; groups]);
    let n = before.len().min(after.len());
    for f in faces.iter() {
        if f.len() < 3 || f.iter().any(|&v| v as usize >= n) {
            continue;
        }
        let area = |p: &[Vec3]| {
            crate::fan(f).fold(Vec3::ZERO, |s, [a, b, c]| {
                let q = |i: u32| p[i as usize];
                s + (q(b) - q(a)).cross(q(c) - q(a))
            })
        };
        let (a0, a1) = (area(before), area(after));
        for &v in f {
            n0[group[v as usize] as usize] += a0;
            n1[group[v as usize] as usize] += a1;
        }
    }
    normals
        .iter()
        .zip(&group)
        .map(|(&nv, &g)| {
            let (a, b) = (
                n0[g as usize].normalize_or_zero(),
                n1[g as usize].normalize_or_zero(),
            );
            if a == b || a == Vec3::ZERO || b == Vec3::ZERO {
                return nv;
            }
            // Half-turns have no shortest arc: keep the face's own normal.
            if a.dot(b) < -0.9999 {
                return b;
            }
            (Quat::from_rotation_arc(a, b) * nv).normalize_or(b)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shapes;

    /// A UV sphere split at its seam and poles as Blender writes it: every
    /// face has its own copies of its corners where the UVs differ; here the
    /// worst case, every face its own corners, normals from the smooth
    /// (welded) sphere.
    fn split_sphere() -> Mesh {
        let welded = shapes::uv_sphere(1.0, 12, 24);
        let normals = crate::vertex_normals(&welded.positions, &welded.faces);
        let mut m = Mesh::default();
        let mut n = Vec::new();
        for f in welded.faces.iter() {
            let base = m.positions.len() as u32;
            for &v in f {
                m.positions.push(welded.positions[v as usize]);
                n.push(normals[v as usize]);
            }
            let face: Vec<u32> = (base..base + f.len() as u32).collect();
            m.faces.push(&face);
        }
        m.normals = Some(n);
        m
    }

    fn max_angle_between_copies(m: &Mesh) -> f32 {
        let n = m.normals.as_ref().expect("normals");
        let mut worst = 0f32;
        for i in 0..m.positions.len() {
            for j in i + 1..m.positions.len() {
                if m.positions[i] == m.positions[j] {
                    worst = worst.max(n[i].angle_between(n[j]).to_degrees());
                }
            }
        }
        worst
    }

    /// Seeded: a smooth bend that moves every vertex differently.
    fn bend(p: &[Vec3], seed: u64) -> Vec<Vec3> {
        let k = 0.3 + (seed % 7) as f32 * 0.05;
        p.iter()
            .map(|q| Vec3::new(q.x + k * q.y * q.y, q.y, q.z * (1.0 + k * q.x)))
            .collect()
    }

    #[test]
    fn nothing_moves_keeps_the_input_normals() {
        let mut m = split_sphere();
        // Normals a tool weighted its own way: not what csrbf would compute.
        let mut s = 12345u64;
        for n in m.normals.as_mut().expect("normals") {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let jitter = ((s >> 40) as f32 / (1u64 << 24) as f32 - 0.5) * 0.02;
            *n = (*n + Vec3::splat(jitter)).normalize();
        }
        let before = m.normals.clone().expect("normals");
        let same = m.positions.clone();
        m.move_vertices(same);
        for (a, b) in before.iter().zip(m.normals.as_ref().expect("normals")) {
            assert!((*a - *b).length() < 1e-6, "{a} became {b}");
        }
    }

    #[test]
    fn a_split_sphere_keeps_equal_normals_at_its_seams() {
        for seed in 0..3 {
            let mut m = split_sphere();
            assert!(max_angle_between_copies(&m) < 1e-3);
            let moved = bend(&m.positions, seed);
            m.move_vertices(moved);
            let worst = max_angle_between_copies(&m);
            assert!(
                worst < 1e-3,
                "seed {seed}: copies differ by {worst} degrees"
            );
            // And the normals did turn with the surface.
            let fresh = {
                let mut w = m.clone();
                w.recompute_normals();
                w
            };
            assert!(
                m.normals.as_ref().expect("normals")[0]
                    .angle_between(fresh.normals.as_ref().expect("normals")[0])
                    < 0.5
            );
        }
    }

    #[test]
    fn a_cube_keeps_its_hard_edges() {
        // Six faces, each with its own four corners and its flat normal.
        let cube = shapes::subdivided_box(Vec3::ONE, [1, 1, 1]);
        let mut m = Mesh::default();
        let mut n = Vec::new();
        for f in cube.faces.iter() {
            let p: Vec<Vec3> = f.iter().map(|&v| cube.positions[v as usize]).collect();
            let normal = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
            let base = m.positions.len() as u32;
            m.positions.extend(&p);
            n.extend(std::iter::repeat_n(normal, p.len()));
            m.faces
                .push(&(base..base + p.len() as u32).collect::<Vec<_>>());
        }
        m.normals = Some(n);
        // A rotation with a stretch: faces stay flat, turn and tilt.
        let r = Quat::from_rotation_y(0.7) * Quat::from_rotation_x(0.3);
        let moved: Vec<Vec3> = m
            .positions
            .iter()
            .map(|&p| r * (p * Vec3::new(2.0, 1.0, 0.5)))
            .collect();
        m.move_vertices(moved);
        let normals = m.normals.as_ref().expect("normals");
        for (fi, f) in m.faces.iter().enumerate() {
            let p: Vec<Vec3> = f.iter().map(|&v| m.positions[v as usize]).collect();
            let flat = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
            for &v in f {
                let angle = normals[v as usize].angle_between(flat).to_degrees();
                assert!(
                    angle < 1e-2,
                    "face {fi} vertex {v}: {angle} degrees off flat"
                );
            }
        }
    }
}
