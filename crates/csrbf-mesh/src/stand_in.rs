//! What the studio draws of a big mesh while it moves (the Picker's drag,
//! the Composer's playback): a vertex clustering that follows the full
//! mesh's deformation by gathering its vertices.

use glam::Vec3;

use crate::{cluster_triangles, triangle_vertex_normals};

/// A light copy of a big mesh, drawn while it moves: the triangles of a
/// vertex clustering ([`cluster_triangles`], about 50k whatever
/// the size) over the few vertices they use, which are gathered from the
/// deformed positions each frame (so it moves by the same map).
pub struct StandIn {
    /// The full mesh's vertices it uses.
    pub vertices: Vec<u32>,
    /// Its triangles, indexing `vertices`.
    pub indices: Vec<u32>,
}

impl StandIn {
    /// The stand-in of a mesh (80 cells along its longest side).
    pub fn new(positions: &[Vec3], triangles: &[[u32; 3]]) -> StandIn {
        let light = cluster_triangles(positions, triangles, 80);
        let mut local = std::collections::HashMap::new();
        let mut vertices = Vec::new();
        let mut indices = Vec::with_capacity(light.len() * 3);
        for t in light {
            for i in t {
                let k = *local.entry(i).or_insert_with(|| {
                    vertices.push(i);
                    vertices.len() as u32 - 1
                });
                indices.push(k);
            }
        }
        StandIn { vertices, indices }
    }

    /// The stand-in's positions and normals (its own, from its triangles:
    /// the full mesh's may lag a drag) given the full mesh's positions.
    pub fn shape(&self, positions: &[Vec3]) -> (Vec<Vec3>, Vec<Vec3>) {
        let p = self.gather(positions);
        let tris: Vec<[u32; 3]> = self
            .indices
            .chunks_exact(3)
            .map(|t| [t[0], t[1], t[2]])
            .collect();
        let n = triangle_vertex_normals(&p, &tris);
        (p, n)
    }

    /// `values` of the full mesh at the stand-in's vertices.
    pub fn gather(&self, values: &[Vec3]) -> Vec<Vec3> {
        self.vertices
            .iter()
            .map(|&i| values.get(i as usize).copied().unwrap_or_default())
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::StandIn;
    use crate::shapes;

    #[test]
    fn the_stand_in_follows_the_full_mesh_with_few_vertices() {
        let m = shapes::uv_sphere(1.0, 400, 800);
        let tris = m.faces.triangles();
        let light = StandIn::new(&m.positions, &tris);
        assert!(light.vertices.len() * 10 < m.positions.len());
        assert!(light.indices.len() * 10 < tris.len() * 3);
        assert!(
            light
                .indices
                .iter()
                .all(|&i| (i as usize) < light.vertices.len())
        );
        // Gathered from moved positions, its vertices are the moved ones.
        let moved: Vec<_> = m.positions.iter().map(|p| *p * 2.0).collect();
        for (k, p) in light.gather(&moved).iter().enumerate() {
            assert_eq!(*p, moved[light.vertices[k] as usize]);
        }
    }
}
