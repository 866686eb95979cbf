//! The tag scanner: the file's head, its pieces and where each data
//! array's text or bytes are.

use std::path::Path;

use crate::volume::scan::Scalar;
use crate::{MeshError, Result};

/// Where a `DataArray` sits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Section {
    Points,
    Cells,
    CellData,
    FieldData,
    Other,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Layout {
    Ascii,
    Binary,
    Appended,
}

pub(super) struct Array {
    pub(super) section: Section,
    pub(super) piece: usize,
    pub(super) name: String,
    pub(super) ty: Option<Scalar>,
    pub(super) ty_name: String,
    pub(super) comps: usize,
    pub(super) layout: Layout,
    pub(super) offset: usize,
    /// The byte ranges of its text (ASCII values or base64).
    pub(super) text: Vec<(usize, usize)>,
    /// The byte offset of its tag.
    pub(super) at: usize,
}

pub(super) struct Piece {
    pub(super) points: usize,
    pub(super) cells: usize,
}

/// What the `VTKFile` tag and `AppendedData` say.
#[derive(Default)]
pub(super) struct Head {
    pub(super) big: bool,
    pub(super) header64: bool,
    pub(super) zlib: bool,
    /// Where the appended data starts (after `_`), and whether it is raw.
    pub(super) appended: Option<(usize, bool)>,
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

pub(super) struct Scanner<'a> {
    pub(super) bytes: &'a [u8],
    pub(super) path: &'a Path,
}

impl<'a> Scanner<'a> {
    pub(super) fn error(&self, at: usize, message: impl Into<String>) -> MeshError {
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
    pub(super) fn scan(&self) -> Result<(Head, Vec<Piece>, Vec<Array>)> {
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
