//! The road's first half: a control document resolved on a mesh and each
//! deformation fitted, a single map or a fold-free sweep, in one place.

use std::time::Instant;

use csrbf::{Combine, FittedStage, Sweep, System, SystemStats};
use csrbf_mesh::Mesh;

use crate::apply::check_region;
use crate::controls::{ControlFile, ControlSpec};
use crate::error::EditError;

/// What the road did, for a front end to show as it likes (the CLI prints
/// progress on standard error and warnings as `warning: ...`; Python warns;
/// the studio shows them in its status line). The texts name the document
/// and the deformation.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum Note {
    /// A step done: "smile.json: handle made 24 control vectors".
    Progress(String),
    /// Something the user should know before trusting the result: a nearly
    /// dense system, a sweep whose fixed steps may fold.
    Warning(String),
}

/// A sweep's figures, as its fit found them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SweepFigures {
    /// How many steps.
    pub steps: usize,
    /// The largest step's bound of |dD/dx| (below 1: it cannot fold).
    pub bound: f64,
    /// The bound of the single straight map the sweep replaces.
    pub plain_bound: f64,
    /// Whether every step's bound is below 1.
    pub certified: bool,
}

/// One deformation fitted: its stages (one, or a sweep's steps) and what
/// the fit found.
#[derive(Clone, Debug)]
pub struct FittedSpec {
    /// The stages, on the deformation's region at its phase.
    pub stages: Vec<FittedStage>,
    /// The single map's system (None for a sweep or an empty deformation).
    pub stats: Option<SystemStats>,
    /// A sweep's figures (None for the single map).
    pub sweep: Option<SweepFigures>,
    /// The milliseconds the fit took.
    pub ms: f64,
}

impl FittedSpec {
    /// The fold-free certificate: the single map's bound of |dD/dx| (below
    /// 1 it cannot fold), or for a sweep the bound of the map it replaces.
    pub fn gradient_bound(&self) -> f64 {
        match (&self.sweep, self.stages.first()) {
            (Some(s), _) => s.plain_bound,
            (None, Some(s)) => s.deformation.gradient_bound(),
            (None, None) => 0.0,
        }
    }
}

/// Fits one resolved deformation: the single map, or the sweep it asks for
/// (a handle must be resolved first: [`ControlSpec::resolve_on`]). The one
/// place a control file's deformation becomes stages.
pub fn fit_spec(spec: &ControlSpec) -> csrbf::Result<FittedSpec> {
    let t = Instant::now();
    if let Some(rigid) = &spec.rigid {
        // A handle: its own vertices moved as one (the rigid part's fit,
        // exact), then the rest of the region blended by the deformation.
        let part = ControlSpec {
            starts: rigid.starts.clone(),
            targets: rigid.targets.clone(),
            options: rigid.options(spec.options),
            region: rigid.region(),
            paths: rigid.paths(),
            rigid: None,
            sweep: spec.sweep_to_use(),
            ..spec.clone()
        };
        let mut stages: Vec<FittedStage> = fit_spec(&part)?
            .stages
            .into_iter()
            .map(|s| s.as_rigid_part(true))
            .collect();
        let sweep = spec.sweep_to_use();
        let own = fit_spec(&ControlSpec {
            rigid: None,
            sweep,
            ..spec.clone()
        })?;
        stages.extend(own.stages);
        return Ok(FittedSpec {
            stages,
            ms: t.elapsed().as_secs_f64() * 1e3,
            ..own
        });
    }
    if spec.handle.is_some() {
        return Err(csrbf::Error::BadHandle(
            "not resolved yet: call ControlSpec::resolve with the mesh first".into(),
        ));
    }
    let done = |stages, stats, sweep| FittedSpec {
        stages,
        stats,
        sweep,
        ms: t.elapsed().as_secs_f64() * 1e3,
    };
    if spec.starts.is_empty() && spec.targets.is_empty() {
        // Work in progress: no control vectors yet (the reader warned). It
        // moves nothing, and the deformations after it keep their numbers.
        let stage = FittedStage::new(csrbf::Deformation::identity(spec.options))
            .with_region(spec.region.clone())
            .with_phase(spec.phase);
        return Ok(done(vec![stage], None, None));
    }
    let Some(options) = spec.sweep else {
        let sys = System::new(&spec.starts, spec.options)?;
        let d = sys.solve(&spec.targets)?;
        let stage = FittedStage::new(d)
            .with_region(spec.region.clone())
            .with_phase(spec.phase);
        return Ok(done(vec![stage], Some(sys.stats().clone()), None));
    };
    let sweep = Sweep::fit(
        &spec.starts,
        &spec.targets,
        &spec.paths,
        spec.options,
        options,
    )?;
    let figures = SweepFigures {
        steps: sweep.len(),
        bound: sweep.bound(),
        plain_bound: sweep.plain_bound,
        certified: sweep.certified(),
    };
    let stages = FittedStage::sweep(sweep, spec.region.clone(), spec.phase);
    Ok(done(stages, None, Some(figures)))
}

/// A control document resolved on a mesh and fitted: what [`Edit::deform`]
/// composes at any phase.
#[derive(Clone, Debug)]
pub struct Edit {
    /// The deformations resolved (handles as control vectors, connected
    /// regions as weights), in the document's order.
    pub specs: Vec<ControlSpec>,
    /// Each deformation fitted, in the same order.
    pub fitted: Vec<FittedSpec>,
    /// How the deformations act together.
    pub combine: Combine,
    /// The milliseconds the resolution and the fits took.
    pub fit_ms: f64,
}

impl Edit {
    /// Every deformation's stages in order, at the phases the document
    /// gives.
    pub fn stages(&self) -> Vec<FittedStage> {
        self.fitted
            .iter()
            .flat_map(|f| f.stages.iter().cloned())
            .collect()
    }
}

/// Where a deformation is, in messages: the document alone when it has one,
/// else `doc: deformations[i]` (its JSON path).
pub(crate) fn stage_name(source: &str, i: usize, count: usize) -> String {
    if count > 1 {
        format!("{source}: deformations[{i}]")
    } else {
        source.to_owned()
    }
}

/// Resolves every deformation of `file` on `mesh`: handles turned into
/// control vectors, connected regions into vertex weights along its
/// surface, regions checked against its parts and vertices. Without a mesh,
/// a deformation that needs one is refused. `source` names the document in
/// messages (its path, or "controls").
pub fn resolve(
    file: &ControlFile,
    source: &str,
    mesh: Option<&Mesh>,
    notes: &mut dyn FnMut(Note),
) -> Result<Vec<ControlSpec>, EditError> {
    let count = file.deformations.len();
    let mut triangles: Option<Vec<[u32; 3]>> = None;
    let mut out = Vec::with_capacity(count);
    for (i, s) in file.deformations.iter().enumerate() {
        let at = stage_name(source, i, count);
        let resolved = match mesh {
            _ if !s.needs_mesh() => s.clone(),
            None if s.handle.is_some() => {
                return Err(EditError::NeedsMesh {
                    at,
                    what: "handle: a handle is sampled on the mesh; give the mesh",
                });
            }
            None => {
                return Err(EditError::NeedsMesh {
                    at,
                    what: "region: a connected region is measured along the mesh; give the mesh",
                });
            }
            Some(m) => {
                let t = Instant::now();
                let tris: &[[u32; 3]] = if s.region.needs_surface() {
                    triangles.get_or_insert_with(|| m.faces.triangles())
                } else {
                    &[]
                };
                let r = s
                    .resolve_on(&m.positions, tris, &|n| m.part_vertices(n))
                    .map_err(|source| EditError::Engine {
                        at: at.clone(),
                        source,
                    })?;
                if s.handle.is_some() {
                    notes(Note::Progress(format!(
                        "{at}: handle made {} control vectors",
                        r.starts.len() - s.starts.len()
                    )));
                }
                if let csrbf::Region::Weights { vertices, weights } = &r.region
                    && s.region.needs_surface()
                {
                    notes(Note::Progress(format!(
                        "{at}: connected region: {} vertices ({} fully)",
                        vertices.len(),
                        weights.iter().filter(|&&w| w == 1.0).count()
                    )));
                }
                let ms = t.elapsed().as_secs_f64() * 1e3;
                notes(Note::Progress(format!(
                    "{at}: resolved on the mesh ({ms:.1} ms)"
                )));
                r
            }
        };
        if let Some(m) = mesh {
            check_region(&resolved.region, m)
                .map_err(|message| EditError::Region { at, message })?;
        }
        out.push(resolved);
    }
    Ok(out)
}

/// Resolves `file` on `mesh` ([`resolve`]) and fits every deformation
/// ([`fit_spec`]), naming the document and the deformation in errors and
/// notes. `allow_large` fits even a system estimated past the memory
/// limit.
pub fn fit(
    file: &ControlFile,
    source: &str,
    mesh: Option<&Mesh>,
    allow_large: bool,
    notes: &mut dyn FnMut(Note),
) -> Result<Edit, EditError> {
    let t = Instant::now();
    let specs = resolve(file, source, mesh, notes)?;
    let mut fitted = Vec::with_capacity(specs.len());
    for (i, s) in specs.iter().enumerate() {
        let at = stage_name(source, i, specs.len());
        warn_if_dense(s, &at, notes);
        // The limit is lifted for this fit alone: the remedies' larger radii
        // keep it (a trial 4x as large could be dense).
        let mut lifted;
        let s = if allow_large {
            lifted = s.clone();
            lifted.options = lifted.options.with_memory_limit(u64::MAX);
            &lifted
        } else {
            s
        };
        let f = fit_spec(s).map_err(|source| EditError::Engine {
            at: at.clone(),
            source,
        })?;
        note_fit(s, &f, &at, notes);
        fitted.push(f);
    }
    Ok(Edit {
        specs,
        fitted,
        combine: file.combine,
        fit_ms: t.elapsed().as_secs_f64() * 1e3,
    })
}

/// The progress line of a fit, and a warning for a sweep that may fold.
fn note_fit(s: &ControlSpec, f: &FittedSpec, at: &str, notes: &mut dyn FnMut(Note)) {
    let o = &s.options;
    if let Some(sw) = &f.sweep {
        if s.sweep.is_none() {
            notes(Note::Progress(format!(
                "{at}: the handle's motion passes the fold-free bound of {} ({:.3} R): taken as a sweep along it in {} steps, each within the bound",
                o.kernel,
                o.kernel.fold_free_ratio(),
                sw.steps
            )));
        }
        notes(Note::Progress(format!(
            "swept {} controls ({}, R {}) in {} step(s), each step's |dD/dx| <= {:.3} (the single map's bound: {:.3}), {:.2} ms",
            s.starts.len(),
            o.kernel,
            csrbf::plain_number(o.radius),
            sw.steps,
            sw.bound,
            sw.plain_bound,
            f.ms
        )));
        if !sw.certified && s.sweep.is_none() {
            notes(Note::Warning(format!(
                "{at}: the sweep along the handle's motion ({} steps) is not certified (a step's gradient bound is {:.3}, >= 1): the report's fold check says whether it folds; \"sweep\": true searches certified steps (slower)",
                sw.steps, sw.bound
            )));
        } else if !sw.certified {
            notes(Note::Warning(format!(
                "{at}: a step of the sweep's {} has a gradient bound of {:.3} (>= 1), so it may fold: leave out \"steps\" and csrbf takes as many as it needs",
                sw.steps, sw.bound
            )));
        }
    } else if let Some(st) = &f.stats {
        notes(Note::Progress(format!(
            "fitted {} controls ({}, R {}, {}): {} solver, band {} -> {}, {:.2} ms",
            st.controls,
            o.kernel,
            csrbf::plain_number(o.radius),
            o.polynomial,
            st.solver,
            st.bandwidth_before,
            st.bandwidth,
            f.ms
        )));
    }
}

/// Warns before a long fit when R reaches most of the starts: the system is
/// then nearly dense (N^2 memory, N^3 work). The estimate is the engine's.
fn warn_if_dense(s: &ControlSpec, at: &str, notes: &mut dyn FnMut(Note)) {
    if s.starts.is_empty() {
        return;
    }
    let e = csrbf::estimate(&s.starts, s.options.radius);
    if e.nearly_dense() {
        notes(Note::Warning(format!(
            "{at}: R = {} reaches about {:.0} % of the {} starts, so the system is nearly dense and the fit will be slow and large; a smaller R keeps it sparse",
            csrbf::plain_number(s.options.radius),
            e.fraction * 100.0,
            e.starts
        )));
    }
}
