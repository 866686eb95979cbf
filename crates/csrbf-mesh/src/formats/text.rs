//! Helpers for line-based text formats.

use std::path::Path;

use crate::{MeshError, Result};

/// The lines of a text file with their 1-based numbers; `#` comments and
/// surrounding white space removed, blank lines skipped. Lines end in LF or
/// CR LF, or in CR alone in a file that has no LF (old Mac files).
pub(crate) fn lines<'a>(
    bytes: &'a [u8],
    path: &'a Path,
) -> impl Iterator<Item = Result<(usize, &'a str)>> + 'a {
    let end = if bytes.contains(&b'\n') { b'\n' } else { b'\r' };
    bytes
        .split(move |&b| b == end)
        .enumerate()
        .filter_map(move |(i, raw)| {
            let line = match std::str::from_utf8(raw) {
                Ok(s) => s,
                Err(_) => {
                    return Some(Err(MeshError::parse(
                        path,
                        Some(i + 1),
                        "the line is not text (UTF-8); is this a binary file?",
                    )));
                }
            };
            let line = line.split('#').next().unwrap_or("").trim();
            (!line.is_empty()).then_some(Ok((i + 1, line)))
        })
}

/// A number a text format holds: parsed, and checked that it fits.
pub(crate) trait Number: std::str::FromStr {
    /// True when the text overflowed the type (a float read as infinite
    /// from digits, like 1e39 for f32).
    fn overflowed(&self, text: &str) -> bool;
}

macro_rules! integer_number {
    ($($t:ty),*) => {$(impl Number for $t { fn overflowed(&self, _: &str) -> bool { false } })*};
}
integer_number!(u32, u64, usize, i64);

impl Number for f32 {
    fn overflowed(&self, text: &str) -> bool {
        self.is_infinite() && !text.to_ascii_lowercase().contains("inf")
    }
}

impl Number for f64 {
    fn overflowed(&self, text: &str) -> bool {
        self.is_infinite() && !text.to_ascii_lowercase().contains("inf")
    }
}

/// Parses a number, naming the line and what it was meant to be; a float
/// beyond its type's range (1e39 for 32-bit vertices) is refused by name.
pub(crate) fn number<T: Number>(
    tok: Option<&str>,
    path: &Path,
    line: usize,
    what: &str,
) -> Result<T> {
    let tok = tok.ok_or_else(|| MeshError::parse(path, Some(line), format!("missing {what}")))?;
    let v: T = tok.parse().map_err(|_| {
        // A count or index (unsigned) given as a negative integer.
        // (Only for a type that holds no negative number: OBJ's signed
        // indices say "out of range" for a huge negative one.)
        let unsigned = "-1".parse::<T>().is_err();
        let why = if unsigned && tok.starts_with('-') && tok[1..].parse::<u64>().is_ok() {
            "is negative: counts and indices start at 0"
        } else {
            "is not a valid number"
        };
        MeshError::parse(path, Some(line), format!("{what}: {tok:?} {why}"))
    })?;
    if v.overflowed(tok) {
        return Err(MeshError::parse(
            path,
            Some(line),
            format!(
                "{what}: {tok} is beyond the range of 32-bit floats (about ±3.4e38) that vertices are kept in"
            ),
        ));
    }
    Ok(v)
}

/// Formats an f32 so that it reads back to the same value.
pub(crate) fn push_f32(out: &mut String, v: f32) {
    use std::fmt::Write;
    let _ = write!(out, "{v}");
}
