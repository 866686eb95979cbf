//! The live preview of a [`Document`]: the edit layer's [`Session`] (each
//! layer's factored system, solve and binding kept; the one report) and a
//! picking tree over the deformed positions, built once and refitted.

use csrbf::Diagnostics;
use csrbf::glam::Vec3;
use csrbf_edit::{Checks, RemedySearch, Report, Session};
use csrbf_mesh::Bvh;

use crate::state::Document;

/// A layer the engine refused, and why (the edit layer's).
pub use csrbf_edit::SessionError as LiveError;

/// The deformed document, kept up to date by [`Live::update`].
pub struct Live {
    session: Session,
    bvh: Option<Bvh>,
}

impl Live {
    /// The preview of `doc` at rest (call [`Live::update`] to deform it),
    /// with a picking tree.
    pub fn new(doc: &Document) -> Live {
        let mut live = Live::without_picking(doc);
        live.bvh = Some(Bvh::new(&doc.mesh.positions, live.session.triangles()));
        live
    }

    /// [`Live::new`] without the picking tree (for a caller that keeps its
    /// own, as the app's worker does: on a 2M-triangle mesh the tree is the
    /// largest thing the preview would hold).
    pub fn without_picking(doc: &Document) -> Live {
        Live {
            session: Session::new(&doc.mesh),
            bvh: None,
        }
    }

    /// Deforms the document as it now stands and checks the result as
    /// `csrbf deform` does (its report, remedies within their bound when a
    /// face folds). On error (a layer the engine refuses: coincident starts,
    /// a radius too small for the mesh) the previous preview stays and the
    /// error says which layer.
    pub fn update(&mut self, doc: &Document) -> Result<(), LiveError> {
        self.session.update(
            &doc.mesh,
            &doc.controls,
            doc.phase,
            &Checks::default(),
            RemedySearch::Bounded,
        )?;
        if let Some(b) = self.bvh.as_mut() {
            b.refit(self.session.positions());
        }
        Ok(())
    }

    /// [`Live::update`] without the checks, which then read None, and
    /// without refitting the picking tree: for the steps of a drag, where
    /// they would cost more than the deformation (on a 1M-vertex mesh, 90
    /// and 26 ms against 30 ms); call `update` on release.
    pub fn update_positions(&mut self, doc: &Document) -> Result<(), LiveError> {
        self.session
            .update_positions(&doc.mesh, &doc.controls, doc.phase)?;
        Ok(())
    }

    /// The deformed positions (the rest ones before the first update).
    pub fn positions(&self) -> &[Vec3] {
        self.session.positions()
    }

    /// The triangles of the mesh, as the picking tree and the renderer see them.
    pub fn triangles(&self) -> &[[u32; 3]] {
        self.session.triangles()
    }

    /// The picking tree, fitted to [`Live::positions`] as of the last
    /// [`Live::update`] (a drag's steps do not refit it); None for a
    /// [`Live::without_picking`].
    pub fn bvh(&self) -> Option<&Bvh> {
        self.bvh.as_ref()
    }

    /// What the last update found (folds, starts out of reach), if any.
    pub fn diagnostics(&self) -> Option<&Diagnostics> {
        self.session.report().map(|r| &r.diagnostics)
    }

    /// The last update's whole report (the diagnostics, the remedies'
    /// advice), as `csrbf deform` makes it.
    pub fn report(&self) -> Option<&Report> {
        self.session.report()
    }

    /// How many control vectors the last update used: the file's, and those
    /// its handles made on the mesh.
    pub fn controls(&self) -> usize {
        self.session.controls()
    }

    /// How many systems were factored so far (a drag should not add any).
    pub fn factorisations(&self) -> usize {
        self.session.factorisations()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Command, History};
    use csrbf::glam::DVec3;
    use std::path::PathBuf;

    #[test]
    fn a_drag_solves_again_without_refactoring_and_matches_a_fresh_fit() {
        let mesh = csrbf_mesh::shapes::uv_sphere(1.0, 16, 32);
        let mut doc = Document::new(mesh, PathBuf::from("s.obj"), 0.6);
        let mut history = History::default();
        let mut live = Live::new(&doc);
        live.update(&doc).expect("empty document");
        assert_eq!(live.positions(), &doc.mesh.positions[..]);
        assert_eq!(live.factorisations(), 0);

        history
            .apply(&mut doc, Command::add(0, DVec3::Y, DVec3::Y))
            .expect("add");
        history
            .apply(&mut doc, Command::add(0, DVec3::NEG_Y, DVec3::NEG_Y))
            .expect("add");
        live.update(&doc).expect("update");
        assert_eq!(live.factorisations(), 1);
        history.begin_drag();
        for k in 1..=5 {
            let target = DVec3::Y * (1.0 + 0.05 * k as f64);
            history
                .apply(
                    &mut doc,
                    Command::SetTarget {
                        layer: 0,
                        index: 0,
                        target,
                    },
                )
                .expect("drag");
            live.update_positions(&doc).expect("update");
            assert!(live.diagnostics().is_none(), "not diagnosed while dragging");
        }
        history.end_drag();
        live.update(&doc).expect("update on release");
        let report = live.diagnostics().expect("diagnosed on release");
        assert!(report.moved > 0 && report.flipped.is_empty(), "{report:?}");
        assert_eq!(live.factorisations(), 1, "a drag must not refactor");

        // The cached result is the one a fresh fit of the same file gives.
        let mut fresh = (*doc.mesh).clone();
        csrbf_edit::apply::deform_mesh(&mut fresh, &doc.controls, doc.phase).expect("fresh fit");
        for (a, b) in live.positions().iter().zip(&fresh.positions) {
            assert!((*a - *b).length() < 1e-5, "{a} vs {b}");
        }
        // The pole followed its destination: exact interpolation.
        let top = live
            .positions()
            .iter()
            .zip(&doc.mesh.positions)
            .find(|(_, r)| (r.as_dvec3() - DVec3::Y).length() < 1e-6)
            .map(|(p, _)| *p)
            .expect("the sphere has a pole at +Y");
        assert!((top.as_dvec3() - DVec3::Y * 1.25).length() < 1e-4, "{top}");

        // Moving a start refactors; a refused layer keeps the last preview.
        history
            .apply(
                &mut doc,
                Command::SetStart {
                    layer: 0,
                    index: 1,
                    start: DVec3::X,
                },
            )
            .expect("start");
        live.update(&doc).expect("update");
        assert_eq!(live.factorisations(), 2);
        let kept = live.positions().to_vec();
        history
            .apply(&mut doc, Command::add(0, DVec3::X, DVec3::X * 2.0))
            .expect("a duplicate start is an edit the engine refuses");
        let err = live.update(&doc).expect_err("coincident starts");
        assert_eq!(err.layer, 0);
        assert_eq!(live.positions(), &kept[..]);
    }

    /// Issue 17: a layer made a sweep (the panel's toggle is a
    /// `ReplaceLayer`, undone like any edit) stops folding in the preview,
    /// and the preview is what `csrbf deform` gives for the same file.
    #[test]
    fn a_sweep_layer_previews_without_folds_and_undoes() {
        let mesh = csrbf_mesh::shapes::uv_sphere(1.0, 24, 48);
        let mut doc = Document::new(mesh, PathBuf::from("s.obj"), 0.5);
        let mut history = History::default();
        let mut live = Live::new(&doc);
        // A pull far past the fold-free bound at R 0.5.
        history
            .apply(
                &mut doc,
                Command::add(0, DVec3::Y, DVec3::new(0.7, 1.0, 0.0)),
            )
            .expect("add");
        live.update(&doc).expect("update");
        let folded = live.diagnostics().expect("diagnosed").inside_out.len();
        assert!(folded > 0, "the single map should fold");
        let mut swept = doc.controls.deformations[0].clone();
        swept.sweep = Some(csrbf::SweepOptions::default());
        history
            .apply(
                &mut doc,
                Command::ReplaceLayer {
                    layer: 0,
                    spec: Box::new(swept),
                },
            )
            .expect("sweep");
        live.update(&doc).expect("update");
        let report = live.diagnostics().expect("diagnosed");
        assert!(
            report.inside_out.is_empty() && report.fold_phase.is_none(),
            "{report:?}"
        );
        let mut fresh = (*doc.mesh).clone();
        csrbf_edit::apply::deform_mesh(&mut fresh, &doc.controls, doc.phase).expect("fresh fit");
        for (a, b) in live.positions().iter().zip(&fresh.positions) {
            assert!((*a - *b).length() < 1e-5, "{a} vs {b}");
        }
        history.undo(&mut doc).expect("undo");
        live.update(&doc).expect("update");
        assert_eq!(
            live.diagnostics().expect("diagnosed").inside_out.len(),
            folded
        );
    }

    #[test]
    fn a_handle_layer_counts_the_controls_it_makes() {
        let mesh = csrbf_mesh::shapes::uv_sphere(1.0, 16, 32);
        let mut doc = Document::new(mesh, PathBuf::from("s.obj"), 0.6);
        let top: Vec<u32> = (0..doc.mesh.positions.len() as u32)
            .filter(|&v| doc.mesh.positions[v as usize].y > 0.8)
            .collect();
        let spec = doc.controls.deformations[0].clone();
        let handle = Command::use_vertices(&doc, &spec, top, crate::tools::VertexTarget::Handle);
        History::default().apply(&mut doc, handle).expect("handle");
        assert!(doc.controls.deformations[0].starts.is_empty());
        let mut live = Live::new(&doc);
        live.update(&doc).expect("update");
        assert!(live.controls() > 0, "the handle's vectors count");
    }
}
