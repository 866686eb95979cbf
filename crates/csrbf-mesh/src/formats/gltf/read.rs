//! Reading glTF: the default scene flattened into one mesh in world space.

use std::collections::HashMap;
use std::path::Path;

use glam::{Mat4, Vec2, Vec3};
use serde_json::Value;

use crate::{
    AlphaMode, Faces, Material, Mesh, MeshError, PartKind, Result, Sampler, TexCoords, TextureMap,
};

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
    // The crate's own validation indexes a primitive's POSITION accessor
    // before checking it exists: check every primitive's accessor indices
    // first, then let it validate the rest.
    if bytes.starts_with(b"glTF") {
        check_glb(bytes).map_err(err)?;
    }
    let raw = gltf::Gltf::from_slice_without_validation(bytes)
        .map_err(|e| err(format!("invalid glTF: {e}")))?;
    check_primitive_indices(raw.document.as_json()).map_err(err)?;
    let blob = raw.blob;
    let document = gltf::Document::from_json(raw.document.into_json())
        .map_err(|e| err(format!("invalid glTF: {e}")))?;
    let gltf = gltf::Gltf { document, blob };
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
    // The file's normals, `None` for vertices of primitives without them.
    let mut normals: Vec<Option<Vec3>> = Vec::new();
    let (mut any_color, mut any_uv) = (false, false);
    let mut parts: HashMap<(PartKind, String), usize> = HashMap::new();
    // Primitives that share their vertex accessors (one mesh, a primitive
    // per material) share their vertices too.
    let mut shared: HashMap<SharedKey, (u32, usize)> = HashMap::new();
    let mut meshes_seen = 0usize;
    let mut extras: Option<Value> = None;

    check_accessors(doc, &buffers).map_err(err)?;
    check_hierarchy(doc).map_err(err)?;
    // Nodes of the default scene (or of every scene), with world transforms.
    let mut stack: Vec<(gltf::Node, Mat4)> =
        match doc.default_scene().or_else(|| doc.scenes().next()) {
            Some(scene) => scene.nodes().map(|n| (n, Mat4::IDENTITY)).collect(),
            None => doc.nodes().map(|n| (n, Mat4::IDENTITY)).collect(),
        };
    stack.reverse();
    while let Some((node, parent)) = stack.pop() {
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
            use gltf::mesh::Mode;
            if !matches!(
                prim.mode(),
                Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
            ) {
                return Err(err(format!(
                    "mesh {}: primitive mode {:?} is not supported: csrbf reads triangles, triangle strips and fans",
                    gmesh.index(),
                    prim.mode()
                )));
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
            let (base, count) = match shared.get(&key) {
                Some(&shared_vertices) => shared_vertices,
                None => {
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
                            uvs.extend(
                                t.into_f32().map(|[u, v]| Vec2::new(u, 1.0 - v)).take(count),
                            );
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
                    // Normals turn with the node (its inverse transpose, for
                    // scaled nodes).
                    let turn = glam::Mat3::from_mat4(world).inverse().transpose();
                    normals.resize(base as usize, None);
                    if let Some(nr) = reader.read_normals() {
                        normals.extend(
                            nr.map(|n| Some((turn * Vec3::from_array(n)).normalize_or_zero()))
                                .take(count),
                        );
                    }
                    normals.resize(mesh.positions.len(), None);
                    shared.insert(key, (base, count));
                    (base, count)
                }
            };
            let first_face = mesh.faces.len() as u32;
            push_triangles(
                &mut mesh,
                &reader,
                base,
                count,
                prim.mode(),
                gmesh.index(),
                &err,
            )?;
            name_parts(
                &mut mesh, &mut parts, &node, &gmesh, &prim, first_face, &buffers, path,
            )?;
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
    // The file's normals are kept (a deformation carries them, see
    // `Mesh::move_vertices`): recomputing them on vertices split at UV seams
    // would show the seams. Vertices of primitives without normals get
    // computed ones.
    if normals.iter().any(Option::is_some) {
        let computed = crate::vertex_normals(&mesh.positions, &mesh.faces);
        mesh.normals = Some(
            normals
                .iter()
                .zip(computed)
                .map(|(n, c)| n.filter(|n| *n != Vec3::ZERO).unwrap_or(c))
                .collect(),
        );
    }
    if meshes_seen == 1
        && let Some(extras) = extras
    {
        apply_extras(&mut mesh, &extras);
    }
    Ok(mesh)
}

/// Checks what the gltf crate would otherwise assert on: every accessor a
/// primitive uses has the type and component type its role allows, and lies
/// inside its buffer view, which lies inside its buffer.
fn check_accessors(doc: &gltf::Document, buffers: &[Vec<u8>]) -> std::result::Result<(), String> {
    use gltf::accessor::{DataType as T, Dimensions as D};
    for a in doc.accessors() {
        let Some(view) = a.view() else {
            return Err(format!(
                "accessor {} has no buffer view (sparse accessors are not supported)",
                a.index()
            ));
        };
        let buffer = buffers.get(view.buffer().index()).map_or(0, Vec::len);
        let elem = a.size();
        if a.count() == 0 {
            return Err(format!("accessor {} has no elements", a.index()));
        }
        let stride = view.stride().unwrap_or(elem);
        if stride < elem {
            return Err(format!(
                "accessor {}: its buffer view's stride {stride} is shorter than one element ({elem} bytes)",
                a.index()
            ));
        }
        let need = if a.count() == 0 {
            0
        } else {
            (a.count() - 1)
                .checked_mul(stride)
                .and_then(|n| n.checked_add(elem))
                .and_then(|n| n.checked_add(a.offset()))
                .unwrap_or(usize::MAX)
        };
        if need > view.length() || view.offset().saturating_add(view.length()) > buffer {
            return Err(format!(
                "accessor {} ({} elements) lies outside its buffer view or buffer",
                a.index(),
                a.count()
            ));
        }
    }
    for m in doc.meshes() {
        for p in m.primitives() {
            let bad = |what: &str, a: &gltf::Accessor| {
                Err(format!(
                    "mesh {}: {what} accessor {} is {:?} of {:?}, which {what} cannot be",
                    m.index(),
                    a.index(),
                    a.dimensions(),
                    a.data_type()
                ))
            };
            if let Some(a) = p.indices()
                && (a.dimensions() != D::Scalar
                    || !matches!(a.data_type(), T::U8 | T::U16 | T::U32))
            {
                return bad("indices", &a);
            }
            for (sem, a) in p.attributes() {
                let ok = match sem {
                    gltf::Semantic::Positions | gltf::Semantic::Normals => {
                        a.dimensions() == D::Vec3 && a.data_type() == T::F32
                    }
                    gltf::Semantic::TexCoords(_) => {
                        a.dimensions() == D::Vec2
                            && matches!(a.data_type(), T::F32 | T::U8 | T::U16)
                    }
                    gltf::Semantic::Colors(_) => {
                        matches!(a.dimensions(), D::Vec3 | D::Vec4)
                            && matches!(a.data_type(), T::F32 | T::U8 | T::U16)
                    }
                    _ => true,
                };
                if !ok {
                    return bad(&format!("{sem:?}"), &a);
                }
            }
        }
    }
    Ok(())
}

/// A GLB's header and chunk lengths fit the file (the crate subtracts them
/// unchecked).
fn check_glb(bytes: &[u8]) -> std::result::Result<(), String> {
    let u32_at = |at: usize| -> Option<usize> {
        bytes
            .get(at..at + 4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize)
    };
    let length = u32_at(8).ok_or("the GLB header is cut short")?;
    if length < 12 || length > bytes.len() {
        return Err(format!(
            "the GLB header says {length} bytes, the file has {}",
            bytes.len()
        ));
    }
    let mut at = 12;
    while at < length {
        let chunk = u32_at(at).ok_or("a GLB chunk header is cut short")?;
        if u32_at(at + 4).is_none() || at + 8 + chunk > length {
            return Err(format!(
                "a GLB chunk at byte {at} says {chunk} bytes, past the end"
            ));
        }
        at += 8 + chunk;
    }
    Ok(())
}

/// Every accessor index a primitive (and its morph targets) names exists.
fn check_primitive_indices(root: &gltf::json::Root) -> std::result::Result<(), String> {
    let n = root.accessors.len();
    for (mi, m) in root.meshes.iter().enumerate() {
        for p in &m.primitives {
            let indices = p.attributes.values().chain(p.indices.iter()).chain(
                p.targets.iter().flatten().flat_map(|t| {
                    t.positions
                        .iter()
                        .chain(t.normals.iter())
                        .chain(t.tangents.iter())
                }),
            );
            for idx in indices {
                if idx.value() >= n {
                    return Err(format!(
                        "mesh {mi}: a primitive names accessor {}, but there are {n}",
                        idx.value()
                    ));
                }
            }
        }
    }
    // Images: a buffer view (in range, with a MIME type) or a URI.
    for (i, im) in root.images.iter().enumerate() {
        match (&im.buffer_view, &im.uri) {
            (Some(v), _) if v.value() >= root.buffer_views.len() || im.mime_type.is_none() => {
                return Err(format!(
                    "image {i}: its buffer view must exist and have a MIME type"
                ));
            }
            (None, None) => return Err(format!("image {i} has neither a buffer view nor a URI")),
            _ => {}
        }
    }
    Ok(())
}

/// glTF's nodes form a forest: no node may be its own ancestor or have two
/// parents (a cycle through a mesh node would add its vertices forever).
fn check_hierarchy(doc: &gltf::Document) -> std::result::Result<(), String> {
    let n = doc.nodes().count();
    let mut parent: Vec<Option<usize>> = vec![None; n];
    for node in doc.nodes() {
        for child in node.children() {
            let c = child.index();
            if let Some(p) = parent[c] {
                return Err(format!(
                    "node {c} is a child of both node {p} and node {}: the node hierarchy must be a tree",
                    node.index()
                ));
            }
            parent[c] = Some(node.index());
        }
    }
    for start in 0..n {
        let (mut at, mut steps) = (start, 0);
        while let Some(p) = parent[at] {
            at = p;
            steps += 1;
            if steps > n {
                return Err(format!(
                    "the node hierarchy has a cycle through node {start}"
                ));
            }
        }
    }
    Ok(())
}

/// The triangles of a primitive over vertices `base..base + count`.
fn push_triangles<'a, 's, F>(
    mesh: &mut Mesh,
    reader: &gltf::mesh::Reader<'a, 's, F>,
    base: u32,
    count: usize,
    mode: gltf::mesh::Mode,
    mesh_index: usize,
    err: &dyn Fn(String) -> MeshError,
) -> Result<()>
where
    F: Clone + Fn(gltf::Buffer<'a>) -> Option<&'s [u8]>,
{
    let listed: Vec<u32> = match reader.read_indices() {
        Some(i) => i.into_u32().collect(),
        None => (0..count as u32).collect(),
    };
    // Strips and fans become a triangle list (strips keep every triangle's
    // winding by swapping every other one).
    let indices: Vec<u32> = match mode {
        gltf::mesh::Mode::TriangleStrip => (2..listed.len())
            .flat_map(|k| {
                if k % 2 == 0 {
                    [listed[k - 2], listed[k - 1], listed[k]]
                } else {
                    [listed[k - 1], listed[k - 2], listed[k]]
                }
            })
            .collect(),
        gltf::mesh::Mode::TriangleFan => (2..listed.len())
            .flat_map(|k| [listed[0], listed[k - 1], listed[k]])
            .collect(),
        _ => listed,
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
/// material parts; the material is recorded once (an error only when one of
/// its images' URIs is refused).
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
) -> Result<()> {
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
        mesh.materials
            .push(material_of(&mat, mat_name.clone(), buffers, path)?);
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
    Ok(())
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
            // Normals per corner too: copies split at a hard edge have
            // their own (kept per corner where a vertex has several).
            let corner_normals: Option<Vec<Option<Vec3>>> = mesh.normals.as_ref().map(|n| {
                mesh.faces
                    .indices
                    .iter()
                    .map(|&v| n.get(v as usize).copied())
                    .collect()
            });
            for v in &mut mesh.faces.indices {
                *v = source[*v as usize];
            }
            mesh.positions.truncate(kept);
            if let Some(c) = &mut mesh.colors {
                c.truncate(kept);
            }
            if let Some(n) = &mut mesh.normals {
                n.truncate(kept);
            }
            if let (Some(n), Some(corners)) = (mesh.normals.take(), corner_normals) {
                let (per_vertex, per_corner) =
                    crate::carry::normals_from_corners(n, &mesh.faces, &corners);
                mesh.normals = Some(per_vertex);
                mesh.corner_normals = per_corner;
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

/// A glTF material's properties; absent fields take glTF's defaults (the
/// gltf crate fills them: metallic 1, roughness 1, no emission, opaque).
fn material_of(
    mat: &gltf::Material,
    name: String,
    buffers: &[Vec<u8>],
    path: &Path,
) -> Result<Material> {
    let pbr = mat.pbr_metallic_roughness();
    let mut m = Material::new(name, pbr.base_color_factor());
    if let Some(info) = pbr.base_color_texture() {
        m.texture = image_of(&info.texture(), buffers, path)?;
        m.sampler = m.texture.as_ref().map(|_| sampler_of(&info.texture()));
    }
    // Maps on a second UV set are not kept: csrbf reads and writes one.
    let map = |t: gltf::Texture, tex_coord: u32, scale: f32| -> Result<Option<TextureMap>> {
        if tex_coord != 0 {
            return Ok(None);
        }
        Ok(image_of(&t, buffers, path)?.map(|image| TextureMap {
            image,
            sampler: Some(sampler_of(&t)),
            scale,
        }))
    };
    if let Some(t) = mat.normal_texture() {
        m.normal_texture = map(t.texture(), t.tex_coord(), t.scale())?;
    }
    if let Some(t) = mat.occlusion_texture() {
        m.occlusion_texture = map(t.texture(), t.tex_coord(), t.strength())?;
    }
    if let Some(t) = mat.emissive_texture() {
        m.emissive_texture = map(t.texture(), t.tex_coord(), 1.0)?;
    }
    if let Some(t) = pbr.metallic_roughness_texture() {
        m.metallic_roughness_texture = map(t.texture(), t.tex_coord(), 1.0)?;
    }
    m.metallic = pbr.metallic_factor();
    m.roughness = pbr.roughness_factor();
    m.emissive = mat.emissive_factor();
    m.double_sided = mat.double_sided();
    m.alpha_mode = Some(match mat.alpha_mode() {
        gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
        gltf::material::AlphaMode::Mask => AlphaMode::Mask(mat.alpha_cutoff().unwrap_or(0.5)),
        gltf::material::AlphaMode::Blend => AlphaMode::Blend,
    });
    Ok(m)
}

/// glTF's default wrap.
const REPEAT: u32 = 10497;

/// How a texture is sampled, in glTF's codes; wraps at glTF's default
/// (repeat) are left out.
fn sampler_of(t: &gltf::Texture) -> Sampler {
    let s = t.sampler();
    Sampler {
        mag_filter: s.mag_filter().map(|f| f.as_gl_enum()),
        min_filter: s.min_filter().map(|f| f.as_gl_enum()),
        wrap_s: Some(s.wrap_s().as_gl_enum()).filter(|&w| w != REPEAT),
        wrap_t: Some(s.wrap_t().as_gl_enum()).filter(|&w| w != REPEAT),
    }
}

/// A texture's image: its MIME type and bytes (from the file's buffers or
/// a URI in the model's folder). `None` when it cannot be read, which
/// leaves the material without it; a URI refused for leaving the model's
/// folder is an error, as for buffers.
fn image_of(
    t: &gltf::Texture,
    buffers: &[Vec<u8>],
    path: &Path,
) -> Result<Option<(String, Vec<u8>)>> {
    match t.source().source() {
        gltf::image::Source::View { view, mime_type } => Ok(buffers
            .get(view.buffer().index())
            .and_then(|b| b.get(view.offset()..view.offset() + view.length()))
            .map(|bytes| (mime_type.to_owned(), bytes.to_vec()))),
        gltf::image::Source::Uri { uri, mime_type } => {
            let data = match load_uri(uri, path) {
                Ok(data) => data,
                Err(e @ MeshError::Parse { .. }) if !uri.starts_with("data:") => return Err(e),
                Err(_) => return Ok(None),
            };
            let mime = mime_type.map(str::to_owned).unwrap_or_else(|| {
                if uri.ends_with(".jpg") || uri.ends_with(".jpeg") {
                    "image/jpeg".into()
                } else {
                    "image/png".into()
                }
            });
            Ok(Some((mime, data)))
        }
    }
}

fn load_uri(uri: &str, path: &Path) -> Result<Vec<u8>> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (_, data) = rest
            .split_once(";base64,")
            .ok_or_else(|| MeshError::parse(path, None, "a data URI is not base64"))?;
        return crate::base64::decode_lenient(data)
            .ok_or_else(|| MeshError::parse(path, None, "a data URI holds invalid base64"));
    }
    // A model from the web must not read local files: a buffer is a file in
    // the model's own folder (or below it), never a URL or a path out of it.
    let decoded = percent_decode(uri);
    let rel = Path::new(&decoded);
    if !crate::formats::inside_folder(&decoded) {
        return Err(MeshError::parse(
            path,
            None,
            format!(
                "URI {uri:?} is refused: only data URIs and files in the model's own folder are read"
            ),
        ));
    }
    let folder = path.parent().unwrap_or(Path::new("."));
    let folder = if folder.as_os_str().is_empty() {
        Path::new(".")
    } else {
        folder
    };
    let file = folder.join(rel);
    // A symlink (or a linked folder) in the model's folder may point
    // anywhere: what is read is where the resolved path lands, which must
    // still be inside the resolved folder.
    let io = |p: &Path, source| MeshError::Io {
        path: p.to_owned(),
        source,
    };
    let real_folder = folder.canonicalize().map_err(|e| io(folder, e))?;
    let real_file = file.canonicalize().map_err(|e| io(&file, e))?;
    if !real_file.starts_with(&real_folder) {
        return Err(MeshError::parse(
            path,
            None,
            format!(
                "URI {uri:?} is refused: it resolves to {}, which leaves the model's folder (a symlink?); only data URIs and files in the model's own folder are read",
                real_file.display()
            ),
        ));
    }
    std::fs::read(&real_file).map_err(|source| io(&file, source))
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
