//! Every edit of a [`Document`] as a value: applying one returns its
//! inverse, so undo is applying the inverse and redo applying the command
//! again. [`History`] keeps the pairs and merges the many small moves of a
//! drag into one step.

use csrbf::Kernel;
use csrbf_edit::controls::ControlSpec;
use glam::DVec3;

use crate::EditError;
use crate::state::Document;

/// One edit.
#[derive(Clone, Debug, PartialEq)]
pub enum Command {
    /// Insert a control vector at `index` of a layer (`None`: at the end).
    Insert {
        /// The layer.
        layer: usize,
        /// Where (`None`: last).
        index: Option<usize>,
        /// Its start.
        start: DVec3,
        /// Its destination.
        target: DVec3,
    },
    /// Remove a control vector.
    Remove {
        /// The layer.
        layer: usize,
        /// Which.
        index: usize,
    },
    /// Move a destination (the drag; no refit).
    SetTarget {
        /// The layer.
        layer: usize,
        /// Which control.
        index: usize,
        /// The new destination.
        target: DVec3,
    },
    /// Move a whole control vector: its start and its destination (a
    /// start dragged carries its vector along).
    MoveControl {
        /// The layer.
        layer: usize,
        /// Which control.
        index: usize,
        /// The new start.
        start: DVec3,
        /// The new destination.
        target: DVec3,
    },
    /// Move a start (a refit).
    SetStart {
        /// The layer.
        layer: usize,
        /// Which control.
        index: usize,
        /// The new start.
        start: DVec3,
    },
    /// Change a layer's radius of support.
    SetRadius {
        /// The layer.
        layer: usize,
        /// The new R (> 0).
        radius: f64,
    },
    /// Change a layer's kernel.
    SetKernel {
        /// The layer.
        layer: usize,
        /// The kernel.
        kernel: Kernel,
    },
    /// Insert a layer (a deformation) at `layer`.
    InsertLayer {
        /// Where.
        layer: usize,
        /// Its content.
        spec: Box<ControlSpec>,
    },
    /// Remove a layer (a document keeps at least one).
    RemoveLayer {
        /// Which.
        layer: usize,
    },
    /// Replace a layer's whole content (a preset, a pasted file).
    ReplaceLayer {
        /// Which.
        layer: usize,
        /// Its new content.
        spec: Box<ControlSpec>,
    },
    /// Several edits as one step (delete a selection, mirror, reorder
    /// layers): all of them or none.
    Batch(Vec<Command>),
}

impl Command {
    /// A control vector added at the end of a layer.
    pub fn add(layer: usize, start: DVec3, target: DVec3) -> Command {
        Command::Insert {
            layer,
            index: None,
            start,
            target,
        }
    }

    /// Applies the command and returns its inverse. On error the document is
    /// unchanged.
    pub fn apply(&self, doc: &mut Document) -> Result<Command, EditError> {
        if let Command::Batch(commands) = self {
            let dirty = doc.dirty;
            let mut inverses = Vec::with_capacity(commands.len());
            for c in commands {
                match c.apply(doc) {
                    Ok(inv) => inverses.push(inv),
                    Err(e) => {
                        // Take back what was done: the document is as before.
                        for inv in inverses.iter().rev() {
                            let _ = inv.apply(doc);
                        }
                        doc.dirty = dirty;
                        return Err(e);
                    }
                }
            }
            inverses.reverse();
            doc.dirty = true;
            return Ok(Command::Batch(inverses));
        }
        let layers = doc.controls.deformations.len();
        let has_layer = |doc: &Document, layer: usize| {
            if layer < doc.controls.deformations.len() {
                Ok(())
            } else {
                Err(EditError::NoLayer(layer))
            }
        };
        let finite = |p: DVec3, what: &str| {
            if p.is_finite() {
                Ok(())
            } else {
                Err(EditError::Invalid(format!("{what} {p} is not finite")))
            }
        };
        let inverse = match self {
            Command::Insert {
                layer,
                index,
                start,
                target,
            } => {
                has_layer(doc, *layer)?;
                finite(*start, "start")?;
                finite(*target, "destination")?;
                let s = &mut doc.controls.deformations[*layer];
                let at = index.unwrap_or(s.starts.len());
                if at > s.starts.len() {
                    return Err(EditError::NoControl {
                        layer: *layer,
                        index: at,
                    });
                }
                s.starts.insert(at, *start);
                s.targets.insert(at, *target);
                Command::Remove {
                    layer: *layer,
                    index: at,
                }
            }
            Command::Remove { layer, index } => {
                has_layer(doc, *layer)?;
                let s = &mut doc.controls.deformations[*layer];
                if *index >= s.starts.len() {
                    return Err(EditError::NoControl {
                        layer: *layer,
                        index: *index,
                    });
                }
                let (start, target) = (s.starts.remove(*index), s.targets.remove(*index));
                doc.selection
                    .0
                    .retain(|&(l, i)| !(l == *layer && i == *index));
                for (l, i) in &mut doc.selection.0 {
                    if *l == *layer && *i > *index {
                        *i -= 1;
                    }
                }
                Command::Insert {
                    layer: *layer,
                    index: Some(*index),
                    start,
                    target,
                }
            }
            Command::SetTarget {
                layer,
                index,
                target,
            } => {
                has_layer(doc, *layer)?;
                finite(*target, "destination")?;
                let s = &mut doc.controls.deformations[*layer];
                let old = *s.targets.get(*index).ok_or(EditError::NoControl {
                    layer: *layer,
                    index: *index,
                })?;
                s.targets[*index] = *target;
                Command::SetTarget {
                    layer: *layer,
                    index: *index,
                    target: old,
                }
            }
            Command::SetStart {
                layer,
                index,
                start,
            } => {
                has_layer(doc, *layer)?;
                finite(*start, "start")?;
                let s = &mut doc.controls.deformations[*layer];
                let old = *s.starts.get(*index).ok_or(EditError::NoControl {
                    layer: *layer,
                    index: *index,
                })?;
                s.starts[*index] = *start;
                Command::SetStart {
                    layer: *layer,
                    index: *index,
                    start: old,
                }
            }
            Command::MoveControl {
                layer,
                index,
                start,
                target,
            } => {
                has_layer(doc, *layer)?;
                finite(*start, "start")?;
                finite(*target, "destination")?;
                let s = &mut doc.controls.deformations[*layer];
                let no = EditError::NoControl {
                    layer: *layer,
                    index: *index,
                };
                let (Some(&old_start), Some(&old_target)) =
                    (s.starts.get(*index), s.targets.get(*index))
                else {
                    return Err(no);
                };
                s.starts[*index] = *start;
                s.targets[*index] = *target;
                Command::MoveControl {
                    layer: *layer,
                    index: *index,
                    start: old_start,
                    target: old_target,
                }
            }
            Command::SetRadius { layer, radius } => {
                has_layer(doc, *layer)?;
                if !(*radius > 0.0 && radius.is_finite()) {
                    return Err(EditError::Invalid(format!(
                        "the radius must be a finite number > 0, got {radius}"
                    )));
                }
                let o = &mut doc.controls.deformations[*layer].options;
                let old = o.radius;
                *o = o.with_radius(*radius);
                Command::SetRadius {
                    layer: *layer,
                    radius: old,
                }
            }
            Command::SetKernel { layer, kernel } => {
                has_layer(doc, *layer)?;
                let o = &mut doc.controls.deformations[*layer].options;
                let old = o.kernel;
                *o = o.with_kernel(*kernel);
                Command::SetKernel {
                    layer: *layer,
                    kernel: old,
                }
            }
            Command::InsertLayer { layer, spec } => {
                if *layer > layers {
                    return Err(EditError::NoLayer(*layer));
                }
                doc.controls.deformations.insert(*layer, (**spec).clone());
                for (l, _) in &mut doc.selection.0 {
                    if *l >= *layer {
                        *l += 1;
                    }
                }
                Command::RemoveLayer { layer: *layer }
            }
            Command::RemoveLayer { layer } => {
                has_layer(doc, *layer)?;
                if layers == 1 {
                    return Err(EditError::Invalid(
                        "a document keeps at least one layer".into(),
                    ));
                }
                let old = doc.controls.deformations.remove(*layer);
                doc.selection.0.retain(|&(l, _)| l != *layer);
                for (l, _) in &mut doc.selection.0 {
                    if *l > *layer {
                        *l -= 1;
                    }
                }
                doc.active_layer = doc.active_layer.min(layers - 2);
                Command::InsertLayer {
                    layer: *layer,
                    spec: Box::new(old),
                }
            }
            Command::Batch(_) => unreachable!("handled above"),
            Command::ReplaceLayer { layer, spec } => {
                has_layer(doc, *layer)?;
                let old =
                    std::mem::replace(&mut doc.controls.deformations[*layer], (**spec).clone());
                Command::ReplaceLayer {
                    layer: *layer,
                    spec: Box::new(old),
                }
            }
        };
        doc.dirty = true;
        Ok(inverse)
    }

    /// Whether this command only moves destinations (the live preview then
    /// solves again without re-factoring).
    pub fn moves_targets_only(&self) -> bool {
        match self {
            Command::SetTarget { .. } => true,
            Command::Batch(c) => c.iter().all(Command::moves_targets_only),
            _ => false,
        }
    }

    /// The selected controls (or every control of the active layer when
    /// none is selected) mirrored across the plane `p[axis] = plane` (axis
    /// 0 X, 1 Y, 2 Z; [`crate::symmetry::symmetry_plane`] finds the model's
    /// own), as one step of new controls; with how many: [`Command::mirror_across`]
    /// of that plane.
    pub fn mirror(doc: &Document, axis: usize, plane: f64) -> Option<(Command, usize)> {
        let plane = crate::symmetry::Plane::axis(axis, plane)?;
        Self::mirror_across(doc, &plane).map(|m| (m.command, m.added))
    }

    /// The selected controls (or every control of the active layer when
    /// none is selected) mirrored across `plane`, of any orientation, as
    /// one step of new controls. The image of a start on the surface is put
    /// on the surface (its nearest point: a model is rarely exactly
    /// symmetric), its destination moved as the original's, mirrored; a
    /// start off the surface (placed in space) is mirrored exactly. A start
    /// on the plane is its own image, and an image already there is not
    /// added twice: None when nothing is left.
    pub fn mirror_across(doc: &Document, plane: &crate::symmetry::Plane) -> Option<Mirrored> {
        let l = doc.active_layer;
        let sel: Vec<(usize, usize)> = if doc.selection.0.is_empty() {
            let n = doc.controls.deformations.get(l)?.starts.len();
            (0..n).map(|i| (l, i)).collect()
        } else {
            doc.selection.0.clone()
        };
        let mesh = &doc.mesh;
        let triangles = mesh.faces.triangles();
        let bvh = csrbf_mesh::Bvh::new(&mesh.positions, &triangles);
        let on_surface = |p: DVec3| {
            bvh.nearest(&mesh.positions, p.as_vec3())
                .map(|h| (h.point.as_dvec3(), h.distance as f64))
        };
        let touch = 1e-4 * doc.diagonal().max(f64::MIN_POSITIVE);
        let mut batch = Vec::new();
        let mut put: Vec<f64> = Vec::new();
        let mut made: Vec<(usize, DVec3)> = Vec::new();
        for &(layer, i) in &sel {
            let s = doc.controls.deformations.get(layer)?;
            let (start, target) = (*s.starts.get(i)?, *s.targets.get(i)?);
            let r = s.options.radius.max(1e-12);
            let exact = plane.reflect(start);
            if exact.distance(start) < 1e-6 * r {
                continue; // on the plane: its own image
            }
            let (a, gap) = match on_surface(start) {
                Some((_, d)) if d <= touch => match on_surface(exact) {
                    Some((q, _)) => (q, q.distance(exact)),
                    None => (exact, 0.0),
                },
                _ => (exact, 0.0),
            };
            let b = a + plane.reflect_vector(target - start);
            let taken = s.starts.iter().any(|p| p.distance(a) < 1e-6 * r)
                || made
                    .iter()
                    .any(|&(k, p)| k == layer && p.distance(a) < 1e-6 * r);
            if !taken {
                batch.push(Command::add(layer, a, b));
                made.push((layer, a));
                put.push(gap / r);
            }
        }
        let added = batch.len();
        (added > 0).then_some(Mirrored {
            command: Command::Batch(batch),
            added,
            gaps: put,
        })
    }

    /// The vertices chosen with the vertex tool made what `target` says,
    /// from the active layer `spec`: a new layer after the others holding a
    /// handle that selects them (its controls and region cleared), or the
    /// active layer with them as its anchor or its region.
    pub fn use_vertices(
        doc: &Document,
        spec: &csrbf_edit::controls::ControlSpec,
        vertices: Vec<u32>,
        target: crate::tools::VertexTarget,
    ) -> Command {
        use crate::tools::VertexTarget;
        let chosen = csrbf::Region::Vertices(vertices);
        let mut new = spec.clone();
        match target {
            VertexTarget::Handle => {
                new.starts.clear();
                new.targets.clear();
                new.region = csrbf::Region::All;
                new.anchor = None;
                new.handle = Some(csrbf::Handle::new(chosen));
                // An active layer with nothing in it yet takes the handle;
                // else the handle is a layer of its own (a second handle
                // never replaces the first).
                let active = doc.controls.deformations.get(doc.active_layer);
                if active.is_some_and(|s| s.starts.is_empty() && s.handle.is_none()) {
                    return Command::ReplaceLayer {
                        layer: doc.active_layer,
                        spec: Box::new(new),
                    };
                }
                return Command::InsertLayer {
                    layer: doc.controls.deformations.len(),
                    spec: Box::new(new),
                };
            }
            VertexTarget::Anchor => new.anchor = Some(chosen),
            VertexTarget::Region => new.region = chosen,
        }
        Command::ReplaceLayer {
            layer: doc.active_layer,
            spec: Box::new(new),
        }
    }

    /// Moves layer `from` to position `to` (both existing indices), as one step.
    pub fn move_layer(doc: &Document, from: usize, to: usize) -> Option<Command> {
        let spec = doc.controls.deformations.get(from)?.clone();
        (to < doc.controls.deformations.len() && from != to).then(|| {
            Command::Batch(vec![
                Command::RemoveLayer { layer: from },
                Command::InsertLayer {
                    layer: to,
                    spec: Box::new(spec),
                },
            ])
        })
    }
}

/// Done and undone commands, each with its inverse.
#[derive(Clone, Debug)]
pub struct History {
    done: Vec<(Command, Command)>,
    undone: Vec<(Command, Command)>,
    /// While true, destination moves of the same control merge into the last step.
    dragging: bool,
    /// Steps done before the drag began: a drag never merges into those.
    drag_base: usize,
    /// How many steps were done when the document was last saved (None:
    /// that state can no longer be reached by undo or redo). The document
    /// is unsaved whenever the steps done are not those.
    saved: Option<usize>,
}

impl Default for History {
    fn default() -> Self {
        History {
            done: Vec::new(),
            undone: Vec::new(),
            dragging: false,
            drag_base: 0,
            saved: Some(0),
        }
    }
}

impl History {
    /// Applies a command and records it; clears what could be redone.
    pub fn apply(&mut self, doc: &mut Document, command: Command) -> Result<(), EditError> {
        let inverse = command.apply(doc)?;
        // A drag's moves of one destination are one step: keep the first
        // inverse (where the drag began) and the last command.
        let same_control = |a: &Command, b: &Command| match (a, b) {
            (
                Command::SetTarget { layer, index, .. },
                Command::SetTarget {
                    layer: l, index: i, ..
                },
            )
            | (
                Command::SetStart { layer, index, .. },
                Command::SetStart {
                    layer: l, index: i, ..
                },
            )
            | (
                Command::MoveControl { layer, index, .. },
                Command::MoveControl {
                    layer: l, index: i, ..
                },
            ) => (layer, index) == (l, i),
            (Command::SetRadius { layer, .. }, Command::SetRadius { layer: l, .. })
            | (Command::ReplaceLayer { layer, .. }, Command::ReplaceLayer { layer: l, .. }) => {
                layer == l
            }
            _ => false,
        };
        // A control placed and dragged out in one gesture is one step: the
        // insert, with the destination where the drag left it.
        if self.dragging
            && self.done.len() > self.drag_base
            && let Some((
                Command::Insert { layer, target, .. },
                Command::Remove { layer: l, index: i },
            )) = self.done.last_mut()
            && let Command::SetTarget {
                layer: cl,
                index: ci,
                target: new,
            } = &command
            && (*layer, *l, *i) == (*cl, *cl, *ci)
        {
            *target = *new;
            // The step that was saved changes: the saved state is gone.
            if self.saved == Some(self.done.len()) {
                self.saved = None;
            }
            self.undone.clear();
            self.mark(doc);
            return Ok(());
        }
        if self.dragging
            && self.done.len() > self.drag_base
            && let Some((last, _)) = self.done.last()
            && same_control(&command, last)
        {
            let first_inverse = self.done.pop().map(|(_, inv)| inv).unwrap_or(inverse);
            // The step that was saved changes: the saved state is gone.
            if self.saved == Some(self.done.len() + 1) {
                self.saved = None;
            }
            self.done.push((command, first_inverse));
        } else {
            // A saved state among the undone steps is gone with them.
            if self.saved.is_some_and(|s| s > self.done.len()) {
                self.saved = None;
            }
            self.done.push((command, inverse));
        }
        self.undone.clear();
        self.mark(doc);
        Ok(())
    }

    /// The document as saved now (after a save, or a file opened).
    pub fn mark_saved(&mut self, doc: &mut Document) {
        self.saved = Some(self.done.len());
        self.mark(doc);
    }

    /// The document as unsaved however it is undone (a session restored
    /// from the recovery file, never saved).
    pub fn mark_unsaved(&mut self, doc: &mut Document) {
        self.saved = None;
        self.mark(doc);
    }

    /// `doc.dirty`: whether the steps done differ from the saved ones.
    fn mark(&self, doc: &mut Document) {
        doc.dirty = self.saved != Some(self.done.len());
    }

    /// Starts merging moves of one control's destination or start (pointer
    /// pressed on a marker).
    pub fn begin_drag(&mut self) {
        self.dragging = true;
        self.drag_base = self.done.len();
    }

    /// Stops merging (pointer released): the next move is a new step.
    pub fn end_drag(&mut self) {
        self.dragging = false;
    }

    /// Undoes the last step.
    pub fn undo(&mut self, doc: &mut Document) -> Result<(), EditError> {
        let (command, inverse) = self.done.pop().ok_or(EditError::Nothing("undo"))?;
        inverse.apply(doc)?;
        self.undone.push((command, inverse));
        self.mark(doc);
        Ok(())
    }

    /// Redoes the last undone step.
    pub fn redo(&mut self, doc: &mut Document) -> Result<(), EditError> {
        let (command, _) = self.undone.pop().ok_or(EditError::Nothing("redo"))?;
        let inverse = command.apply(doc)?;
        self.done.push((command, inverse));
        self.mark(doc);
        Ok(())
    }

    /// Steps that can be undone.
    pub fn undo_steps(&self) -> usize {
        self.done.len()
    }

    /// Steps that can be redone.
    pub fn redo_steps(&self) -> usize {
        self.undone.len()
    }
}

/// What [`Command::mirror_across`] made: the step, how many controls it
/// adds, and for each image how far it was put onto the surface, in units
/// of its layer's R (0 when it was not: a start off the surface, or an
/// exact image on it).
#[derive(Clone, Debug, PartialEq)]
pub struct Mirrored {
    /// The new controls, as one step.
    pub command: Command,
    /// How many.
    pub added: usize,
    /// Each image's move onto the surface, in R.
    pub gaps: Vec<f64>,
}

impl Mirrored {
    /// The largest move onto the surface, in R (0 for none).
    pub fn largest_gap(&self) -> f64 {
        self.gaps.iter().copied().fold(0.0, f64::max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn doc() -> Document {
        Document::new(
            csrbf_mesh::shapes::uv_sphere(1.0, 8, 16),
            PathBuf::from("s.obj"),
            0.5,
        )
    }

    #[test]
    fn mirror_adds_each_image_once_and_none_for_a_start_on_the_plane() {
        let mut d = doc();
        let mut h = History::default();
        h.apply(
            &mut d,
            Command::add(0, DVec3::new(0.5, 0.2, 0.0), DVec3::new(0.6, 0.2, 0.0)),
        )
        .unwrap();
        h.apply(&mut d, Command::add(0, DVec3::new(0.0, 0.9, 0.1), DVec3::Y))
            .unwrap();
        // Across X: the first has an image, the second is on the plane.
        let (c, n) = Command::mirror(&d, 0, 0.0).expect("one image");
        assert_eq!(n, 1);
        h.apply(&mut d, c).unwrap();
        let s = &d.controls.deformations[0];
        assert_eq!(s.starts[2], DVec3::new(-0.5, 0.2, 0.0));
        assert_eq!(s.targets[2], DVec3::new(-0.6, 0.2, 0.0));
        // Mirrored again: every image is already there.
        assert!(Command::mirror(&d, 0, 0.0).is_none());
        // Only the selection when there is one.
        d.selection.0 = vec![(0, 0)];
        let (_, n) = Command::mirror(&d, 1, 0.0).expect("image across Y");
        // Across another plane: the image is there.
        let (Command::Batch(b), _) = Command::mirror(&d, 0, 0.25).expect("image") else {
            panic!("a batch");
        };
        assert!(
            matches!(b[0], Command::Insert { start, .. } if start == DVec3::new(0.0, 0.2, 0.0))
        );
        assert_eq!(n, 1);
    }

    #[test]
    fn an_image_of_a_start_on_the_surface_is_put_on_the_surface() {
        // Issue 42: across a plane the sphere is not symmetric about (x =
        // 0.05) and a tilted one, an image floats off the surface: it is
        // put on the surface's nearest point, the move reported in R.
        let mut d = doc();
        let mut h = History::default();
        let v = (d.mesh.positions.iter())
            .map(|p| p.as_dvec3())
            .max_by(|a, b| (a.x + 0.3 * a.y).total_cmp(&(b.x + 0.3 * b.y)))
            .expect("vertices");
        assert!(v.x > 0.2, "{v}");
        h.apply(&mut d, Command::add(0, v, v * 1.1)).unwrap();
        let bvh = csrbf_mesh::Bvh::new(&d.mesh.positions, &d.mesh.faces.triangles());
        for plane in [
            crate::symmetry::Plane::axis(0, 0.05).expect("x = 0.05"),
            crate::symmetry::Plane::new(DVec3::ZERO, DVec3::new(1.0, 0.3, -0.2)).expect("tilted"),
        ] {
            let m = Command::mirror_across(&d, &plane).expect("an image");
            assert_eq!(m.added, 1);
            let Command::Batch(b) = &m.command else {
                panic!("a batch")
            };
            let Command::Insert { start, target, .. } = b[0] else {
                panic!("an insert")
            };
            let off = bvh
                .nearest(&d.mesh.positions, start.as_vec3())
                .expect("a face")
                .distance;
            assert!(off < 1e-6, "{start} is {off} off the surface");
            assert!(m.largest_gap() > 0.0 && m.largest_gap() < 0.5, "{m:?}");
            // The destination moved as the start's, mirrored.
            let want = plane.reflect_vector(v * 0.1);
            assert!((target - start - want).length() < 1e-12, "{target} {start}");
        }
    }

    #[test]
    fn chosen_vertices_become_a_handle_layer_an_anchor_or_a_region() {
        use crate::tools::VertexTarget;
        let mut d = doc();
        let mut h = History::default();
        h.apply(&mut d, Command::add(0, DVec3::Y, DVec3::Y * 1.2))
            .unwrap();
        let spec = d.controls.deformations[0].clone();
        let c = Command::use_vertices(&d, &spec, vec![1, 2], VertexTarget::Handle);
        h.apply(&mut d, c).unwrap();
        let new = &d.controls.deformations[1];
        assert!(new.starts.is_empty() && new.anchor.is_none());
        assert_eq!(
            new.handle.as_ref().map(|h| &h.select),
            Some(&csrbf::Region::Vertices(vec![1, 2]))
        );
        assert_eq!(new.options, spec.options);
        for (target, anchor) in [(VertexTarget::Anchor, true), (VertexTarget::Region, false)] {
            let c = Command::use_vertices(&d, &spec, vec![3], target);
            h.apply(&mut d, c).unwrap();
            let layer = &d.controls.deformations[0];
            assert_eq!(layer.starts, spec.starts, "the controls stay");
            let got = if anchor {
                layer.anchor.clone()
            } else {
                Some(layer.region.clone())
            };
            assert_eq!(got, Some(csrbf::Region::Vertices(vec![3])));
        }
    }

    #[test]
    fn a_handle_takes_an_empty_layer_and_a_second_handle_adds_one() {
        use crate::tools::VertexTarget;
        let mut d = doc();
        let mut h = History::default();
        // The new document's empty Layer 1 becomes the handle: no empty
        // layer is left behind to be saved.
        let spec = d.controls.deformations[0].clone();
        let c = Command::use_vertices(&d, &spec, vec![1, 2], VertexTarget::Handle);
        h.apply(&mut d, c).unwrap();
        assert_eq!(d.controls.deformations.len(), 1);
        assert!(d.controls.deformations[0].handle.is_some());
        // A second handle on that layer is a new layer; the first stays.
        let spec = d.controls.deformations[0].clone();
        let c = Command::use_vertices(&d, &spec, vec![5], VertexTarget::Handle);
        h.apply(&mut d, c).unwrap();
        assert_eq!(d.controls.deformations.len(), 2);
        let selects: Vec<_> = (d.controls.deformations.iter())
            .map(|s| s.handle.as_ref().map(|h| h.select.clone()))
            .collect();
        assert_eq!(
            selects,
            [
                Some(csrbf::Region::Vertices(vec![1, 2])),
                Some(csrbf::Region::Vertices(vec![5]))
            ]
        );
    }

    #[test]
    fn undoing_back_to_the_saved_state_is_saved_and_leaving_it_is_not() {
        let mut d = doc();
        let mut h = History::default();
        h.apply(&mut d, Command::add(0, DVec3::Y, DVec3::Y * 1.2))
            .unwrap();
        assert!(d.dirty);
        h.mark_saved(&mut d);
        assert!(!d.dirty);
        h.apply(&mut d, Command::add(0, DVec3::X, DVec3::X))
            .unwrap();
        assert!(d.dirty);
        h.undo(&mut d).unwrap();
        assert!(!d.dirty, "back at the saved state");
        h.undo(&mut d).unwrap();
        assert!(d.dirty, "before it");
        h.redo(&mut d).unwrap();
        assert!(!d.dirty);
        // A drag that merges into the saved step changes it.
        h.begin_drag();
        h.apply(
            &mut d,
            Command::SetTarget {
                layer: 0,
                index: 0,
                target: DVec3::Z,
            },
        )
        .unwrap();
        h.apply(
            &mut d,
            Command::SetTarget {
                layer: 0,
                index: 0,
                target: DVec3::ZERO,
            },
        )
        .unwrap();
        h.end_drag();
        h.undo(&mut d).unwrap();
        assert!(!d.dirty, "the drag was one step after the saved one");
        // A new edit after undoing below the saved state loses it.
        h.undo(&mut d).unwrap();
        h.apply(&mut d, Command::add(0, DVec3::Z, DVec3::Z))
            .unwrap();
        h.undo(&mut d).unwrap();
        assert!(d.dirty, "the saved state is not reachable any more");
        // A restored session is unsaved however far it is undone.
        h.mark_unsaved(&mut d);
        assert!(d.dirty);
    }

    #[test]
    fn every_command_undoes_exactly() {
        let mut d = doc();
        let mut h = History::default();
        let before = d.controls.clone();
        let layer = Box::new(ControlSpec::new(
            vec![DVec3::X],
            vec![DVec3::X * 1.1],
            csrbf::FitOptions::new(0.3),
        ));
        let steps = vec![
            Command::add(0, DVec3::Y, DVec3::Y * 1.2),
            Command::add(0, DVec3::Z, DVec3::Z),
            Command::SetTarget {
                layer: 0,
                index: 1,
                target: DVec3::Z * 1.3,
            },
            Command::SetStart {
                layer: 0,
                index: 0,
                start: DVec3::NEG_Y,
            },
            Command::MoveControl {
                layer: 0,
                index: 1,
                start: DVec3::X,
                target: DVec3::X * 1.5,
            },
            Command::SetRadius {
                layer: 0,
                radius: 0.8,
            },
            Command::SetKernel {
                layer: 0,
                kernel: Kernel::C4,
            },
            Command::InsertLayer {
                layer: 1,
                spec: layer.clone(),
            },
            Command::ReplaceLayer {
                layer: 1,
                spec: layer,
            },
            Command::Remove { layer: 0, index: 0 },
            Command::RemoveLayer { layer: 0 },
        ];
        let mut states = vec![d.controls.clone()];
        for c in steps {
            h.apply(&mut d, c).expect("apply");
            states.push(d.controls.clone());
        }
        assert!(d.dirty);
        // Undo walks back through every state exactly, redo forward again.
        for want in states.iter().rev().skip(1) {
            h.undo(&mut d).expect("undo");
            assert_eq!(&d.controls, want);
        }
        assert_eq!(d.controls, before);
        assert_eq!(h.undo(&mut d), Err(EditError::Nothing("undo")));
        for want in states.iter().skip(1) {
            h.redo(&mut d).expect("redo");
            assert_eq!(&d.controls, want);
        }
    }

    #[test]
    fn a_control_placed_and_dragged_out_in_one_gesture_is_one_step() {
        let mut d = doc();
        let before = d.controls.clone();
        let mut h = History::default();
        h.begin_drag();
        h.apply(&mut d, Command::add(0, DVec3::Y, DVec3::Y))
            .expect("add");
        for k in 1..=5 {
            let target = DVec3::Y * (1.0 + 0.1 * k as f64);
            let set = Command::SetTarget {
                layer: 0,
                index: 0,
                target,
            };
            h.apply(&mut d, set).expect("drag");
        }
        h.end_drag();
        assert_eq!(h.undo_steps(), 1);
        let placed = d.controls.clone();
        assert_eq!(placed.deformations[0].targets[0], DVec3::Y * 1.5);
        h.undo(&mut d).expect("undo");
        assert_eq!(d.controls, before, "the control is gone");
        h.redo(&mut d).expect("redo");
        assert_eq!(d.controls, placed, "back where the drag left it");
        // Placed without a drag (a click, then a later drag): two steps.
        h.apply(&mut d, Command::add(0, DVec3::X, DVec3::X))
            .expect("add");
        h.begin_drag();
        let set = Command::SetTarget {
            layer: 0,
            index: 1,
            target: DVec3::X * 2.0,
        };
        h.apply(&mut d, set).expect("drag");
        h.end_drag();
        assert_eq!(h.undo_steps(), 3);
    }

    #[test]
    fn a_drag_is_one_step_and_bad_edits_change_nothing() {
        let mut d = doc();
        let mut h = History::default();
        h.apply(&mut d, Command::add(0, DVec3::Y, DVec3::Y))
            .expect("add");
        h.begin_drag();
        for k in 1..=10 {
            let target = DVec3::Y * (1.0 + 0.01 * k as f64);
            h.apply(
                &mut d,
                Command::SetTarget {
                    layer: 0,
                    index: 0,
                    target,
                },
            )
            .expect("drag");
        }
        h.end_drag();
        assert_eq!(h.undo_steps(), 2);
        // A second drag of the same destination is a step of its own.
        h.begin_drag();
        let moved = d.controls.deformations[0].targets[0];
        h.apply(
            &mut d,
            Command::SetTarget {
                layer: 0,
                index: 0,
                target: DVec3::X,
            },
        )
        .expect("drag");
        h.end_drag();
        assert_eq!(h.undo_steps(), 3);
        h.undo(&mut d).expect("undo");
        assert_eq!(d.controls.deformations[0].targets[0], moved);
        h.undo(&mut d).expect("undo");
        assert_eq!(d.controls.deformations[0].targets[0], DVec3::Y);
        // Several edits as one step, all or none.
        let before = d.controls.clone();
        h.apply(
            &mut d,
            Command::Batch(vec![
                Command::add(0, DVec3::X, DVec3::X),
                Command::add(0, DVec3::Z, DVec3::Z * 1.1),
            ]),
        )
        .expect("batch");
        assert_eq!(d.controls.deformations[0].starts.len(), 3);
        h.undo(&mut d).expect("undo");
        assert_eq!(d.controls, before);
        let bad = Command::Batch(vec![
            Command::add(0, DVec3::X, DVec3::X),
            Command::RemoveLayer { layer: 5 },
        ]);
        assert!(h.apply(&mut d, bad).is_err());
        assert_eq!(d.controls, before, "a failed batch leaves nothing behind");
        let snapshot = d.controls.clone();
        for bad in [
            Command::SetRadius {
                layer: 0,
                radius: 0.0,
            },
            Command::SetRadius {
                layer: 0,
                radius: -1.0,
            },
            Command::SetTarget {
                layer: 0,
                index: 7,
                target: DVec3::ONE,
            },
            Command::add(3, DVec3::ONE, DVec3::ONE),
            Command::add(0, DVec3::NAN, DVec3::ONE),
            Command::RemoveLayer { layer: 0 },
        ] {
            assert!(bad.apply(&mut d).is_err(), "{bad:?}");
            assert_eq!(d.controls, snapshot, "{bad:?} changed the document");
        }
    }
}
