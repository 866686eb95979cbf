//! Polygon meshes for csrbf: [`Mesh`] with positions, polygon faces, UVs,
//! vertex colours and named parts, read and written as OBJ, PLY (ASCII and
//! binary), STL (ASCII and binary), OFF and glTF 2.0 (`.gltf`, `.glb`).
//!
//! Vertex order and count are kept from the file (STL, which stores
//! triangles apart, is welded on exact equal positions), so a deformed mesh
//! can be compared with its input vertex by vertex. Every error names the
//! file and the line or element.
//!
//! ```
//! use csrbf_mesh::{Mesh, Format};
//!
//! let obj = b"v 0 0 0\nv 1 0 0\nv 0 1 0\ng tri\nf 1 2 3\n";
//! let mut mesh = Mesh::from_bytes(obj, Format::Obj, "tri.obj".as_ref())?;
//! assert_eq!(mesh.positions.len(), 3);
//! assert_eq!(mesh.part_vertices("tri"), Some(vec![0, 1, 2]));
//! mesh.positions[2].z = 0.5;
//! mesh.recompute_normals();
//! let bytes = mesh.to_bytes(Format::Ply)?;
//! let back = Mesh::from_bytes(&bytes, Format::Ply, "tri.ply".as_ref())?;
//! assert_eq!(back.positions, mesh.positions);
//! # Ok::<(), csrbf_mesh::MeshError>(())
//! ```

// `unwrap` only in tests (clippy.toml allows it there); library code says
// why a value is there with `expect`, or handles its absence.
#![warn(clippy::unwrap_used)]

mod base64;
pub mod bvh;
mod carry;
mod error;
/// The file formats.
pub mod formats;
mod geometry;
pub mod intersect;
mod io;
mod normals;
pub mod shapes;
mod stand_in;
pub mod volume;

pub use bvh::{Bvh, Hit, Nearest, Ray};
pub use carry::{SAME_NORMAL_COS, carry_normals, smooth_groups};
pub use error::{MeshError, Result};
pub use formats::Format;
pub use geometry::{
    cluster_triangles, guess_up, triangle_vertex_normals, triangle_vertex_normals_into,
    vertex_normals,
};
pub use io::{
    Loaded, TEMP_PREFIX, WriteOptions, Written, load, read, remove_live_temps, remove_stale_temps,
    replace, temp_beside, track_temp, untrack_temp, write, write_all_atomic, write_atomic,
    write_with,
};
pub use normals::{
    CacheAligned, NormalsScratch, POINT_FLOATS, VertexNormals, add_scaled, scaled_sum_into,
};
pub use stand_in::StandIn;

use glam::{Vec2, Vec3};

/// Polygon faces in compressed form: face `f` is
/// `indices[offsets[f]..offsets[f + 1]]`, vertex indices in the file's order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Faces {
    /// Start of each face in `indices`, plus the end.
    pub offsets: Vec<u32>,
    /// Vertex indices of every face corner.
    pub indices: Vec<u32>,
}

impl Faces {
    /// No faces.
    pub fn new() -> Faces {
        Faces {
            offsets: vec![0],
            indices: Vec::new(),
        }
    }

    /// Number of faces.
    pub fn len(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// Whether there is no face.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The vertex indices of face `f`.
    pub fn face(&self, f: usize) -> &[u32] {
        &self.indices[self.offsets[f] as usize..self.offsets[f + 1] as usize]
    }

    /// Appends a face.
    pub fn push(&mut self, corners: &[u32]) {
        if self.offsets.is_empty() {
            self.offsets.push(0);
        }
        self.indices.extend_from_slice(corners);
        self.offsets.push(self.indices.len() as u32);
    }

    /// Every face.
    pub fn iter(&self) -> impl Iterator<Item = &[u32]> + '_ {
        (0..self.len()).map(|f| self.face(f))
    }

    /// Number of triangles after fan triangulation.
    pub fn triangle_count(&self) -> usize {
        self.iter().map(|f| f.len().saturating_sub(2)).sum()
    }

    /// The face a triangle of [`Faces::triangles`] came from (the last face
    /// for an index past the end).
    pub fn face_of_triangle(&self, triangle: usize) -> usize {
        let mut seen = 0;
        for (f, corners) in self.iter().enumerate() {
            seen += corners.len().saturating_sub(2);
            if triangle < seen {
                return f;
            }
        }
        self.len().saturating_sub(1)
    }

    /// Fan triangulation of every face.
    pub fn triangles(&self) -> Vec<[u32; 3]> {
        let mut out = Vec::with_capacity(self.triangle_count());
        for f in self.iter() {
            out.extend(fan(f));
        }
        out
    }

    /// The fan triangles of the faces listed (a part's), flattened into an
    /// index list.
    pub fn triangle_indices(&self, faces: &[u32]) -> Vec<u32> {
        let mut out = Vec::new();
        for &f in faces {
            if (f as usize) < self.len() {
                out.extend(fan(self.face(f as usize)).flatten());
            }
        }
        out
    }
}

/// The fan triangulation of one polygon: `[c0, ck, ck+1]` for k in 1..n-1;
/// nothing for fewer than 3 corners. The one triangulation every writer,
/// renderer and measure uses.
pub fn fan<T: Copy>(corners: &[T]) -> impl Iterator<Item = [T; 3]> + '_ {
    (1..corners.len().saturating_sub(1)).map(move |k| [corners[0], corners[k], corners[k + 1]])
}

/// Texture coordinates: per vertex, or per face corner with their own
/// indices (as OBJ stores them).
#[derive(Clone, Debug, PartialEq)]
pub struct TexCoords {
    /// The coordinates.
    pub values: Vec<Vec2>,
    /// For per-corner coordinates, the index into `values` of every face
    /// corner (aligned with [`Faces::indices`]); `None` when per vertex.
    pub corners: Option<Vec<u32>>,
}

impl TexCoords {
    /// One coordinate per vertex, when every corner of a vertex has the same
    /// coordinate (or the coordinates are per vertex already).
    pub fn per_vertex(&self, faces: &Faces, vertices: usize) -> Option<Vec<Vec2>> {
        let Some(corners) = &self.corners else {
            return (self.values.len() == vertices).then(|| self.values.clone());
        };
        let mut out: Vec<Option<Vec2>> = vec![None; vertices];
        for (&v, &t) in faces.indices.iter().zip(corners) {
            let uv = *self.values.get(t as usize)?;
            match &mut out[v as usize] {
                Some(old) if *old != uv => return None,
                slot => *slot = Some(uv),
            }
        }
        Some(out.into_iter().map(|v| v.unwrap_or(Vec2::ZERO)).collect())
    }
}

/// What a named part came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PartKind {
    /// An OBJ `g` group or a glTF mesh.
    Group,
    /// An OBJ `o` object or a glTF node.
    Object,
    /// A material (`usemtl`, a glTF material).
    Material,
}

impl PartKind {
    /// The lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            PartKind::Group => "group",
            PartKind::Object => "object",
            PartKind::Material => "material",
        }
    }
}

/// A named set of faces.
#[derive(Clone, Debug, PartialEq)]
pub struct Part {
    /// The name in the file.
    pub name: String,
    /// Group, object or material.
    pub kind: PartKind,
    /// Indices of the part's faces, ascending.
    pub faces: Vec<u32>,
}

/// A material's look, where the file gives one.
///
/// Made with [`Material::new`] (or `Default`) and the fields set after:
/// the struct is `#[non_exhaustive]` so that a new property does not break
/// every construction site. The defaults are what csrbf has always written
/// for materials of formats without PBR properties (OBJ, PLY, OFF):
/// metallic 0, roughness 0.8, no emission, one-sided, the alpha mode chosen
/// from the colour's alpha. The glTF reader sets every property from the
/// file, with glTF's own defaults where a field is absent (metallic 1,
/// roughness 1).
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct Material {
    /// Its name.
    pub name: String,
    /// Base colour, linear RGBA: glTF's `baseColorFactor`; an OBJ's
    /// material library holds it as `Kd` and `d` (read and written as these
    /// numbers, so they survive OBJ -> glTF -> OBJ). A texture is multiplied
    /// by it, in both formats. Default: light grey, opaque.
    pub color: [f32; 4],
    /// An embedded base-colour image: its MIME type and bytes.
    pub texture: Option<(String, Vec<u8>)>,
    /// How the base-colour image is sampled (glTF's sampler); `None`:
    /// the reader's default (glTF: linear, repeat).
    pub sampler: Option<Sampler>,
    /// Metalness in [0, 1]. Default 0 (glTF's own default, 1, when a glTF
    /// material leaves it out).
    pub metallic: f32,
    /// Perceptual roughness in [0, 1]. Default 0.8 (glTF: 1 when absent).
    pub roughness: f32,
    /// Emitted light, linear RGB. Default black.
    pub emissive: [f32; 3],
    /// Drawn from both sides (no back-face culling). Default false.
    pub double_sided: bool,
    /// How alpha is used; `None` (the default): blended when the colour's
    /// alpha is below 1, opaque otherwise.
    pub alpha_mode: Option<AlphaMode>,
    /// glTF's tangent-space normal map, written back unchanged: it stays
    /// right on a deformed mesh because csrbf writes no tangents, so readers
    /// rebuild the tangent frame (MikkTSpace, as glTF requires) from the
    /// deformed normals and the UVs; the map's bumps turn with the surface.
    /// Its `scale` is glTF's normal scale.
    pub normal_texture: Option<TextureMap>,
    /// glTF's occlusion map (red channel); its `scale` is the strength.
    pub occlusion_texture: Option<TextureMap>,
    /// glTF's emissive map, times `emissive`.
    pub emissive_texture: Option<TextureMap>,
    /// glTF's metallic-roughness map (blue: metal, green: roughness), times
    /// `metallic` and `roughness`.
    pub metallic_roughness_texture: Option<TextureMap>,
}

/// A material's texture other than the base colour: an embedded image read
/// through the first UV set (csrbf keeps one UV set; a glTF map on another
/// is not kept).
#[derive(Clone, Debug, PartialEq)]
pub struct TextureMap {
    /// The image: its MIME type and bytes.
    pub image: (String, Vec<u8>),
    /// How it is sampled.
    pub sampler: Option<Sampler>,
    /// The normal map's scale or the occlusion map's strength; 1 otherwise.
    pub scale: f32,
}

impl Default for Material {
    fn default() -> Self {
        Material {
            name: String::new(),
            color: [0.8, 0.8, 0.8, 1.0],
            texture: None,
            sampler: None,
            metallic: 0.0,
            roughness: 0.8,
            emissive: [0.0; 3],
            double_sided: false,
            alpha_mode: None,
            normal_texture: None,
            occlusion_texture: None,
            emissive_texture: None,
            metallic_roughness_texture: None,
        }
    }
}

impl Material {
    /// A material of this name and base colour, the rest at the defaults.
    pub fn new(name: impl Into<String>, color: [f32; 4]) -> Self {
        Material {
            name: name.into(),
            color,
            ..Material::default()
        }
    }
}

/// How a material's alpha is used (glTF's `alphaMode`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AlphaMode {
    /// Alpha ignored.
    Opaque,
    /// Drawn where alpha is at least the cutoff, not drawn elsewhere.
    Mask(f32),
    /// Blended with what lies behind.
    Blend,
}

/// How a texture is sampled, in glTF's codes (kept as numbers so that a
/// round trip writes back exactly what it read): filters 9728 nearest,
/// 9729 linear, 9984-9987 the mipmap minifications; wraps 33071 clamp,
/// 33648 mirrored repeat, 10497 repeat.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Sampler {
    /// Magnification filter; `None`: the reader chooses.
    pub mag_filter: Option<u32>,
    /// Minification filter; `None`: the reader chooses.
    pub min_filter: Option<u32>,
    /// Wrap along u; `None`: repeat.
    pub wrap_s: Option<u32>,
    /// Wrap along v; `None`: repeat.
    pub wrap_t: Option<u32>,
}

/// A polygon mesh.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Polygon faces.
    pub faces: Faces,
    /// Texture coordinates, if the file has them.
    pub uvs: Option<TexCoords>,
    /// Per-vertex normals: from the file, or recomputed. Where the file
    /// gives a vertex several normals (see `corner_normals`), its normalised
    /// mean.
    pub normals: Option<Vec<Vec3>>,
    /// Per face-corner normals (aligned with [`Faces::indices`]), kept only
    /// when the file gives some vertex different normals on different
    /// corners (hard edges, custom split normals: an OBJ's `f v//vn`), as
    /// per-corner UVs keep UV seams. The OBJ and glTF writers write them
    /// (glTF splits such vertices, and csrbf welds them back on reading);
    /// the others write `normals`. [`Mesh::move_vertices`] carries them,
    /// [`Mesh::recompute_normals`] drops them. Ignored unless it has one
    /// entry per face corner.
    pub corner_normals: Option<Vec<Vec3>>,
    /// Per-vertex colours, linear RGBA in [0, 1].
    pub colors: Option<Vec<[f32; 4]>>,
    /// Named parts: groups, objects, materials.
    pub parts: Vec<Part>,
    /// Materials by name, for formats that carry them.
    pub materials: Vec<Material>,
    /// The OBJ material library the file referred to (its `mtllib` line).
    pub material_library: Option<String>,
    /// The material library files `materials` were read from (canonical
    /// paths), when all were read: an OBJ written beside them names them
    /// instead of writing a copy (which keeps what csrbf does not read:
    /// shininess, bump maps, ...).
    pub material_files: Vec<std::path::PathBuf>,
    /// Each face's OBJ smoothing group (`s N`; 0 is `s off`), when the file
    /// smoothed any face: Blender and Maya shade those faces smooth. Ignored
    /// unless it has one entry per face.
    pub smoothing: Option<Vec<u32>>,
}

impl Mesh {
    /// The index of the part of this kind and name, made (empty) if missing;
    /// `index` remembers the parts made so far, for readers.
    pub(crate) fn part_index(
        &mut self,
        index: &mut std::collections::HashMap<(PartKind, String), usize>,
        kind: PartKind,
        name: String,
    ) -> usize {
        *index.entry((kind, name.clone())).or_insert_with(|| {
            self.parts.push(Part {
                name,
                kind,
                faces: Vec::new(),
            });
            self.parts.len() - 1
        })
    }

    /// The vertices of the faces of every part called `name`, ascending;
    /// `None` when no part has that name.
    pub fn part_vertices(&self, name: &str) -> Option<Vec<u32>> {
        let mut found = false;
        let mut mark = vec![false; self.positions.len()];
        for p in self.parts.iter().filter(|p| p.name == name) {
            found = true;
            for &f in &p.faces {
                for &v in self.faces.face(f as usize) {
                    if let Some(m) = mark.get_mut(v as usize) {
                        *m = true;
                    }
                }
            }
        }
        found.then(|| {
            (0..mark.len() as u32)
                .filter(|&i| mark[i as usize])
                .collect()
        })
    }

    /// Every part name with its vertex indices, for regions.
    pub fn part_table(&self) -> Vec<(String, Vec<u32>)> {
        let mut names: Vec<&str> = self.parts.iter().map(|p| p.name.as_str()).collect();
        names.sort_unstable();
        names.dedup();
        names
            .into_iter()
            .filter_map(|n| Some((n.to_owned(), self.part_vertices(n)?)))
            .collect()
    }
}
