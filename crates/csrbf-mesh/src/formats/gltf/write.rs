//! Writing glTF: one node, one mesh, a primitive per material over shared
//! vertex accessors, vertices split at UV seams, parts kept in the extras.

use std::collections::HashMap;

use glam::{Vec2, Vec3};
use serde_json::{Value, json};

use crate::{Faces, Mesh, PartKind};

/// A binary buffer being laid out, with its views and accessors (used by
/// the scene exporter too).
#[derive(Default)]
pub struct Builder {
    /// The binary buffer.
    pub bin: Vec<u8>,
    /// Buffer views, as glTF JSON.
    pub views: Vec<Value>,
    /// Accessors, as glTF JSON.
    pub accessors: Vec<Value>,
}

impl Builder {
    /// Appends bytes as a buffer view (4-byte aligned); returns its index.
    pub fn view(&mut self, bytes: &[u8], target: Option<u32>) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let mut v = json!({ "buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len() });
        if let Some(t) = target {
            v["target"] = json!(t);
        }
        self.bin.extend_from_slice(bytes);
        self.views.push(v);
        self.views.len() - 1
    }

    /// A float accessor of `width` components per element ("VEC3", ...);
    /// `with_bounds` adds min and max (required for positions and animation inputs).
    pub fn floats(&mut self, data: &[f32], width: usize, ty: &str, with_bounds: bool) -> usize {
        self.floats_for(data, width, ty, with_bounds, Some(34962))
    }

    /// A float accessor for animation data: its buffer view has no vertex target.
    pub fn animation_floats(
        &mut self,
        data: &[f32],
        width: usize,
        ty: &str,
        with_bounds: bool,
    ) -> usize {
        self.floats_for(data, width, ty, with_bounds, None)
    }

    fn floats_for(
        &mut self,
        data: &[f32],
        width: usize,
        ty: &str,
        with_bounds: bool,
        target: Option<u32>,
    ) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.view(&bytes, target);
        let mut a = json!({ "bufferView": view, "componentType": 5126, "count": data.len() / width, "type": ty });
        if with_bounds {
            let mut lo = vec![f32::INFINITY; width];
            let mut hi = vec![f32::NEG_INFINITY; width];
            for e in data.chunks_exact(width) {
                for k in 0..width {
                    lo[k] = lo[k].min(e[k]);
                    hi[k] = hi[k].max(e[k]);
                }
            }
            a["min"] = json!(lo);
            a["max"] = json!(hi);
        }
        self.accessors.push(a);
        self.accessors.len() - 1
    }

    /// An index accessor.
    pub fn indices(&mut self, data: &[u32]) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.view(&bytes, Some(34963));
        let max = data.iter().copied().max().unwrap_or(0);
        let min = data.iter().copied().min().unwrap_or(0);
        self.accessors.push(json!({
            "bufferView": view, "componentType": 5125, "count": data.len(), "type": "SCALAR",
            "min": [min], "max": [max]
        }));
        self.accessors.len() - 1
    }
}

/// Packs a glTF JSON document and its binary buffer as GLB or as JSON with
/// the buffer in a data URI.
pub fn package(mut doc: Value, bin: Vec<u8>, glb: bool) -> Vec<u8> {
    if glb {
        doc["buffers"] = json!([{ "byteLength": bin.len() }]);
        let mut js = doc.to_string().into_bytes();
        while !js.len().is_multiple_of(4) {
            js.push(b' ');
        }
        let mut bin = bin;
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        let total = 12 + 8 + js.len() + 8 + bin.len();
        let mut out = Vec::with_capacity(total);
        out.extend_from_slice(b"glTF");
        out.extend_from_slice(&2u32.to_le_bytes());
        out.extend_from_slice(&(total as u32).to_le_bytes());
        out.extend_from_slice(&(js.len() as u32).to_le_bytes());
        out.extend_from_slice(b"JSON");
        out.extend_from_slice(&js);
        out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&bin);
        out
    } else {
        doc["buffers"] = json!([{
            "byteLength": bin.len(),
            "uri": format!("data:application/octet-stream;base64,{}", crate::base64::encode(&bin))
        }]);
        serde_json::to_vec_pretty(&doc).unwrap_or_default()
    }
}

pub(crate) fn encode(mesh: &Mesh, glb: bool, name: &str) -> Vec<u8> {
    let n = mesh.positions.len();
    let mut b = Builder::default();
    // glTF keeps one UV per vertex: where the mesh's UVs have seams (one
    // vertex, several UVs), the vertex is written once per UV, and the
    // `csrbf` extras name the source vertex of each written one so this
    // reader welds them back (other readers see an ordinary split mesh).
    // Hard edges (per-corner normals) split vertices the same way, on the
    // UV and the normal together.
    let (split, split_normals) = match split_uv_and_normal_seams(mesh) {
        Some((s, normals)) => (Some(s), Some(normals)),
        None => (split_uv_seams(mesh), None),
    };
    let source: Vec<u32> = split
        .as_ref()
        .map_or_else(|| (0..n as u32).collect(), |s| s.source.clone());
    let corner_vertex = |c: usize, v: u32| -> u32 { split.as_ref().map_or(v, |s| s.corners[c]) };
    let pos: Vec<f32> = source
        .iter()
        .flat_map(|&v| mesh.positions[v as usize].to_array())
        .collect();
    let mut attributes = json!({ "POSITION": b.floats(&pos, 3, "VEC3", true) });
    let mut normals_mesh;
    let normals = match &mesh.normals {
        Some(nm) if nm.len() == n => nm,
        _ => {
            normals_mesh = mesh.clone();
            normals_mesh.recompute_normals();
            normals_mesh.normals.as_ref().map_or(&mesh.positions, |v| v)
        }
    };
    let nrm: Vec<f32> = match &split_normals {
        Some(written) => written
            .iter()
            .flat_map(|n| n.normalize_or(Vec3::Z).to_array())
            .collect(),
        None => source
            .iter()
            .flat_map(|&v| normals[v as usize].normalize_or(Vec3::Z).to_array())
            .collect(),
    };
    attributes["NORMAL"] = json!(b.floats(&nrm, 3, "VEC3", false));
    let uv_values: Option<Vec<Vec2>> = match &split {
        Some(s) if mesh.uvs.is_some() => Some(s.uvs.clone()),
        Some(_) => None,
        None => mesh.uvs.as_ref().and_then(|u| u.per_vertex(&mesh.faces, n)),
    };
    if let Some(uv) = &uv_values {
        let t: Vec<f32> = uv.iter().flat_map(|v| [v.x, 1.0 - v.y]).collect();
        attributes["TEXCOORD_0"] = json!(b.floats(&t, 2, "VEC2", false));
    }
    if let Some(c) = &mesh.colors {
        let t: Vec<f32> = source.iter().flat_map(|&v| c[v as usize]).collect();
        attributes["COLOR_0"] = json!(b.floats(&t, 4, "VEC4", false));
    }
    let (materials, images, textures, samplers) = material_json(mesh, &mut b);
    let mut primitives = Vec::new();
    // Where each polygon's triangles land when read back (primitive by
    // primitive), for the parts in the extras.
    let mut triangles_of: Vec<Vec<u32>> = vec![Vec::new(); mesh.faces.len()];
    let mut next_triangle = 0u32;
    let starts = face_starts(&mesh.faces);
    for (m, faces) in faces_by_material(mesh) {
        let mut idx = Vec::new();
        for f in faces {
            let face = mesh.faces.face(f as usize);
            let c0 = starts[f as usize];
            let local: Vec<usize> = (0..face.len()).collect();
            for [a, b, c] in crate::fan(&local) {
                idx.extend_from_slice(&[
                    corner_vertex(c0 + a, face[a]),
                    corner_vertex(c0 + b, face[b]),
                    corner_vertex(c0 + c, face[c]),
                ]);
                triangles_of[f as usize].push(next_triangle);
                next_triangle += 1;
            }
        }
        if idx.is_empty() {
            continue;
        }
        let mut p =
            json!({ "attributes": attributes.clone(), "indices": b.indices(&idx), "mode": 4 });
        if let Some(m) = m {
            p["material"] = json!(m);
        }
        primitives.push(p);
    }
    let parts: Vec<Value> = mesh
        .parts
        .iter()
        .map(|p| {
            let tris: Vec<u32> = p
                .faces
                .iter()
                .flat_map(|&f| triangles_of.get(f as usize).cloned().unwrap_or_default())
                .collect();
            json!({ "name": p.name, "kind": p.kind.name(), "triangles": tris })
        })
        .collect();
    let mut extras = json!({ "parts": parts });
    if split.is_some() {
        extras["source_vertices"] = json!(source);
    }
    let mut doc = json!({
        "asset": { "version": "2.0", "generator": "csrbf" },
        "scene": 0,
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0, "name": name }],
        "meshes": [{ "primitives": primitives, "name": name, "extras": { "csrbf": extras } }],
    });
    if !materials.is_empty() {
        doc["materials"] = json!(materials);
    }
    if !images.is_empty() {
        doc["images"] = json!(images);
        doc["textures"] = json!(textures);
        doc["samplers"] = json!(samplers);
    }
    doc["bufferViews"] = json!(b.views);
    doc["accessors"] = json!(b.accessors);
    package(doc, b.bin, glb)
}

/// The index of each face's first corner in the face list's corners.
fn face_starts(faces: &Faces) -> Vec<usize> {
    let mut at = 0;
    faces
        .iter()
        .map(|f| {
            let s = at;
            at += f.len();
            s
        })
        .collect()
}

/// A mesh's vertices split where its per-corner UVs differ (UV seams), as
/// glTF needs one UV per vertex: the source vertex of each written vertex,
/// its UV, and the written vertex of every face corner. The first written
/// vertices are the mesh's own, in order; the copies follow.
#[derive(Clone, Debug, PartialEq)]
pub struct UvSplit {
    /// The mesh vertex each written vertex copies.
    pub source: Vec<u32>,
    /// The UV of each written vertex.
    pub uvs: Vec<Vec2>,
    /// The written vertex of every face corner (aligned with [`Faces::indices`]).
    pub corners: Vec<u32>,
}

impl UvSplit {
    /// The fan triangles of the faces listed (a part's) over the written
    /// vertices, flattened into an index list, as
    /// [`Faces::triangle_indices`] gives them over the mesh's own.
    pub fn triangle_indices(&self, faces: &Faces, list: &[u32]) -> Vec<u32> {
        let mut out = Vec::new();
        for &f in list {
            let f = f as usize;
            if f >= faces.len() {
                continue;
            }
            let (a, b) = (faces.offsets[f] as usize, faces.offsets[f + 1] as usize);
            if let Some(corners) = self.corners.get(a..b) {
                out.extend(crate::fan(corners).flatten());
            }
        }
        out
    }
}

/// The mesh's vertices split at UV seams; `None` when it has no UVs or one
/// UV per vertex already (then [`TexCoords::per_vertex`] gives them).
///
/// [`TexCoords::per_vertex`]: crate::TexCoords::per_vertex
pub fn split_uv_seams(mesh: &Mesh) -> Option<UvSplit> {
    let uv = mesh.uvs.as_ref()?;
    let corners = uv.corners.as_ref()?;
    if uv.per_vertex(&mesh.faces, mesh.positions.len()).is_some() {
        return None;
    }
    let n = mesh.positions.len();
    // Every vertex keeps its own index for its first UV; later UVs get new
    // vertices after the originals, so the first n keep their order.
    let mut first: Vec<Option<u32>> = vec![None; n];
    let mut extra: HashMap<(u32, u32), u32> = HashMap::new();
    let mut source: Vec<u32> = (0..n as u32).collect();
    let mut uvs = vec![Vec2::ZERO; n];
    let mut out = Vec::with_capacity(corners.len());
    for (&v, &t) in mesh.faces.indices.iter().zip(corners) {
        let value = uv.values.get(t as usize).copied().unwrap_or(Vec2::ZERO);
        let written = match first[v as usize] {
            None => {
                first[v as usize] = Some(t);
                uvs[v as usize] = value;
                v
            }
            Some(t0) if uv.values.get(t0 as usize) == uv.values.get(t as usize) => v,
            Some(_) => *extra.entry((v, t)).or_insert_with(|| {
                source.push(v);
                uvs.push(value);
                (source.len() - 1) as u32
            }),
        };
        out.push(written);
    }
    Some(UvSplit {
        source,
        uvs,
        corners: out,
    })
}

/// The mesh's vertices split where a vertex's corners differ in UV or in
/// normal, as [`split_uv_seams`] splits them at UV seams, with the normal
/// of every written vertex; `None` unless the mesh keeps normals per corner
/// (one per face corner).
fn split_uv_and_normal_seams(mesh: &Mesh) -> Option<(UvSplit, Vec<Vec3>)> {
    let normals = mesh
        .corner_normals
        .as_ref()
        .filter(|c| c.len() == mesh.faces.indices.len())?;
    let n = mesh.positions.len();
    let per_vertex_uv = mesh
        .uvs
        .as_ref()
        .filter(|u| u.corners.is_none() && u.values.len() == n);
    let uv_of = |c: usize, v: u32| -> Vec2 {
        let Some(uv) = &mesh.uvs else {
            return Vec2::ZERO;
        };
        let t = match (&uv.corners, per_vertex_uv) {
            (Some(idx), _) => idx.get(c).copied(),
            (None, Some(_)) => Some(v),
            (None, None) => None,
        };
        t.and_then(|t| uv.values.get(t as usize).copied())
            .unwrap_or(Vec2::ZERO)
    };
    let key = |uv: Vec2, nm: Vec3| {
        let [a, b] = uv.to_array().map(f32::to_bits);
        let [x, y, z] = nm.to_array().map(f32::to_bits);
        [a, b, x, y, z]
    };
    let mut first: Vec<Option<[u32; 5]>> = vec![None; n];
    let mut extra: HashMap<(u32, [u32; 5]), u32> = HashMap::new();
    let mut source: Vec<u32> = (0..n as u32).collect();
    let mut uvs = vec![Vec2::ZERO; n];
    let mut written = mesh
        .normals
        .clone()
        .filter(|v| v.len() == n)
        .unwrap_or_else(|| vec![Vec3::Z; n]);
    let mut out = Vec::with_capacity(normals.len());
    for (c, (&v, &nm)) in mesh.faces.indices.iter().zip(normals).enumerate() {
        if v as usize >= n {
            return None;
        }
        let uv = uv_of(c, v);
        let k = key(uv, nm);
        let at = match first[v as usize] {
            None => {
                first[v as usize] = Some(k);
                uvs[v as usize] = uv;
                written[v as usize] = nm;
                v
            }
            Some(k0) if k0 == k => v,
            Some(_) => *extra.entry((v, k)).or_insert_with(|| {
                source.push(v);
                uvs.push(uv);
                written.push(nm);
                (source.len() - 1) as u32
            }),
        };
        out.push(at);
    }
    Some((
        UvSplit {
            source,
            uvs,
            corners: out,
        },
        written,
    ))
}

/// Materials as glTF JSON (with their textures, images and samplers),
/// embedded images as buffer views. A name without a [`Material`] gets
/// [`Material::default`]'s look.
///
/// [`Material`]: crate::Material
type MaterialJson = (Vec<Value>, Vec<Value>, Vec<Value>, Vec<Value>);

fn material_json(mesh: &Mesh, b: &mut Builder) -> MaterialJson {
    let (mut mats, mut images, mut textures, mut samplers) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let fallback = crate::Material::default();
    for name in material_names(mesh) {
        let m = mesh
            .materials
            .iter()
            .find(|m| m.name == name)
            .unwrap_or(&fallback);
        let mut pbr = json!({
            "baseColorFactor": m.color, "metallicFactor": m.metallic, "roughnessFactor": m.roughness
        });
        // Each texture its image, sampler and texture entry; returns the
        // texture's index.
        let mut texture = |(mime, bytes): &(String, Vec<u8>), sampler: Option<crate::Sampler>| {
            let view = b.view(bytes, None);
            images.push(json!({ "bufferView": view, "mimeType": mime }));
            samplers.push(sampler_json(sampler.unwrap_or_default()));
            textures.push(json!({ "source": images.len() - 1, "sampler": samplers.len() - 1 }));
            textures.len() - 1
        };
        if let Some(image) = &m.texture {
            pbr["baseColorTexture"] = json!({ "index": texture(image, m.sampler) });
        }
        if let Some(t) = &m.metallic_roughness_texture {
            pbr["metallicRoughnessTexture"] = json!({ "index": texture(&t.image, t.sampler) });
        }
        let mut mat = json!({ "name": name, "pbrMetallicRoughness": pbr });
        if let Some(t) = &m.normal_texture {
            mat["normalTexture"] =
                json!({ "index": texture(&t.image, t.sampler), "scale": t.scale });
        }
        if let Some(t) = &m.occlusion_texture {
            mat["occlusionTexture"] =
                json!({ "index": texture(&t.image, t.sampler), "strength": t.scale });
        }
        if let Some(t) = &m.emissive_texture {
            mat["emissiveTexture"] = json!({ "index": texture(&t.image, t.sampler) });
        }
        if m.emissive != [0.0; 3] {
            mat["emissiveFactor"] = json!(m.emissive);
        }
        if m.double_sided {
            mat["doubleSided"] = json!(true);
        }
        match m.alpha_mode {
            Some(crate::AlphaMode::Opaque) => {}
            Some(crate::AlphaMode::Mask(cutoff)) => {
                mat["alphaMode"] = json!("MASK");
                mat["alphaCutoff"] = json!(cutoff);
            }
            // Without it, readers draw a see-through material opaque.
            Some(crate::AlphaMode::Blend) => mat["alphaMode"] = json!("BLEND"),
            None if m.color[3] < 1.0 => mat["alphaMode"] = json!("BLEND"),
            None => {}
        }
        mats.push(mat);
    }
    (mats, images, textures, samplers)
}

/// A sampler as glTF JSON: only the fields set (absent ones are glTF's
/// defaults).
fn sampler_json(s: crate::Sampler) -> Value {
    let mut v = json!({});
    for (key, value) in [
        ("magFilter", s.mag_filter),
        ("minFilter", s.min_filter),
        ("wrapS", s.wrap_s),
        ("wrapT", s.wrap_t),
    ] {
        if let Some(x) = value {
            v[key] = json!(x);
        }
    }
    v
}

fn material_names(mesh: &Mesh) -> Vec<String> {
    let mut names: Vec<String> = Vec::new();
    for p in mesh.parts.iter().filter(|p| p.kind == PartKind::Material) {
        if !names.contains(&p.name) {
            names.push(p.name.clone());
        }
    }
    names
}

/// Faces grouped by material index (None: no material).
fn faces_by_material(mesh: &Mesh) -> Vec<(Option<usize>, Vec<u32>)> {
    let names = material_names(mesh);
    let mut of_face: Vec<Option<usize>> = vec![None; mesh.faces.len()];
    for p in mesh.parts.iter().filter(|p| p.kind == PartKind::Material) {
        let m = names.iter().position(|n| *n == p.name);
        for &f in &p.faces {
            if let Some(slot) = of_face.get_mut(f as usize) {
                *slot = m;
            }
        }
    }
    let mut groups: Vec<(Option<usize>, Vec<u32>)> = Vec::new();
    for key in std::iter::once(None).chain((0..names.len()).map(Some)) {
        let faces: Vec<u32> = (0..mesh.faces.len() as u32)
            .filter(|&f| of_face[f as usize] == key)
            .collect();
        if !faces.is_empty() {
            groups.push((key, faces));
        }
    }
    groups
}
