//! The papers' lazy pipeline: deformations applied one after another, each on
//! a region of the object, recomputing only what an input change invalidates.
//!
//! Each stage acts on the previous stage's output ([`Combine::Chain`], the
//! default): its starts are in those deformed coordinates, as a user placing
//! them on the deformed model sees it. With [`Combine::Add`] every stage acts
//! on the rest points and the displacements add. Regions are always chosen
//! on the rest points, so a stage's region does not drift with earlier stages.
//!
//! Each stage caches its system (depends on the starts and options), its
//! solved deformation (also on the destinations), its binding (on the stage's
//! input points and region) and its displacements. A change marks only what
//! depends on it: new destinations re-solve with the existing factor and
//! re-use the binding; a new phase costs one multiply-add per point.

use glam::{DVec3, Vec3};

use crate::binding::Binding;
use crate::deformation::Deformation;
use crate::error::{Error, Result, at_stage};
use crate::region::Region;
use crate::stage::{Combine, FittedStage};
use crate::sweep::{Paths, SweepOptions};
use crate::system::{FitOptions, System};

/// One deformation of a pipeline, as the user describes it.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct Stage {
    /// Start points of the control vectors.
    pub starts: Vec<DVec3>,
    /// Their destinations.
    pub targets: Vec<DVec3>,
    /// Kernel, radius, polynomial, ordering, solver.
    pub options: FitOptions,
    /// Where it applies.
    pub region: Region,
    /// Phase in [0, 1]: 0 rest, 1 full deformation.
    pub phase: f64,
    /// A fold-free sweep instead of the single map (None: the single map).
    pub sweep: Option<SweepOptions>,
    /// The paths the starts follow in a sweep (straight unless a handle's).
    pub paths: Paths,
    /// A handle's rigid part, joined with the stage after it (see
    /// [`FittedStage::rigid_part`]).
    pub rigid_part: bool,
}

impl Stage {
    /// A stage over every point at full phase.
    pub fn new(starts: Vec<DVec3>, targets: Vec<DVec3>, options: FitOptions) -> Stage {
        Stage {
            starts,
            targets,
            options,
            region: Region::All,
            phase: 1.0,
            sweep: None,
            paths: Paths::default(),
            rigid_part: false,
        }
    }

    /// As a handle's rigid part (see [`FittedStage::rigid_part`]).
    pub fn as_rigid_part(mut self, rigid: bool) -> Stage {
        self.rigid_part = rigid;
        self
    }

    /// As a fold-free sweep along `paths` (None: the single map).
    pub fn with_sweep(mut self, sweep: Option<SweepOptions>, paths: Paths) -> Stage {
        self.sweep = sweep;
        self.paths = paths;
        self
    }

    /// With this region.
    pub fn with_region(mut self, region: Region) -> Stage {
        self.region = region;
        self
    }

    /// With this phase, in [0, 1]; a phase outside is refused when the
    /// pipeline evaluates (the one check, as [`Pipeline::set_phase`] makes).
    pub fn with_phase(mut self, phase: f64) -> Stage {
        self.phase = phase;
        self
    }
}

/// How much work the pipeline has done: each counter goes up by one when that
/// step runs. Tests use it to check that a change recomputes only what it must.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Work {
    /// Systems built and factored.
    pub systems: usize,
    /// Solves for destinations.
    pub solves: usize,
    /// Bindings made (neighbour searches over the points).
    pub bindings: usize,
    /// Displacement products through a binding.
    pub displacements: usize,
    /// Stage outputs computed.
    pub outputs: usize,
}

/// Generations a cached value was computed from.
type Key3 = (u64, u64, u64);

/// A binding with the points it covers.
#[derive(Debug)]
struct Bound {
    key: Key3,
    active: Vec<u32>,
    /// Weight of each active point (1, or less in a region's falloff).
    weights: Vec<f32>,
    binding: Binding,
}

/// A stage's output, the generations it came from and its own generation.
#[derive(Debug)]
struct Output {
    key: Key3,
    points: Vec<Vec3>,
    generation: u64,
}

#[derive(Debug)]
struct StageState {
    stage: Stage,
    /// Generation of the last change to starts/options, targets, region, phase.
    gen_system: u64,
    gen_targets: u64,
    gen_region: u64,
    gen_phase: u64,
    system: Option<(u64, System)>,
    /// The fitted map; a sweep's first step.
    deformation: Option<((u64, u64), Deformation)>,
    /// A sweep's every step, fitted with `deformation`.
    steps: Vec<Deformation>,
    /// Active points, and the generations (input, region, system) the binding was made from.
    binding: Option<Bound>,
    displacement: Option<(Key3, u64, Vec<Vec3>)>,
    output: Option<Output>,
}

/// A chain of deformations over a set of rest points.
#[derive(Debug)]
pub struct Pipeline {
    rest: Vec<Vec3>,
    gen_rest: u64,
    next_gen: u64,
    stages: Vec<StageState>,
    groups: Vec<(String, Vec<u32>)>,
    combine: Combine,
    work: Work,
    /// Whether the last evaluate's output is still what evaluate would give.
    current: bool,
}

impl Pipeline {
    /// A pipeline over these rest points with no stage yet.
    pub fn new(rest: Vec<Vec3>) -> Pipeline {
        Pipeline {
            rest,
            gen_rest: 1,
            next_gen: 2,
            stages: Vec::new(),
            groups: Vec::new(),
            combine: Combine::Chain,
            work: Work::default(),
            current: false,
        }
    }

    /// With stages combined this way (default [`Combine::Chain`]).
    pub fn with_combine(mut self, combine: Combine) -> Pipeline {
        self.set_combine(combine);
        self
    }

    /// How the stages combine.
    pub fn combine(&self) -> Combine {
        self.combine
    }

    /// Changes how the stages combine; every stage is bound again.
    pub fn set_combine(&mut self, combine: Combine) {
        if combine != self.combine {
            self.combine = combine;
            self.gen_rest = self.bump();
        }
    }

    /// Names parts of the points, for [`Region::Group`].
    pub fn with_groups(mut self, groups: Vec<(String, Vec<u32>)>) -> Pipeline {
        self.groups = groups;
        self
    }

    fn bump(&mut self) -> u64 {
        self.current = false;
        self.next_gen += 1;
        self.next_gen
    }

    /// The points the last [`Pipeline::evaluate`] gave, when nothing changed
    /// since; None when something did (call `evaluate`). Reads, never computes.
    pub fn output(&self) -> Option<&[Vec3]> {
        self.current.then(|| self.last_points())
    }

    /// Stage `i` as last fitted (a sweep's every step), with its region and
    /// phase, when it is still current; None when it was never fitted or its
    /// inputs changed. Reads, never computes.
    pub fn fitted_stages(&self, i: usize) -> Option<Vec<FittedStage>> {
        let d = self.fitted(i)?;
        let s = &self.stages[i];
        let (region, phase) = (s.stage.region.clone(), s.stage.phase);
        let rigid = s.stage.rigid_part;
        Some(if s.stage.sweep.is_some() {
            FittedStage::from_steps(s.steps.clone(), region, phase)
                .into_iter()
                .map(|f| f.as_rigid_part(rigid))
                .collect()
        } else {
            vec![
                FittedStage::new(d.clone())
                    .with_region(region)
                    .with_phase(phase)
                    .as_rigid_part(rigid),
            ]
        })
    }

    /// Stage `i`'s deformation as last fitted (a sweep's first step), when
    /// it is still current; None when it was never fitted or its inputs
    /// changed. Reads, never computes.
    pub fn fitted(&self, i: usize) -> Option<&Deformation> {
        let s = self.stages.get(i)?;
        match &s.deformation {
            Some(((g_sys, g_targets), d))
                if *g_sys == s.gen_system && *g_targets == s.gen_targets =>
            {
                Some(d)
            }
            _ => None,
        }
    }

    fn last_points(&self) -> &[Vec3] {
        match self.stages.last() {
            Some(StageState {
                output: Some(o), ..
            }) => &o.points,
            _ => &self.rest,
        }
    }

    /// Adds a stage at the end; returns its index.
    pub fn push(&mut self, stage: Stage) -> usize {
        let g = self.bump();
        self.stages.push(StageState {
            stage,
            gen_system: g,
            gen_targets: g,
            gen_region: g,
            gen_phase: g,
            system: None,
            deformation: None,
            steps: Vec::new(),
            binding: None,
            displacement: None,
            output: None,
        });
        self.stages.len() - 1
    }

    /// Number of stages.
    pub fn len(&self) -> usize {
        self.stages.len()
    }

    /// Whether there is no stage.
    pub fn is_empty(&self) -> bool {
        self.stages.is_empty()
    }

    /// The stage at `i`.
    pub fn stage(&self, i: usize) -> Option<&Stage> {
        self.stages.get(i).map(|s| &s.stage)
    }

    /// Work done so far.
    pub fn work(&self) -> Work {
        self.work
    }

    /// The rest points.
    pub fn rest(&self) -> &[Vec3] {
        &self.rest
    }

    /// Replaces the rest points (same or other count).
    pub fn set_rest(&mut self, rest: Vec<Vec3>) {
        self.rest = rest;
        self.gen_rest = self.bump();
    }

    fn state(&mut self, i: usize) -> Result<&mut StageState> {
        let n = self.stages.len();
        self.stages
            .get_mut(i)
            .ok_or(Error::StageIndex { index: i, count: n })
    }

    /// New destinations for stage `i`: re-solves with the existing factor.
    pub fn set_targets(&mut self, i: usize, targets: Vec<DVec3>) -> Result<()> {
        let g = self.bump();
        let s = self.state(i)?;
        s.stage.targets = targets;
        s.gen_targets = g;
        Ok(())
    }

    /// New control vectors (starts and destinations) for stage `i`: rebuilds its system.
    pub fn set_controls(
        &mut self,
        i: usize,
        starts: Vec<DVec3>,
        targets: Vec<DVec3>,
    ) -> Result<()> {
        let g = self.bump();
        let s = self.state(i)?;
        s.stage.starts = starts;
        s.stage.targets = targets;
        s.gen_system = g;
        s.gen_targets = g;
        Ok(())
    }

    /// New options (kernel, radius, ...) for stage `i`: rebuilds its system.
    pub fn set_options(&mut self, i: usize, options: FitOptions) -> Result<()> {
        let g = self.bump();
        let s = self.state(i)?;
        s.stage.options = options;
        s.gen_system = g;
        Ok(())
    }

    /// A new region for stage `i`, refused at once when no point could be
    /// in it ([`Region::check`]: a sphere or box not finite, a falloff of no
    /// width).
    pub fn set_region(&mut self, i: usize, region: Region) -> Result<()> {
        region.check()?;
        let g = self.bump();
        let s = self.state(i)?;
        s.stage.region = region;
        s.gen_region = g;
        Ok(())
    }

    /// Stage `i` as a fold-free sweep along `paths`, or (None) the single map.
    pub fn set_sweep(&mut self, i: usize, sweep: Option<SweepOptions>, paths: Paths) -> Result<()> {
        let g = self.bump();
        let s = self.state(i)?;
        s.stage.sweep = sweep;
        s.stage.paths = paths;
        s.gen_system = g;
        Ok(())
    }

    /// A new phase for stage `i`, in [0, 1].
    pub fn set_phase(&mut self, i: usize, phase: f64) -> Result<()> {
        crate::error::check_phase(phase)?;
        let g = self.bump();
        let s = self.state(i)?;
        s.stage.phase = phase;
        s.gen_phase = g;
        Ok(())
    }

    /// The deformation of stage `i`, fitting it if needed.
    pub fn deformation(&mut self, i: usize) -> Result<&Deformation> {
        self.refresh_deformation(i).map_err(at_stage(i))?;
        // refresh_deformation filled it, or returned the error.
        Ok(&self.stages[i]
            .deformation
            .as_ref()
            .expect("just refreshed")
            .1)
    }

    /// The system of stage `i`, building it if needed.
    pub fn system(&mut self, i: usize) -> Result<&System> {
        self.refresh_system(i).map_err(at_stage(i))?;
        // refresh_system filled it, or returned the error.
        Ok(&self.stages[i].system.as_ref().expect("just refreshed").1)
    }

    fn refresh_system(&mut self, i: usize) -> Result<()> {
        let s = self.state(i)?;
        if s.system.as_ref().is_none_or(|(g, _)| *g != s.gen_system) {
            // The system before keeps its ordering and structure when the
            // starts moved within their neighbours (a drag).
            let sys = match &s.system {
                Some((_, before)) => before.rebuild(&s.stage.starts, s.stage.options)?,
                None => System::new(&s.stage.starts, s.stage.options)?,
            };
            s.system = Some((s.gen_system, sys));
            self.work.systems += 1;
        }
        Ok(())
    }

    fn refresh_deformation(&mut self, i: usize) -> Result<()> {
        let s = self.state(i)?;
        if let Some(sweep) = s.stage.sweep {
            // A sweep fits its own systems, one per step.
            let key = (s.gen_system, s.gen_targets);
            if s.deformation.as_ref().is_none_or(|(k, _)| *k != key) {
                let st = &s.stage;
                let fitted =
                    crate::Sweep::fit(&st.starts, &st.targets, &st.paths, st.options, sweep)?;
                s.deformation = Some((key, fitted.steps[0].clone()));
                s.steps = fitted.steps;
                self.work.solves += 1;
            }
            return Ok(());
        }
        self.refresh_system(i)?;
        let s = &mut self.stages[i];
        let key = (s.gen_system, s.gen_targets);
        if s.deformation.as_ref().is_none_or(|(k, _)| *k != key) {
            // refresh_system above filled it, or returned the error.
            let (_, sys) = s.system.as_ref().expect("system refreshed first");
            s.deformation = Some((key, sys.solve(&s.stage.targets)?));
            self.work.solves += 1;
        }
        Ok(())
    }

    /// Every stage fitted (as needed) with its region and phase: what a
    /// `.csrbf` file keeps. `pipeline.to_replay()?.to_bytes()` saves it;
    /// [`crate::format::Replay::compose`] replays it on the rest points.
    pub fn to_replay(&mut self) -> Result<crate::format::Replay> {
        let mut stages = Vec::with_capacity(self.stages.len());
        for i in 0..self.stages.len() {
            self.refresh_deformation(i).map_err(at_stage(i))?;
            stages.extend(self.fitted_stages(i).expect("just refreshed"));
        }
        // The points alone: the faces are the caller's (a file saved from
        // it is stamped with the count of points, see `MeshStamp`).
        let mesh = crate::format::Replay::lists_vertices(&stages).then(|| {
            crate::format::MeshStamp::of(self.rest.len(), None::<std::iter::Empty<&[u32]>>)
        });
        Ok(crate::format::Replay {
            stages,
            combine: self.combine,
            mesh,
        })
    }

    /// The points after every stage, recomputing only what changed.
    pub fn evaluate(&mut self) -> Result<&[Vec3]> {
        let mut input_gen = self.gen_rest;
        for i in 0..self.stages.len() {
            self.refresh_deformation(i).map_err(at_stage(i))?;
            input_gen = self.refresh_output(i, input_gen).map_err(at_stage(i))?;
        }
        self.current = true;
        Ok(self.last_points())
    }

    /// Brings stage `i`'s output up to date for an input of generation
    /// `input_gen`; returns the output's generation.
    fn refresh_output(&mut self, i: usize, input_gen: u64) -> Result<u64> {
        let (head, tail) = self.stages.split_at_mut(i);
        let input: &[Vec3] = match head.last() {
            Some(StageState {
                output: Some(o), ..
            }) => &o.points,
            _ => &self.rest,
        };
        let s = &mut tail[0];
        let groups = &self.groups;
        // A phase set when the stage was made is checked here, as set_phase checks.
        crate::error::check_phase(s.stage.phase)?;
        if s.stage.sweep.is_some() {
            if self.combine == Combine::Add {
                return Err(Error::SweepAdded { stage: i });
            }
            return Self::sweep_output(
                s,
                input,
                input_gen,
                &self.rest,
                groups,
                &mut self.next_gen,
                &mut self.work,
            );
        }
        // evaluate refreshed the deformation before the output.
        let (_, def) = s.deformation.as_ref().expect("deformation refreshed first");

        // Chained stages are bound on their input, added ones on the rest points.
        let (bind_input, bind_gen) = match self.combine {
            Combine::Chain => (input, input_gen),
            Combine::Add => (&self.rest[..], self.gen_rest),
        };
        let bkey = (bind_gen, s.gen_region, s.gen_system);
        if s.binding.as_ref().is_none_or(|b| b.key != bkey) {
            let lookup = |name: &str| {
                groups
                    .iter()
                    .find(|(n, _)| n == name)
                    .map(|(_, v)| v.clone())
            };
            let (active, weights) = s.stage.region.weights(&self.rest, &lookup)?;
            let pts: Vec<Vec3> = active.iter().map(|&k| bind_input[k as usize]).collect();
            // The stale binding's memory is reused (no fresh pages to fault
            // in, and no two bindings of the stage at once).
            let binding = match s.binding.take() {
                Some(Bound { mut binding, .. }) => {
                    binding.rebind(def, &pts);
                    binding
                }
                None => Binding::new(def, &pts),
            };
            s.binding = Some(Bound {
                key: bkey,
                active,
                weights,
                binding,
            });
            self.work.bindings += 1;
        }
        // Filled just above.
        let bound = s.binding.as_ref().expect("binding refreshed");

        if s.displacement
            .as_ref()
            .is_none_or(|(k, t, _)| *k != bkey || *t != s.gen_targets)
        {
            s.displacement = Some((bkey, s.gen_targets, bound.binding.displacements(def)?));
            self.work.displacements += 1;
        }
        // Filled just above.
        let (_, _, disp) = s.displacement.as_ref().expect("displacement refreshed");

        let okey = (
            input_gen,
            bkey.1.max(bkey.2).max(s.gen_targets),
            s.gen_phase,
        );
        if let Some(o) = &s.output
            && o.key == okey
        {
            return Ok(o.generation);
        }
        let mut out = input.to_vec();
        let t = s.stage.phase as f32;
        for ((&k, d), w) in bound.active.iter().zip(disp).zip(&bound.weights) {
            out[k as usize] += *d * (t * w);
        }
        self.next_gen += 1;
        let generation = self.next_gen;
        s.output = Some(Output {
            key: okey,
            points: out,
            generation,
        });
        self.work.outputs += 1;
        Ok(generation)
    }
}

impl Pipeline {
    /// A sweep stage's output: its steps chained at their shares of the
    /// phase, on the points of its region (no binding: every step is
    /// evaluated where the steps before it moved the points).
    fn sweep_output(
        s: &mut StageState,
        input: &[Vec3],
        input_gen: u64,
        rest: &[Vec3],
        groups: &[(String, Vec<u32>)],
        next_gen: &mut u64,
        work: &mut Work,
    ) -> Result<u64> {
        let okey = (
            input_gen,
            s.gen_region.max(s.gen_system).max(s.gen_targets),
            s.gen_phase,
        );
        if let Some(o) = &s.output
            && o.key == okey
        {
            return Ok(o.generation);
        }
        let lookup = |name: &str| {
            groups
                .iter()
                .find(|(n, _)| n == name)
                .map(|(_, v)| v.clone())
        };
        let (active, weights) = s.stage.region.weights(rest, &lookup)?;
        let mut out = input.to_vec();
        let k = s.steps.len();
        // In f64 through the steps, rounded once (as compose does).
        let mut pos: Vec<DVec3> = active.iter().map(|&a| out[a as usize].as_dvec3()).collect();
        for (j, step) in s.steps.iter().enumerate() {
            let f = crate::sweep::step_phase(s.stage.phase, j, k);
            if f == 0.0 {
                break;
            }
            let d = step.displacements(&pos);
            for ((p, d), w) in pos.iter_mut().zip(d).zip(&weights) {
                *p += d * (f * *w as f64);
            }
        }
        for (&a, p) in active.iter().zip(&pos) {
            out[a as usize] = p.as_vec3();
        }
        *next_gen += 1;
        s.output = Some(Output {
            key: okey,
            points: out,
            generation: *next_gen,
        });
        work.outputs += 1;
        Ok(*next_gen)
    }
}
