//! glTF 2.0 in (`.gltf` with embedded, data-URI or external buffers, and
//! `.glb`) and out. Reading flattens the default scene into one mesh in world
//! space: each primitive's vertices are appended in order, triangles become
//! faces, and meshes, nodes and materials become named parts. Writing makes
//! one node with one mesh, one primitive per material part.

use std::collections::HashMap;
use std::path::Path;

use glam::{Mat4, Vec2, Vec3};
use serde_json::{Value, json};

use crate::{Faces, Material, Mesh, MeshError, PartKind, Result, TexCoords};

pub(crate) fn parse(bytes: &[u8], path: &Path) -> Result<Mesh> {
    // The gltf crate asserts on some malformed accessors; a malformed file
    // must be an error, never a crash.
    match std::panic::catch_unwind(|| parse_inner(bytes, path)) {
        Ok(r) => r,
        Err(_) => Err(MeshError::parse(
            path,
            None,
            "malformed glTF: an accessor or buffer view is inconsistent",
        )),
    }
}

fn parse_inner(bytes: &[u8], path: &Path) -> Result<Mesh> {
    let err = |m: String| MeshError::parse(path, None, m);
    let gltf = gltf::Gltf::from_slice(bytes).map_err(|e| err(format!("invalid glTF: {e}")))?;
    let doc = &gltf.document;
    let mut buffers: Vec<Vec<u8>> = Vec::new();
    for b in doc.buffers() {
        let data = match b.source() {
            gltf::buffer::Source::Bin => gltf
                .blob
                .clone()
                .ok_or_else(|| err("buffer refers to a missing GLB binary chunk".into()))?,
            gltf::buffer::Source::Uri(uri) => load_uri(uri, path)?,
        };
        if data.len() < b.length() {
            return Err(err(format!(
                "buffer {} has {} bytes, the file declares {}",
                b.index(),
                data.len(),
                b.length()
            )));
        }
        buffers.push(data);
    }
    let mut mesh = Mesh {
        faces: Faces::new(),
        ..Mesh::default()
    };
    let mut colors: Vec<[f32; 4]> = Vec::new();
    let mut uvs: Vec<Vec2> = Vec::new();
    let (mut any_color, mut any_uv) = (false, false);
    let mut parts: HashMap<(PartKind, String), usize> = HashMap::new();

    // Nodes of the default scene (or of every scene), with world transforms.
    let mut stack: Vec<(gltf::Node, Mat4)> =
        match doc.default_scene().or_else(|| doc.scenes().next()) {
            Some(scene) => scene.nodes().map(|n| (n, Mat4::IDENTITY)).collect(),
            None => doc.nodes().map(|n| (n, Mat4::IDENTITY)).collect(),
        };
    stack.reverse();
    let mut guard = 0usize;
    while let Some((node, parent)) = stack.pop() {
        guard += 1;
        if guard > 1_000_000 {
            return Err(err("the node hierarchy has a cycle".into()));
        }
        let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        for child in node.children().collect::<Vec<_>>().into_iter().rev() {
            stack.push((child, world));
        }
        let Some(gmesh) = node.mesh() else { continue };
        for prim in gmesh.primitives() {
            if prim.mode() != gltf::mesh::Mode::Triangles {
                continue;
            }
            let reader = prim.reader(|b| buffers.get(b.index()).map(|v| v.as_slice()));
            let pos_acc = prim.get(&gltf::Semantic::Positions).ok_or_else(|| {
                err(format!(
                    "mesh {} has a primitive without positions",
                    gmesh.index()
                ))
            })?;
            if pos_acc.dimensions() != gltf::accessor::Dimensions::Vec3
                || pos_acc.data_type() != gltf::accessor::DataType::F32
            {
                return Err(err(format!(
                    "mesh {}: positions must be float VEC3",
                    gmesh.index()
                )));
            }
            let base = mesh.positions.len() as u32;
            let positions: Vec<Vec3> = reader
                .read_positions()
                .ok_or_else(|| {
                    err(format!(
                        "mesh {}: positions lie outside their buffer",
                        gmesh.index()
                    ))
                })?
                .map(|p| world.transform_point3(Vec3::from_array(p)))
                .collect();
            let count = positions.len();
            mesh.positions.extend(positions);
            match reader.read_tex_coords(0) {
                Some(t) => {
                    any_uv = true;
                    uvs.resize(base as usize, Vec2::ZERO);
                    // glTF puts the texture origin at the top left; meshes here keep OBJ's
                    // bottom-left origin.
                    uvs.extend(t.into_f32().map(|[u, v]| Vec2::new(u, 1.0 - v)).take(count));
                }
                None => uvs.resize(base as usize, Vec2::ZERO),
            }
            uvs.resize(mesh.positions.len(), Vec2::ZERO);
            match reader.read_colors(0) {
                Some(c) => {
                    any_color = true;
                    colors.resize(base as usize, [1.0; 4]);
                    colors.extend(c.into_rgba_f32().take(count));
                }
                None => colors.resize(base as usize, [1.0; 4]),
            }
            colors.resize(mesh.positions.len(), [1.0; 4]);
            let indices: Vec<u32> = match reader.read_indices() {
                Some(i) => i.into_u32().collect(),
                None => (0..count as u32).collect(),
            };
            if !indices.len().is_multiple_of(3) {
                return Err(err(format!(
                    "mesh {}: {} indices is not a whole number of triangles",
                    gmesh.index(),
                    indices.len()
                )));
            }
            if let Some(&bad) = indices.iter().find(|&&i| i as usize >= count) {
                return Err(err(format!(
                    "mesh {}: index {bad} is out of range for {count} vertices",
                    gmesh.index()
                )));
            }
            let first_face = mesh.faces.len() as u32;
            for t in indices.chunks_exact(3) {
                mesh.faces.push(&[base + t[0], base + t[1], base + t[2]]);
            }
            let faces: Vec<u32> = (first_face..mesh.faces.len() as u32).collect();
            let mat = prim.material();
            let mat_name = mat
                .name()
                .map(str::to_owned)
                .unwrap_or_else(|| match mat.index() {
                    Some(i) => format!("material{i}"),
                    None => "default".to_owned(),
                });
            if mat.index().is_some() && !mesh.materials.iter().any(|m| m.name == mat_name) {
                mesh.materials.push(Material {
                    name: mat_name.clone(),
                    color: mat.pbr_metallic_roughness().base_color_factor(),
                    texture: texture_of(&mat, &buffers, path),
                });
            }
            let names = [
                (
                    PartKind::Group,
                    gmesh
                        .name()
                        .map(str::to_owned)
                        .unwrap_or_else(|| format!("mesh{}", gmesh.index())),
                ),
                (
                    PartKind::Object,
                    node.name()
                        .map(str::to_owned)
                        .unwrap_or_else(|| format!("node{}", node.index())),
                ),
                (PartKind::Material, mat_name),
            ];
            for (kind, name) in names {
                let id = mesh.part_index(&mut parts, kind, name);
                mesh.parts[id].faces.extend_from_slice(&faces);
            }
        }
    }
    if any_uv {
        mesh.uvs = Some(TexCoords {
            values: uvs,
            corners: None,
        });
    }
    if any_color {
        mesh.colors = Some(colors);
    }
    Ok(mesh)
}

/// The base-colour image of a material, when it is embedded.
fn texture_of(mat: &gltf::Material, buffers: &[Vec<u8>], path: &Path) -> Option<(String, Vec<u8>)> {
    let info = mat.pbr_metallic_roughness().base_color_texture()?;
    match info.texture().source().source() {
        gltf::image::Source::View { view, mime_type } => {
            let b = buffers.get(view.buffer().index())?;
            Some((
                mime_type.to_owned(),
                b.get(view.offset()..view.offset() + view.length())?
                    .to_vec(),
            ))
        }
        gltf::image::Source::Uri { uri, mime_type } => {
            let data = load_uri(uri, path).ok()?;
            let mime = mime_type.map(str::to_owned).unwrap_or_else(|| {
                if uri.ends_with(".jpg") || uri.ends_with(".jpeg") {
                    "image/jpeg".into()
                } else {
                    "image/png".into()
                }
            });
            Some((mime, data))
        }
    }
}

fn load_uri(uri: &str, path: &Path) -> Result<Vec<u8>> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (_, data) = rest
            .split_once(";base64,")
            .ok_or_else(|| MeshError::parse(path, None, "a data URI is not base64"))?;
        return base64_decode(data)
            .ok_or_else(|| MeshError::parse(path, None, "a data URI holds invalid base64"));
    }
    let file = path
        .parent()
        .unwrap_or(Path::new("."))
        .join(percent_decode(uri));
    std::fs::read(&file).map_err(|source| MeshError::Io { path: file, source })
}

fn percent_decode(s: &str) -> String {
    let b = s.as_bytes();
    let hex = |c: u8| (c as char).to_digit(16);
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%'
            && i + 2 < b.len()
            && let (Some(h), Some(l)) = (hex(b[i + 1]), hex(b[i + 2]))
        {
            out.push((h * 16 + l) as u8);
            i += 3;
            continue;
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

const B64: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

fn base64_decode(s: &str) -> Option<Vec<u8>> {
    let mut out = Vec::with_capacity(s.len() * 3 / 4);
    let (mut acc, mut bits) = (0u32, 0);
    for c in s.bytes().filter(|c| !c.is_ascii_whitespace() && *c != b'=') {
        let v = B64.iter().position(|&b| b == c)? as u32;
        acc = (acc << 6) | v;
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
        }
    }
    Some(out)
}

fn base64_encode(data: &[u8]) -> String {
    let mut s = String::with_capacity(data.len().div_ceil(3) * 4);
    for c in data.chunks(3) {
        let n = (c[0] as u32) << 16
            | (*c.get(1).unwrap_or(&0) as u32) << 8
            | *c.get(2).unwrap_or(&0) as u32;
        for k in 0..4 {
            if k <= c.len() {
                s.push(B64[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                s.push('=');
            }
        }
    }
    s
}

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
            "uri": format!("data:application/octet-stream;base64,{}", base64_encode(&bin))
        }]);
        serde_json::to_vec_pretty(&doc).unwrap_or_default()
    }
}

pub(crate) fn encode(mesh: &Mesh, glb: bool) -> Vec<u8> {
    let n = mesh.positions.len();
    let mut b = Builder::default();
    let pos: Vec<f32> = mesh.positions.iter().flat_map(|p| p.to_array()).collect();
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
    let nrm: Vec<f32> = normals
        .iter()
        .flat_map(|p| p.normalize_or(Vec3::Z).to_array())
        .collect();
    attributes["NORMAL"] = json!(b.floats(&nrm, 3, "VEC3", false));
    if let Some(uv) = mesh.uvs.as_ref().and_then(|u| u.per_vertex(&mesh.faces, n)) {
        let t: Vec<f32> = uv.iter().flat_map(|v| [v.x, 1.0 - v.y]).collect();
        attributes["TEXCOORD_0"] = json!(b.floats(&t, 2, "VEC2", false));
    }
    if let Some(c) = &mesh.colors {
        let t: Vec<f32> = c.iter().flatten().copied().collect();
        attributes["COLOR_0"] = json!(b.floats(&t, 4, "VEC4", false));
    }
    let (materials, images, textures) = material_json(mesh, &mut b);
    let mut primitives = Vec::new();
    for (m, faces) in faces_by_material(mesh) {
        let mut idx = Vec::new();
        for f in faces {
            let face = mesh.faces.face(f as usize);
            for k in 1..face.len().saturating_sub(1) {
                idx.extend_from_slice(&[face[0], face[k], face[k + 1]]);
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
    let mut doc = json!({
        "asset": { "version": "2.0", "generator": "csrbf" },
        "scene": 0,
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0, "name": "mesh" }],
        "meshes": [{ "primitives": primitives, "name": "mesh" }],
    });
    if !materials.is_empty() {
        doc["materials"] = json!(materials);
    }
    if !images.is_empty() {
        doc["images"] = json!(images);
        doc["textures"] = json!(textures);
        doc["samplers"] = json!([{}]);
    }
    doc["bufferViews"] = json!(b.views);
    doc["accessors"] = json!(b.accessors);
    package(doc, b.bin, glb)
}

/// Materials as glTF JSON, with embedded textures as buffer views.
fn material_json(mesh: &Mesh, b: &mut Builder) -> (Vec<Value>, Vec<Value>, Vec<Value>) {
    let (mut mats, mut images, mut textures) = (Vec::new(), Vec::new(), Vec::new());
    for name in material_names(mesh) {
        let m = mesh.materials.iter().find(|m| m.name == name);
        let color = m.map_or([0.8, 0.8, 0.8, 1.0], |m| m.color);
        let mut pbr =
            json!({ "baseColorFactor": color, "metallicFactor": 0.0, "roughnessFactor": 0.8 });
        if let Some((mime, bytes)) = m.and_then(|m| m.texture.as_ref()) {
            let view = b.view(bytes, None);
            images.push(json!({ "bufferView": view, "mimeType": mime }));
            textures.push(json!({ "source": images.len() - 1, "sampler": 0 }));
            pbr["baseColorTexture"] = json!({ "index": textures.len() - 1 });
        }
        mats.push(json!({ "name": name, "pbrMetallicRoughness": pbr }));
    }
    (mats, images, textures)
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_round_trips() {
        for n in 0..20 {
            let data: Vec<u8> = (0..n as u8).map(|i| i.wrapping_mul(37)).collect();
            assert_eq!(base64_decode(&base64_encode(&data)), Some(data));
        }
        assert_eq!(base64_encode(b"Man"), "TWFu");
        assert_eq!(base64_encode(b"Ma"), "TWE=");
    }
}
