//! [`SceneEdit::apply`]: each kind of edit is a function of its own module
//! (`objects`, `keys`, `look`), as the Picker's commands are; the scene it
//! gives is then checked whole, as the CLI would check it.

use csrbf_anim::SceneFile;

use super::{SceneDoc, SceneEdit, keys, look, objects};
use crate::EditError;

impl SceneEdit {
    /// Applies the edit to `doc` (its playhead places new keys); on error
    /// the document is unchanged.
    pub fn apply(&self, doc: &mut SceneDoc) -> Result<(), EditError> {
        let mut file = doc.file.clone();
        let f = &mut file;
        let t = doc.playhead;
        match self {
            SceneEdit::AddObject(o) => objects::add(f, o)?,
            SceneEdit::RemoveObject(i) => objects::remove(f, *i)?,
            SceneEdit::RenameObject(i, name) => objects::rename(f, *i, name)?,
            SceneEdit::ReplaceObject(i, o) => objects::replace(f, *i, o)?,
            SceneEdit::AddKey {
                object,
                track,
                value,
            } => keys::paste(f, *object, *track, t, *value, None)?,
            SceneEdit::SetKey {
                object,
                track,
                index,
                value,
            } => keys::set(f, *object, *track, *index, *value)?,
            SceneEdit::CopyKey {
                object,
                track,
                index,
            } => keys::copy(f, *object, *track, *index, t)?,
            SceneEdit::PasteKey {
                object,
                track,
                value,
                tcb,
            } => keys::paste(f, *object, *track, t, *value, *tcb)?,
            SceneEdit::MoveKey {
                object,
                track,
                index,
                time,
            } => keys::move_to(f, *object, *track, *index, *time)?,
            SceneEdit::DeleteKey {
                object,
                track,
                index,
            } => keys::delete(f, *object, *track, *index)?,
            SceneEdit::SetTcb { object, index, tcb } => keys::set_tcb(f, *object, *index, *tcb)?,
            SceneEdit::SetCamera(camera) => f.camera = camera.clone(),
            SceneEdit::SetLights(lights) => look::set_lights(f, lights)?,
            SceneEdit::SetLook { size, background } => look::set_look(f, *size, *background)?,
            SceneEdit::SetTiming { fps, duration } => look::set_timing(f, *fps, *duration)?,
        }
        // What the CLI would refuse is refused here (frame limits, sizes).
        check(&file)?;
        doc.file = file;
        doc.playhead = doc.playhead.clamp(0.0, doc.file.duration);
        doc.dirty = true;
        Ok(())
    }
}

/// The CLI's whole-scene checks, but for "no object": a scene being built
/// may have none yet (saving one is refused, see [`SceneDoc::saveable`]).
fn check(file: &SceneFile) -> Result<(), EditError> {
    match file.check() {
        Ok(()) => Ok(()),
        // The object count is checked last: everything else passed.
        Err(e) if e.at == "objects" && file.objects.is_empty() => Ok(()),
        Err(e) => Err(EditError::Invalid(format!("{}: {}", e.at, e.message))),
    }
}
