//! glTF 2.0 in (`.gltf` with embedded, data-URI or external buffers, and
//! `.glb`) and out. Reading flattens the default scene into one mesh in world
//! space: each primitive's vertices are appended in order (primitives that
//! share their accessors share their vertices), triangles become faces, and
//! meshes, nodes and materials become named parts. Writing makes one node
//! with one mesh, one primitive per material part, over one set of vertex
//! accessors; vertices are split where UVs have seams. The mesh's `csrbf`
//! extras keep the parts (groups, objects, materials) by triangle and the
//! source of every split vertex, so this reader gives back the vertex order
//! and count, the parts and the per-corner UVs it was given.

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

/// A primitive's node and its position, UV and colour accessors: primitives
/// with the same key share their vertices.
type SharedKey = (usize, usize, Option<usize>, Option<usize>);

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
    // Primitives that share their vertex accessors (one mesh, a primitive
    // per material) share their vertices too.
    let mut shared: HashMap<SharedKey, (u32, usize)> = HashMap::new();
    let mut meshes_seen = 0usize;
    let mut extras: Option<Value> = None;

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
        meshes_seen += 1;
        if extras.is_none() {
            extras = gmesh
                .extras()
                .as_ref()
                .and_then(|r| serde_json::from_str::<Value>(r.get()).ok())
                .and_then(|v| v.get("csrbf").cloned());
        }
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
            let key = (
                node.index(),
                pos_acc.index(),
                prim.get(&gltf::Semantic::TexCoords(0)).map(|a| a.index()),
                prim.get(&gltf::Semantic::Colors(0)).map(|a| a.index()),
            );
            if let Some(&(base, count)) = shared.get(&key) {
                let first_face = mesh.faces.len() as u32;
                push_triangles(&mut mesh, &reader, base, count, gmesh.index(), &err)?;
                name_parts(
                    &mut mesh, &mut parts, &node, &gmesh, &prim, first_face, &buffers, path,
                );
                continue;
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
            shared.insert(key, (base, count));
            let first_face = mesh.faces.len() as u32;
            push_triangles(&mut mesh, &reader, base, count, gmesh.index(), &err)?;
            name_parts(
                &mut mesh, &mut parts, &node, &gmesh, &prim, first_face, &buffers, path,
            );
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
    if meshes_seen == 1
        && let Some(extras) = extras
    {
        apply_extras(&mut mesh, &extras);
    }
    Ok(mesh)
}

/// The triangles of a primitive over vertices `base..base + count`.
fn push_triangles<'a, 's, F>(
    mesh: &mut Mesh,
    reader: &gltf::mesh::Reader<'a, 's, F>,
    base: u32,
    count: usize,
    mesh_index: usize,
    err: &dyn Fn(String) -> MeshError,
) -> Result<()>
where
    F: Clone + Fn(gltf::Buffer<'a>) -> Option<&'s [u8]>,
{
    let indices: Vec<u32> = match reader.read_indices() {
        Some(i) => i.into_u32().collect(),
        None => (0..count as u32).collect(),
    };
    if !indices.len().is_multiple_of(3) {
        return Err(err(format!(
            "mesh {mesh_index}: {} indices is not a whole number of triangles",
            indices.len()
        )));
    }
    if let Some(&bad) = indices.iter().find(|&&i| i as usize >= count) {
        return Err(err(format!(
            "mesh {mesh_index}: index {bad} is out of range for {count} vertices"
        )));
    }
    for t in indices.chunks_exact(3) {
        mesh.faces.push(&[base + t[0], base + t[1], base + t[2]]);
    }
    Ok(())
}

/// The faces from `first_face` on belong to the primitive's mesh, node and
/// material parts; the material is recorded once.
#[allow(clippy::too_many_arguments)]
fn name_parts(
    mesh: &mut Mesh,
    parts: &mut HashMap<(PartKind, String), usize>,
    node: &gltf::Node,
    gmesh: &gltf::Mesh,
    prim: &gltf::Primitive,
    first_face: u32,
    buffers: &[Vec<u8>],
    path: &Path,
) {
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
            texture: texture_of(&mat, buffers, path),
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
        let id = mesh.part_index(parts, kind, name);
        mesh.parts[id].faces.extend_from_slice(&faces);
    }
}

/// What this writer keeps in a mesh's `csrbf` extras: the parts by
/// triangle, and the source vertex of every vertex split at a UV seam (the
/// split vertices are welded back, the UVs kept per corner).
fn apply_extras(mesh: &mut Mesh, extras: &Value) {
    let n = mesh.positions.len();
    if let Some(src) = extras.get("source_vertices").and_then(Value::as_array) {
        let source: Option<Vec<u32>> = src.iter().map(|v| v.as_u64().map(|v| v as u32)).collect();
        // Ours: the first vertices are the originals, the rest copies of them.
        let kept = source.as_ref().map_or(0, |s| {
            s.iter()
                .enumerate()
                .take_while(|&(i, &v)| v as usize == i)
                .count()
        });
        if let Some(source) =
            source.filter(|s| s.len() == n && s[kept..].iter().all(|&v| (v as usize) < kept))
        {
            // UVs per corner from the split vertices, before welding.
            if let Some(uv) = &mesh.uvs {
                mesh.uvs = Some(TexCoords {
                    values: uv.values.clone(),
                    corners: Some(mesh.faces.indices.clone()),
                });
            }
            for v in &mut mesh.faces.indices {
                *v = source[*v as usize];
            }
            mesh.positions.truncate(kept);
            if let Some(c) = &mut mesh.colors {
                c.truncate(kept);
            }
        }
    }
    if let Some(list) = extras.get("parts").and_then(Value::as_array) {
        let faces = mesh.faces.len() as u64;
        let mut restored = Vec::new();
        for p in list {
            let name = p.get("name").and_then(Value::as_str);
            let kind = match p.get("kind").and_then(Value::as_str) {
                Some("group") => Some(PartKind::Group),
                Some("object") => Some(PartKind::Object),
                Some("material") => Some(PartKind::Material),
                _ => None,
            };
            let tris: Option<Vec<u32>> =
                p.get("triangles").and_then(Value::as_array).and_then(|a| {
                    a.iter()
                        .map(|t| t.as_u64().filter(|&t| t < faces).map(|t| t as u32))
                        .collect()
                });
            match (name, kind, tris) {
                (Some(name), Some(kind), Some(mut faces)) => {
                    faces.sort_unstable();
                    restored.push(crate::Part {
                        name: name.to_owned(),
                        kind,
                        faces,
                    });
                }
                // Not ours after all: keep the parts the file's structure gave.
                _ => return,
            }
        }
        mesh.parts = restored;
    }
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
    // glTF keeps one UV per vertex: where the mesh's UVs have seams (one
    // vertex, several UVs), the vertex is written once per UV, and the
    // `csrbf` extras name the source vertex of each written one so this
    // reader welds them back (other readers see an ordinary split mesh).
    let split = split_uv_seams(mesh);
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
    let nrm: Vec<f32> = source
        .iter()
        .flat_map(|&v| normals[v as usize].normalize_or(Vec3::Z).to_array())
        .collect();
    attributes["NORMAL"] = json!(b.floats(&nrm, 3, "VEC3", false));
    let uv_values: Option<Vec<Vec2>> = match &split {
        Some(s) => Some(s.uvs.clone()),
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
    let (materials, images, textures) = material_json(mesh, &mut b);
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
        "nodes": [{ "mesh": 0, "name": "mesh" }],
        "meshes": [{ "primitives": primitives, "name": "mesh", "extras": { "csrbf": extras } }],
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

/// Vertices split where per-corner UVs differ: the source vertex of each
/// written vertex, its UV, and the written vertex of every face corner.
struct Split {
    source: Vec<u32>,
    uvs: Vec<Vec2>,
    corners: Vec<u32>,
}

fn split_uv_seams(mesh: &Mesh) -> Option<Split> {
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
    Some(Split {
        source,
        uvs,
        corners: out,
    })
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
