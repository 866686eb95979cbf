//! Reading: the arrays' values decoded, the pieces joined into one mesh.

use std::path::Path;

use super::tags::{Array, Head, Layout, Scanner, Section};
use crate::volume::VolumeMesh;
use crate::volume::scan::{self, Scalar, ZONE_ARRAYS};
use crate::{MeshError, Result};

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

    /// An ASCII array's words parsed, naming the first that is not `what`.
    fn ascii<T: std::str::FromStr>(&self, a: &Array, what: &str) -> Result<Vec<T>> {
        self.words(a)
            .map(|w| {
                std::str::from_utf8(w)
                    .ok()
                    .and_then(|s| s.parse().ok())
                    .ok_or_else(|| {
                        self.error(a, format!("{:?} is not {what}", String::from_utf8_lossy(w)))
                    })
            })
            .collect()
    }

    fn floats(&self, a: &Array) -> Result<Vec<f64>> {
        let ty = self.check_type(a)?;
        if a.layout == Layout::Ascii {
            return self.ascii(a, "a number");
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
            return self.ascii(a, "an integer");
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

pub(in crate::volume) fn read(bytes: &[u8], path: &Path) -> Result<VolumeMesh> {
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
            && let Some(z) = scan::named_zone(&a.name, &v)
        {
            named.push(z);
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
        let cells = crate::volume::vtk::build_cells(&offsets, &conn, &types, mesh.points.len())
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
