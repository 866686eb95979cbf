//! VTK XML unstructured grids (`.vtu`), read with a small tag scanner (an
//! XML library cannot step over raw appended data): `format="ascii"`,
//! `"binary"` (base64) and `"appended"` (raw or base64), with or without
//! `vtkZLibDataCompressor`, UInt32 or UInt64 headers, either byte order;
//! several pieces are joined. Zones as for the legacy files: an integer
//! cell array (`gmsh:physical`, ...) and field data `name` = [tag, dim].
//!
//! Written with every array appended raw (or ASCII), UInt64 headers,
//! little-endian.

use std::path::Path;

use super::scan::{self, Scalar, ZONE_ARRAY, ZONE_ARRAYS};
use super::{VolumeMesh, Zone};
use crate::{MeshError, Result};

/// Bytes per block of compressed data, as VTK writes them.
const BLOCK: usize = 32768;

/// Where a `DataArray` sits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Section {
    Points,
    Cells,
    CellData,
    FieldData,
    Other,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Layout {
    Ascii,
    Binary,
    Appended,
}

struct Array {
    section: Section,
    piece: usize,
    name: String,
    ty: Option<Scalar>,
    ty_name: String,
    comps: usize,
    layout: Layout,
    offset: usize,
    /// The byte ranges of its text (ASCII values or base64).
    text: Vec<(usize, usize)>,
    /// The byte offset of its tag.
    at: usize,
}

struct Piece {
    points: usize,
    cells: usize,
}

/// What the `VTKFile` tag and `AppendedData` say.
#[derive(Default)]
struct Head {
    big: bool,
    header64: bool,
    zlib: bool,
    /// Where the appended data starts (after `_`), and whether it is raw.
    appended: Option<(usize, bool)>,
}

/// One XML tag: its name, attributes, whether it closes itself (or is a
/// closing tag), and the byte after it.
struct Tag<'a> {
    name: &'a str,
    attrs: Vec<(&'a str, String)>,
    empty: bool,
    end: usize,
}

impl Tag<'_> {
    fn attr(&self, name: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(k, _)| *k == name)
            .map(|(_, v)| v.as_str())
    }
}

fn find(bytes: &[u8], from: usize, what: &[u8]) -> Option<usize> {
    bytes
        .get(from..)?
        .windows(what.len())
        .position(|w| w == what)
        .map(|i| from + i)
}

/// Replaces XML's entities in an attribute value.
fn unescape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    let mut rest = s;
    while let Some(i) = rest.find('&') {
        out.push_str(&rest[..i]);
        rest = &rest[i..];
        let Some(j) = rest.find(';') else { break };
        let ent = &rest[1..j];
        let c = match ent {
            "lt" => Some('<'),
            "gt" => Some('>'),
            "amp" => Some('&'),
            "quot" => Some('"'),
            "apos" => Some('\''),
            _ => ent
                .strip_prefix("#x")
                .map(|h| u32::from_str_radix(h, 16))
                .or_else(|| ent.strip_prefix('#').map(str::parse))
                .and_then(|v| v.ok())
                .and_then(char::from_u32),
        };
        match c {
            Some(c) => {
                out.push(c);
                rest = &rest[j + 1..];
            }
            None => {
                out.push('&');
                rest = &rest[1..];
            }
        }
    }
    out.push_str(rest);
    out
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

struct Scanner<'a> {
    bytes: &'a [u8],
    path: &'a Path,
}

impl<'a> Scanner<'a> {
    fn error(&self, at: usize, message: impl Into<String>) -> MeshError {
        let line = 1 + self.bytes[..at.min(self.bytes.len())]
            .iter()
            .filter(|&&b| b == b'\n')
            .count();
        MeshError::parse(self.path, Some(line), message)
    }

    /// The tag that starts at `at` (a `<` not followed by `/`, `?` or `!`).
    fn tag(&self, at: usize) -> Result<Tag<'a>> {
        let b = self.bytes;
        let unterminated = || self.error(at, "a tag that is not closed with '>'");
        let mut i = at + 1;
        let name_end = (i..b.len())
            .find(|&k| b[k].is_ascii_whitespace() || b[k] == b'/' || b[k] == b'>')
            .ok_or_else(unterminated)?;
        let name = std::str::from_utf8(&b[i..name_end])
            .map_err(|_| self.error(at, "a tag name that is not text"))?;
        i = name_end;
        let mut attrs = Vec::new();
        loop {
            while i < b.len() && b[i].is_ascii_whitespace() {
                i += 1;
            }
            match b.get(i) {
                None => return Err(unterminated()),
                Some(b'>') => {
                    return Ok(Tag {
                        name,
                        attrs,
                        empty: false,
                        end: i + 1,
                    });
                }
                Some(b'/') if b.get(i + 1) == Some(&b'>') => {
                    return Ok(Tag {
                        name,
                        attrs,
                        empty: true,
                        end: i + 2,
                    });
                }
                _ => {}
            }
            let k = i;
            while i < b.len() && b[i] != b'=' && !b[i].is_ascii_whitespace() && b[i] != b'>' {
                i += 1;
            }
            let key = std::str::from_utf8(&b[k..i])
                .map_err(|_| self.error(k, "an attribute name that is not text"))?;
            while i < b.len() && b[i].is_ascii_whitespace() {
                i += 1;
            }
            if b.get(i) != Some(&b'=') {
                return Err(self.error(k, format!("attribute {key:?} of <{name}> has no value")));
            }
            i += 1;
            while i < b.len() && b[i].is_ascii_whitespace() {
                i += 1;
            }
            let quote = *b.get(i).ok_or_else(unterminated)?;
            if quote != b'"' && quote != b'\'' {
                return Err(self.error(i, format!("attribute {key:?}'s value is not quoted")));
            }
            let end = (i + 1..b.len())
                .find(|&e| b[e] == quote)
                .ok_or_else(unterminated)?;
            let value = std::str::from_utf8(&b[i + 1..end])
                .map_err(|_| self.error(i, format!("attribute {key:?} is not text")))?;
            attrs.push((key, unescape(value)));
            i = end + 1;
        }
    }

    /// Walks the tags: the file's head, pieces and data arrays, up to the
    /// appended data.
    fn scan(&self) -> Result<(Head, Vec<Piece>, Vec<Array>)> {
        let b = self.bytes;
        let mut head = Head::default();
        let mut pieces: Vec<Piece> = Vec::new();
        let mut arrays: Vec<Array> = Vec::new();
        let mut stack: Vec<&str> = Vec::new();
        let mut seen_file = false;
        let mut pos = 0;
        while let Some(lt) = find(b, pos, b"<") {
            if stack.last() == Some(&"DataArray")
                && let Some(a) = arrays.last_mut()
            {
                a.text.push((pos, lt));
            }
            let rest = &b[lt..];
            let skip = |end: &[u8], len: usize| {
                find(b, lt, end)
                    .map(|e| e + len)
                    .ok_or_else(|| self.error(lt, "a comment or declaration that does not end"))
            };
            if rest.starts_with(b"<?") {
                pos = skip(b"?>", 2)?;
                continue;
            }
            if rest.starts_with(b"<!--") {
                pos = skip(b"-->", 3)?;
                continue;
            }
            if rest.starts_with(b"<!") {
                pos = skip(b">", 1)?;
                continue;
            }
            if rest.starts_with(b"</") {
                let end = skip(b">", 1)?;
                let name = b[lt + 2..end - 1].trim_ascii();
                match stack.pop() {
                    Some(open) if open.as_bytes() == name => {}
                    open => {
                        return Err(self.error(
                            lt,
                            format!(
                                "</{}> closes <{}>",
                                String::from_utf8_lossy(name),
                                open.unwrap_or("nothing")
                            ),
                        ));
                    }
                }
                pos = end;
                continue;
            }
            let tag = self.tag(lt)?;
            pos = tag.end;
            match tag.name {
                "VTKFile" => {
                    seen_file = true;
                    self.file_tag(&tag, lt, &mut head)?;
                }
                _ if !seen_file => {
                    return Err(self.error(lt, "not a VTK XML file: no <VTKFile> tag"));
                }
                "Piece" => {
                    let count = |k: &str| -> Result<usize> {
                        let v = tag.attr(k).unwrap_or("0");
                        v.trim()
                            .parse()
                            .map_err(|_| self.error(lt, format!("<Piece {k}={v:?}>: not a count")))
                    };
                    pieces.push(Piece {
                        points: count("NumberOfPoints")?,
                        cells: count("NumberOfCells")?,
                    });
                }
                "DataArray" | "Array" => arrays.push(self.array(&tag, lt, &stack, &pieces)?),
                "AppendedData" => {
                    let raw = match tag.attr("encoding").unwrap_or("raw") {
                        "raw" => true,
                        "base64" => false,
                        e => {
                            return Err(
                                self.error(lt, format!("unknown AppendedData encoding {e:?}"))
                            );
                        }
                    };
                    let start = find(b, pos, b"_")
                        .ok_or_else(|| self.error(lt, "the appended data has no '_' mark"))?;
                    head.appended = Some((start + 1, raw));
                    break;
                }
                _ => {}
            }
            if !tag.empty {
                stack.push(tag.name);
            }
        }
        if !seen_file {
            return Err(self.error(0, "not a VTK XML file: no <VTKFile> tag"));
        }
        if head.appended.is_none()
            && let Some(open) = stack.last()
        {
            return Err(self.error(
                b.len(),
                format!("the file ends inside <{open}>: it was cut off"),
            ));
        }
        if pieces.is_empty() {
            return Err(self.error(b.len(), "the file has no <Piece>"));
        }
        Ok((head, pieces, arrays))
    }

    fn file_tag(&self, tag: &Tag, at: usize, head: &mut Head) -> Result<()> {
        match tag.attr("type") {
            Some("UnstructuredGrid") => {}
            Some("PolyData") => {
                return Err(self.error(
                    at,
                    "csrbf reads unstructured grids from .vtu; this file holds PolyData: \
                     read it as a surface mesh (convert it to .ply or .obj)",
                ));
            }
            t => {
                return Err(self.error(
                    at,
                    format!(
                        "csrbf reads unstructured grids from .vtu; this file holds {}",
                        t.unwrap_or("no type")
                    ),
                ));
            }
        }
        head.big = match tag.attr("byte_order").unwrap_or("LittleEndian") {
            "LittleEndian" => false,
            "BigEndian" => true,
            o => return Err(self.error(at, format!("unknown byte_order {o:?}"))),
        };
        head.header64 = match tag.attr("header_type").unwrap_or("UInt32") {
            "UInt32" => false,
            "UInt64" => true,
            h => return Err(self.error(at, format!("unknown header_type {h:?}"))),
        };
        head.zlib = match tag.attr("compressor").unwrap_or("") {
            "" => false,
            "vtkZLibDataCompressor" => true,
            c => {
                return Err(self.error(
                    at,
                    format!("compressor {c:?}: csrbf reads uncompressed and zlib data only"),
                ));
            }
        };
        Ok(())
    }

    fn array(&self, tag: &Tag, at: usize, stack: &[&str], pieces: &[Piece]) -> Result<Array> {
        let section = match stack.last().copied() {
            Some("Points") => Section::Points,
            Some("Cells") => Section::Cells,
            Some("CellData") => Section::CellData,
            Some("FieldData") => Section::FieldData,
            _ => Section::Other,
        };
        let ty_name = tag.attr("type").unwrap_or("").to_string();
        let comps = tag.attr("NumberOfComponents").unwrap_or("1");
        let comps: usize = comps
            .trim()
            .parse()
            .ok()
            .filter(|&c| c > 0)
            .ok_or_else(|| self.error(at, format!("NumberOfComponents={comps:?}: not a count")))?;
        let layout = match tag.attr("format").unwrap_or("ascii") {
            "ascii" => Layout::Ascii,
            "binary" => Layout::Binary,
            "appended" => Layout::Appended,
            f => return Err(self.error(at, format!("unknown DataArray format {f:?}"))),
        };
        let offset = tag.attr("offset").unwrap_or("0");
        let offset = offset
            .trim()
            .parse()
            .map_err(|_| self.error(at, format!("offset={offset:?}: not a byte offset")))?;
        Ok(Array {
            section,
            piece: pieces.len().saturating_sub(1),
            name: tag.attr("Name").unwrap_or("").to_string(),
            ty: Scalar::from_vtu(&ty_name),
            ty_name,
            comps,
            layout,
            offset,
            text: Vec::new(),
            at,
        })
    }
}

/// Decodes the arrays' values.
struct Decoder<'a> {
    s: Scanner<'a>,
    head: Head,
    /// Every appended array's offset, ascending (where a base64 one ends).
    offsets: Vec<usize>,
}

impl Decoder<'_> {
    fn error(&self, a: &Array, message: impl std::fmt::Display) -> MeshError {
        self.s
            .error(a.at, format!("DataArray {:?}: {message}", a.name))
    }

    /// Header number `i` of a binary array (UInt32 or UInt64).
    fn uint(&self, b: &[u8], i: usize) -> Option<u64> {
        let size = if self.head.header64 { 8 } else { 4 };
        let s = b.get(i * size..(i + 1) * size)?;
        let mut a = [0u8; 8];
        if self.head.big {
            a[8 - size..].copy_from_slice(s);
            Some(u64::from_be_bytes(a))
        } else {
            a[..size].copy_from_slice(s);
            Some(u64::from_le_bytes(a))
        }
    }

    /// A binary array's data without its header, decompressed.
    fn unpack(&self, b: &[u8]) -> Result<Vec<u8>, String> {
        let hs = if self.head.header64 { 8 } else { 4 };
        let short = |what: &str| format!("the data ends inside its {what}");
        let first = self.uint(b, 0).ok_or_else(|| short("header"))?;
        if !self.head.zlib {
            let n = usize::try_from(first)
                .ok()
                .filter(|&n| n <= b.len() - hs)
                .ok_or_else(|| {
                    format!(
                        "its header says {first} bytes, but {} are left",
                        b.len() - hs
                    )
                })?;
            return Ok(b[hs..hs + n].to_vec());
        }
        let blocks = usize::try_from(first)
            .ok()
            .filter(|&n| n.saturating_add(3).saturating_mul(hs) <= b.len())
            .ok_or_else(|| {
                format!("its header says {first} compressed blocks, more than it holds")
            })?;
        let size = self.uint(b, 1).ok_or_else(|| short("header"))?;
        let last = self.uint(b, 2).ok_or_else(|| short("header"))?;
        let mut at = (3 + blocks) * hs;
        let mut out = Vec::new();
        for k in 0..blocks {
            let n = self.uint(b, 3 + k).ok_or_else(|| short("header"))?;
            let block = usize::try_from(n)
                .ok()
                .and_then(|n| b.get(at..at.checked_add(n)?))
                .ok_or_else(|| format!("compressed block {k} of {n} bytes runs past the end"))?;
            at += block.len();
            let want = if k + 1 == blocks && last != 0 {
                last
            } else {
                size
            };
            let want = usize::try_from(want).map_err(|_| format!("block size {want}"))?;
            let data = miniz_oxide::inflate::decompress_to_vec_zlib_with_limit(block, want)
                .map_err(|e| format!("compressed block {k} does not inflate ({:?})", e.status))?;
            if data.len() != want {
                return Err(format!(
                    "compressed block {k} inflates to {} bytes, not {want}",
                    data.len()
                ));
            }
            out.extend_from_slice(&data);
        }
        Ok(out)
    }

    /// A binary or appended array's bytes.
    fn bytes(&self, a: &Array) -> Result<Vec<u8>> {
        let b = self.s.bytes;
        let decoded;
        let data: &[u8] = match a.layout {
            Layout::Binary => {
                let mut text = Vec::new();
                for &(s, e) in &a.text {
                    text.extend_from_slice(&b[s..e]);
                }
                decoded = crate::base64::decode(&text)
                    .map_err(|i| self.error(a, format!("bad base64 at character {i}")))?;
                &decoded
            }
            Layout::Appended => {
                let (start, raw) = self
                    .head
                    .appended
                    .ok_or_else(|| self.error(a, "format=\"appended\" but no <AppendedData>"))?;
                let from = start
                    .checked_add(a.offset)
                    .filter(|&f| f <= b.len())
                    .ok_or_else(|| {
                        self.error(
                            a,
                            format!("offset {} is past the end of the file", a.offset),
                        )
                    })?;
                if raw {
                    &b[from..]
                } else {
                    let next = self.offsets.iter().find(|&&o| o > a.offset);
                    let mut end = next.map_or(b.len(), |&o| (start + o).min(b.len()));
                    if let Some(stop) = b[from..end].iter().position(|&c| {
                        c != b'=' && c != b'+' && c != b'/' && !c.is_ascii_alphanumeric()
                    }) {
                        end = from + stop;
                    }
                    decoded = crate::base64::decode(&b[from..end])
                        .map_err(|i| self.error(a, format!("bad base64 at character {i}")))?;
                    &decoded
                }
            }
            Layout::Ascii => return Err(self.error(a, "not binary")),
        };
        self.unpack(data).map_err(|m| self.error(a, m))
    }

    fn check_type(&self, a: &Array) -> Result<Scalar> {
        a.ty.ok_or_else(|| self.error(a, format!("type {:?} is not one csrbf reads", a.ty_name)))
    }

    fn words<'b>(&'b self, a: &'b Array) -> impl Iterator<Item = &'b [u8]> + 'b {
        a.text.iter().flat_map(move |&(s, e)| {
            self.s.bytes[s..e]
                .split(|c| c.is_ascii_whitespace())
                .filter(|w| !w.is_empty())
        })
    }

    fn floats(&self, a: &Array) -> Result<Vec<f64>> {
        let ty = self.check_type(a)?;
        if a.layout == Layout::Ascii {
            return self
                .words(a)
                .map(|w| {
                    std::str::from_utf8(w)
                        .ok()
                        .and_then(|s| s.parse().ok())
                        .ok_or_else(|| {
                            self.error(
                                a,
                                format!("{:?} is not a number", String::from_utf8_lossy(w)),
                            )
                        })
                })
                .collect();
        }
        let b = self.bytes(a)?;
        if b.len() % ty.size() != 0 {
            return Err(self.error(a, format!("{} bytes of {}", b.len(), a.ty_name)));
        }
        Ok(b.chunks_exact(ty.size())
            .map(|c| ty.f64(c, self.head.big))
            .collect())
    }

    fn ints(&self, a: &Array) -> Result<Vec<i64>> {
        let ty = self.check_type(a)?;
        if ty.is_float() {
            return Err(self.error(a, format!("must hold integers, not {}", a.ty_name)));
        }
        if a.layout == Layout::Ascii {
            return self
                .words(a)
                .map(|w| {
                    std::str::from_utf8(w)
                        .ok()
                        .and_then(|s| s.parse().ok())
                        .ok_or_else(|| {
                            self.error(
                                a,
                                format!("{:?} is not an integer", String::from_utf8_lossy(w)),
                            )
                        })
                })
                .collect();
        }
        let b = self.bytes(a)?;
        if b.len() % ty.size() != 0 {
            return Err(self.error(a, format!("{} bytes of {}", b.len(), a.ty_name)));
        }
        b.chunks_exact(ty.size())
            .map(|c| {
                ty.i64(c, self.head.big)
                    .ok_or_else(|| self.error(a, "a value beyond 64-bit integers"))
            })
            .collect()
    }
}

pub(super) fn read(bytes: &[u8], path: &Path) -> Result<VolumeMesh> {
    let s = Scanner { bytes, path };
    let (head, pieces, arrays) = s.scan()?;
    let mut offsets: Vec<usize> = arrays
        .iter()
        .filter(|a| a.layout == Layout::Appended)
        .map(|a| a.offset)
        .collect();
    offsets.sort_unstable();
    let d = Decoder { s, head, offsets };
    let mut mesh = VolumeMesh::default();
    let mut named = Vec::new();
    for a in arrays.iter().filter(|a| a.section == Section::FieldData) {
        if a.ty.is_some_and(|t| !t.is_float())
            && let Ok(v) = d.ints(a)
            && let [tag, dim] = v[..]
            && let (Ok(tag), Ok(dim)) = (i32::try_from(tag), u8::try_from(dim))
            && tag != 0
            && dim <= 3
        {
            named.push(Zone {
                name: a.name.clone(),
                tag,
                dim,
            });
        }
    }
    let mut zoned = false;
    let mut zones: Vec<i32> = Vec::new();
    for (k, piece) in pieces.iter().enumerate() {
        let mine = |sec: Section, name: Option<&str>| {
            arrays
                .iter()
                .find(|a| a.piece == k && a.section == sec && name.is_none_or(|n| a.name == n))
        };
        let at = |what: &str| {
            d.s.error(bytes.len(), format!("piece {k} has no {what} array"))
        };
        let pts = mine(Section::Points, None).ok_or_else(|| at("Points"))?;
        let v = d.floats(pts)?;
        if pts.comps != 3 || v.len() != piece.points.saturating_mul(3) {
            return Err(d.error(
                pts,
                format!(
                    "{} values in {} components for {} points",
                    v.len(),
                    pts.comps,
                    piece.points
                ),
            ));
        }
        let base = mesh.points.len();
        mesh.points.extend(
            v.chunks_exact(3)
                .map(|p| glam::DVec3::new(p[0], p[1], p[2])),
        );
        let conn_a =
            mine(Section::Cells, Some("connectivity")).ok_or_else(|| at("connectivity"))?;
        let off_a = mine(Section::Cells, Some("offsets")).ok_or_else(|| at("offsets"))?;
        let types_a = mine(Section::Cells, Some("types")).ok_or_else(|| at("types"))?;
        let conn = d.ints(conn_a)?;
        let mut offsets = d.ints(off_a)?;
        let types = d.ints(types_a)?;
        if offsets.len() != piece.cells || types.len() != piece.cells {
            return Err(d.error(
                off_a,
                format!(
                    "{} offsets and {} types for {} cells",
                    offsets.len(),
                    types.len(),
                    piece.cells
                ),
            ));
        }
        if offsets.last().copied().unwrap_or(0) != conn.len() as i64 {
            return Err(d.error(
                off_a,
                format!(
                    "the last offset is not the connectivity's size, {}",
                    conn.len()
                ),
            ));
        }
        offsets.insert(0, 0);
        let conn: Vec<i64> = conn
            .iter()
            .map(|&v| v.saturating_add(base as i64))
            .collect();
        let cells = super::vtk::build_cells(&offsets, &conn, &types, mesh.points.len())
            .map_err(|m| d.error(conn_a, format!("piece {k}: {m}")))?;
        for (kind, nodes) in cells.iter() {
            mesh.cells.push(kind, nodes);
        }
        let zone_a = ZONE_ARRAYS.iter().find_map(|&z| {
            arrays.iter().find(|a| {
                a.piece == k
                    && a.section == Section::CellData
                    && a.name == z
                    && a.comps == 1
                    && a.ty.is_some_and(|t| !t.is_float())
            })
        });
        match zone_a {
            Some(a) => {
                let v = d.ints(a)?;
                if v.len() != cells.len() {
                    return Err(d.error(
                        a,
                        format!("{} zone tags for {} cells", v.len(), cells.len()),
                    ));
                }
                zones.resize(mesh.cells.len() - cells.len(), 0);
                for t in v {
                    zones.push(
                        i32::try_from(t).map_err(|_| d.error(a, "a zone tag beyond 32 bits"))?,
                    );
                }
                zoned = true;
            }
            None => zones.resize(mesh.cells.len(), 0),
        }
    }
    if zoned {
        zones.resize(mesh.cells.len(), 0);
        mesh.zones = scan::zones(named, &zones, &mesh.cells.kinds);
        mesh.cell_zones = zones;
    }
    Ok(mesh)
}

/// How the arrays are written.
#[derive(Clone, Copy, Debug)]
pub(super) enum Encoding {
    /// Numbers as text.
    Ascii,
    /// Base64 inside each `DataArray`.
    #[cfg_attr(not(test), allow(dead_code))]
    Inline { zlib: bool },
    /// Raw bytes in `<AppendedData>`.
    Appended { zlib: bool },
}

/// An array to write: its name, type, components, and little-endian bytes
/// or text.
struct Data {
    name: &'static str,
    ty: &'static str,
    comps: usize,
    bytes: Vec<u8>,
    text: String,
}

/// The header and data of one array in a binary file (UInt64 headers).
fn block(data: &[u8], zlib: bool) -> (Vec<u8>, Vec<u8>) {
    let mut head = Vec::new();
    if !zlib {
        head.extend_from_slice(&(data.len() as u64).to_le_bytes());
        return (head, data.to_vec());
    }
    let chunks: Vec<Vec<u8>> = data
        .chunks(BLOCK)
        .map(|c| miniz_oxide::deflate::compress_to_vec_zlib(c, 6))
        .collect();
    for v in [chunks.len(), BLOCK, data.len() % BLOCK] {
        head.extend_from_slice(&(v as u64).to_le_bytes());
    }
    for c in &chunks {
        head.extend_from_slice(&(c.len() as u64).to_le_bytes());
    }
    (head, chunks.concat())
}

pub(super) fn write(mesh: &VolumeMesh, enc: Encoding) -> Vec<u8> {
    let ascii = matches!(enc, Encoding::Ascii);
    let c = &mesh.cells;
    let mut arrays = Vec::new();
    let mut add = |name, ty, comps, vals: &mut dyn Iterator<Item = (Vec<u8>, String)>| {
        let mut d = Data {
            name,
            ty,
            comps,
            bytes: Vec::new(),
            text: String::new(),
        };
        for (k, (b, t)) in vals.enumerate() {
            if ascii {
                d.text.push(if k % 9 == 0 { '\n' } else { ' ' });
                d.text.push_str(&t);
            } else {
                d.bytes.extend_from_slice(&b);
            }
        }
        arrays.push(d);
    };
    let f = |v: f64| {
        let mut s = String::new();
        scan::push_f64(&mut s, v);
        (
            v.to_le_bytes().to_vec(),
            if ascii { s } else { String::new() },
        )
    };
    let i = |v: i64| {
        (
            v.to_le_bytes().to_vec(),
            if ascii { v.to_string() } else { String::new() },
        )
    };
    add(
        "Points",
        "Float64",
        3,
        &mut mesh.points.iter().flat_map(|p| p.to_array()).map(f),
    );
    add(
        "connectivity",
        "Int64",
        1,
        &mut c.nodes.iter().map(|&v| i(v as i64)),
    );
    add(
        "offsets",
        "Int64",
        1,
        &mut c.offsets[1..].iter().map(|&v| i(v as i64)),
    );
    add(
        "types",
        "UInt8",
        1,
        &mut c
            .kinds
            .iter()
            .map(|k| (vec![k.vtk_type()], k.vtk_type().to_string())),
    );
    let zoned = !mesh.zones.is_empty() || !mesh.cell_zones.is_empty();
    if zoned {
        let tags = (0..c.len()).map(|k| mesh.cell_zones.get(k).copied().unwrap_or(0));
        add(
            ZONE_ARRAY,
            "Int32",
            1,
            &mut tags.map(|t| (t.to_le_bytes().to_vec(), t.to_string())),
        );
    }
    let mut out = String::new();
    let mut appended: Vec<u8> = Vec::new();
    out.push_str("<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\"");
    if matches!(
        enc,
        Encoding::Inline { zlib: true } | Encoding::Appended { zlib: true }
    ) {
        out.push_str(" compressor=\"vtkZLibDataCompressor\"");
    }
    out.push_str(">\n  <UnstructuredGrid>\n");
    if !mesh.zones.is_empty() {
        out.push_str("    <FieldData>\n");
        for z in &mesh.zones {
            out.push_str(&format!(
                "      <DataArray type=\"Int32\" Name=\"{}\" NumberOfTuples=\"2\" format=\"ascii\">{} {}</DataArray>\n",
                escape(&z.name),
                z.tag,
                z.dim
            ));
        }
        out.push_str("    </FieldData>\n");
    }
    out.push_str(&format!(
        "    <Piece NumberOfPoints=\"{}\" NumberOfCells=\"{}\">\n",
        mesh.points.len(),
        c.len()
    ));
    for (k, a) in arrays.iter().enumerate() {
        let open = match k {
            0 => "      <Points>\n",
            1 => "      <Cells>\n",
            4 => "      <CellData>\n",
            _ => "",
        };
        out.push_str(open);
        out.push_str(&format!(
            "        <DataArray type=\"{}\" Name=\"{}\" NumberOfComponents=\"{}\" format=\"{}\"",
            a.ty,
            a.name,
            a.comps,
            match enc {
                Encoding::Ascii => "ascii",
                Encoding::Inline { .. } => "binary",
                Encoding::Appended { .. } => "appended",
            }
        ));
        match enc {
            Encoding::Ascii => {
                out.push('>');
                out.push_str(&a.text);
                out.push_str("\n        </DataArray>\n");
            }
            Encoding::Inline { zlib } => {
                let (head, data) = block(&a.bytes, zlib);
                let mut text = Vec::new();
                if zlib {
                    crate::base64::encode_into(&head, &mut text);
                    crate::base64::encode_into(&data, &mut text);
                } else {
                    crate::base64::encode_into(&[head, data].concat(), &mut text);
                }
                out.push_str(">\n          ");
                out.push_str(&String::from_utf8_lossy(&text));
                out.push_str("\n        </DataArray>\n");
            }
            Encoding::Appended { zlib } => {
                out.push_str(&format!(" offset=\"{}\"/>\n", appended.len()));
                let (head, data) = block(&a.bytes, zlib);
                appended.extend_from_slice(&head);
                appended.extend_from_slice(&data);
            }
        }
        let close = match k {
            0 => "      </Points>\n",
            3 => "      </Cells>\n",
            4 => "      </CellData>\n",
            _ => "",
        };
        out.push_str(close);
    }
    out.push_str("    </Piece>\n  </UnstructuredGrid>\n");
    let mut bytes = out.into_bytes();
    if let Encoding::Appended { .. } = enc {
        bytes.extend_from_slice(b"  <AppendedData encoding=\"raw\">\n   _");
        bytes.extend_from_slice(&appended);
        bytes.extend_from_slice(b"\n  </AppendedData>\n");
    }
    bytes.extend_from_slice(b"</VTKFile>\n");
    bytes
}
