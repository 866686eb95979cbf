//! The live preview of a [`Document`]: the deformed positions, what the
//! diagnostics say about them, and a picking tree over them.
//!
//! Each layer's [`System`] (octree, ordering, factorisation) is kept between
//! updates and built again only when that layer's starts or options change;
//! moving destinations, the drag, costs one solve per layer and the
//! evaluation. The tree is built once and refitted to the moved positions.

use csrbf::glam::{DVec3, Vec3};
use csrbf::{Diagnostics, FitOptions, System, compose_diagnosed};
use csrbf_mesh::Bvh;

use crate::state::Document;

/// A layer's factored system and what it was built from.
struct Factored {
    starts: Vec<DVec3>,
    options: FitOptions,
    system: System,
}

/// The deformed document, kept up to date by [`Live::update`].
pub struct Live {
    factored: Vec<Option<Factored>>,
    triangles: Vec<[u32; 3]>,
    positions: Vec<Vec3>,
    diagnostics: Option<Diagnostics>,
    bvh: Bvh,
    factorisations: usize,
}

impl Live {
    /// The preview of `doc` at rest (call [`Live::update`] to deform it).
    pub fn new(doc: &Document) -> Live {
        let triangles = doc.mesh.faces.triangles();
        let bvh = Bvh::new(&doc.mesh.positions, &triangles);
        Live {
            factored: Vec::new(),
            triangles,
            positions: doc.mesh.positions.clone(),
            diagnostics: None,
            bvh,
            factorisations: 0,
        }
    }

    /// Deforms the document as it now stands. On error (a layer the engine
    /// refuses: coincident starts, a radius too small for the mesh) the
    /// previous preview stays and the error says which layer.
    pub fn update(&mut self, doc: &Document) -> Result<(), LiveError> {
        let lookup = |n: &str| doc.mesh.part_vertices(n);
        let layers = &doc.controls.deformations;
        self.factored.resize_with(layers.len(), || None);
        self.factored.truncate(layers.len());
        let mut stages = Vec::with_capacity(layers.len());
        for (layer, spec) in layers.iter().enumerate() {
            let engine = |source| LiveError { layer, source };
            let spec = spec.resolve(&doc.mesh.positions, &lookup).map_err(engine)?;
            if spec.starts.is_empty() {
                self.factored[layer] = None;
                continue;
            }
            let slot = &mut self.factored[layer];
            let reusable = slot
                .as_ref()
                .is_some_and(|f| f.starts == spec.starts && f.options == spec.options);
            if !reusable {
                let system = System::new(&spec.starts, spec.options).map_err(engine)?;
                self.factorisations += 1;
                *slot = Some(Factored {
                    starts: spec.starts.clone(),
                    options: spec.options,
                    system,
                });
            }
            let Some(f) = slot.as_ref() else { continue };
            let deformation = f.system.solve(&spec.targets).map_err(engine)?;
            stages.push((deformation, spec.region.clone(), spec.phase * doc.phase));
        }
        let (moved, report) = compose_diagnosed(
            &doc.mesh.positions,
            &stages,
            doc.controls.combine,
            &self.triangles,
            &lookup,
        )
        .map_err(|source| LiveError { layer: 0, source })?;
        self.positions = moved;
        self.bvh.refit(&self.positions);
        self.diagnostics = Some(report);
        Ok(())
    }

    /// The deformed positions (the rest ones before the first update).
    pub fn positions(&self) -> &[Vec3] {
        &self.positions
    }

    /// The triangles of the mesh, as the picking tree and the renderer see them.
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// The picking tree over [`Live::positions`].
    pub fn bvh(&self) -> &Bvh {
        &self.bvh
    }

    /// What the last update found (folds, starts out of reach), if any.
    pub fn diagnostics(&self) -> Option<&Diagnostics> {
        self.diagnostics.as_ref()
    }

    /// How many systems were factored so far (a drag should not add any).
    pub fn factorisations(&self) -> usize {
        self.factorisations
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
            live.update(&doc).expect("update");
        }
        history.end_drag();
        assert_eq!(live.factorisations(), 1, "a drag must not refactor");

        // The cached result is the one a fresh fit of the same file gives.
        let mut fresh = doc.mesh.clone();
        csrbf_anim::apply::deform_mesh(&mut fresh, &doc.controls, doc.phase).expect("fresh fit");
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
}
