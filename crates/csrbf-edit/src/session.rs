//! A live edit: a control document on one mesh, deformed again and again as
//! it changes (the studio's preview, Blender's Live, Python's `Session`),
//! each layer's factored system, solved deformation and binding kept.
//!
//! The layers run through a [`Pipeline`]: moving destinations (a drag)
//! costs one solve per changed layer and a product through the bindings; a
//! new start, radius or kernel refits only that layer; regions, phases,
//! handles and sweeps are applied here, so no front end places a region or
//! refuses a start itself. [`Session::update`] also checks the result and
//! makes the one [`Report`] (remedies included, as asked).

use std::time::Instant;

use csrbf::{Pipeline, Stage};
use csrbf_mesh::Mesh;
use glam::Vec3;

use crate::apply::{Checks, check_region, compose_checked};
use crate::controls::{ControlFile, ControlSpec, SurfaceCache};
use crate::remedy::{RemedySearch, remedies};
use crate::report::Report;

/// A control document deformed live on one mesh, kept up to date by
/// [`Session::update`] (positions and report) or
/// [`Session::update_positions`] (positions alone, for a drag's steps).
///
/// ```
/// use csrbf_edit::{Checks, ControlFile, RemedySearch, Session};
/// use csrbf_mesh::shapes::uv_sphere;
///
/// let mesh = uv_sphere(1.0, 8, 16);
/// let mut session = Session::new(&mesh);
/// for step in 1..=3 {
///     let z = 1.0 + 0.05 * step as f64; // the pointer moves the destination
///     let file = ControlFile::parse(&format!(
///         r#"{{"radius": 0.8, "controls": [{{"from": [0, 0, 1], "to": [0, 0, {z}]}}]}}"#
///     ))?;
///     session.update_positions(&mesh, &file, 1.0)?;
/// }
/// assert_eq!(session.factorisations(), 1); // solved again, never refactored
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct Session {
    pipeline: Pipeline,
    /// The layer of each pipeline stage (layers without controls have none).
    layers: Vec<usize>,
    /// The layers resolved on the mesh, for the remedies.
    specs: Vec<ControlSpec>,
    /// Systems factored by pipelines replaced since.
    earlier_systems: usize,
    triangles: Vec<[u32; 3]>,
    positions: Vec<Vec3>,
    report: Option<Report>,
    /// Control vectors in use: the file's and those its handles make.
    controls: usize,
    /// The milliseconds of the last update's resolution and deformation.
    update_ms: f64,
    /// The surface's graph and the connected regions resolved lately: a
    /// drag step that moves destinations only walks the surface again for
    /// none of them.
    surface: SurfaceCache,
}

/// A layer the engine refused, and why.
#[derive(Debug, thiserror::Error)]
#[error("layer {layer}")]
pub struct SessionError {
    /// Which layer (the control file's deformation, from 0).
    pub layer: usize,
    /// Why.
    #[source]
    pub source: csrbf::Error,
}

impl Session {
    /// A session on `mesh` at rest (call [`Session::update`] to deform it).
    /// Give every update the same mesh.
    pub fn new(mesh: &Mesh) -> Session {
        Session {
            pipeline: Pipeline::new(Vec::new()),
            layers: Vec::new(),
            specs: Vec::new(),
            earlier_systems: 0,
            triangles: mesh.faces.triangles(),
            positions: mesh.positions.clone(),
            report: None,
            controls: 0,
            update_ms: 0.0,
            surface: SurfaceCache::default(),
        }
    }

    /// Deforms `mesh` by `file` at `phase` (each layer at its own phase
    /// times this one), checks the result as `checks` says and makes the
    /// [`Report`], with the remedies searched as `search` says when a face
    /// folds. On error (a layer the engine refuses: coincident starts, a
    /// radius too small for the mesh) the previous positions stay and the
    /// error says which layer.
    pub fn update(
        &mut self,
        mesh: &Mesh,
        file: &ControlFile,
        phase: f64,
        checks: &Checks,
        search: RemedySearch,
    ) -> Result<&Report, SessionError> {
        self.update_positions(mesh, file, phase)?;
        let t = Instant::now();
        let lookup = |n: &str| mesh.part_vertices(n);
        // The document's stages as `csrbf deform` fits them: each layer's
        // (a sweep's every step), a layer without controls the map that
        // moves nothing, so that warnings number layers as the file does.
        let mut fitted = Vec::new();
        let mut k = 0;
        for (layer, spec) in self.specs.iter().enumerate() {
            if self.layers.get(k) == Some(&layer) {
                // A handle's layer has two stages: its rigid part, then its blend.
                while self.layers.get(k) == Some(&layer) {
                    fitted.extend(self.pipeline.fitted_stages(k).unwrap_or_default());
                    k += 1;
                }
            } else {
                fitted.push(
                    csrbf::FittedStage::new(csrbf::Deformation::identity(spec.options))
                        .with_region(spec.region.clone())
                        .with_phase(spec.phase * phase),
                );
            }
        }
        // Checked as `csrbf deform` checks (the same composition, the same
        // options): the same report.
        let (_, diagnostics) =
            compose_checked(mesh, &fitted, file.combine, checks).map_err(|e| {
                let layer = e
                    .stage()
                    .and_then(|k| self.layers.get(k).copied())
                    .unwrap_or_else(|| self.layers.first().copied().unwrap_or(0));
                SessionError {
                    layer,
                    source: e.without_stage(),
                }
            })?;
        let mut report = Report::new(self.positions.len(), phase, diagnostics);
        report.fit_ms = self.update_ms;
        report.deform_ms = t.elapsed().as_secs_f64() * 1e3;
        if !report.diagnostics.inside_out.is_empty() && search != RemedySearch::Off {
            report.remedies = remedies(
                &mesh.positions,
                &self.triangles,
                &self.specs,
                file.combine,
                phase,
                &lookup,
                search,
                report.fit_ms + report.deform_ms,
            )
            .ok();
        }
        Ok(self.report.insert(report))
    }

    /// [`Session::update`] without the checks, after which
    /// [`Session::report`] reads None: for the steps of a drag, where they
    /// would cost more than the deformation (on a 1M-vertex mesh, 90 ms
    /// against 30 ms); call `update` on release.
    pub fn update_positions(
        &mut self,
        mesh: &Mesh,
        file: &ControlFile,
        phase: f64,
    ) -> Result<&[Vec3], SessionError> {
        let t = Instant::now();
        csrbf::check_phase(phase).map_err(|source| SessionError { layer: 0, source })?;
        let lookup = |n: &str| mesh.part_vertices(n);
        let mut stages = Vec::new();
        let mut layers = Vec::new();
        let mut specs = Vec::with_capacity(file.deformations.len());
        let mut controls = 0;
        for (layer, spec) in file.deformations.iter().enumerate() {
            // A connected region is measured along the surface: the
            // triangles go with the points.
            let spec = spec
                .resolve_cached(&mesh.positions, &self.triangles, &lookup, &mut self.surface)
                .map_err(|source| SessionError { layer, source })?;
            // As `csrbf deform` checks a region: a part the mesh lacks, a
            // vertex past its end.
            check_region(&spec.region, mesh).map_err(|m| SessionError {
                layer,
                source: csrbf::RegionError::Invalid(m).into(),
            })?;
            controls += spec.starts.len();
            if !spec.starts.is_empty() {
                for stage in spec
                    .to_stages()
                    .map_err(|source| SessionError { layer, source })?
                {
                    stages.push(stage.with_phase(spec.phase * phase));
                    layers.push(layer);
                }
            }
            specs.push(spec);
        }
        self.controls = controls;
        self.specs = specs;
        self.sync(mesh, file, stages, layers)?;
        let layers = &self.layers;
        let named = |e: csrbf::Error| {
            // The pipeline names its stage; a stage is a layer with controls.
            let layer = e
                .stage()
                .and_then(|k| layers.get(k).copied())
                .unwrap_or_else(|| layers.first().copied().unwrap_or(0));
            SessionError {
                layer,
                source: e.without_stage(),
            }
        };
        let moved = self.pipeline.evaluate().map_err(named)?.to_vec();
        self.positions = moved;
        self.report = None;
        self.update_ms = t.elapsed().as_secs_f64() * 1e3;
        Ok(&self.positions)
    }

    /// Brings the pipeline to these stages, telling it only what changed (a
    /// new set of layers or a new combine starts a new pipeline).
    fn sync(
        &mut self,
        mesh: &Mesh,
        file: &ControlFile,
        stages: Vec<Stage>,
        layers: Vec<usize>,
    ) -> Result<(), SessionError> {
        let same_shape = layers == self.layers
            && self.pipeline.combine() == file.combine
            && self.pipeline.rest().len() == mesh.positions.len();
        if !same_shape {
            self.earlier_systems += self.pipeline.work().systems;
            let groups = mesh
                .parts
                .iter()
                .filter_map(|p| Some((p.name.clone(), mesh.part_vertices(&p.name)?)))
                .collect();
            self.pipeline = Pipeline::new(mesh.positions.clone())
                .with_combine(file.combine)
                .with_groups(groups);
            for stage in stages {
                self.pipeline.push(stage);
            }
            self.layers = layers;
            return Ok(());
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
            // A phase or region the pipeline refuses is the layer's error.
            let layer = self.layers[k];
            let at = |source| SessionError { layer, source };
            let p = &mut self.pipeline;
            if starts {
                p.set_controls(k, new.starts, new.targets).map_err(at)?;
            } else if targets {
                p.set_targets(k, new.targets).map_err(at)?;
            }
            if options {
                p.set_options(k, new.options).map_err(at)?;
            }
            if region {
                p.set_region(k, new.region).map_err(at)?;
            }
            if phase {
                p.set_phase(k, new.phase).map_err(at)?;
            }
            if sweep {
                p.set_sweep(k, new.sweep, new.paths.clone()).map_err(at)?;
            }
        }
        Ok(())
    }

    /// The deformed positions (the rest ones before the first update).
    pub fn positions(&self) -> &[Vec3] {
        &self.positions
    }

    /// The mesh's triangles, as the checks see them.
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// What the last [`Session::update`] found; None after
    /// [`Session::update_positions`].
    pub fn report(&self) -> Option<&Report> {
        self.report.as_ref()
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
