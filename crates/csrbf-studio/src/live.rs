//! The live preview of a [`Document`]: the deformed positions, what the
//! diagnostics say about them, and a picking tree over them.
//!
//! The layers run through a [`Pipeline`], which keeps each one's factored
//! system, solved deformation and binding: moving destinations, the drag,
//! costs one solve per changed layer and a product through the bindings; a
//! new start or radius rebuilds only that layer's system. The tree is built
//! once and refitted to the moved positions.

use csrbf::glam::Vec3;
use csrbf::{Diagnostics, Pipeline, Stage, diagnose};
use csrbf_edit::controls::SurfaceCache;
use csrbf_mesh::Bvh;

use crate::state::Document;

/// The deformed document, kept up to date by [`Live::update`].
pub struct Live {
    pipeline: Pipeline,
    /// The layer of each pipeline stage (layers without controls have none).
    layers: Vec<usize>,
    /// Systems factored by pipelines replaced since.
    earlier_systems: usize,
    triangles: Vec<[u32; 3]>,
    positions: Vec<Vec3>,
    diagnostics: Option<Diagnostics>,
    bvh: Option<Bvh>,
    /// Control vectors in use: the file's and those its handles make.
    controls: usize,
    /// The surface's graph and the connected regions resolved lately: a
    /// drag step that moves destinations only walks the surface again for
    /// none of them.
    surface: SurfaceCache,
}

impl Live {
    /// The preview of `doc` at rest (call [`Live::update`] to deform it),
    /// with a picking tree.
    pub fn new(doc: &Document) -> Live {
        let mut live = Live::without_picking(doc);
        live.bvh = Some(Bvh::new(&doc.mesh.positions, &live.triangles));
        live
    }

    /// [`Live::new`] without the picking tree (for a caller that keeps its
    /// own, as the app's worker does: on a 2M-triangle mesh the tree is the
    /// largest thing the preview would hold).
    pub fn without_picking(doc: &Document) -> Live {
        let triangles = doc.mesh.faces.triangles();
        let bvh = None;
        Live {
            pipeline: Pipeline::new(Vec::new()),
            layers: Vec::new(),
            earlier_systems: 0,
            controls: 0,
            surface: SurfaceCache::default(),
            triangles,
            positions: doc.mesh.positions.clone(),
            diagnostics: None,
            bvh,
        }
    }

    /// Deforms the document as it now stands and diagnoses the result. On
    /// error (a layer the engine refuses: coincident starts, a radius too
    /// small for the mesh) the previous preview stays and the error says
    /// which layer.
    pub fn update(&mut self, doc: &Document) -> Result<(), LiveError> {
        self.update_positions(doc)?;
        let lookup = |n: &str| doc.mesh.part_vertices(n);
        // Every layer's fitted stages (a sweep's every step).
        let fitted: Vec<_> = (0..self.layers.len())
            .filter_map(|k| self.pipeline.fitted_stages(k))
            .flatten()
            .collect();
        let layer = self.layers.first().copied().unwrap_or(0);
        let report = diagnose(
            &doc.mesh.positions,
            &self.positions,
            &self.triangles,
            &fitted,
            self.pipeline.combine(),
            &lookup,
        )
        .map_err(|source| LiveError { layer, source })?;
        let mut report = report;
        // Faces the edit made pass through each other (as `csrbf deform`
        // checks them: up to its limit of triangles).
        if self.triangles.len() <= csrbf_edit::apply::SELF_INTERSECTION_TRIANGLES {
            report.set_self_intersections(csrbf_mesh::intersect::new_self_intersections(
                &doc.mesh.positions,
                &self.positions,
                &self.triangles,
            ));
        }
        self.diagnostics = Some(report);
        if let Some(b) = self.bvh.as_mut() {
            b.refit(&self.positions);
        }
        Ok(())
    }

    /// [`Live::update`] without the diagnostics, which then read None, and
    /// without refitting the picking tree: for the steps of a drag, where
    /// they would cost more than the deformation (on a 1M-vertex mesh, 90
    /// and 26 ms against 30 ms); call `update` on release.
    pub fn update_positions(&mut self, doc: &Document) -> Result<(), LiveError> {
        let lookup = |n: &str| doc.mesh.part_vertices(n);
        let mut stages = Vec::new();
        let mut layers = Vec::new();
        let mut controls = 0;
        for (layer, spec) in doc.controls.deformations.iter().enumerate() {
            // A connected region is measured along the surface: the
            // triangles go with the points.
            let spec = spec
                .resolve_cached(
                    &doc.mesh.positions,
                    &self.triangles,
                    &lookup,
                    &mut self.surface,
                )
                .map_err(|source| LiveError { layer, source })?;
            controls += spec.starts.len();
            if !spec.starts.is_empty() {
                let stage = spec
                    .to_stage()
                    .map_err(|source| LiveError { layer, source })?;
                stages.push(stage.with_phase(spec.phase * doc.phase));
                layers.push(layer);
            }
        }
        self.controls = controls;
        self.sync(doc, stages, layers);
        for (k, &layer) in self.layers.iter().enumerate() {
            self.pipeline
                .deformation(k)
                .map_err(|source| LiveError { layer, source })?;
        }
        let layer = self.layers.first().copied().unwrap_or(0);
        let moved = self
            .pipeline
            .evaluate()
            .map_err(|source| LiveError { layer, source })?
            .to_vec();
        self.positions = moved;
        self.diagnostics = None;
        Ok(())
    }

    /// Brings the pipeline to these stages, telling it only what changed (a
    /// new set of layers or a new combine starts a new pipeline).
    fn sync(&mut self, doc: &Document, stages: Vec<Stage>, layers: Vec<usize>) {
        let same_shape = layers == self.layers
            && self.pipeline.combine() == doc.controls.combine
            && self.pipeline.rest().len() == doc.mesh.positions.len();
        if !same_shape {
            self.earlier_systems += self.pipeline.work().systems;
            let groups = doc
                .mesh
                .parts
                .iter()
                .filter_map(|p| Some((p.name.clone(), doc.mesh.part_vertices(&p.name)?)))
                .collect();
            self.pipeline = Pipeline::new(doc.mesh.positions.clone())
                .with_combine(doc.controls.combine)
                .with_groups(groups);
            for stage in stages {
                self.pipeline.push(stage);
            }
            self.layers = layers;
            return;
        }
        for (k, new) in stages.into_iter().enumerate() {
            let Some(old) = self.pipeline.stage(k) else {
                continue;
            };
            let sweep = old.sweep != new.sweep || old.paths != new.paths;
            let (starts, targets, options, region, phase) = (
                old.starts != new.starts,
                old.targets != new.targets,
                old.options != new.options,
                old.region != new.region,
                old.phase != new.phase,
            );
            // The index exists (checked above), so these calls cannot fail;
            // a phase outside [0, 1] is refused by the evaluation instead.
            let p = &mut self.pipeline;
            if starts {
                let _ = p.set_controls(k, new.starts, new.targets);
            } else if targets {
                let _ = p.set_targets(k, new.targets);
            }
            if options {
                let _ = p.set_options(k, new.options);
            }
            if region {
                let _ = p.set_region(k, new.region);
            }
            if phase {
                let _ = p.set_phase(k, new.phase);
            }
            if sweep {
                let _ = p.set_sweep(k, new.sweep, new.paths.clone());
            }
        }
    }

    /// The deformed positions (the rest ones before the first update).
    pub fn positions(&self) -> &[Vec3] {
        &self.positions
    }

    /// The triangles of the mesh, as the picking tree and the renderer see them.
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// The picking tree, fitted to [`Live::positions`] as of the last
    /// [`Live::update`] (a drag's steps do not refit it); None for a
    /// [`Live::without_picking`].
    pub fn bvh(&self) -> Option<&Bvh> {
        self.bvh.as_ref()
    }

    /// What the last update found (folds, starts out of reach), if any.
    pub fn diagnostics(&self) -> Option<&Diagnostics> {
        self.diagnostics.as_ref()
    }

    /// How many control vectors the last update used: the file's, and those
    /// its handles made on the mesh.
    pub fn controls(&self) -> usize {
        self.controls
    }

    /// How many systems were factored so far (a drag should not add any).
    pub fn factorisations(&self) -> usize {
        self.earlier_systems + self.pipeline.work().systems
    }
}

/// A layer the engine refused, and why.
#[derive(Debug, thiserror::Error)]
#[error("layer {layer}")]
pub struct LiveError {
    /// Which layer.
    pub layer: usize,
    /// Why.
    #[source]
    pub source: csrbf::Error,
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
