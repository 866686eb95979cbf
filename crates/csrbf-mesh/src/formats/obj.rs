//! Wavefront OBJ: `v` (with optional colours), `vt`, `vn`, polygon `f`
//! with any corner form and negative indices, `g`, `o`, `usemtl`, `mtllib`,
//! and `s` (smoothing groups, per face). The material library itself is
//! read by [`super::materials`] when the OBJ is read from a file.

use std::collections::HashMap;
use std::fmt::Write;
use std::path::Path;

use glam::{Vec2, Vec3};

use super::Skipped;
use super::text::{lines, number, push_f32};
use crate::{Faces, Mesh, MeshError, PartKind, Result, TexCoords};

pub(crate) fn parse(bytes: &[u8], path: &Path, skipped: &mut Skipped) -> Result<Mesh> {
    let mut mesh = Mesh {
        faces: Faces::new(),
        ..Mesh::default()
    };
    let mut colors: Vec<[f32; 4]> = Vec::new();
    let mut any_color = false;
    let mut uvs: Vec<Vec2> = Vec::new();
    // The file's normals; `None` for one that is not finite or of zero
    // length (exporters write `vn 0 0 0` for degenerate faces): its corners
    // are read as corners without a normal.
    let mut normals: Vec<Option<Vec3>> = Vec::new();
    // Each face corner's normal, `None` where it names none; empty until a
    // face names one (a file without normals costs nothing), then padded.
    let mut corners_normal: Vec<Option<Vec3>> = Vec::new();
    let mut corners_uv: Vec<u32> = Vec::new();
    let mut any_face_uv = false;
    let mut parts: HashMap<(PartKind, String), usize> = HashMap::new();
    let mut current: Vec<usize> = Vec::new();
    let mut current_by_kind: HashMap<PartKind, Vec<usize>> = HashMap::new();
    let mut corner = Vec::new();
    let mut corner_uv = Vec::new();
    let mut corner_normal = Vec::new();
    // The smoothing group of each face, and of the faces to come.
    let mut smoothing: Vec<u32> = Vec::new();
    let mut group = 0u32;

    for item in lines(bytes, path) {
        let (ln, line) = item?;
        let mut tok = line.split_ascii_whitespace();
        let Some(key) = tok.next() else { continue };
        match key {
            "v" => {
                let vals: Vec<f32> = tok
                    .map(|t| number::<f32>(Some(t), path, ln, "vertex coordinate"))
                    .collect::<Result<_>>()?;
                if vals.len() < 3 {
                    return Err(MeshError::parse(
                        path,
                        Some(ln),
                        format!("a vertex needs 3 coordinates, found {}", vals.len()),
                    ));
                }
                mesh.positions.push(Vec3::new(vals[0], vals[1], vals[2]));
                if vals.len() >= 6 {
                    any_color = true;
                    colors.resize(mesh.positions.len() - 1, [1.0; 4]);
                    colors.push([vals[3], vals[4], vals[5], 1.0]);
                }
            }
            "vt" => {
                let u = number::<f32>(tok.next(), path, ln, "texture u")?;
                let v = tok
                    .next()
                    .map(|t| number::<f32>(Some(t), path, ln, "texture v"))
                    .transpose()?
                    .unwrap_or(0.0);
                uvs.push(Vec2::new(u, v));
            }
            "vn" => {
                let mut n = [0.0f32; 3];
                for (k, c) in n.iter_mut().enumerate() {
                    *c = number::<f32>(
                        tok.next(),
                        path,
                        ln,
                        ["normal x", "normal y", "normal z"][k],
                    )?;
                }
                let n = Vec3::from_array(n);
                normals.push((n.is_finite() && n.length_squared() > 0.0).then_some(n));
            }
            "f" | "fo" => {
                corner.clear();
                corner_uv.clear();
                corner_normal.clear();
                for c in tok {
                    let mut it = c.split('/');
                    let v = resolve(it.next(), mesh.positions.len(), path, ln, "vertex")?;
                    corner.push(v);
                    if let Some(t) = it.next().filter(|t| !t.is_empty()) {
                        corner_uv.push(resolve(
                            Some(t),
                            uvs.len(),
                            path,
                            ln,
                            "texture coordinate",
                        )?);
                    }
                    // A corner without a normal index (even in a face whose
                    // other corners have one) is a corner without a normal.
                    let n = match it.next().filter(|t| !t.is_empty()) {
                        Some(n) => {
                            normals[resolve(Some(n), normals.len(), path, ln, "normal")? as usize]
                        }
                        None => None,
                    };
                    corner_normal.push(n);
                }
                if corner.len() < 3 {
                    return Err(MeshError::parse(
                        path,
                        Some(ln),
                        format!("a face needs at least 3 corners, found {}", corner.len()),
                    ));
                }
                if !corner_uv.is_empty() && corner_uv.len() != corner.len() {
                    return Err(MeshError::parse(
                        path,
                        Some(ln),
                        "some corners of the face have texture coordinates and some do not",
                    ));
                }
                let f = mesh.faces.len() as u32;
                mesh.faces.push(&corner);
                smoothing.push(group);
                if corner_uv.is_empty() {
                    corners_uv.extend(std::iter::repeat_n(u32::MAX, corner.len()));
                } else {
                    any_face_uv = true;
                    corners_uv.extend_from_slice(&corner_uv);
                }
                if !corners_normal.is_empty() || corner_normal.iter().any(Option::is_some) {
                    let before = mesh.faces.indices.len() - corner.len();
                    corners_normal.resize(before, None);
                    corners_normal.extend_from_slice(&corner_normal);
                }
                for &p in &current {
                    mesh.parts[p].faces.push(f);
                }
            }
            "g" | "o" | "usemtl" => {
                let kind = match key {
                    "g" => PartKind::Group,
                    "o" => PartKind::Object,
                    _ => PartKind::Material,
                };
                let names: Vec<String> = if kind == PartKind::Group {
                    tok.map(str::to_owned).collect()
                } else {
                    line[key.len()..]
                        .trim()
                        .split_ascii_whitespace()
                        .next()
                        .map(str::to_owned)
                        .into_iter()
                        .collect()
                };
                let mut ids = Vec::new();
                for name in names {
                    let id = mesh.part_index(&mut parts, kind, name);
                    ids.push(id);
                }
                current_by_kind.insert(kind, ids);
                current = current_by_kind.values().flatten().copied().collect();
            }
            "mtllib" => mesh.material_library = Some(line[key.len()..].trim().to_owned()),
            // `s off`, `s 0` or a bare `s`: flat; `s on` or any other word: 1.
            "s" => {
                group = match tok.next() {
                    None | Some("off") => 0,
                    Some(t) => t.parse().unwrap_or(1),
                }
            }
            // Lines, points, curves, surfaces and vendor statements: nothing
            // a mesh of faces keeps, but said.
            "l" => skipped.add("polylines (`l`)", 1),
            "p" => skipped.add("points (`p`)", 1),
            _ => skipped.add(&format!("{} statements", Skipped::name(key)), 1),
        }
    }
    if any_color {
        colors.resize(mesh.positions.len(), [1.0; 4]);
        mesh.colors = Some(colors);
    }
    if any_face_uv {
        // Corners without coordinates point at one extra (0, 0).
        let missing = uvs.len() as u32;
        let mut need_default = false;
        for c in &mut corners_uv {
            if *c == u32::MAX {
                *c = missing;
                need_default = true;
            }
        }
        if need_default {
            uvs.push(Vec2::ZERO);
        }
        mesh.uvs = Some(TexCoords {
            values: uvs,
            corners: Some(corners_uv),
        });
    }
    // The file's normals where its faces name them (split per corner where
    // a vertex has several: hard edges); vertices without get computed ones.
    // A file whose faces name none keeps none, as before.
    if corners_normal.iter().any(Option::is_some) {
        corners_normal.resize(mesh.faces.indices.len(), None);
        let computed = crate::vertex_normals(&mesh.positions, &mesh.faces);
        let (per_vertex, per_corner) =
            crate::carry::normals_from_corners(computed, &mesh.faces, &corners_normal);
        mesh.normals = Some(per_vertex);
        mesh.corner_normals = per_corner;
    }
    if smoothing.iter().any(|&g| g != 0) {
        mesh.smoothing = Some(smoothing);
    }
    mesh.parts.retain(|p| !p.faces.is_empty());
    for p in &mut mesh.parts {
        p.faces.dedup();
    }
    Ok(mesh)
}

/// A 1-based (or negative, relative) OBJ index into a list of `count` items.
fn resolve(tok: Option<&str>, count: usize, path: &Path, line: usize, what: &str) -> Result<u32> {
    let i: i64 = number(tok, path, line, &format!("{what} index"))?;
    let idx = if i > 0 { i - 1 } else { count as i64 + i };
    if i == 0 || idx < 0 || idx >= count as i64 {
        return Err(MeshError::parse(
            path,
            Some(line),
            format!("{what} index {i} is out of range: {count} defined so far"),
        ));
    }
    Ok(idx as u32)
}

/// The first line of every OBJ and MTL file csrbf writes.
pub(crate) const WRITTEN_BY: &str = "# written by csrbf";

/// The OBJ text; `library` is the `mtllib` line's file, written only when
/// it exists beside the OBJ (see [`library`]), never a dangling name.
pub(crate) fn encode(mesh: &Mesh, library: Option<&str>) -> Vec<u8> {
    let mut s = String::with_capacity(mesh.positions.len() * 40 + mesh.faces.indices.len() * 12);
    s.push_str(WRITTEN_BY);
    s.push('\n');
    if let Some(lib) = library {
        let _ = writeln!(s, "mtllib {lib}");
    }
    for (i, p) in mesh.positions.iter().enumerate() {
        s.push('v');
        for c in p.to_array() {
            s.push(' ');
            push_f32(&mut s, c);
        }
        if let Some(col) = mesh.colors.as_ref().and_then(|c| c.get(i)) {
            for c in &col[..3] {
                s.push(' ');
                push_f32(&mut s, *c);
            }
        }
        s.push('\n');
    }
    if let Some(uv) = &mesh.uvs {
        for t in &uv.values {
            s.push_str("vt ");
            push_f32(&mut s, t.x);
            s.push(' ');
            push_f32(&mut s, t.y);
            s.push('\n');
        }
    }
    // One `vn` per vertex, or, where the mesh keeps normals per corner
    // (hard edges), one per distinct corner normal in the order corners use
    // them, each corner naming its own.
    let corner_normals = mesh
        .corner_normals
        .as_ref()
        .filter(|c| c.len() == mesh.faces.indices.len());
    let mut corner_vn: Vec<u32> = Vec::new();
    let written: Vec<Vec3> = match (corner_normals, &mesh.normals) {
        (Some(corners), _) => {
            let mut index: HashMap<[u32; 3], u32> = HashMap::new();
            let mut distinct = Vec::new();
            for n in corners {
                let k = *index
                    .entry(n.to_array().map(f32::to_bits))
                    .or_insert_with(|| {
                        distinct.push(*n);
                        distinct.len() as u32 - 1
                    });
                corner_vn.push(k);
            }
            distinct
        }
        (None, Some(normals)) => normals.clone(),
        (None, None) => Vec::new(),
    };
    for n in &written {
        s.push_str("vn");
        for c in n.to_array() {
            s.push(' ');
            push_f32(&mut s, c);
        }
        s.push('\n');
    }
    let has_normals = corner_normals.is_some() || mesh.normals.is_some();
    // Which part of each kind each face is in, to emit o/g/usemtl on change.
    let nf = mesh.faces.len();
    let mut labels: [Vec<Vec<&str>>; 3] = [
        vec![Vec::new(); nf],
        vec![Vec::new(); nf],
        vec![Vec::new(); nf],
    ];
    for p in &mesh.parts {
        let k = match p.kind {
            PartKind::Object => 0,
            PartKind::Group => 1,
            PartKind::Material => 2,
        };
        for &f in &p.faces {
            labels[k][f as usize].push(&p.name);
        }
    }
    let keys = ["o", "g", "usemtl"];
    let mut last: [Option<&Vec<&str>>; 3] = [None, None, None];
    // Smoothing groups where the mesh has them for every face; faces start flat.
    let smoothing = mesh.smoothing.as_ref().filter(|s| s.len() == nf);
    let mut last_group = 0u32;
    #[allow(clippy::needless_range_loop)] // f indexes three label tables and the faces
    for f in 0..nf {
        for k in 0..3 {
            let cur = &labels[k][f];
            if last[k] != Some(cur) {
                if !(cur.is_empty() && last[k].is_none()) {
                    let name = if cur.is_empty() {
                        "default".to_owned()
                    } else {
                        cur.join(" ")
                    };
                    let name = if k == 1 {
                        name
                    } else {
                        cur.first().copied().unwrap_or("default").to_owned()
                    };
                    let _ = writeln!(s, "{} {}", keys[k], name);
                }
                last[k] = Some(cur);
            }
        }
        if let Some(&g) = smoothing.and_then(|sm| sm.get(f))
            && g != last_group
        {
            if g == 0 {
                s.push_str("s off\n");
            } else {
                let _ = writeln!(s, "s {g}");
            }
            last_group = g;
        }
        s.push('f');
        let start = mesh.faces.offsets[f] as usize;
        for (c, &v) in mesh.faces.face(f).iter().enumerate() {
            let _ = write!(s, " {}", v + 1);
            let uv = mesh.uvs.as_ref().map(|uv| match &uv.corners {
                Some(idx) => idx[start + c],
                None => v,
            });
            let vn = corner_vn.get(start + c).copied().unwrap_or(v);
            match (uv, has_normals) {
                (Some(t), true) => {
                    let _ = write!(s, "/{}/{}", t + 1, vn + 1);
                }
                (Some(t), false) => {
                    let _ = write!(s, "/{}", t + 1);
                }
                (None, true) => {
                    let _ = write!(s, "//{}", vn + 1);
                }
                (None, false) => {}
            }
        }
        s.push('\n');
    }
    s.into_bytes()
}

/// A material library (`.mtl`) for an OBJ: every material part's name,
/// colour and texture file, in the order the parts come.
pub(crate) struct Library {
    pub materials: Vec<LibraryMaterial>,
}

/// One material of a [`Library`].
pub(crate) struct LibraryMaterial {
    pub name: String,
    pub color: [f32; 4],
    /// The texture's file name beside the OBJ and its bytes.
    pub texture: Option<(String, Vec<u8>)>,
}

/// The material library of a mesh with material parts, for an OBJ whose
/// file stem is `stem`: every material's colour (`Kd`, and `d` below 1) as
/// the mesh knows it (light grey otherwise) and its embedded texture as
/// `STEM_K.png` (or `.jpg`) named by `map_Kd`; `None` without materials.
pub(crate) fn library(mesh: &Mesh, stem: &str) -> Option<Library> {
    let mut names: Vec<&str> = Vec::new();
    for p in mesh.parts.iter().filter(|p| p.kind == PartKind::Material) {
        if !names.contains(&p.name.as_str()) {
            names.push(&p.name);
        }
    }
    if names.is_empty() {
        return None;
    }
    let mut materials = Vec::new();
    let mut count = 0;
    for name in names {
        let m = mesh.materials.iter().find(|m| m.name == name);
        let [r, g, b] = super::mtl::DEFAULT_KD;
        let texture = m.and_then(|m| m.texture.as_ref()).map(|(mime, bytes)| {
            let ext = if mime == "image/jpeg" { "jpg" } else { "png" };
            count += 1;
            (format!("{stem}_{}.{ext}", count - 1), bytes.clone())
        });
        materials.push(LibraryMaterial {
            name: name.to_owned(),
            color: m.map_or([r, g, b, 1.0], |m| m.color),
            texture,
        });
    }
    Some(Library { materials })
}

impl Library {
    /// The `.mtl` text, starting with [`WRITTEN_BY`] (how a later write
    /// knows the file is csrbf's to replace).
    pub(crate) fn text(&self) -> String {
        let mut text = format!("{WRITTEN_BY}\n");
        for m in &self.materials {
            let [r, g, b, a] = m.color;
            let _ = writeln!(text, "\nnewmtl {}\nKd {r} {g} {b}", m.name);
            if a < 1.0 {
                let _ = writeln!(text, "d {a}");
            }
            if let Some((file, _)) = &m.texture {
                let _ = writeln!(text, "map_Kd {file}");
            }
        }
        text
    }
}
