//! Undo and redo of scene edits.

use csrbf_anim::SceneFile;

use super::{SceneDoc, SceneEdit};
use crate::EditError;

/// Undo and redo of scene edits: the scene before each one (scene files are
/// small; the meshes they name are not in them).
#[derive(Clone, Debug, Default)]
pub struct SceneHistory {
    done: Vec<SceneFile>,
    undone: Vec<SceneFile>,
    /// The tag of the last edit, when it may take the next one in.
    merging: Option<&'static str>,
    /// The scene as last saved (or opened): the document is unsaved
    /// whenever it differs, so undoing back to it is saved again.
    saved: Option<SceneFile>,
}

impl SceneHistory {
    /// Applies an edit and records it; clears what could be redone.
    pub fn apply(&mut self, doc: &mut SceneDoc, edit: &SceneEdit) -> Result<(), EditError> {
        let before = doc.file.clone();
        edit.apply(doc)?;
        self.done.push(before);
        self.undone.clear();
        self.merging = None;
        self.mark(doc);
        Ok(())
    }

    /// [`SceneHistory::apply`], but one undo step with the edits before it
    /// of the same `tag` (the steps of a slider drag or of typing a value),
    /// until [`SceneHistory::end_merge`].
    pub fn apply_merging(
        &mut self,
        doc: &mut SceneDoc,
        edit: &SceneEdit,
        tag: &'static str,
    ) -> Result<(), EditError> {
        if self.merging == Some(tag) && !self.done.is_empty() {
            edit.apply(doc)?;
            self.undone.clear();
            self.mark(doc);
            return Ok(());
        }
        self.apply(doc, edit)?;
        self.merging = Some(tag);
        Ok(())
    }

    /// Ends a merged run: the next edit is a step of its own.
    pub fn end_merge(&mut self) {
        self.merging = None;
    }

    /// Steps that can be undone.
    pub fn undo_steps(&self) -> usize {
        self.done.len()
    }

    /// Undoes the last edit.
    pub fn undo(&mut self, doc: &mut SceneDoc) -> Result<(), EditError> {
        let before = self.done.pop().ok_or(EditError::Nothing("undo"))?;
        self.merging = None;
        self.undone.push(std::mem::replace(&mut doc.file, before));
        self.mark(doc);
        Ok(())
    }

    /// Redoes the last undone edit.
    pub fn redo(&mut self, doc: &mut SceneDoc) -> Result<(), EditError> {
        let after = self.undone.pop().ok_or(EditError::Nothing("redo"))?;
        self.done.push(std::mem::replace(&mut doc.file, after));
        self.mark(doc);
        Ok(())
    }

    /// The scene as saved now (after a save, or a file opened).
    pub fn mark_saved(&mut self, doc: &mut SceneDoc) {
        self.saved = Some(doc.file.clone());
        doc.dirty = false;
    }

    /// `doc.dirty`: whether the scene differs from the one saved.
    fn mark(&self, doc: &mut SceneDoc) {
        doc.dirty = self.saved.as_ref() != Some(&doc.file);
    }
}
