//! Helpers for line-based text formats.

use std::path::Path;

use crate::{MeshError, Result};

/// The lines of a text file with their 1-based numbers; `#` comments and
/// surrounding white space removed, blank lines skipped.
pub(crate) fn lines<'a>(
    bytes: &'a [u8],
    path: &'a Path,
) -> impl Iterator<Item = Result<(usize, &'a str)>> + 'a {
    bytes
        .split(|&b| b == b'\n')
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

/// Parses a number, naming the line and what it was meant to be.
pub(crate) fn number<T: std::str::FromStr>(
    tok: Option<&str>,
    path: &Path,
    line: usize,
    what: &str,
) -> Result<T> {
    let tok = tok.ok_or_else(|| MeshError::parse(path, Some(line), format!("missing {what}")))?;
    tok.parse().map_err(|_| {
        MeshError::parse(
            path,
            Some(line),
            format!("{what}: {tok:?} is not a valid number"),
        )
    })
}

/// Formats an f32 so that it reads back to the same value.
pub(crate) fn push_f32(out: &mut String, v: f32) {
    use std::fmt::Write;
    let _ = write!(out, "{v}");
}
