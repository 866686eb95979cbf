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
    pub fn recompute_normals(&mut self) {
        self.normals = Some(vertex_normals(&self.positions, &self.faces));
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
