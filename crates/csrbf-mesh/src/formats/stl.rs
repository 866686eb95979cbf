//! STL, ASCII and binary. Triangles are stored apart in STL; reading welds
//! corners at exactly equal positions, in order of first appearance. Each
//! `solid` of an ASCII file becomes a part.

use std::collections::HashMap;
use std::path::Path;

use glam::Vec3;

use super::text::number;
use crate::{Faces, Mesh, MeshError, Part, PartKind, Result};

pub(crate) fn parse(bytes: &[u8], path: &Path) -> Result<Mesh> {
    if bytes.len() >= 84 {
        let count = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as usize;
        if 84 + 50 * count == bytes.len() {
            return parse_binary(bytes, count);
        }
    }
    let head = bytes
        .iter()
        .skip_while(|b| b.is_ascii_whitespace())
        .take(5)
        .copied()
        .collect::<Vec<_>>();
    if head.eq_ignore_ascii_case(b"solid") && std::str::from_utf8(bytes).is_ok() {
        return parse_ascii(bytes, path);
    }
    if bytes.len() < 84 {
        return Err(MeshError::parse(
            path,
            None,
            format!(
                "truncated: {} bytes, less than a binary STL header (84)",
                bytes.len()
            ),
        ));
    }
    let count = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as usize;
    Err(MeshError::parse(
        path,
        None,
        format!(
            "binary STL header says {count} triangles ({} bytes) but the file has {} bytes: truncated or not an STL file",
            84 + 50 * count as u128,
            bytes.len()
        ),
    ))
}

#[derive(Default)]
struct Welder {
    mesh: Mesh,
    index: HashMap<[u32; 3], u32>,
}

impl Welder {
    fn vertex(&mut self, p: Vec3) -> u32 {
        // +0.0 folds -0.0 into 0.0 so both weld.
        let key = (p + Vec3::ZERO).to_array().map(f32::to_bits);
        let positions = &mut self.mesh.positions;
        *self.index.entry(key).or_insert_with(|| {
            positions.push(p);
            positions.len() as u32 - 1
        })
    }
}

fn parse_binary(bytes: &[u8], count: usize) -> Result<Mesh> {
    let mut w = Welder {
        mesh: Mesh {
            faces: Faces::new(),
            ..Mesh::default()
        },
        ..Welder::default()
    };
    for t in 0..count {
        let rec = &bytes[84 + 50 * t..84 + 50 * (t + 1)];
        let f = |k: usize| f32::from_le_bytes([rec[k], rec[k + 1], rec[k + 2], rec[k + 3]]);
        let mut tri = [0u32; 3];
        for (c, v) in tri.iter_mut().enumerate() {
            let o = 12 + 12 * c;
            *v = w.vertex(Vec3::new(f(o), f(o + 4), f(o + 8)));
        }
        w.mesh.faces.push(&tri);
    }
    Ok(w.mesh)
}

fn parse_ascii(bytes: &[u8], path: &Path) -> Result<Mesh> {
    let text = std::str::from_utf8(bytes).map_err(|_| MeshError::parse(path, None, "not text"))?;
    let mut w = Welder {
        mesh: Mesh {
            faces: Faces::new(),
            ..Mesh::default()
        },
        ..Welder::default()
    };
    let mut corners: Vec<u32> = Vec::new();
    let mut in_solid = false;
    let mut ended = false;
    for (i, line) in text.lines().enumerate() {
        let ln = i + 1;
        let mut tok = line.split_ascii_whitespace();
        match tok.next() {
            Some("solid") => {
                in_solid = true;
                ended = false;
                let name = line.trim_start()[5..].trim();
                let name = if name.is_empty() {
                    format!("solid{}", w.mesh.parts.len())
                } else {
                    name.to_owned()
                };
                w.mesh.parts.push(Part {
                    name,
                    kind: PartKind::Object,
                    faces: Vec::new(),
                });
            }
            Some("vertex") => {
                let x = number(tok.next(), path, ln, "vertex x")?;
                let y = number(tok.next(), path, ln, "vertex y")?;
                let z = number(tok.next(), path, ln, "vertex z")?;
                corners.push(w.vertex(Vec3::new(x, y, z)));
            }
            Some("facet") | Some("outer") if !in_solid => {
                return Err(MeshError::parse(path, Some(ln), "facet outside of a solid"));
            }
            Some("facet") | Some("outer") => {}
            Some("endloop") => {
                if corners.len() < 3 {
                    return Err(MeshError::parse(
                        path,
                        Some(ln),
                        format!("a facet needs 3 vertices, found {}", corners.len()),
                    ));
                }
                let f = w.mesh.faces.len() as u32;
                w.mesh.faces.push(&corners);
                if let Some(p) = w.mesh.parts.last_mut() {
                    p.faces.push(f);
                }
                corners.clear();
            }
            Some("endfacet") => {}
            Some("endsolid") => {
                in_solid = false;
                ended = true;
            }
            Some(other) => {
                return Err(MeshError::parse(
                    path,
                    Some(ln),
                    format!("unexpected {other:?} in an ASCII STL file"),
                ));
            }
            None => {}
        }
    }
    if !ended || !corners.is_empty() {
        return Err(MeshError::parse(
            path,
            None,
            "truncated: the file ends before \"endsolid\"",
        ));
    }
    if w.mesh.parts.len() <= 1 {
        w.mesh.parts.clear();
    }
    Ok(w.mesh)
}

pub(crate) fn encode(mesh: &Mesh) -> Vec<u8> {
    let tris = mesh.faces.triangles();
    let mut out = Vec::with_capacity(84 + 50 * tris.len());
    let mut header = [0u8; 80];
    let tag = b"binary STL written by csrbf";
    header[..tag.len()].copy_from_slice(tag);
    out.extend_from_slice(&header);
    out.extend_from_slice(&(tris.len() as u32).to_le_bytes());
    for t in tris {
        let p = t.map(|i| mesh.positions[i as usize]);
        let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
        for v in std::iter::once(n).chain(p) {
            for c in v.to_array() {
                out.extend_from_slice(&c.to_le_bytes());
            }
        }
        out.extend_from_slice(&0u16.to_le_bytes());
    }
    out
}
