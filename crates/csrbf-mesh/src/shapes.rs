//! Simple meshes made in code: a box with subdivided faces and a UV sphere,
//! for demos and tests.

use glam::{Vec2, Vec3};

use crate::{Faces, Mesh, TexCoords};

/// An axis-aligned box centred at the origin with `size`, each face split
/// into a grid of quads (`segments` along x, y, z); vertices are shared
/// between faces. With 8 segments everywhere it has 386 vertices and 384
/// quads (768 triangles): the papers' deformable box.
pub fn subdivided_box(size: Vec3, segments: [u32; 3]) -> Mesh {
    let n = segments.map(|s| s.max(1) as usize);
    let half = size * 0.5;
    let mut positions: Vec<Vec3> = Vec::new();
    let mut index = std::collections::HashMap::new();
    let mut faces = Faces::new();
    let mut vertex = |i: [usize; 3]| -> u32 {
        *index.entry(i).or_insert_with(|| {
            let p = Vec3::new(
                i[0] as f32 / n[0] as f32,
                i[1] as f32 / n[1] as f32,
                i[2] as f32 / n[2] as f32,
            );
            positions.push((p * 2.0 - 1.0) * half);
            positions.len() as u32 - 1
        })
    };
    // For each axis a and side, the face's grid runs over the other two axes.
    for a in 0..3 {
        let (u, v) = ((a + 1) % 3, (a + 2) % 3);
        for side in [0, n[a]] {
            for i in 0..n[u] {
                for j in 0..n[v] {
                    let at = |di: usize, dj: usize| {
                        let mut c = [0usize; 3];
                        c[a] = side;
                        c[u] = i + di;
                        c[v] = j + dj;
                        c
                    };
                    let q = [
                        vertex(at(0, 0)),
                        vertex(at(1, 0)),
                        vertex(at(1, 1)),
                        vertex(at(0, 1)),
                    ];
                    // Outward winding.
                    if side == 0 {
                        faces.push(&[q[0], q[3], q[2], q[1]]);
                    } else {
                        faces.push(&q);
                    }
                }
            }
        }
    }
    Mesh {
        positions,
        faces,
        ..Mesh::default()
    }
}

/// A UV sphere of `radius` centred at the origin with `rings` bands of
/// latitude and `segments` of longitude, with texture coordinates.
pub fn uv_sphere(radius: f32, rings: u32, segments: u32) -> Mesh {
    let (rings, segments) = (rings.max(2), segments.max(3));
    let mut positions = vec![Vec3::Y * radius];
    let mut uvs = vec![Vec2::new(0.5, 1.0)];
    for r in 1..rings {
        let theta = std::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..segments {
            let phi = std::f32::consts::TAU * s as f32 / segments as f32;
            positions.push(
                Vec3::new(
                    theta.sin() * phi.cos(),
                    theta.cos(),
                    -theta.sin() * phi.sin(),
                ) * radius,
            );
            uvs.push(Vec2::new(
                s as f32 / segments as f32,
                1.0 - r as f32 / rings as f32,
            ));
        }
    }
    positions.push(Vec3::NEG_Y * radius);
    uvs.push(Vec2::new(0.5, 0.0));
    let south = positions.len() as u32 - 1;
    let ring = |r: u32, s: u32| 1 + (r - 1) * segments + s % segments;
    let mut faces = Faces::new();
    for s in 0..segments {
        faces.push(&[0, ring(1, s), ring(1, s + 1)]);
        for r in 1..rings - 1 {
            faces.push(&[
                ring(r, s),
                ring(r + 1, s),
                ring(r + 1, s + 1),
                ring(r, s + 1),
            ]);
        }
        faces.push(&[ring(rings - 1, s), south, ring(rings - 1, s + 1)]);
    }
    Mesh {
        positions,
        faces,
        uvs: Some(TexCoords {
            values: uvs,
            corners: None,
        }),
        ..Mesh::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Signed volume: positive for a closed mesh with outward faces.
    fn volume(m: &Mesh) -> f32 {
        let tri = |t: &[u32; 3]| {
            let [a, b, c] = t.map(|i| m.positions[i as usize]);
            a.dot(b.cross(c)) / 6.0
        };
        m.faces.triangles().iter().map(tri).sum()
    }

    #[test]
    fn the_papers_box_has_386_vertices_and_768_triangles() {
        let m = subdivided_box(Vec3::splat(2.0), [8, 8, 8]);
        assert_eq!(m.positions.len(), 386);
        assert_eq!(m.faces.triangle_count(), 768);
        m.validate(std::path::Path::new("box")).expect("valid");
        // Closed and outward: the signed volume is positive and equals 8.
        let vol = volume(&m);
        assert!((vol - 8.0).abs() < 1e-3, "{vol}");
    }

    #[test]
    fn sphere_is_closed_and_outward() {
        let m = uv_sphere(1.0, 12, 24);
        m.validate(std::path::Path::new("sphere")).expect("valid");
        let vol = volume(&m);
        assert!(vol > 3.9 && vol < 4.2, "{vol}");
    }
}

/// Faces for points lying on a sphere about `centre` (a Fibonacci lattice, a
/// scan of a ball): their spherical Delaunay triangulation, which is their
/// convex hull, found as the planar Delaunay triangulation of their
/// stereographic projection from the pole above the centre, with the hole
/// around that pole closed by a fan. Triangles face outwards. Points not on
/// the sphere give a triangulation of their directions from `centre`.
pub fn sphere_faces(points: &[Vec3], centre: Vec3) -> Faces {
    let mut faces = Faces::new();
    if points.len() < 4 {
        return faces;
    }
    let dirs: Vec<glam::DVec3> = points
        .iter()
        .map(|p| (*p - centre).as_dvec3().normalize_or_zero())
        .collect();
    // Project from the pole: no point sits exactly on it for a lattice; one
    // that does is left out of the planar step and joins through the fan.
    let planar: Vec<delaunator::Point> = dirs
        .iter()
        .map(|d| {
            let k = 1.0 - d.z;
            if k > 1e-12 {
                delaunator::Point {
                    x: d.x / k,
                    y: d.y / k,
                }
            } else {
                delaunator::Point { x: 1e12, y: 1e12 }
            }
        })
        .collect();
    let t = delaunator::triangulate(&planar);
    let mut push = |a: usize, b: usize, c: usize| {
        let (pa, pb, pc) = (dirs[a], dirs[b], dirs[c]);
        let outward = (pb - pa).cross(pc - pa).dot(pa + pb + pc) > 0.0;
        if outward {
            faces.push(&[a as u32, b as u32, c as u32]);
        } else {
            faces.push(&[a as u32, c as u32, b as u32]);
        }
    };
    for tri in t.triangles.chunks_exact(3) {
        push(tri[0], tri[1], tri[2]);
    }
    // The cap around the pole: the planar hull, closed by a fan.
    for k in 1..t.hull.len().saturating_sub(1) {
        push(t.hull[0], t.hull[k], t.hull[k + 1]);
    }
    faces
}

#[cfg(test)]
mod sphere_tests {
    use super::*;

    #[test]
    fn a_lattice_on_a_sphere_gets_a_closed_outward_surface() {
        // A Fibonacci lattice of 5,000 points.
        let n = 5000;
        let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
        let centre = Vec3::splat(0.5);
        let pts: Vec<Vec3> = (0..n)
            .map(|i| {
                let z = 1.0 - (i as f32 + 0.5) * 2.0 / n as f32;
                let r = (1.0 - z * z).sqrt();
                let a = golden * i as f32;
                centre + Vec3::new(r * a.cos(), r * a.sin(), z) * 0.4
            })
            .collect();
        let faces = sphere_faces(&pts, centre);
        // A closed triangulated sphere: 2V - 4 faces, every edge twice.
        assert_eq!(faces.len(), 2 * n - 4);
        let mut edges = std::collections::HashMap::new();
        for f in faces.iter() {
            for k in 0..3 {
                let (a, b) = (f[k], f[(k + 1) % 3]);
                *edges.entry((a.min(b), a.max(b))).or_insert(0) += 1;
                // Outward: the face's normal points away from the centre.
                let p = |i: u32| pts[i as usize] - centre;
                let nrm = (p(f[1]) - p(f[0])).cross(p(f[2]) - p(f[0]));
                assert!(nrm.dot(p(f[0]) + p(f[1]) + p(f[2])) > 0.0);
            }
        }
        assert!(
            edges.values().all(|&c| c == 2),
            "every edge shared by two faces"
        );
        // The area is the sphere's, near enough.
        let area: f32 = faces
            .iter()
            .map(|f| {
                let p = |i: u32| pts[i as usize];
                (p(f[1]) - p(f[0])).cross(p(f[2]) - p(f[0])).length() * 0.5
            })
            .sum();
        let want = 4.0 * std::f32::consts::PI * 0.16;
        assert!((area / want - 1.0).abs() < 0.01, "{area} vs {want}");
        assert!(sphere_faces(&pts[..3], centre).is_empty());
    }
}
