//! Textures: PNG or JPEG images from files or embedded in a mesh's materials.

use std::path::{Path, PathBuf};

use csrbf_mesh::Mesh;

use super::Texture;

/// The embedded texture of the material a part is selected by, or for a
/// part of the whole mesh the only textured material's, if any.
pub(super) fn embedded_texture(mesh: &Mesh, select: &serde_json::Value) -> Option<Texture> {
    let textured: Vec<_> = mesh
        .materials
        .iter()
        .filter(|m| m.texture.is_some())
        .collect();
    let mat = match select.get("group").and_then(|g| g.as_str()) {
        Some(name) => mesh.materials.iter().find(|m| m.name == name)?,
        None if select.as_str() == Some("all") && textured.len() == 1 => textured[0],
        None => return None,
    };
    let (_, bytes) = mat.texture.as_ref()?;
    decode_texture(bytes.clone(), Path::new(&format!("material {}", mat.name))).ok()
}

/// A texture that cannot be used.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{}: {reason}", path.display())]
pub struct TextureError {
    /// The image file (or the material that embeds it).
    pub path: PathBuf,
    /// Why.
    pub reason: String,
}

/// Decodes a PNG or JPEG texture.
pub fn load_texture(path: &Path) -> std::result::Result<Texture, TextureError> {
    let encoded = std::fs::read(path).map_err(|e| TextureError {
        path: path.to_owned(),
        reason: e.to_string(),
    })?;
    decode_texture(encoded, path)
}

/// Decodes PNG or JPEG bytes; `path` names them in errors.
pub fn decode_texture(encoded: Vec<u8>, path: &Path) -> std::result::Result<Texture, TextureError> {
    let bad = |reason: String| TextureError {
        path: path.to_owned(),
        reason,
    };
    let format = image::guess_format(&encoded).map_err(|e| bad(format!("not an image: {e}")))?;
    let mime = match format {
        image::ImageFormat::Png => "image/png",
        image::ImageFormat::Jpeg => "image/jpeg",
        other => {
            return Err(bad(format!(
                "{other:?} images are not supported; use PNG or JPEG"
            )));
        }
    };
    let img = image::load_from_memory_with_format(&encoded, format)
        .map_err(|e| bad(format!("cannot decode the image: {e}")))?
        .to_rgba8();
    Ok(Texture {
        path: path.to_owned(),
        width: img.width(),
        height: img.height(),
        rgba: img.into_raw(),
        encoded,
        mime: mime.into(),
    })
}
