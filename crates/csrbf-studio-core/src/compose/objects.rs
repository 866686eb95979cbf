//! Object edits: add, remove, rename, replace; names stay unique.

use csrbf_anim::{ObjectFile, SceneFile};

use super::keys::object_mut;
use crate::EditError;

/// `object` added at the end.
pub(super) fn add(file: &mut SceneFile, object: &ObjectFile) -> Result<(), EditError> {
    if file.objects.iter().any(|x| x.name == object.name) {
        return Err(EditError::Invalid(format!(
            "an object is already named {:?}",
            object.name
        )));
    }
    file.objects.push(object.clone());
    Ok(())
}

/// Object `i` removed.
pub(super) fn remove(file: &mut SceneFile, i: usize) -> Result<(), EditError> {
    if i >= file.objects.len() {
        return Err(EditError::Invalid(format!("no object {i}")));
    }
    file.objects.remove(i);
    Ok(())
}

/// Object `i` named `name`.
pub(super) fn rename(file: &mut SceneFile, i: usize, name: &str) -> Result<(), EditError> {
    free_name(file, i, name)?;
    object_mut(file, i)?.name = name.to_string();
    Ok(())
}

/// Object `i` described by `object` (its scale, parts, colours, textures,
/// deformations, contact).
pub(super) fn replace(
    file: &mut SceneFile,
    i: usize,
    object: &ObjectFile,
) -> Result<(), EditError> {
    free_name(file, i, &object.name)?;
    *object_mut(file, i)? = object.clone();
    Ok(())
}

/// Whether object `i` may be called `name`: not empty, no other's.
fn free_name(file: &SceneFile, i: usize, name: &str) -> Result<(), EditError> {
    if name.trim().is_empty() {
        return Err(EditError::Invalid("a name cannot be empty".into()));
    }
    if file
        .objects
        .iter()
        .enumerate()
        .any(|(k, x)| k != i && x.name == name)
    {
        return Err(EditError::Invalid(format!(
            "an object is already named {name:?}"
        )));
    }
    Ok(())
}
