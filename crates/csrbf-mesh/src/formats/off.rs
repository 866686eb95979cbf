//! Object File Format: `OFF` with the optional `C` (vertex colours), `N`
//! (normals, read only) and `ST` (texture coordinates) prefixes; polygon
//! faces (a face's colour is not kept: `load` says so).

use std::fmt::Write;
use std::path::Path;

use glam::{Vec2, Vec3};

use super::Skipped;
use super::text::{lines, number, push_f32};
use crate::{Faces, Mesh, MeshError, Result, TexCoords};

pub(crate) fn parse(bytes: &[u8], path: &Path, skipped: &mut Skipped) -> Result<Mesh> {
    let mut it = lines(bytes, path);
    let (ln, header) = it
        .next()
        .transpose()?
        .ok_or_else(|| MeshError::parse(path, None, "the file is empty"))?;
    let mut words = header.split_ascii_whitespace();
    let magic = words.next().unwrap_or("");
    let Some(prefix) = magic.strip_suffix("OFF") else {
        return Err(MeshError::parse(
            path,
            Some(ln),
            format!("expected the OFF header, found {magic:?}"),
        ));
    };
    if prefix.contains('4') || prefix.contains('n') {
        return Err(MeshError::parse(
            path,
            Some(ln),
            format!("{magic}: only 3-dimensional OFF is supported"),
        ));
    }
    let (has_st, has_c, has_n) = (
        prefix.contains("ST"),
        prefix.contains('C'),
        prefix.contains('N'),
    );
    // The counts may follow the keyword on the same line.
    let rest: Vec<&str> = words.collect();
    let (cl, counts): (usize, Vec<&str>) = if rest.is_empty() {
        let (l, s) = it
            .next()
            .transpose()?
            .ok_or_else(|| MeshError::parse(path, None, "truncated: no vertex and face counts"))?;
        (l, s.split_ascii_whitespace().collect())
    } else {
        (ln, rest)
    };
    let nv: usize = number(counts.first().copied(), path, cl, "vertex count")?;
    let nf: usize = number(counts.get(1).copied(), path, cl, "face count")?;

    let mut mesh = Mesh {
        faces: Faces::new(),
        ..Mesh::default()
    };
    mesh.positions.reserve(nv.min(bytes.len() / 6));
    let mut colors = Vec::new();
    let mut uvs = Vec::new();
    let mut normals = Vec::new();
    // Vertex lines at the end that have a face line's shape (`3 0 1 2`): a
    // vertex count too large reads the faces as vertices.
    let mut face_shaped = 0usize;
    for v in 0..nv {
        let (l, s) = it.next().transpose()?.ok_or_else(|| {
            let message = if face_shaped > 0 {
                format!(
                    "truncated: expected {nv} vertices, found {} and then {face_shaped} face line(s) (if the file is whole, the header's vertex count is too large)",
                    v - face_shaped
                )
            } else {
                format!("truncated: expected {nv} vertices, found {v}")
            };
            MeshError::parse(path, None, message)
        })?;
        face_shaped = if looks_like_face(s) {
            face_shaped + 1
        } else {
            0
        };
        let vals: Vec<f32> = s
            .split_ascii_whitespace()
            .map(|t| number::<f32>(Some(t), path, l, "vertex coordinate"))
            .collect::<Result<_>>()?;
        let need =
            3 + if has_n { 3 } else { 0 } + if has_c { 3 } else { 0 } + if has_st { 2 } else { 0 };
        if vals.len() < need {
            return Err(MeshError::parse(
                path,
                Some(l),
                format!("vertex {v} has {} numbers, expected {need}", vals.len()),
            ));
        }
        mesh.positions.push(Vec3::new(vals[0], vals[1], vals[2]));
        if has_n {
            normals.push(Vec3::new(vals[3], vals[4], vals[5]));
        }
        let mut k = 3 + if has_n { 3 } else { 0 };
        if has_c {
            let rgba_len = if vals.len() >= k + 4 + if has_st { 2 } else { 0 } {
                4
            } else {
                3
            };
            let mut c = [1.0f32; 4];
            c[..rgba_len].copy_from_slice(&vals[k..k + rgba_len]);
            colors.push(c);
            k += rgba_len;
        }
        if has_st {
            uvs.push(Vec2::new(vals[k], vals[k + 1]));
        }
    }
    for f in 0..nf {
        let (l, s) = it.next().transpose()?.ok_or_else(|| {
            MeshError::parse(
                path,
                None,
                format!(
                    "truncated: expected {nf} faces, found {f} (if the file is whole, the header's counts are wrong: it says {nv} vertices and {nf} faces, and face lines read as vertices when the vertex count is too large)"
                ),
            )
        })?;
        let mut tok = s.split_ascii_whitespace();
        let k: usize = number(tok.next(), path, l, "face corner count")?;
        let rest: Vec<&str> = tok.collect();
        // A count is checked against what the line holds before anything is
        // allocated for it (a forged count must not ask for gigabytes).
        if k > rest.len() {
            return Err(MeshError::parse(
                path,
                Some(l),
                format!(
                    "face {f} declares {k} corners but its line holds {} numbers",
                    rest.len()
                ),
            ));
        }
        let mut tok = rest.into_iter();
        let mut corners = Vec::with_capacity(k);
        for _ in 0..k {
            let v: u32 = number(tok.next(), path, l, "face vertex index")?;
            if v as usize >= nv {
                return Err(MeshError::parse(
                    path,
                    Some(l),
                    format!("face {f} refers to vertex {v}, but there are only {nv}"),
                ));
            }
            corners.push(v);
        }
        // A colour (three or four numbers, or a colour map index) may
        // follow the corners.
        if tok.next().is_some() {
            skipped.add("faces' colours", 1);
        }
        if k < 3 {
            return Err(MeshError::parse(
                path,
                Some(l),
                format!("face {f} has {k} corners; a face needs at least 3"),
            ));
        }
        mesh.faces.push(&corners);
    }
    if has_c {
        // Integer colours are 0..255.
        if colors.iter().flatten().any(|c| *c > 1.0) {
            for c in colors.iter_mut().flatten() {
                *c /= 255.0;
            }
        }
        mesh.colors = Some(colors);
    }
    if has_st {
        mesh.uvs = Some(TexCoords {
            values: uvs,
            corners: None,
        });
    }
    if has_n {
        mesh.normals = Some(normals);
    }
    Ok(mesh)
}

pub(crate) fn encode(mesh: &Mesh) -> Vec<u8> {
    let mut s = String::with_capacity(mesh.positions.len() * 32 + mesh.faces.indices.len() * 8);
    let uvs = mesh
        .uvs
        .as_ref()
        .and_then(|u| u.per_vertex(&mesh.faces, mesh.positions.len()));
    // No normals (`NOFF`): trimesh, among others, refuses that header, and
    // a deformed mesh always has normals (carried or computed).
    let _ = writeln!(
        s,
        "{}{}OFF\n{} {} 0",
        if uvs.is_some() { "ST" } else { "" },
        if mesh.colors.is_some() { "C" } else { "" },
        mesh.positions.len(),
        mesh.faces.len()
    );
    for (i, p) in mesh.positions.iter().enumerate() {
        let mut first = true;
        let mut put = |s: &mut String, v: f32| {
            if !first {
                s.push(' ');
            }
            first = false;
            push_f32(s, v);
        };
        for c in p.to_array() {
            put(&mut s, c);
        }
        if let Some(c) = &mesh.colors {
            for v in c[i] {
                put(&mut s, v);
            }
        }
        if let Some(uv) = &uvs {
            put(&mut s, uv[i].x);
            put(&mut s, uv[i].y);
        }
        s.push('\n');
    }
    for f in mesh.faces.iter() {
        let _ = write!(s, "{}", f.len());
        for v in f {
            let _ = write!(s, " {v}");
        }
        s.push('\n');
    }
    s.into_bytes()
}

/// Whether a line reads as a face (`n i j k ...`: whole numbers, the first
/// at least 3 and the count of those after it).
fn looks_like_face(line: &str) -> bool {
    let tok: Vec<&str> = line.split_ascii_whitespace().collect();
    let whole = |t: &str| t.parse::<usize>().ok();
    match tok.first().and_then(|t| whole(t)) {
        Some(n) => n >= 3 && tok.len() - 1 == n && tok[1..].iter().all(|t| whole(t).is_some()),
        None => false,
    }
}
