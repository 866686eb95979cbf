//! Checks and derived geometry: bounds, normals, validation.

use std::path::Path;

use glam::Vec3;

use crate::{Mesh, MeshError, Result};

impl Mesh {
    /// Smallest and largest coordinates; `None` for a mesh with no vertex.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        if self.positions.is_empty() {
            return None;
        }
        Some(self.positions.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), p| (lo.min(*p), hi.max(*p)),
        ))
    }

    /// Length of the bounding-box diagonal (0 when empty).
    pub fn diagonal(&self) -> f32 {
        self.bounds().map_or(0.0, |(lo, hi)| (hi - lo).length())
    }

    /// Area-weighted vertex normals from the faces (fan-triangulated).
    /// Vertices on no face get +Z.
    /// Per-corner normals are dropped: the recomputed ones are smooth.
    pub fn recompute_normals(&mut self) {
        self.normals = Some(vertex_normals(&self.positions, &self.faces));
        self.corner_normals = None;
    }

    /// Checks what every consumer relies on: at least one vertex, finite
    /// coordinates, faces of at least 3 corners with indices in range, and
    /// attributes of matching lengths. `path` names the file in the message.
    pub fn validate(&self, path: &Path) -> Result<()> {
        let invalid = |message: String| MeshError::Invalid {
            path: path.to_owned(),
            message,
        };
        let n = self.positions.len();
        if n == 0 {
            return Err(invalid("the mesh has no vertices".into()));
        }
        if let Some(i) = self.positions.iter().position(|p| !p.is_finite()) {
            return Err(invalid(format!(
                "vertex {i} has a coordinate that is not finite: {}",
                self.positions[i]
            )));
        }
        for (f, face) in self.faces.iter().enumerate() {
            if face.len() < 3 {
                return Err(invalid(format!(
                    "face {f} has {} corners; a face needs at least 3",
                    face.len()
                )));
            }
            if let Some(&v) = face.iter().find(|&&v| v as usize >= n) {
                return Err(invalid(format!(
                    "face {f} refers to vertex {v}, but there are only {n} vertices"
                )));
            }
        }
        if let Some(uv) = &self.uvs {
            match &uv.corners {
                None if uv.values.len() != n => {
                    return Err(invalid(format!(
                        "{} texture coordinates for {n} vertices",
                        uv.values.len()
                    )));
                }
                Some(c) if c.len() != self.faces.indices.len() => {
                    return Err(invalid(
                        "texture coordinate indices do not match the face corners".into(),
                    ));
                }
                Some(c) => {
                    if let Some(&t) = c.iter().find(|&&t| t as usize >= uv.values.len()) {
                        return Err(invalid(format!(
                            "a face refers to texture coordinate {t}, but there are only {}",
                            uv.values.len()
                        )));
                    }
                }
                None => {}
            }
        }
        if let Some(c) = &self.colors
            && c.len() != n
        {
            return Err(invalid(format!("{} colours for {n} vertices", c.len())));
        }
        let faces = self.faces.len() as u32;
        for p in &self.parts {
            if let Some(&f) = p.faces.iter().find(|&&f| f >= faces) {
                return Err(invalid(format!(
                    "part {:?} refers to face {f}, but there are only {faces}",
                    p.name
                )));
            }
        }
        Ok(())
    }
}

/// Area-weighted vertex normals of `positions` over `faces` (fan-triangulated);
/// vertices on no face get +Z.
pub fn vertex_normals(positions: &[Vec3], faces: &crate::Faces) -> Vec<Vec3> {
    let mut n = vec![Vec3::ZERO; positions.len()];
    for f in faces.iter() {
        if f.len() < 3 || f.iter().any(|&v| v as usize >= positions.len()) {
            continue;
        }
        // The sum over the fan gives the polygon's area vector.
        let mut area = Vec3::ZERO;
        for [a, b, c] in crate::fan(f) {
            let p = |i: u32| positions[i as usize];
            area += (p(b) - p(a)).cross(p(c) - p(a));
        }
        for &v in f {
            n[v as usize] += area;
        }
    }
    for v in &mut n {
        *v = v.try_normalize().unwrap_or(Vec3::Z);
    }
    n
}

/// Area-weighted vertex normals over a triangle list (faster than
/// [`vertex_normals`] when the triangles are kept between calls); vertices on
/// no triangle get +Z, triangles with an index out of range are skipped.
pub fn triangle_vertex_normals(positions: &[Vec3], triangles: &[[u32; 3]]) -> Vec<Vec3> {
    let mut out = Vec::new();
    triangle_vertex_normals_into(positions, triangles, &mut out);
    out
}

/// [`triangle_vertex_normals`] into `out`, reusing its memory.
pub fn triangle_vertex_normals_into(
    positions: &[Vec3],
    triangles: &[[u32; 3]],
    out: &mut Vec<Vec3>,
) {
    let n = positions.len();
    out.clear();
    out.resize(n, Vec3::ZERO);
    for t in triangles {
        let [a, b, c] = t.map(|i| i as usize);
        if a >= n || b >= n || c >= n {
            continue;
        }
        let (pa, pb, pc) = (positions[a], positions[b], positions[c]);
        let area = (pb - pa).cross(pc - pa);
        out[a] += area;
        out[b] += area;
        out[c] += area;
    }
    for v in out.iter_mut() {
        let len2 = v.length_squared();
        *v = if len2 > 0.0 {
            *v * len2.sqrt().recip()
        } else {
            Vec3::Z
        };
    }
}

/// The model's up axis when the user did not say, with the reason: glTF is
/// +Y by its specification, STL +Z by the habit of CAD tools; otherwise +Z
/// when the model is clearly taller along Z than along Y, else +Y.
pub fn guess_up(mesh: &crate::Mesh, path: &Path) -> (Vec3, &'static str) {
    use crate::Format;
    match Format::from_path(path) {
        Ok(Format::Gltf | Format::Glb) => return (Vec3::Y, "glTF is Y-up"),
        Ok(Format::Stl) => return (Vec3::Z, "STL files are usually Z-up"),
        _ => {}
    }
    let Some((lo, hi)) = mesh.bounds() else {
        return (Vec3::Y, "empty model");
    };
    let e = hi - lo;
    if e.z > 1.5 * e.y && e.z >= e.x {
        (Vec3::Z, "the model is tallest along Z")
    } else {
        (Vec3::Y, "the usual convention")
    }
}

/// A lighter stand-in for drawing a big mesh while it moves: vertex
/// clustering on a grid of `cells` cells along the longest side of the
/// bounds of `positions`. Each cell keeps one of its vertices (the first);
/// a triangle survives, re-indexed to the kept vertices, when its corners
/// fall in three different cells, once per set of cells. The indices point
/// into the same vertex array, so the stand-in follows any deformation of
/// the full mesh at no cost. Out-of-range triangles are skipped.
pub fn cluster_triangles(positions: &[Vec3], triangles: &[[u32; 3]], cells: u32) -> Vec<[u32; 3]> {
    let n = positions.len();
    let (lo, hi) = positions
        .iter()
        .filter(|p| p.is_finite())
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), p| {
            (a.min(*p), b.max(*p))
        });
    if !(lo.cmple(hi).all()) || cells == 0 {
        return triangles.to_vec();
    }
    let side = (hi - lo).max_element().max(f32::MIN_POSITIVE);
    let cells = cells.clamp(1, 1 << 20) as f32;
    let cell_of = |p: Vec3| -> u64 {
        let c = ((p - lo) / side * cells)
            .floor()
            .clamp(Vec3::ZERO, Vec3::splat(cells));
        (c.x as u64) | ((c.y as u64) << 21) | ((c.z as u64) << 42)
    };
    let mut representative: std::collections::HashMap<u64, u32> =
        std::collections::HashMap::with_capacity(n / 4);
    let mut kept = vec![0u32; n];
    for (i, p) in positions.iter().enumerate() {
        kept[i] = *representative.entry(cell_of(*p)).or_insert(i as u32);
    }
    let mut seen = std::collections::HashSet::with_capacity(triangles.len() / 4);
    let mut out = Vec::new();
    for t in triangles {
        if t.iter().any(|&i| i as usize >= n) {
            continue;
        }
        let k = t.map(|i| kept[i as usize]);
        if k[0] == k[1] || k[1] == k[2] || k[0] == k[2] {
            continue;
        }
        let mut key = k;
        key.sort_unstable();
        if seen.insert(key) {
            out.push(k);
        }
    }
    out
}

#[cfg(test)]
mod cluster_tests {
    use super::*;

    #[test]
    fn the_stand_in_is_lighter_uses_kept_vertices_and_keeps_the_shape() {
        let m = crate::shapes::uv_sphere(1.0, 200, 400);
        let tris = m.faces.triangles();
        let light = cluster_triangles(&m.positions, &tris, 40);
        assert!(
            light.len() * 8 < tris.len(),
            "{} of {}",
            light.len(),
            tris.len()
        );
        assert!(light.len() > 2000, "{}", light.len());
        // Every triangle is proper and on the sphere's surface.
        for t in &light {
            assert!(t[0] != t[1] && t[1] != t[2] && t[0] != t[2]);
            for &i in t {
                assert!((m.positions[i as usize].length() - 1.0).abs() < 1e-4);
            }
        }
        // It still covers the sphere: its area is within 5 % of the full one.
        let area = |ts: &[[u32; 3]]| -> f32 {
            ts.iter()
                .map(|t| {
                    let p = |k: usize| m.positions[t[k] as usize];
                    (p(1) - p(0)).cross(p(2) - p(0)).length() * 0.5
                })
                .sum()
        };
        let (a, b) = (area(&light), area(&tris));
        assert!((a / b - 1.0).abs() < 0.05, "{a} vs {b}");
        // Degenerate inputs do not panic.
        assert!(cluster_triangles(&[], &[], 10).is_empty());
        assert_eq!(
            cluster_triangles(&m.positions, &[[0, 1, 99_999_999]], 10).len(),
            0
        );
    }
}
