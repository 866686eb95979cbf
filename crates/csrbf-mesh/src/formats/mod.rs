//! The file formats, one module each, behind [`Format`].

/// glTF reading and writing, and the buffer builder the scene exporter shares.
pub mod gltf;
mod obj;
mod off;
mod ply;
mod stl;
mod text;

use std::path::Path;

use crate::{Mesh, MeshError, Result};

/// A mesh file format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Format {
    /// Wavefront OBJ.
    Obj,
    /// Stanford PLY, ASCII or binary in; binary little-endian out.
    Ply,
    /// PLY written as ASCII.
    PlyAscii,
    /// STL, ASCII or binary in; binary out.
    Stl,
    /// Object File Format.
    Off,
    /// glTF 2.0 JSON with an embedded buffer.
    Gltf,
    /// glTF 2.0 binary.
    Glb,
}

impl Format {
    /// The extensions recognised, for messages.
    pub const EXTENSIONS: &'static str = ".obj, .ply, .stl, .off, .gltf, .glb";

    /// The format of a path, by its extension (case-insensitive).
    pub fn from_path(path: &Path) -> Result<Format> {
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase())
            .unwrap_or_default();
        Ok(match ext.as_str() {
            "obj" => Format::Obj,
            "ply" => Format::Ply,
            "stl" => Format::Stl,
            "off" => Format::Off,
            "gltf" => Format::Gltf,
            "glb" => Format::Glb,
            _ => {
                return Err(MeshError::UnknownFormat {
                    path: path.to_owned(),
                    ext,
                });
            }
        })
    }
}

pub(crate) fn parse(bytes: &[u8], format: Format, path: &Path) -> Result<Mesh> {
    match format {
        Format::Obj => obj::parse(bytes, path),
        Format::Ply | Format::PlyAscii => ply::parse(bytes, path),
        Format::Stl => stl::parse(bytes, path),
        Format::Off => off::parse(bytes, path),
        Format::Gltf | Format::Glb => gltf::parse(bytes, path),
    }
}

pub(crate) fn encode(mesh: &Mesh, format: Format) -> Vec<u8> {
    match format {
        Format::Obj => obj::encode(mesh),
        Format::Ply => ply::encode(mesh, false),
        Format::PlyAscii => ply::encode(mesh, true),
        Format::Stl => stl::encode(mesh),
        Format::Off => off::encode(mesh),
        Format::Gltf => gltf::encode(mesh, false),
        Format::Glb => gltf::encode(mesh, true),
    }
}

#[cfg(test)]
mod tests;
