//! The file formats, one module each, behind [`Format`].

/// glTF reading and writing, and the buffer builder the scene exporter shares.
pub mod gltf;
pub(crate) mod materials;
mod mtl;
pub(crate) mod obj;
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

    /// What writing `mesh` in this format cannot keep, when anything: STL
    /// stores triangles, not vertices, so reading it back gives vertices in
    /// the order the triangles first use them, without unused ones, with
    /// coincident ones merged, and no parts, UVs or colours; PLY and OFF keep
    /// one UV per vertex, PLY one normal per vertex and OFF none (its readers
    /// often refuse `NOFF`), OFF no parts.
    pub fn loses(self, mesh: &crate::Mesh) -> Option<String> {
        match self {
            Format::Stl => {}
            Format::Ply | Format::PlyAscii | Format::Off => return loses_per_vertex(self, mesh),
            Format::Obj | Format::Gltf | Format::Glb => return None,
        }
        let mut seen = vec![false; mesh.positions.len()];
        let mut order = Vec::with_capacity(mesh.positions.len());
        for &v in &mesh.faces.indices {
            if let Some(s) = seen.get_mut(v as usize)
                && !*s
            {
                *s = true;
                order.push(v);
            }
        }
        let unused = mesh.positions.len() - order.len();
        let reordered = order.iter().enumerate().any(|(i, &v)| v as usize != i);
        let mut lost = Vec::new();
        if unused > 0 {
            lost.push(format!("{unused} unused vertices"));
        }
        if reordered {
            lost.push(
                "the vertex order (vertices come back in the order triangles use them)".into(),
            );
        }
        if !mesh.parts.is_empty() || mesh.uvs.is_some() || mesh.colors.is_some() {
            lost.push("parts, UVs and colours".into());
        }
        (!lost.is_empty()).then(|| {
            format!(
                "STL stores triangles, not vertices: it cannot keep {}; use PLY, OBJ, OFF or glTF to compare vertex by vertex",
                lost.join(", ")
            )
        })
    }

    /// The format's name for messages.
    fn label(self) -> &'static str {
        match self {
            Format::Obj => "OBJ",
            Format::Ply | Format::PlyAscii => "PLY",
            Format::Stl => "STL",
            Format::Off => "OFF",
            Format::Gltf | Format::Glb => "glTF",
        }
    }

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

/// What PLY and OFF cannot keep: UVs that differ between the corners of
/// one vertex (seams), and parts (OFF none; PLY one part of each kind per
/// face, as face properties that only csrbf reads back as parts).
fn loses_per_vertex(format: Format, mesh: &Mesh) -> Option<String> {
    let mut lost = Vec::new();
    if let Some(uv) = &mesh.uvs
        && uv.per_vertex(&mesh.faces, mesh.positions.len()).is_none()
    {
        lost.push("its UVs, which have seams (a vertex with several UVs)".to_owned());
    }
    if mesh
        .corner_normals
        .as_ref()
        .is_some_and(|c| c.len() == mesh.faces.indices.len())
    {
        lost.push("its hard edges (a vertex with several normals)".to_owned());
    }
    let mut names: Vec<&str> = mesh.parts.iter().map(|p| p.name.as_str()).collect();
    names.dedup();
    let shown = names.iter().take(5).copied().collect::<Vec<_>>().join(", ");
    let more = if names.len() > 5 { ", ..." } else { "" };
    let mut kept = None;
    if mesh.parts.is_empty() {
        // Nothing to keep.
    } else if format == Format::Off {
        lost.push(format!("its parts ({shown}{more})"));
    } else if ply::parts_overlap(mesh) {
        lost.push(format!(
            "the parts ({shown}{more}) beyond the first of each kind where a face is in several"
        ));
    } else {
        kept = Some(format!(
            "{} keeps the parts ({shown}{more}) as face properties, which csrbf reads back but Blender's and trimesh's importers do not",
            format.label()
        ));
    }
    if lost.is_empty() {
        return kept.map(|k| format!("{k}; use OBJ or glTF for them"));
    }
    let what = if format == Format::Off {
        "keeps one UV per vertex and no parts"
    } else {
        "keeps one UV per vertex and one part of each kind per face"
    };
    let mut said = format!(
        "{} {what}: it cannot keep {}",
        format.label(),
        lost.join(" or ")
    );
    if let Some(k) = kept {
        said = format!("{said}; {k}");
    }
    Some(format!("{said}; use OBJ or glTF to keep them"))
}

/// Whether a file name a model gives (a glTF buffer URI, decoded; an OBJ's
/// material library or texture) stays in the model's folder: relative, no
/// drive or scheme (a colon before the first `/`), no `..`. A model from
/// the web must not make csrbf read other local files.
pub(crate) fn inside_folder(name: &str) -> bool {
    let rel = Path::new(name);
    let scheme = name
        .split('/')
        .next()
        .is_some_and(|first| first.contains(':'));
    let escapes = rel.is_absolute()
        || rel.has_root()
        || rel.components().any(|c| {
            !matches!(
                c,
                std::path::Component::Normal(_) | std::path::Component::CurDir
            )
        });
    !(scheme || escapes || name.is_empty())
}

/// What a reader met in a file and does not keep (an OBJ's polylines and
/// points, a PLY's other elements and properties, an OFF's face colours),
/// counted by kind, for one warning that names the file: a mesh written
/// from it will not have them.
#[derive(Debug, Default)]
pub(crate) struct Skipped {
    kinds: Vec<(String, usize)>,
    /// Whether kinds beyond [`Skipped::KINDS`] were met.
    more: bool,
}

impl Skipped {
    /// Kinds counted apart; beyond them the warning says only that there
    /// were others (a file of a million made-up keywords must not make a
    /// million kinds).
    const KINDS: usize = 12;

    /// Counts `n` more of `what` (`polylines (\`l\`)`).
    pub(crate) fn add(&mut self, what: &str, n: usize) {
        if n == 0 {
            return;
        }
        let full = self.kinds.len() >= Self::KINDS;
        match self.kinds.iter_mut().find(|(w, _)| w == what) {
            Some((_, count)) => *count = count.saturating_add(n),
            None if full => self.more = true,
            None => self.kinds.push((what.to_owned(), n)),
        }
    }

    /// A name taken from the file, for a label: control characters
    /// escaped, cut to 32 characters, in backticks.
    pub(crate) fn name(name: &str) -> String {
        let escaped: String = name.escape_debug().collect();
        match escaped.char_indices().nth(32) {
            Some((cut, _)) => format!("`{}...`", &escaped[..cut]),
            None => format!("`{escaped}`"),
        }
    }

    /// The warning for `path`, if anything was skipped.
    pub(crate) fn warning(&self, path: &Path) -> Option<String> {
        let mut list: Vec<String> = self
            .kinds
            .iter()
            .map(|(w, n)| format!("{w}: {n}"))
            .collect();
        if self.more {
            list.push("and other kinds".to_owned());
        }
        (!list.is_empty()).then(|| {
            format!(
                "{}: not kept (a file written from this mesh will not have them): {}",
                path.display(),
                list.join(", ")
            )
        })
    }
}

/// Parses a mesh (not validated); what the format's reader does not keep
/// is counted in `skipped`.
pub(crate) fn parse(
    bytes: &[u8],
    format: Format,
    path: &Path,
    skipped: &mut Skipped,
) -> Result<Mesh> {
    // A byte-order mark before a text header (an editor's habit) is skipped;
    // a binary STL's 80-byte header is free text and is left alone unless it
    // then reads as ASCII STL.
    const BOM: &[u8] = b"\xEF\xBB\xBF";
    let bytes = match bytes.strip_prefix(BOM) {
        Some(rest)
            if format != Format::Glb && (format != Format::Stl || rest.starts_with(b"solid")) =>
        {
            rest
        }
        _ => bytes,
    };
    match format {
        Format::Obj => obj::parse(bytes, path, skipped),
        Format::Ply | Format::PlyAscii => ply::parse(bytes, path, skipped),
        Format::Stl => stl::parse(bytes, path),
        Format::Off => off::parse(bytes, path, skipped),
        Format::Gltf | Format::Glb => gltf::parse(bytes, path),
    }
}

/// A mesh's bytes in a format; an OBJ names no material library (it has
/// no folder to put one in: [`crate::write`] writes one beside the file).
/// `name` names a glTF's node and mesh (the object an importer makes).
pub(crate) fn encode(mesh: &Mesh, format: Format, name: &str) -> Vec<u8> {
    match format {
        Format::Obj => obj::encode(mesh, None),
        Format::Ply => ply::encode(mesh, false),
        Format::PlyAscii => ply::encode(mesh, true),
        Format::Stl => stl::encode(mesh),
        Format::Off => off::encode(mesh),
        Format::Gltf => gltf::encode(mesh, false, name),
        Format::Glb => gltf::encode(mesh, true, name),
    }
}

#[cfg(test)]
mod fuzz;
#[cfg(test)]
mod obj_material_tests;
#[cfg(test)]
mod obj_normal_tests;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod write_tests;
