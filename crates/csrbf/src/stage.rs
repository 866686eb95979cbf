//! What a fitted deformation applies to and how much ([`FittedStage`]), how
//! several act together ([`Combine`]), and their one-shot composition
//! ([`compose`]): the unit the diagnostics, the folds, the `.csrbf` file and
//! the [`crate::Pipeline`] share. It reads the fitted deformation and its
//! evaluation, and nothing above them.

use glam::{DVec3, Vec3};

use crate::deformation::Deformation;
use crate::error::{Error, NameError, Result};
use crate::region::Region;

/// How the deformations of one file act together.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "lowercase"))]
#[non_exhaustive]
pub enum Combine {
    /// Each deformation moves the points the ones before it moved (the
    /// papers' VTK pipeline; the default): later starts are in deformed
    /// coordinates.
    #[default]
    Chain,
    /// Every deformation is evaluated at the rest points and their
    /// displacements are added (blend shapes, as glTF morph targets are).
    Add,
}

impl Combine {
    /// Both choices.
    pub const ALL: [Combine; 2] = [Combine::Chain, Combine::Add];

    /// The lower-case name used in control files.
    pub fn name(self) -> &'static str {
        match self {
            Combine::Chain => "chain",
            Combine::Add => "add",
        }
    }
}

impl std::fmt::Display for Combine {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Combine {
    type Err = NameError;
    fn from_str(s: &str) -> Result<Combine, NameError> {
        Combine::ALL
            .into_iter()
            .find(|c| c.name().eq_ignore_ascii_case(s))
            .ok_or_else(|| NameError::UnknownCombine(s.to_owned()))
    }
}

/// A fitted deformation with where and how much it applies: one stage of
/// [`compose`], of a `.csrbf` file ([`crate::format::Replay`]) and of the
/// diagnostics.
///
/// A fold-free sweep ([`crate::Sweep`]) is a run of consecutive stages, one
/// per step, chained: each carries `sweep` (its step and the count), every
/// step has the sweep's region and phase, and step j of k moves by
/// clamp(phase k - j, 0, 1) of its map ([`FittedStage::phase_at`]).
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct FittedStage {
    /// The fitted map.
    pub deformation: Deformation,
    /// Where it applies (chosen on the rest points).
    pub region: Region,
    /// Its phase in [0, 1] (a sweep's steps: the sweep's phase).
    pub phase: f64,
    /// Which step of a sweep this is; None for a plain deformation.
    pub sweep: Option<SweepStep>,
    /// A handle's rigid part: the affine map that moves the handle's own
    /// points as one (exactly), joined with the stages after it (the blend
    /// of the rest of its region) as one deformation of the document:
    /// warnings number it with them and it never warns of folding (an
    /// affine map of positive determinant cannot fold).
    pub rigid_part: bool,
}

/// Step `index` of a sweep of `count` steps.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct SweepStep {
    /// Which step, from 0.
    pub index: u32,
    /// How many steps the sweep has.
    pub count: u32,
}

impl FittedStage {
    /// A deformation over every point at full phase.
    pub fn new(deformation: Deformation) -> FittedStage {
        FittedStage {
            deformation,
            region: Region::All,
            phase: 1.0,
            sweep: None,
            rigid_part: false,
        }
    }

    /// A fitted sweep's steps as stages, each on `region` at the sweep's
    /// `phase`.
    pub fn sweep(sweep: crate::Sweep, region: Region, phase: f64) -> Vec<FittedStage> {
        Self::from_steps(sweep.steps, region, phase)
    }

    /// A sweep's steps (in order) as stages.
    pub(crate) fn from_steps(
        steps: Vec<Deformation>,
        region: Region,
        phase: f64,
    ) -> Vec<FittedStage> {
        let count = steps.len() as u32;
        steps
            .into_iter()
            .enumerate()
            .map(|(j, deformation)| FittedStage {
                deformation,
                region: region.clone(),
                phase,
                sweep: (count > 1).then_some(SweepStep {
                    index: j as u32,
                    count,
                }),
                rigid_part: false,
            })
            .collect()
    }

    /// How far this stage moves when every phase is scaled by `scale`: its
    /// phase times `scale`, or for step j of a sweep of k,
    /// clamp(phase scale k - j, 0, 1).
    pub fn phase_at(&self, scale: f64) -> f64 {
        let t = self.phase * scale;
        match self.sweep {
            None => t,
            Some(s) => crate::sweep::step_phase(t, s.index as usize, s.count as usize),
        }
    }

    /// How far this stage moves: [`FittedStage::phase_at`] 1.
    pub fn applied_phase(&self) -> f64 {
        self.phase_at(1.0)
    }

    /// With this region.
    pub fn with_region(mut self, region: Region) -> FittedStage {
        self.region = region;
        self
    }

    /// With this phase, in [0, 1] (checked where it is used).
    pub fn with_phase(mut self, phase: f64) -> FittedStage {
        self.phase = phase;
        self
    }

    /// As a handle's rigid part (see [`FittedStage::rigid_part`]).
    pub fn as_rigid_part(mut self, rigid: bool) -> FittedStage {
        self.rigid_part = rigid;
        self
    }
}

/// What one stage's evaluation saw: the points of its region, which of them
/// lie within R of a start, which starts lie within R of one of them.
pub(crate) struct StageReach {
    /// The region's points, ascending.
    pub(crate) selected: Vec<u32>,
    /// Per selected point.
    pub(crate) near: Vec<bool>,
    /// Per start.
    pub(crate) touched: Vec<bool>,
}

/// The index among the user's deformations of stage `at`: a sweep's steps
/// count as one.
pub(crate) fn deformation_index(stages: &[FittedStage], at: usize) -> usize {
    stages[..at]
        .iter()
        .filter(|s| !s.rigid_part && s.sweep.is_none_or(|s| s.index + 1 == s.count))
        .count()
}

/// One-shot composition without bindings (the least memory): applies each
/// deformation, at its phase, to the points of its region (selected on the
/// rest points), combined as `combine` says: [`Combine::Chain`] evaluates
/// each at the points the ones before it moved, [`Combine::Add`] every one
/// at the rest points. A region naming a part needs
/// [`compose_with_groups`].
///
/// What it computes, per stage: the displacement by the f32 evaluation
/// ([`Deformation::displacements_f32`]), times the stage's phase and the
/// point's region weight, added to the point in f32 (p + D(p) t w). A
/// [`Pipeline`](crate::Pipeline) computes the same through its [`Binding`](crate::Binding)s (whose product is
/// the f32 evaluation's, bit for bit), so the two give the same positions
/// bit for bit. A sweep's steps carry the region's points in f64 through
/// the f64 evaluation and round once after each stage's last step.
pub fn compose(rest: &[Vec3], stages: &[FittedStage], combine: Combine) -> Result<Vec<Vec3>> {
    compose_traced(rest, stages, combine, &|_| None, None)
}

/// [`compose`] with `groups` resolving the part names of
/// [`Region::Group`] regions into point indices.
pub fn compose_with_groups(
    rest: &[Vec3],
    stages: &[FittedStage],
    combine: Combine,
    groups: &dyn Fn(&str) -> Option<Vec<u32>>,
) -> Result<Vec<Vec3>> {
    compose_traced(rest, stages, combine, groups, None)
}

/// [`compose_with_groups`] in f64 throughout, for points that must come
/// back as precise as they went in (a solver's volume mesh): each stage's
/// displacement by the f64 evaluation ([`Deformation::displacements`]),
/// times its phase and the point's region weight (the region chosen on the
/// rest points rounded to f32, as every composition chooses it). A point
/// no stage reaches keeps its coordinates bit for bit.
pub fn compose_f64(
    rest: &[DVec3],
    stages: &[FittedStage],
    combine: Combine,
    groups: &dyn Fn(&str) -> Option<Vec<u32>>,
) -> Result<Vec<DVec3>> {
    let rest32: Vec<Vec3> = rest.iter().map(|p| p.as_vec3()).collect();
    let mut points = rest.to_vec();
    for (k, stage) in stages.iter().enumerate() {
        crate::error::check_phase(stage.phase)?;
        if combine == Combine::Add && stage.sweep.is_some() {
            return Err(Error::SweepAdded {
                stage: deformation_index(stages, k),
            });
        }
        let t = stage.applied_phase();
        // The region is resolved even at phase 0: a part the mesh lacks is
        // refused as `compose` refuses it.
        let (active, weights) = stage.region.weights(&rest32, groups)?;
        if t == 0.0 {
            continue;
        }
        // A sweep's steps chain whatever the document's combination says.
        let from = if combine == Combine::Chain || stage.sweep.is_some() {
            &points
        } else {
            rest
        };
        let sub: Vec<DVec3> = active.iter().map(|&i| from[i as usize]).collect();
        let d = stage.deformation.displacements(&sub);
        for ((&i, d), w) in active.iter().zip(d).zip(weights) {
            points[i as usize] += d * (t * w as f64);
        }
        if let Some(&i) = active
            .iter()
            .find(|&&i| !points[i as usize].is_finite() && rest[i as usize].is_finite())
        {
            return Err(Error::NonFiniteResult {
                stage: deformation_index(stages, k),
                point: i as usize,
            });
        }
    }
    Ok(points)
}

/// [`compose`], recording each stage's reach for the diagnostics when asked.
pub(crate) fn compose_traced(
    rest: &[Vec3],
    stages: &[FittedStage],
    combine: Combine,
    groups: &dyn Fn(&str) -> Option<Vec<u32>>,
    mut trace: Option<&mut Vec<StageReach>>,
) -> Result<Vec<Vec3>> {
    let mut points = rest.to_vec();
    // A sweep's points in f64 through its steps (k roundings to f32 would
    // add up to more than the 1e-6 of the diagonal its starts land within).
    let mut run: Option<Vec<DVec3>> = None;
    for (k, stage) in stages.iter().enumerate() {
        let (def, region) = (&stage.deformation, &stage.region);
        crate::error::check_phase(stage.phase)?;
        if combine == Combine::Add && stage.sweep.is_some() {
            return Err(Error::SweepAdded {
                stage: deformation_index(stages, k),
            });
        }
        let (active, weights) = region.weights(rest, groups)?;
        let t = stage.applied_phase() as f32;
        if let Some(step) = stage.sweep {
            let pos = match run.as_mut() {
                Some(pos) if step.index > 0 && pos.len() == active.len() => pos,
                _ => run.insert(
                    active
                        .iter()
                        .map(|&i| points[i as usize].as_dvec3())
                        .collect(),
                ),
            };
            if let Some(trace) = trace.as_deref_mut() {
                let sub: Vec<Vec3> = pos.iter().map(|p| p.as_vec3()).collect();
                let (_, near, touched) = def.displacements_reach(&sub);
                trace.push(StageReach {
                    selected: active.clone(),
                    near,
                    touched,
                });
            }
            if t > 0.0 {
                let d = def.displacements(pos);
                for ((p, d), w) in pos.iter_mut().zip(d).zip(&weights) {
                    *p += d * (t as f64 * *w as f64);
                }
                for (&i, p) in active.iter().zip(pos.iter()) {
                    points[i as usize] = p.as_vec3();
                }
            }
            if let Some(i) = active
                .iter()
                .position(|&i| !points[i as usize].is_finite() && rest[i as usize].is_finite())
            {
                return Err(Error::NonFiniteResult {
                    stage: deformation_index(stages, k),
                    point: active[i] as usize,
                });
            }
            continue;
        }
        run = None;
        let all = active.len() == points.len() && !matches!(region, Region::Falloff { .. });
        // Where this stage is evaluated: the moved points, or the rest ones.
        let from = match combine {
            Combine::Chain => &points[..],
            Combine::Add => rest,
        };
        let sub: Vec<Vec3> = if all {
            Vec::new()
        } else {
            active.iter().map(|&i| from[i as usize]).collect()
        };
        let input = if all { from } else { &sub[..] };
        // The values from the f32 path either way, so that a diagnosed
        // composition moves points exactly as a plain one; the reach from a
        // pass of its own.
        let d = def.displacements_f32(input);
        if let Some(trace) = trace.as_deref_mut() {
            let (_, near, touched) = def.displacements_reach(input);
            trace.push(StageReach {
                selected: active.clone(),
                near,
                touched,
            });
        }
        if all {
            for (p, d) in points.iter_mut().zip(d) {
                *p += d * t;
            }
        } else {
            for ((&i, d), w) in active.iter().zip(d).zip(weights) {
                points[i as usize] += d * (t * w);
            }
        }
        // A finite input that came out non-finite: the cause is this stage.
        if let Some(i) = points
            .iter()
            .zip(rest)
            .position(|(p, r)| !p.is_finite() && r.is_finite())
        {
            return Err(Error::NonFiniteResult {
                stage: deformation_index(stages, k),
                point: i,
            });
        }
    }
    Ok(points)
}
