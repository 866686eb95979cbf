//! Stanford PLY: ASCII, binary little- and big-endian in; binary
//! little-endian (or ASCII) out. Vertex positions, colours, texture
//! coordinates and normals; polygon faces; parts as integer face
//! properties `group`, `object` and `material` (-1: in none of that kind),
//! named by `comment part <kind> <index> <name>` header lines, which is how
//! csrbf writes them; other elements are skipped.

use std::fmt::Write;
use std::path::Path;

use glam::{Vec2, Vec3};

use super::Skipped;
use super::text::push_f32;
use crate::{Faces, Mesh, MeshError, Part, PartKind, Result, TexCoords};

#[derive(Clone, Copy, Debug, PartialEq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(s: &str) -> Option<Scalar> {
        Some(match s {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }
    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }
}

#[derive(Debug)]
struct Property {
    name: String,
    ty: Scalar,
    /// For a list, the type of its count.
    list: Option<Scalar>,
}

#[derive(Debug)]
struct Element {
    name: String,
    count: usize,
    props: Vec<Property>,
}

#[derive(Clone, Copy, PartialEq)]
enum Encoding {
    Ascii,
    Little,
    Big,
}

pub(crate) fn parse(bytes: &[u8], path: &Path, skipped: &mut Skipped) -> Result<Mesh> {
    let err = |line: Option<usize>, m: String| MeshError::parse(path, line, m);
    let end = find(bytes, b"end_header").ok_or_else(|| {
        err(
            None,
            "no \"end_header\": not a PLY file, or truncated in its header".into(),
        )
    })?;
    let mut body = end + b"end_header".len();
    // The header ends with a line break (\n or \r\n).
    while body < bytes.len() && bytes[body] != b'\n' {
        body += 1;
    }
    body += 1;
    let header = std::str::from_utf8(&bytes[..end])
        .map_err(|_| err(None, "the header is not text".into()))?;
    let mut encoding = None;
    let mut elements: Vec<Element> = Vec::new();
    let mut part_names: Vec<(PartKind, i64, String)> = Vec::new();
    for (i, line) in header.lines().enumerate() {
        let ln = i + 1;
        let tok: Vec<&str> = line.split_ascii_whitespace().collect();
        match tok.first().copied() {
            Some("comment") => {
                if let Some(named) = part_comment(line) {
                    part_names.push(named);
                }
            }
            Some("ply") | Some("obj_info") | None => {}
            Some("format") => {
                encoding = Some(match tok.get(1).copied() {
                    Some("ascii") => Encoding::Ascii,
                    Some("binary_little_endian") => Encoding::Little,
                    Some("binary_big_endian") => Encoding::Big,
                    other => return Err(err(Some(ln), format!("unknown PLY format {other:?}"))),
                })
            }
            Some("element") => {
                let name = tok
                    .get(1)
                    .ok_or_else(|| err(Some(ln), "element without a name".into()))?;
                let count = tok
                    .get(2)
                    .and_then(|c| c.parse().ok())
                    .ok_or_else(|| err(Some(ln), format!("element {name} has no valid count")))?;
                elements.push(Element {
                    name: name.to_string(),
                    count,
                    props: Vec::new(),
                });
            }
            Some("property") => {
                let el = elements
                    .last_mut()
                    .ok_or_else(|| err(Some(ln), "property before any element".into()))?;
                let bad = |t: &str| err(Some(ln), format!("unknown property type {t:?}"));
                let prop = if tok.get(1) == Some(&"list") {
                    let (c, t, n) = (tok.get(2), tok.get(3), tok.get(4));
                    let (Some(c), Some(t), Some(n)) = (c, t, n) else {
                        return Err(err(Some(ln), "incomplete list property".into()));
                    };
                    Property {
                        name: n.to_string(),
                        ty: Scalar::parse(t).ok_or_else(|| bad(t))?,
                        list: Some(Scalar::parse(c).ok_or_else(|| bad(c))?),
                    }
                } else {
                    let (Some(t), Some(n)) = (tok.get(1), tok.get(2)) else {
                        return Err(err(Some(ln), "incomplete property".into()));
                    };
                    Property {
                        name: n.to_string(),
                        ty: Scalar::parse(t).ok_or_else(|| bad(t))?,
                        list: None,
                    }
                };
                el.props.push(prop);
            }
            Some(other) => {
                return Err(err(
                    Some(ln),
                    format!("unexpected {other:?} in the PLY header"),
                ));
            }
        }
    }
    if !header.starts_with("ply") {
        return Err(err(Some(1), "the file does not start with \"ply\"".into()));
    }
    let encoding = encoding.ok_or_else(|| err(None, "the header has no format line".into()))?;
    let header_lines = header.lines().count() + 1;
    let mut src = Source::new(
        &bytes[body.min(bytes.len())..],
        encoding,
        header_lines,
        path,
    );

    let mut mesh = Mesh {
        faces: Faces::new(),
        ..Mesh::default()
    };
    let mut colors = Vec::new();
    let mut uvs = Vec::new();
    let mut normals = Vec::new();
    // Per kind of part, each face's index in it (-1: none).
    let mut face_parts: Vec<(PartKind, Vec<i64>)> = Vec::new();
    let mut vals: Vec<f64> = Vec::new();
    for el in &elements {
        let is_vertex = el.name == "vertex";
        let is_face = el.name == "face";
        let find = |names: &[&str]| {
            el.props
                .iter()
                .position(|p| names.contains(&p.name.as_str()))
        };
        let (px, py, pz) = (find(&["x"]), find(&["y"]), find(&["z"]));
        let col = [
            find(&["red", "r", "diffuse_red"]),
            find(&["green", "g", "diffuse_green"]),
            find(&["blue", "b", "diffuse_blue"]),
            find(&["alpha", "a"]),
        ];
        let (tu, tv) = (
            find(&["u", "s", "texture_u", "texture_s"]),
            find(&["v", "t", "texture_v", "texture_t"]),
        );
        let (nx, ny, nz) = (find(&["nx"]), find(&["ny"]), find(&["nz"]));
        let list_prop = find(&["vertex_indices", "vertex_index"]);
        let part_props: Vec<(PartKind, usize)> = if is_face {
            PART_KINDS
                .iter()
                .filter_map(|&k| {
                    let i = find(&[k.name()])?;
                    (el.props[i].list.is_none()).then_some((k, i))
                })
                .collect()
        } else {
            Vec::new()
        };
        if is_face {
            face_parts = part_props
                .iter()
                .map(|&(k, _)| (k, Vec::with_capacity(el.count.min(bytes.len() / 4))))
                .collect();
        }
        // The properties read below; the others are said to be skipped.
        let used: Vec<usize> = if is_vertex {
            let mut used = vec![px, py, pz];
            if col[0].is_some() {
                used.extend(col);
            }
            if tu.is_some() && tv.is_some() {
                used.extend([tu, tv]);
            }
            if nx.is_some() && ny.is_some() && nz.is_some() {
                used.extend([nx, ny, nz]);
            }
            used.into_iter().flatten().collect()
        } else {
            part_props
                .iter()
                .map(|&(_, i)| i)
                .chain(list_prop)
                .collect()
        };
        if is_vertex || is_face {
            let whose = if is_vertex { "vertices'" } else { "faces'" };
            for (k, p) in el.props.iter().enumerate() {
                if !used.contains(&k) {
                    skipped.add(&format!("{whose} {}", Skipped::name(&p.name)), el.count);
                }
            }
        } else {
            skipped.add(&format!("{} elements", Skipped::name(&el.name)), el.count);
        }
        if is_vertex && (px.is_none() || py.is_none() || pz.is_none()) {
            return Err(err(
                None,
                "the vertex element has no x, y and z properties".into(),
            ));
        }
        if is_vertex {
            mesh.positions.reserve(el.count.min(bytes.len() / 12));
        }
        for r in 0..el.count {
            src.start_record();
            let mut corners: Vec<u32> = Vec::new();
            vals.clear();
            for (k, p) in el.props.iter().enumerate() {
                match p.list {
                    None => vals.push(src.scalar(p.ty, &el.name, r)?),
                    Some(ct) => {
                        vals.push(0.0);
                        let n = src.scalar(ct, &el.name, r)?;
                        if !(0.0..=1e6).contains(&n) || n.fract() != 0.0 {
                            return Err(
                                src.error(format!("{} {r}: list length {n} is not valid", el.name))
                            );
                        }
                        for _ in 0..n as usize {
                            let v = src.scalar(p.ty, &el.name, r)?;
                            if is_face && Some(k) == list_prop {
                                if !(v >= 0.0 && v < u32::MAX as f64 && v.fract() == 0.0) {
                                    return Err(src.error(format!(
                                        "face {r}: vertex index {v} is not valid"
                                    )));
                                }
                                corners.push(v as u32);
                            }
                        }
                    }
                }
            }
            src.end_record(&el.name, r)?;
            if is_vertex {
                let get = |i: Option<usize>| i.map(|i| vals[i] as f32);
                for i in [px, py, pz].into_iter().flatten() {
                    if vals[i].is_finite() && !(vals[i] as f32).is_finite() {
                        return Err(src.error(format!(
                            "vertex {r}: coordinate {} is beyond the range of 32-bit floats (about ±3.4e38) that vertices are kept in",
                            vals[i]
                        )));
                    }
                }
                mesh.positions.push(Vec3::new(
                    vals[px.unwrap_or(0)] as f32,
                    vals[py.unwrap_or(0)] as f32,
                    vals[pz.unwrap_or(0)] as f32,
                ));
                if col[0].is_some() {
                    let scale = |i: Option<usize>| {
                        i.map_or(1.0, |i| {
                            let integer =
                                el.props[i].ty != Scalar::F32 && el.props[i].ty != Scalar::F64;
                            (vals[i] / if integer { 255.0 } else { 1.0 }) as f32
                        })
                    };
                    colors.push([scale(col[0]), scale(col[1]), scale(col[2]), scale(col[3])]);
                }
                if let (Some(u), Some(v)) = (get(tu), get(tv)) {
                    uvs.push(Vec2::new(u, v));
                }
                if let (Some(x), Some(y), Some(z)) = (get(nx), get(ny), get(nz)) {
                    normals.push(Vec3::new(x, y, z));
                }
            } else if is_face {
                if corners.len() < 3 {
                    return Err(src.error(format!(
                        "face {r} has {} corners; a face needs at least 3",
                        corners.len()
                    )));
                }
                mesh.faces.push(&corners);
                for ((_, i), (_, of)) in part_props.iter().zip(face_parts.iter_mut()) {
                    let v = vals[*i];
                    of.push(if v >= 0.0 && v.fract() == 0.0 && v < u32::MAX as f64 {
                        v as i64
                    } else {
                        -1
                    });
                }
            }
        }
    }
    if !colors.is_empty() {
        mesh.colors = Some(colors);
    }
    if !uvs.is_empty() {
        mesh.uvs = Some(TexCoords {
            values: uvs,
            corners: None,
        });
    }
    if !normals.is_empty() {
        mesh.normals = Some(normals);
    }
    mesh.parts = parts_from_faces(&face_parts, &part_names);
    Ok(mesh)
}

const PART_KINDS: [PartKind; 3] = [PartKind::Group, PartKind::Object, PartKind::Material];

/// `comment part material 3 red paint`: (Material, 3, "red paint").
fn part_comment(line: &str) -> Option<(PartKind, i64, String)> {
    let rest = line.trim_start().strip_prefix("comment")?.trim_start();
    let rest = rest.strip_prefix("part ")?.trim_start();
    let (kind, rest) = rest.split_once(' ')?;
    let kind = *PART_KINDS.iter().find(|k| k.name() == kind)?;
    let rest = rest.trim_start();
    let (index, name) = rest.split_once(' ').unwrap_or((rest, ""));
    Some((kind, index.parse().ok()?, name.to_owned()))
}

/// Parts from the faces' indices of each kind, in the order of their
/// indices, named by the header's comments (else `group 3` and so on).
fn parts_from_faces(
    face_parts: &[(PartKind, Vec<i64>)],
    names: &[(PartKind, i64, String)],
) -> Vec<Part> {
    let mut parts = Vec::new();
    for (kind, of) in face_parts {
        let mut by_index: std::collections::BTreeMap<i64, Vec<u32>> = Default::default();
        for (f, &i) in of.iter().enumerate() {
            if i >= 0 {
                by_index.entry(i).or_default().push(f as u32);
            }
        }
        for (i, faces) in by_index {
            let name = names
                .iter()
                .find(|(k, j, _)| k == kind && *j == i)
                .map_or_else(|| format!("{} {i}", kind.name()), |(_, _, n)| n.clone());
            parts.push(Part {
                name,
                kind: *kind,
                faces,
            });
        }
    }
    parts
}

/// Per kind of part the mesh has, each face's part of that kind (-1: none;
/// a face in two parts of one kind keeps the first, which `Format::loses`
/// reports) and the parts' names.
fn face_part_columns(mesh: &Mesh) -> Vec<(PartKind, Vec<i32>, Vec<&str>)> {
    let faces = mesh.faces.len();
    let mut columns = Vec::new();
    for kind in PART_KINDS {
        let parts: Vec<&Part> = mesh.parts.iter().filter(|p| p.kind == kind).collect();
        if parts.is_empty() {
            continue;
        }
        let mut of = vec![-1i32; faces];
        for (i, p) in parts.iter().enumerate() {
            for &f in &p.faces {
                if let Some(slot) = of.get_mut(f as usize)
                    && *slot < 0
                {
                    *slot = i as i32;
                }
            }
        }
        columns.push((kind, of, parts.iter().map(|p| p.name.as_str()).collect()));
    }
    columns
}

/// Whether a face lies in two parts of one kind (a PLY face holds one).
pub(crate) fn parts_overlap(mesh: &Mesh) -> bool {
    PART_KINDS.iter().any(|&kind| {
        let mut seen = vec![false; mesh.faces.len()];
        mesh.parts.iter().filter(|p| p.kind == kind).any(|p| {
            p.faces.iter().any(|&f| {
                seen.get_mut(f as usize)
                    .is_some_and(|s| std::mem::replace(s, true))
            })
        })
    })
}

fn find(hay: &[u8], needle: &[u8]) -> Option<usize> {
    hay.windows(needle.len()).position(|w| w == needle)
}

/// The body of the file, read value by value.
struct Source<'a> {
    bytes: &'a [u8],
    at: usize,
    encoding: Encoding,
    /// ASCII: tokens of the current line and its number.
    line: usize,
    tokens: Vec<&'a str>,
    next_token: usize,
    lines: std::slice::Split<'a, u8, fn(&u8) -> bool>,
    path: &'a Path,
}

impl<'a> Source<'a> {
    fn new(bytes: &'a [u8], encoding: Encoding, header_lines: usize, path: &'a Path) -> Source<'a> {
        let newline: fn(&u8) -> bool = |b| *b == b'\n';
        Source {
            bytes,
            at: 0,
            encoding,
            line: header_lines,
            tokens: Vec::new(),
            next_token: 0,
            lines: bytes.split(newline),
            path,
        }
    }

    fn error(&self, message: String) -> MeshError {
        match self.encoding {
            Encoding::Ascii => MeshError::parse(self.path, Some(self.line), message),
            _ => MeshError::parse(self.path, None, format!("at byte {}: {message}", self.at)),
        }
    }

    /// ASCII: a record is one non-empty line.
    fn start_record(&mut self) {
        if self.encoding != Encoding::Ascii {
            return;
        }
        self.tokens.clear();
        self.next_token = 0;
        for raw in self.lines.by_ref() {
            self.line += 1;
            let s = std::str::from_utf8(raw).unwrap_or("\u{fffd}");
            let t: Vec<&str> = s.split_ascii_whitespace().collect();
            if !t.is_empty() {
                self.tokens = t;
                break;
            }
        }
    }

    fn end_record(&mut self, element: &str, r: usize) -> Result<()> {
        if self.encoding == Encoding::Ascii && self.next_token < self.tokens.len() {
            return Err(self.error(format!(
                "{element} {r}: {} values more than the header declares",
                self.tokens.len() - self.next_token
            )));
        }
        Ok(())
    }

    fn scalar(&mut self, ty: Scalar, element: &str, r: usize) -> Result<f64> {
        if self.encoding == Encoding::Ascii {
            let Some(tok) = self.tokens.get(self.next_token) else {
                return Err(self.error(format!(
                    "truncated: {element} {r} has fewer values than the header declares"
                )));
            };
            self.next_token += 1;
            return tok
                .parse::<f64>()
                .map_err(|_| self.error(format!("{element} {r}: {tok:?} is not a number")));
        }
        let n = ty.size();
        if self.at + n > self.bytes.len() {
            return Err(self.error(format!("truncated in {element} {r}")));
        }
        let mut b = [0u8; 8];
        b[..n].copy_from_slice(&self.bytes[self.at..self.at + n]);
        if self.encoding == Encoding::Big {
            b[..n].reverse();
        }
        self.at += n;
        Ok(match ty {
            Scalar::I8 => b[0] as i8 as f64,
            Scalar::U8 => b[0] as f64,
            Scalar::I16 => i16::from_le_bytes([b[0], b[1]]) as f64,
            Scalar::U16 => u16::from_le_bytes([b[0], b[1]]) as f64,
            Scalar::I32 => i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Scalar::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Scalar::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Scalar::F64 => f64::from_le_bytes(b),
        })
    }
}

pub(crate) fn encode(mesh: &Mesh, ascii: bool) -> Vec<u8> {
    let n = mesh.positions.len();
    let uvs = mesh.uvs.as_ref().and_then(|u| u.per_vertex(&mesh.faces, n));
    let mut h = String::from("ply\n");
    h.push_str(if ascii {
        "format ascii 1.0\n"
    } else {
        "format binary_little_endian 1.0\n"
    });
    h.push_str("comment written by csrbf\n");
    let part_columns = face_part_columns(mesh);
    for (kind, _, names) in &part_columns {
        for (i, name) in names.iter().enumerate() {
            // A header line cannot hold a line break.
            let name = name.replace(['\r', '\n'], " ");
            let _ = writeln!(h, "comment part {} {i} {name}", kind.name());
        }
    }
    let _ = writeln!(h, "element vertex {n}");
    h.push_str("property float x\nproperty float y\nproperty float z\n");
    if mesh.normals.is_some() {
        h.push_str("property float nx\nproperty float ny\nproperty float nz\n");
    }
    if mesh.colors.is_some() {
        h.push_str(
            "property float red\nproperty float green\nproperty float blue\nproperty float alpha\n",
        );
    }
    if uvs.is_some() {
        // `s t`: the names Blender's and trimesh's readers take as UVs
        // (Blender keeps `u v` as plain attributes).
        h.push_str("property float s\nproperty float t\n");
    }
    let face_records: usize = mesh
        .faces
        .iter()
        .map(|f| if f.len() <= 255 { 1 } else { f.len() - 2 })
        .sum();
    let _ = writeln!(h, "element face {face_records}");
    h.push_str("property list uchar int vertex_indices\n");
    for (kind, _, _) in &part_columns {
        let _ = writeln!(h, "property int {}", kind.name());
    }
    h.push_str("end_header\n");
    let mut floats: Vec<f32> = Vec::with_capacity(12);
    let mut out = h.into_bytes();
    let mut line = String::new();
    for i in 0..n {
        floats.clear();
        floats.extend_from_slice(&mesh.positions[i].to_array());
        if let Some(nm) = &mesh.normals {
            floats.extend_from_slice(&nm[i].to_array());
        }
        if let Some(c) = &mesh.colors {
            floats.extend_from_slice(&c[i]);
        }
        if let Some(uv) = &uvs {
            floats.extend_from_slice(&uv[i].to_array());
        }
        if ascii {
            line.clear();
            for (k, v) in floats.iter().enumerate() {
                if k > 0 {
                    line.push(' ');
                }
                push_f32(&mut line, *v);
            }
            line.push('\n');
            out.extend_from_slice(line.as_bytes());
        } else {
            for v in &floats {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
    }
    for (face, f) in mesh.faces.iter().enumerate() {
        // Faces of more than 255 corners do not fit a uchar count: fan them.
        let pieces: Vec<Vec<u32>> = if f.len() <= 255 {
            vec![f.to_vec()]
        } else {
            crate::fan(f).map(|t| t.to_vec()).collect()
        };
        for f in pieces {
            if ascii {
                line.clear();
                let _ = write!(line, "{}", f.len());
                for v in &f {
                    let _ = write!(line, " {v}");
                }
                for (_, of, _) in &part_columns {
                    let _ = write!(line, " {}", of[face]);
                }
                line.push('\n');
                out.extend_from_slice(line.as_bytes());
            } else {
                out.push(f.len() as u8);
                for v in &f {
                    out.extend_from_slice(&(*v as i32).to_le_bytes());
                }
                for (_, of, _) in &part_columns {
                    out.extend_from_slice(&of[face].to_le_bytes());
                }
            }
        }
    }
    out
}
