//! What the volume readers and writers share: a cursor over a file's bytes
//! that reads words, numbers and raw binary runs and names the line of an
//! error; scalar types and their byte decoding; base64; zone naming.

use std::fmt::Write as _;
use std::path::Path;
use std::str::FromStr;

use super::{CellKind, Zone};
use crate::{MeshError, Result};

/// A position in a file's bytes: words (white space separated), numbers,
/// and raw runs of bytes for the binary parts.
pub(super) struct Cursor<'a> {
    pub bytes: &'a [u8],
    pub pos: usize,
    pub path: &'a Path,
}

impl<'a> Cursor<'a> {
    pub fn new(bytes: &'a [u8], path: &'a Path) -> Cursor<'a> {
        Cursor {
            bytes,
            pos: 0,
            path,
        }
    }

    /// The 1-based line of `pos`.
    pub fn line_at(&self, pos: usize) -> usize {
        1 + self.bytes[..pos.min(self.bytes.len())]
            .iter()
            .filter(|&&b| b == b'\n')
            .count()
    }

    /// A parse error at the current line.
    pub fn error(&self, message: impl Into<String>) -> MeshError {
        MeshError::parse(self.path, Some(self.line_at(self.pos)), message)
    }

    /// A parse error at a byte offset (binary parts have no lines).
    pub fn error_at_byte(&self, pos: usize, message: impl std::fmt::Display) -> MeshError {
        MeshError::parse(self.path, None, format!("at byte {pos}: {message}"))
    }

    /// Bytes not read yet.
    pub fn left(&self) -> usize {
        self.bytes.len().saturating_sub(self.pos)
    }

    fn skip_space(&mut self) {
        while self.pos < self.bytes.len() && self.bytes[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
    }

    /// The next word, or `None` at the end of the file.
    pub fn word(&mut self) -> Option<&'a [u8]> {
        self.skip_space();
        let start = self.pos;
        while self.pos < self.bytes.len() && !self.bytes[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        (self.pos > start).then(|| &self.bytes[start..self.pos])
    }

    /// The next word without moving past it.
    pub fn peek_word(&mut self) -> Option<&'a [u8]> {
        let pos = self.pos;
        let w = self.word();
        self.pos = pos;
        w
    }

    /// The next word as text; its absence or non-text an error naming
    /// `what` was expected.
    pub fn text(&mut self, what: &str) -> Result<&'a str> {
        let w = self
            .word()
            .ok_or_else(|| self.error(format!("the file ends where {what} should be")))?;
        std::str::from_utf8(w).map_err(|_| self.error(format!("{what} is not text")))
    }

    /// The next word as a number.
    pub fn number<T: FromStr>(&mut self, what: &str) -> Result<T> {
        let w = self.text(what)?;
        w.parse()
            .map_err(|_| self.error(format!("{what}: {w:?} is not a valid number here")))
    }

    /// A count of things that each take at least `bytes_each` bytes of what
    /// is left (binary), or one word (text, two bytes with its separator):
    /// a count the file cannot hold is refused before anything is
    /// allocated for it.
    pub fn count(&mut self, what: &str, bytes_each: usize) -> Result<usize> {
        let n: u64 = self.number(what)?;
        self.fits(n, bytes_each, what)
    }

    /// Checks that `n` things of `bytes_each` bytes can be in the rest of
    /// the file.
    pub fn fits(&self, n: u64, bytes_each: usize, what: &str) -> Result<usize> {
        let need = (n as u128) * (bytes_each.max(1) as u128);
        if need > self.left() as u128 + 1 {
            return Err(self.error(format!(
                "{what} {n} is more than the file holds ({} bytes left)",
                self.left()
            )));
        }
        Ok(n as usize)
    }

    /// Moves past the end of the current line (to where binary data
    /// starts).
    pub fn end_line(&mut self) {
        match self.bytes[self.pos.min(self.bytes.len())..]
            .iter()
            .position(|&b| b == b'\n')
        {
            Some(i) => self.pos += i + 1,
            None => self.pos = self.bytes.len(),
        }
    }

    /// The rest of the current line, trimmed, and moves past it.
    pub fn rest_of_line(&mut self) -> &'a [u8] {
        let start = self.pos.min(self.bytes.len());
        self.end_line();
        self.bytes[start..self.pos].trim_ascii()
    }

    /// The next `n` bytes.
    pub fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8]> {
        if n > self.left() {
            return Err(self.error_at_byte(
                self.pos,
                format!(
                    "the file ends inside {what}: {n} bytes needed, {} left",
                    self.left()
                ),
            ));
        }
        let s = &self.bytes[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    /// `n` binary values of `ty` (`big`-endian or little), each as a
    /// number.
    pub fn binary(&mut self, n: usize, ty: Scalar, big: bool, what: &str) -> Result<Binary<'a>> {
        let len = n
            .checked_mul(ty.size())
            .filter(|&l| l <= self.left())
            .ok_or_else(|| {
                self.error_at_byte(
                    self.pos,
                    format!(
                        "the file ends inside {what}: {n} values of {} bytes, {} bytes left",
                        ty.size(),
                        self.left()
                    ),
                )
            })?;
        let start = self.pos;
        Ok(Binary {
            bytes: self.take(len, what)?,
            ty,
            big,
            start,
        })
    }
}

/// The scalar types of the binary formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    I64,
    U64,
    F32,
    F64,
}

impl Scalar {
    pub fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::I64 | Scalar::U64 | Scalar::F64 => 8,
        }
    }

    pub fn is_float(self) -> bool {
        matches!(self, Scalar::F32 | Scalar::F64)
    }

    /// VTK XML's name of the type.
    pub fn from_vtu(name: &str) -> Option<Scalar> {
        Some(match name {
            "Int8" | "Char" => Scalar::I8,
            "UInt8" | "UChar" => Scalar::U8,
            "Int16" => Scalar::I16,
            "UInt16" => Scalar::U16,
            "Int32" => Scalar::I32,
            "UInt32" => Scalar::U32,
            "Int64" => Scalar::I64,
            "UInt64" => Scalar::U64,
            "Float32" => Scalar::F32,
            "Float64" => Scalar::F64,
            _ => return None,
        })
    }

    /// One value from its bytes (`b.len() == self.size()`), as f64.
    pub fn f64(self, b: &[u8], big: bool) -> f64 {
        macro_rules! get {
            ($t:ty) => {{
                let mut a = [0u8; std::mem::size_of::<$t>()];
                a.copy_from_slice(b);
                if big {
                    <$t>::from_be_bytes(a)
                } else {
                    <$t>::from_le_bytes(a)
                }
            }};
        }
        match self {
            Scalar::I8 => get!(i8) as f64,
            Scalar::U8 => get!(u8) as f64,
            Scalar::I16 => get!(i16) as f64,
            Scalar::U16 => get!(u16) as f64,
            Scalar::I32 => get!(i32) as f64,
            Scalar::U32 => get!(u32) as f64,
            Scalar::I64 => get!(i64) as f64,
            Scalar::U64 => get!(u64) as f64,
            Scalar::F32 => get!(f32) as f64,
            Scalar::F64 => get!(f64),
        }
    }

    /// One integer value from its bytes; `None` for a float type or a
    /// UInt64 beyond i64.
    pub fn i64(self, b: &[u8], big: bool) -> Option<i64> {
        let mut a = [0u8; 8];
        let n = self.size();
        if big {
            a[8 - n..].copy_from_slice(b);
            a.reverse();
        } else {
            a[..n].copy_from_slice(b);
        }
        let u = u64::from_le_bytes(a);
        let shift = 64 - 8 * n as u32;
        Some(match self {
            Scalar::I8 | Scalar::I16 | Scalar::I32 | Scalar::I64 => ((u << shift) as i64) >> shift,
            Scalar::U8 | Scalar::U16 | Scalar::U32 => u as i64,
            Scalar::U64 => i64::try_from(u).ok()?,
            Scalar::F32 | Scalar::F64 => return None,
        })
    }
}

/// A run of binary values in a file.
pub(super) struct Binary<'a> {
    pub bytes: &'a [u8],
    pub ty: Scalar,
    pub big: bool,
    /// Its byte offset in the file.
    pub start: usize,
}

impl Binary<'_> {
    pub fn f64s(&self) -> impl Iterator<Item = f64> + '_ {
        self.bytes
            .chunks_exact(self.ty.size())
            .map(|b| self.ty.f64(b, self.big))
    }

    /// The integers; a float type or a UInt64 beyond i64 is an error naming
    /// the value's byte offset.
    pub fn i64s(&self, path: &Path, what: &str) -> Result<Vec<i64>> {
        let size = self.ty.size();
        self.bytes
            .chunks_exact(size)
            .enumerate()
            .map(|(i, b)| {
                self.ty.i64(b, self.big).ok_or_else(|| {
                    MeshError::parse(
                        path,
                        None,
                        format!(
                            "at byte {}: {what} must be integers that fit 64 bits",
                            self.start + i * size
                        ),
                    )
                })
            })
            .collect()
    }
}

/// Converts a node index or count read from a file to u32, naming what it
/// was when it does not fit.
pub(super) fn index(v: i64, n: usize, what: impl FnOnce() -> String) -> Result<u32, String> {
    if v < 0 || v as u64 >= n as u64 {
        return Err(format!("{} is {v}, but there are {n} nodes", what()));
    }
    Ok(v as u32)
}

/// A number as text that reads back to the same f64 (Rust's shortest
/// round-trip form).
pub(super) fn push_f64(out: &mut String, v: f64) {
    let _ = write!(out, "{v:?}");
}

/// The zones of a file: those it names (`named`: name, tag, dim; the first
/// of a tag wins) in its order, then each tag the cells use without a name
/// as `zone <tag>`, with the dimension of its first cell.
pub(super) fn zones(named: Vec<Zone>, cell_zones: &[i32], kinds: &[CellKind]) -> Vec<Zone> {
    let mut zones: Vec<Zone> = Vec::new();
    for z in named {
        if z.tag != 0 && !zones.iter().any(|y| y.tag == z.tag) {
            zones.push(z);
        }
    }
    let mut known: std::collections::HashSet<i32> = zones.iter().map(|z| z.tag).collect();
    for (c, &t) in cell_zones.iter().enumerate() {
        if t != 0 && known.insert(t) {
            zones.push(Zone {
                name: format!("zone {t}"),
                tag: t,
                dim: kinds.get(c).map_or(3, |k| k.dim()),
            });
        }
    }
    zones
}

/// The zone a field data array names (`name` = [tag, dim], as meshio keeps
/// Gmsh's physical groups), if its values are a tag and a dimension.
pub(super) fn named_zone(name: &str, v: &[i64]) -> Option<Zone> {
    if let [tag, dim] = *v
        && let (Ok(tag), Ok(dim)) = (i32::try_from(tag), u8::try_from(dim))
        && tag != 0
        && dim <= 3
    {
        return Some(Zone {
            name: name.to_string(),
            tag,
            dim,
        });
    }
    None
}

/// The names csrbf reads a cell zone array by, most wanted first.
pub(super) const ZONE_ARRAYS: [&str; 4] = ["gmsh:physical", "zone", "cell_zone", "CellEntityIds"];

/// The array name csrbf writes zones as (meshio reads it as Gmsh's
/// physical tags).
pub(super) const ZONE_ARRAY: &str = "gmsh:physical";

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scalars_decode_both_byte_orders() {
        assert_eq!(Scalar::I16.i64(&[0xff, 0xfe], true), Some(-2));
        assert_eq!(Scalar::I16.i64(&[0xfe, 0xff], false), Some(-2));
        assert_eq!(Scalar::U32.i64(&[0, 0, 1, 0], true), Some(256));
        assert_eq!(Scalar::U64.i64(&[0xff; 8], false), None);
        assert_eq!(Scalar::F64.f64(&1.5f64.to_be_bytes(), true), 1.5);
    }

    #[test]
    fn a_huge_count_is_refused_before_allocating() {
        let mut c = Cursor::new(b"1152921504606846976 1 2", Path::new("x.vtk"));
        let e = c.count("the number of points", 24).unwrap_err().to_string();
        assert!(e.starts_with("x.vtk:1: the number of points"), "{e}");
    }
}
