//! An OBJ's materials from the files beside it: the libraries its
//! `mtllib` names and the textures they name.
//!
//! A material library is a side file: a model whose library or texture is
//! missing, unreadable or malformed still loads (its materials grey, or
//! without their picture), with a warning naming the file. Only files in the
//! model's own folder (or below it) are read, never an absolute path or one
//! that climbs out with `..`: a downloaded model must not make csrbf read
//! other local files.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use super::{inside_folder, mtl};
use crate::{Material, Mesh, PartKind};

/// The largest material library read (bytes); a bigger one is not a
/// material library.
pub(crate) const MAX_LIBRARY_BYTES: u64 = 16 << 20;

/// The largest texture read (bytes); real textures, even 16k PNGs, are
/// smaller.
pub(crate) const MAX_TEXTURE_BYTES: u64 = 256 << 20;

/// The most libraries one OBJ's `mtllib` lines name that are read.
pub(crate) const MAX_LIBRARIES: usize = 16;

/// The MIME type of an image by its first bytes: PNG or JPEG, the two that
/// glTF carries and csrbf's renderer draws.
pub(crate) fn image_mime(bytes: &[u8]) -> Option<&'static str> {
    if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
        Some("image/png")
    } else if bytes.starts_with(b"\xFF\xD8\xFF") {
        Some("image/jpeg")
    } else {
        None
    }
}

/// The libraries an `mtllib` line names: the whole line when a file of that
/// name is there (names with spaces), else each word (several libraries).
pub(crate) fn library_names(line: &str, dir: &Path) -> Vec<String> {
    let whole = line.replace('\\', "/");
    if line.split_ascii_whitespace().nth(1).is_none() || dir.join(&whole).is_file() {
        return vec![whole];
    }
    line.split_ascii_whitespace()
        .map(|n| n.replace('\\', "/"))
        .collect()
}

/// Fills `mesh.materials` from the libraries beside the OBJ at `obj`, and
/// notes the library files read in `mesh.material_files` (for a writer
/// beside them to name instead of copying). What could not be read is said
/// in `warnings`.
pub(crate) fn read_beside(obj: &Path, mesh: &mut Mesh, warnings: &mut Vec<String>) {
    let Some(line) = mesh.material_library.clone() else {
        return;
    };
    // "" for a bare file name, so messages say `duck.mtl`, not `./duck.mtl`.
    let dir = obj.parent().unwrap_or(Path::new(""));
    let mut textures: HashMap<PathBuf, Option<(String, Vec<u8>)>> = HashMap::new();
    let mut files = Vec::new();
    let mut all_read = true;
    let mut names = library_names(&line, dir);
    if names.len() > MAX_LIBRARIES {
        warnings.push(format!(
            "{}: mtllib names {} libraries; only the first {MAX_LIBRARIES} are read",
            obj.display(),
            names.len()
        ));
        names.truncate(MAX_LIBRARIES);
        all_read = false;
    }
    for name in names {
        let Some(path) = local(dir, &name) else {
            warnings.push(format!(
                "{}: material library {name:?} is refused: only files in the model's own folder are read; its materials are grey",
                obj.display()
            ));
            all_read = false;
            continue;
        };
        let bytes = match read_limited(&path, MAX_LIBRARY_BYTES) {
            Ok(b) => b,
            Err(e) => {
                warnings.push(format!(
                    "{}: its material library {}: {e}; its materials are grey",
                    obj.display(),
                    path.display()
                ));
                all_read = false;
                continue;
            }
        };
        let base = path.parent().unwrap_or(dir).to_owned();
        for entry in mtl::parse(&bytes, &path, warnings) {
            if mesh.materials.iter().any(|m| m.name == entry.name) {
                continue; // The first definition wins, as in other readers.
            }
            let texture = entry.texture.as_ref().and_then(|t| {
                textures
                    .entry(base.join(t))
                    .or_insert_with(|| texture(&path, &base, t, warnings))
                    .clone()
            });
            mesh.materials.push(Material {
                texture,
                ..Material::new(entry.name, entry.color)
            });
        }
        files.push(std::fs::canonicalize(&path).unwrap_or(path));
    }
    if all_read {
        mesh.material_files = files;
    }
    let missing: Vec<&str> = mesh
        .parts
        .iter()
        .filter(|p| p.kind == PartKind::Material)
        .map(|p| p.name.as_str())
        .filter(|n| !mesh.materials.iter().any(|m| m.name == *n))
        .collect();
    if all_read && !missing.is_empty() {
        let shown: Vec<&str> = missing.iter().take(5).copied().collect();
        warnings.push(format!(
            "{}: material(s) {}{} are used but not defined in {line}; they are grey",
            obj.display(),
            shown.join(", "),
            if missing.len() > 5 { ", ..." } else { "" }
        ));
    }
}

/// A texture a library names, relative to the library's folder: its MIME
/// type and bytes, or `None` with a warning (the colour is kept).
fn texture(
    library: &Path,
    base: &Path,
    name: &str,
    warnings: &mut Vec<String>,
) -> Option<(String, Vec<u8>)> {
    let Some(path) = local(base, name) else {
        warnings.push(format!(
            "{}: texture {name:?} is refused: only files in the model's own folder are read; the material keeps its colour only",
            library.display()
        ));
        return None;
    };
    match read_limited(&path, MAX_TEXTURE_BYTES) {
        Ok(bytes) => match image_mime(&bytes) {
            Some(mime) => Some((mime.to_owned(), bytes)),
            None => {
                warnings.push(format!(
                    "{}: texture {} is neither PNG nor JPEG; the material keeps its colour only",
                    library.display(),
                    path.display()
                ));
                None
            }
        },
        Err(e) => {
            warnings.push(format!(
                "{}: texture {}: {e}; the material keeps its colour only",
                library.display(),
                path.display()
            ));
            None
        }
    }
}

/// `name` under `dir` when it stays inside it: no root, drive, scheme or
/// `..` in the name, and, where it exists, its resolved path inside the
/// resolved folder (a symlink in the model's folder may point anywhere; the
/// glTF reader checks its URIs the same way).
fn local(dir: &Path, name: &str) -> Option<PathBuf> {
    if !inside_folder(name) {
        return None;
    }
    let path = dir.join(name);
    let folder = if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    };
    // Missing: kept, so that reading it says so. Present: it must resolve
    // inside the resolved folder and be a plain file (a link whose target
    // cannot be resolved, a pipe or a device is refused: reading one could
    // take another program's input or never end).
    match path.symlink_metadata() {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Some(path),
        Err(_) => None,
        Ok(_) => match (folder.canonicalize(), path.canonicalize()) {
            (Ok(folder), Ok(real))
                if real.starts_with(&folder) && real.metadata().is_ok_and(|m| m.is_file()) =>
            {
                Some(path)
            }
            _ => None,
        },
    }
}

/// A file's bytes, refused past `limit`: by its size before any is read,
/// and while reading for what has no size (a link to a device).
fn read_limited(path: &Path, limit: u64) -> std::io::Result<Vec<u8>> {
    use std::io::Read;
    let too_big = |len: u64| {
        std::io::Error::other(format!(
            "{len} bytes or more, more than the {limit} read for a side file"
        ))
    };
    let file = std::fs::File::open(path)?;
    let len = file.metadata()?.len();
    if len > limit {
        return Err(too_big(len));
    }
    let mut bytes = Vec::with_capacity(len as usize);
    file.take(limit + 1).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > limit {
        return Err(too_big(bytes.len() as u64));
    }
    Ok(bytes)
}
