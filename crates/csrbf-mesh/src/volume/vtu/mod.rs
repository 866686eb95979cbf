//! VTK XML unstructured grids (`.vtu`), read with a small tag scanner (an
//! XML library cannot step over raw appended data): `format="ascii"`,
//! `"binary"` (base64) and `"appended"` (raw or base64), with or without
//! `vtkZLibDataCompressor`, UInt32 or UInt64 headers, either byte order;
//! several pieces are joined. Zones as for the legacy files: an integer
//! cell array (`gmsh:physical`, ...) and field data `name` = [tag, dim].
//!
//! Written with every array appended raw (or ASCII), UInt64 headers,
//! little-endian.

mod read;
mod tags;
#[cfg(test)]
pub(super) mod tests;
mod write;

pub(super) use read::read;
pub(super) use write::{Encoding, write};
