//! Fold-free sweeps: a deformation taken as a chain of k small CSRBF steps
//! that carry every start along its path, each certified not to fold.
//!
//! The papers' map moves a point by v + t D(v): one straight step, which
//! folds space where D changes faster than 1 per unit of length. A sweep
//! splits the motion: step j moves the starts from where their paths are
//! at phase j/k to where they are at (j+1)/k, by a CSRBF map D_j fitted as
//! usual. If |dD_j/dx| < 1 everywhere, x -> x + f D_j(x) is one-to-one for
//! every f in [0, 1] (|x + f D_j(x) - y - f D_j(y)| >= (1 - |dD_j|) |x - y|),
//! and so is the chain of steps: no face can turn inside out at any phase,
//! and every start still lands on its destination (each step interpolates).
//!
//! The bound of |dD_j/dx| is a certificate, not a sample: over a grid of
//! cells of side R/4 covering every point some start reaches, it sums
//! |alpha_i| max|phi'| / R over the starts within R of the cell (max|phi'|
//! over the distances the cell leaves possible, [`Kernel::max_derivative_from`]),
//! plus the polynomial part's constant gradient. Outside every cell only the
//! polynomial part acts.
//!
//! At phase t the sweep is at step j = floor(t k) with fraction t k - j:
//! the steps before it in full, that one in part. t = 0.5 is half way along
//! every path, so a handle that turns by 90 degrees has turned by 45.

use std::collections::HashMap;

use glam::{DQuat, DVec3};

use crate::deformation::Deformation;
use crate::error::FitError;
use crate::kernel::Kernel;
use crate::octree::Octree;
use crate::system::{FitOptions, System};

/// How a sweep chooses its steps (the control file's `"sweep"`).
///
/// ```
/// use csrbf::SweepOptions;
/// let certified = SweepOptions::default(); // the fewest steps that cannot fold
/// let fixed = SweepOptions::default().with_steps(Some(8));
/// assert_eq!((certified.steps, fixed.steps), (None, Some(8)));
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[non_exhaustive]
pub struct SweepOptions {
    /// A fixed number of steps (`"sweep": {"steps": k}`, 1 to
    /// [`MAX_STEPS`]); None (the default): the fewest whose every step is
    /// certified (`"sweep": true`).
    pub steps: Option<usize>,
}

impl SweepOptions {
    /// With a fixed number of steps, or (None) the fewest certified.
    pub fn with_steps(mut self, steps: Option<usize>) -> SweepOptions {
        self.steps = steps;
        self
    }
}

/// The most steps a sweep takes before it gives up (its home is the
/// errors, the lowest module that names it).
pub use crate::error::MAX_STEPS;

/// A step whose bound is below this is certified with a margin; the
/// automatic choice aims here.
const AIM: f64 = 0.8;

/// A handle's turn spread over a sweep: at most this many degrees a step,
/// so the path (an arc) is followed rather than its chord.
const MAX_TURN_PER_STEP_DEG: f64 = 10.0;

/// The way a start goes from its start to its destination.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Path {
    /// A straight line at even speed.
    Straight,
    /// A handle's motion spread over the phase: scaled by `scale^s` and
    /// turned by `s * angle` (radians) about `axis` through `pivot`, then
    /// moved by `s * translate`.
    Motion {
        /// The point the turn and the scale are about.
        pivot: DVec3,
        /// The axis of the turn (unit length, or zero for none).
        axis: DVec3,
        /// The whole turn, in radians.
        angle: f64,
        /// The whole scale (> 0).
        scale: f64,
        /// The whole translation.
        translate: DVec3,
    },
}

impl Path {
    /// Where a start on this path is at phase `s` in [0, 1] (its start at 0,
    /// its destination at 1, exactly).
    pub fn at(&self, start: DVec3, target: DVec3, s: f64) -> DVec3 {
        if s <= 0.0 {
            return start;
        }
        if s >= 1.0 {
            return target;
        }
        match *self {
            Path::Straight => start + (target - start) * s,
            Path::Motion {
                pivot,
                axis,
                angle,
                scale,
                translate,
            } => {
                let turn = if axis == DVec3::ZERO {
                    DQuat::IDENTITY
                } else {
                    DQuat::from_axis_angle(axis, angle * s)
                };
                pivot + turn * ((start - pivot) * scale.powf(s)) + translate * s
            }
        }
    }

    /// Degrees turned over the whole path.
    fn turn_deg(&self) -> f64 {
        match *self {
            Path::Straight => 0.0,
            Path::Motion { axis, angle, .. } if axis != DVec3::ZERO => angle.abs().to_degrees(),
            Path::Motion { .. } => 0.0,
        }
    }
}

/// The paths of a deformation's starts: straight, except a run of them
/// (a handle's moving samples) that follows one motion.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Paths {
    /// The run of starts (by index) on `path`, and the path.
    pub moving: Option<(std::ops::Range<usize>, Path)>,
}

impl Paths {
    /// The path of start `i`.
    pub fn of(&self, i: usize) -> Path {
        match &self.moving {
            Some((run, p)) if run.contains(&i) => *p,
            _ => Path::Straight,
        }
    }
}

/// A fitted sweep: its steps in order, and each step's certified bound of
/// |dD/dx| (below 1: that step cannot fold).
#[derive(Clone, Debug, PartialEq)]
pub struct Sweep {
    /// The steps, each a CSRBF map from the starts' places at phase j/k to
    /// their places at (j+1)/k.
    pub steps: Vec<Deformation>,
    /// Each step's bound of |dD/dx| over all of space.
    pub bounds: Vec<f64>,
    /// The bound of the single straight map the sweep replaces (for the
    /// record: `info` shows both).
    pub plain_bound: f64,
}

impl Sweep {
    /// Fits a sweep of `starts` to `targets` along `paths`. With
    /// `sweep.steps` None, k is the fewest steps whose bounds are all below
    /// 1 (tried from the plain map's bound, then raised), a handle's turn
    /// taking at least one step per 10 degrees; with a fixed k, that k
    /// (check [`Sweep::certified`]). Starts whose paths meet are refused,
    /// naming both controls and the phase.
    pub fn fit(
        starts: &[DVec3],
        targets: &[DVec3],
        paths: &Paths,
        options: FitOptions,
        sweep: SweepOptions,
    ) -> Result<Sweep, FitError> {
        if starts.len() != targets.len() {
            return Err(FitError::LengthMismatch {
                starts: starts.len(),
                targets: targets.len(),
            });
        }
        let plain = System::new(starts, options)?.solve(targets)?;
        let plain_bound = plain.gradient_bound();
        if let Some(k) = sweep.steps {
            if k == 0 || k > MAX_STEPS {
                return Err(FitError::SweepSteps { steps: k });
            }
            return Self::fit_steps(starts, targets, paths, options, k, plain, plain_bound);
        }
        let turn = paths.moving.as_ref().map_or(0.0, |(_, p)| p.turn_deg());
        let min_steps = (turn / MAX_TURN_PER_STEP_DEG).ceil() as usize;
        // The single map is certified already when its bound is below 1.
        let from_bound = if plain_bound < 1.0 {
            1
        } else {
            (plain_bound / AIM).ceil() as usize
        };
        let mut k = from_bound.max(min_steps).max(1);
        loop {
            let s = Self::fit_steps(
                starts,
                targets,
                paths,
                options,
                k.min(MAX_STEPS),
                plain.clone(),
                plain_bound,
            )?;
            let worst = s.bound();
            if worst < 1.0 {
                return Ok(s);
            }
            if k >= MAX_STEPS {
                return Err(FitError::SweepTooStiff {
                    steps: MAX_STEPS,
                    bound: worst,
                });
            }
            // Bounds fall about as 1/k: aim below 1 with a margin, and
            // always take more.
            k = ((k as f64 * worst / AIM).ceil() as usize).max(k + k / 2 + 1);
        }
    }

    fn fit_steps(
        starts: &[DVec3],
        targets: &[DVec3],
        paths: &Paths,
        options: FitOptions,
        k: usize,
        plain: Deformation,
        plain_bound: f64,
    ) -> Result<Sweep, FitError> {
        if k == 1 && paths.moving.is_none() {
            return Ok(Sweep {
                bounds: vec![plain_bound],
                steps: vec![plain],
                plain_bound,
            });
        }
        let place = |s: f64| -> Vec<DVec3> {
            starts
                .iter()
                .zip(targets)
                .enumerate()
                .map(|(i, (&a, &b))| paths.of(i).at(a, b, s))
                .collect()
        };
        let mut from = starts.to_vec();
        let mut steps = Vec::with_capacity(k);
        let mut bounds = Vec::with_capacity(k);
        for j in 0..k {
            let to = if j + 1 == k {
                targets.to_vec()
            } else {
                place((j + 1) as f64 / k as f64)
            };
            let phase = j as f64 / k as f64;
            if let Some((first, second, f)) = first_meeting(&from, &to, options.radius) {
                return Err(FitError::PathsMeet {
                    first,
                    second,
                    phase: (j as f64 + f) / k as f64,
                });
            }
            let step = System::new(&from, options)
                .and_then(|sys| sys.solve(&to))
                .map_err(|e| match e {
                    FitError::DuplicateStart { first, second }
                    | FitError::StartsTooClose { first, second, .. }
                    | FitError::ConflictingStarts { first, second, .. }
                        if j > 0 =>
                    {
                        FitError::PathsMeet {
                            first,
                            second,
                            phase,
                        }
                    }
                    other => other,
                })?;
            bounds.push(step.gradient_bound());
            steps.push(step);
            from = to;
        }
        Ok(Sweep {
            steps,
            bounds,
            plain_bound,
        })
    }

    /// The largest step bound: below 1, no step (and so no phase of the
    /// sweep) can fold.
    pub fn bound(&self) -> f64 {
        self.bounds.iter().copied().fold(0.0, f64::max)
    }

    /// Whether every step is certified not to fold.
    pub fn certified(&self) -> bool {
        self.bound() < 1.0
    }

    /// Number of steps.
    pub fn len(&self) -> usize {
        self.steps.len()
    }

    /// Whether it has no step (never, once fitted).
    pub fn is_empty(&self) -> bool {
        self.steps.is_empty()
    }
}

/// Two starts that meet while a step moves each straight from `from` to
/// `to` (their closest approach is within 1e-9 R), with the fraction of the
/// step where; the pair with the smallest index first.
fn first_meeting(from: &[DVec3], to: &[DVec3], radius: f64) -> Option<(usize, usize, f64)> {
    let longest = from
        .iter()
        .zip(to)
        .map(|(a, b)| a.distance(*b))
        .fold(0.0, f64::max);
    let eps = radius * 1e-9;
    let tree = Octree::new(from);
    let mut found: Option<(usize, usize, f64)> = None;
    for i in 0..from.len() {
        tree.for_each_within(from[i], 2.0 * longest + eps, |l, _| {
            let l = l as usize;
            if l <= i {
                return;
            }
            // The gap between the two at fraction f: gap0 + f (gap1 - gap0).
            let gap0 = from[i] - from[l];
            let change = (to[i] - to[l]) - gap0;
            let c2 = change.length_squared();
            let f = if c2 > 0.0 {
                (-gap0.dot(change) / c2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            if (gap0 + change * f).length() <= eps && found.is_none_or(|m| (i, l) < (m.0, m.1)) {
                found = Some((i, l, f));
            }
        });
    }
    found
}

/// How far step `index` of `count` has gone at the sweep's phase `t`:
/// clamp(t count - index, 0, 1).
pub fn step_phase(t: f64, index: usize, count: usize) -> f64 {
    (t * count as f64 - index as f64).clamp(0.0, 1.0)
}

impl Deformation {
    /// An upper bound of |dD/dx| (spectral norm) over all of space: the
    /// polynomial part's gradient plus, over a grid of cells of side R/4,
    /// the largest sum of |alpha_i| max|phi'| / R of the starts within R of
    /// a cell. Below 1, the map x + t D(x) is one-to-one for every t in
    /// [0, 1]: no face can fold.
    pub fn gradient_bound(&self) -> f64 {
        let radius = self.radius();
        let cell = radius / 4.0;
        let (kernel, starts, alpha) = (self.kernel(), self.starts(), self.coefficients());
        // Each half of the starts sums into its own map (two cores), then
        // the smaller map is added into the larger.
        let sums = |range: std::ops::Range<usize>| {
            let mut sums: CellSums = HashMap::default();
            for j in range {
                add_to_cells(
                    &mut sums,
                    starts[j],
                    alpha[j].length(),
                    kernel,
                    radius,
                    cell,
                );
            }
            sums
        };
        let half = starts.len() / 2;
        let (mut a, mut b) = if starts.len() > 256 {
            rayon::join(|| sums(0..half), || sums(half..starts.len()))
        } else {
            (sums(0..starts.len()), HashMap::default())
        };
        if a.len() < b.len() {
            std::mem::swap(&mut a, &mut b);
        }
        for (key, v) in b {
            *a.entry(key).or_insert(0.0) += v;
        }
        let most = a.values().copied().fold(0.0, f64::max);
        self.affine_gradient_norm() + most / radius
    }
}

/// Sums of |alpha| max|phi'| per cell of the bound's grid.
type CellSums = HashMap<(i64, i64, i64), f64, std::hash::BuildHasherDefault<CellHasher>>;

/// Adds one start's share to every cell of side `cell` within R of it.
fn add_to_cells(
    sums: &mut CellSums,
    s: DVec3,
    weight: f64,
    kernel: Kernel,
    radius: f64,
    cell: f64,
) {
    if weight == 0.0 {
        return;
    }
    // Cells within R of a start's cell: R / (R/4) + 1 each way.
    let reach = 5i64;
    // A start astronomically far (a control moved by 1e30) is clamped to a
    // cell still far from everything, not cast past i64 (its neighbours'
    // keys would overflow).
    const FAR: f64 = (1u64 << 52) as f64;
    let home = (s / cell)
        .floor()
        .clamp(DVec3::splat(-FAR), DVec3::splat(FAR));
    let (hx, hy, hz) = (home.x as i64, home.y as i64, home.z as i64);
    for dz in -reach..=reach {
        for dy in -reach..=reach {
            for dx in -reach..=reach {
                let key = (hx + dx, hy + dy, hz + dz);
                let lo = DVec3::new(key.0 as f64, key.1 as f64, key.2 as f64) * cell;
                let nearest = s.clamp(lo, lo + DVec3::splat(cell));
                let r0 = s.distance(nearest) / radius;
                if r0 < 1.0 {
                    *sums.entry(key).or_insert(0.0) += weight * kernel.max_derivative_from(r0);
                }
            }
        }
    }
}

/// A fast hash of a cell's three coordinates (the map's keys are not
/// chosen by anyone who could make them collide on purpose).
#[derive(Default)]
struct CellHasher(u64);

impl std::hash::Hasher for CellHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(b as u64);
        }
    }
    fn write_i64(&mut self, v: i64) {
        // One round of a multiply-rotate mix per coordinate.
        self.0 = (self.0.rotate_left(23) ^ v as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    }
    fn write_u64(&mut self, v: u64) {
        self.write_i64(v as i64);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{Rng, grid};
    use crate::{Combine, FittedStage, Kernel, Polynomial, compose, folds};
    use glam::{DMat3, Vec3};

    /// The spectral norm of G (power iteration on G^T G).
    fn spectral(g: DMat3) -> f64 {
        let m = g.transpose() * g;
        let mut v = DVec3::new(0.6, 0.7, 0.4);
        for _ in 0..100 {
            let w = m * v;
            if w.length() == 0.0 {
                return 0.0;
            }
            v = w.normalize();
        }
        (m * v).length().sqrt()
    }

    #[test]
    fn the_gradient_bound_is_above_the_gradient_everywhere() {
        let mut rng = Rng::new(17);
        for (kernel, polynomial) in [
            (Kernel::C0, Polynomial::None),
            (Kernel::C2, Polynomial::Linear),
            (Kernel::C4, Polynomial::None),
            (Kernel::C6, Polynomial::Linear),
        ] {
            let starts: Vec<DVec3> = (0..30).map(|_| rng.vec3()).collect();
            let targets: Vec<DVec3> = starts.iter().map(|s| *s + rng.vec3() * 0.2).collect();
            let options = FitOptions::new(0.45)
                .with_kernel(kernel)
                .with_polynomial(polynomial);
            let d = crate::Deformation::fit(&starts, &targets, options).expect("fit");
            let bound = d.gradient_bound();
            let most = (0..20_000)
                .map(|_| spectral(d.gradient_at(rng.vec3() * 1.6 - DVec3::splat(0.3))))
                .fold(0.0, f64::max);
            assert!(
                most <= bound,
                "{kernel}: |G| {most} above the bound {bound}"
            );
            // Not uselessly loose either.
            assert!(
                bound < 40.0 * most,
                "{kernel}: bound {bound} for |G| {most}"
            );
        }
    }

    /// A pull of 0.35 at R 0.3 turns the plain map inside out; the sweep
    /// folds nowhere, lands every start on its destination and is at the
    /// half-way point of every path at phase 0.5.
    #[test]
    fn a_sweep_of_a_folding_pull_folds_nowhere_and_lands_exactly() {
        let (rest, tris) = grid(60);
        let starts = [DVec3::new(0.5, 0.5, 0.0), DVec3::new(0.2, 0.8, 0.0)];
        let targets = [DVec3::new(0.85, 0.5, 0.0), DVec3::new(0.2, 0.8, 0.0)];
        let options = FitOptions::new(0.3).with_kernel(Kernel::C2);
        let plain = crate::Deformation::fit(&starts, &targets, options).expect("fit");
        let none = |_: &str| None;
        let plain_folds = folds(
            &rest,
            &tris,
            &[FittedStage::new(plain)],
            Combine::Chain,
            &none,
        )
        .expect("folds");
        assert!(!plain_folds.triangles.is_empty() && plain_folds.fold_phase.is_some());

        let sweep = Sweep::fit(
            &starts,
            &targets,
            &Paths::default(),
            options,
            SweepOptions::default(),
        )
        .expect("sweep");
        assert!(
            sweep.certified() && sweep.len() > 1,
            "{} steps, bound {}",
            sweep.len(),
            sweep.bound()
        );
        assert!(sweep.plain_bound > 1.0);
        let k = sweep.len();
        for phase in [1.0, 0.5, 0.37] {
            let stages = FittedStage::sweep(sweep.clone(), crate::Region::All, phase);
            let found = folds(&rest, &tris, &stages, Combine::Chain, &none).expect("folds");
            assert_eq!(found, crate::Folds::default(), "phase {phase}");
            // Measured, not only proven: det J of the chained map (f64) by
            // central differences at every centroid.
            let map = |x: DVec3| {
                stages.iter().fold(x, |p, st| {
                    p + st.deformation.displacement_at(p) * st.applied_phase()
                })
            };
            let h = 1e-6;
            for t in &tris {
                let c = t
                    .iter()
                    .map(|&v| rest[v as usize].as_dvec3())
                    .sum::<DVec3>()
                    / 3.0;
                let col = |k: usize| {
                    (map(c + DVec3::AXES[k] * h) - map(c - DVec3::AXES[k] * h)) / (2.0 * h)
                };
                let det = DMat3::from_cols(col(0), col(1), col(2)).determinant();
                assert!(det > 0.0, "phase {phase}: det {det} at {c}");
            }
            // The starts, carried by the chain.
            let pts: Vec<Vec3> = starts.iter().map(|s| s.as_vec3()).collect();
            let moved = compose(&pts, &stages, Combine::Chain).expect("compose");
            let t = (phase * k as f64).floor() / k as f64;
            if t == phase {
                for (m, (s, g)) in moved.iter().zip(starts.iter().zip(&targets)) {
                    let want = Path::Straight.at(*s, *g, phase);
                    assert!(
                        m.as_dvec3().distance(want) < 1e-6,
                        "phase {phase}: {m} vs {want}"
                    );
                }
            }
        }
    }

    #[test]
    fn a_turning_handle_follows_its_arc_and_a_fixed_count_is_kept() {
        // Eight starts on a ring turn by 90 degrees about z; eight pins
        // farther out stay.
        let ring = |r: f64, n: usize| -> Vec<DVec3> {
            (0..n)
                .map(|i| {
                    let a = i as f64 / n as f64 * std::f64::consts::TAU;
                    DVec3::new(r * a.cos(), r * a.sin(), 0.0)
                })
                .collect()
        };
        let path = Path::Motion {
            pivot: DVec3::ZERO,
            axis: DVec3::Z,
            angle: std::f64::consts::FRAC_PI_2,
            scale: 1.0,
            translate: DVec3::ZERO,
        };
        let mut starts = ring(0.3, 8);
        let mut targets: Vec<DVec3> = starts
            .iter()
            .map(|s| path.at(*s, *s, 1.0 - 1e-300))
            .collect();
        targets = targets
            .iter()
            .zip(&starts)
            .map(|(_, s)| DVec3::new(-s.y, s.x, s.z))
            .collect();
        starts.extend(ring(1.2, 8));
        targets.extend(ring(1.2, 8));
        let paths = Paths {
            moving: Some((0..8, path)),
        };
        let options = FitOptions::new(1.0).with_kernel(Kernel::C2);
        let auto =
            Sweep::fit(&starts, &targets, &paths, options, SweepOptions::default()).expect("auto");
        assert!(auto.len() >= 9, "{} steps for a 90 degree turn", auto.len());
        let fixed = Sweep::fit(
            &starts,
            &targets,
            &paths,
            options,
            SweepOptions { steps: Some(12) },
        )
        .expect("fixed");
        assert_eq!(fixed.len(), 12);
        let stages = FittedStage::sweep(fixed, crate::Region::All, 0.5);
        let pts: Vec<Vec3> = starts.iter().map(|s| s.as_vec3()).collect();
        let moved = compose(&pts, &stages, Combine::Chain).expect("compose");
        // Half the phase is half the turn: 45 degrees, on the arc.
        for (m, s) in moved.iter().zip(&starts).take(8) {
            let want = path.at(*s, DVec3::new(-s.y, s.x, s.z), 0.5);
            assert!(m.as_dvec3().distance(want) < 1e-6, "{m} vs {want}");
            assert!((m.length() as f64 - 0.3).abs() < 1e-6);
        }
        assert!(compose(&pts, &stages, Combine::Add).is_err());
    }

    #[test]
    fn paths_that_meet_are_refused_naming_both_and_the_phase() {
        let starts = [
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(0.5, 1.0, 0.0),
        ];
        let targets = [
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(0.5, 1.0, 0.0),
        ];
        let e = Sweep::fit(
            &starts,
            &targets,
            &Paths::default(),
            FitOptions::new(2.0),
            SweepOptions { steps: Some(3) },
        )
        .expect_err("swap");
        match e {
            FitError::PathsMeet {
                first: 0,
                second: 1,
                phase,
            } => assert!((phase - 0.5).abs() < 1e-12),
            other => panic!("{other}"),
        }
        assert!(e.to_string().contains("controls 0 and 1 meet"), "{e}");
        for k in [0, MAX_STEPS + 1] {
            let e = Sweep::fit(
                &starts[2..],
                &targets[2..],
                &Paths::default(),
                FitOptions::new(2.0),
                SweepOptions { steps: Some(k) },
            )
            .expect_err("steps");
            assert!(matches!(e, FitError::SweepSteps { .. }), "{e}");
        }
    }

    /// The live pipeline (the studio's preview) gives what `compose` gives
    /// for a sweep at every phase, switches between the single map and the
    /// sweep, and saves the steps in its replay.
    #[test]
    fn a_pipeline_stage_sweeps_as_compose_does() {
        let (rest, _) = grid(20);
        let starts = vec![DVec3::new(0.5, 0.5, 0.0), DVec3::new(0.1, 0.9, 0.0)];
        let targets = vec![DVec3::new(0.8, 0.55, 0.0), DVec3::new(0.1, 0.9, 0.0)];
        let options = FitOptions::new(0.3);
        let mut p = crate::Pipeline::new(rest.clone());
        p.push(
            crate::Stage::new(starts.clone(), targets.clone(), options)
                .with_sweep(Some(SweepOptions::default()), Paths::default()),
        );
        let sweep = Sweep::fit(
            &starts,
            &targets,
            &Paths::default(),
            options,
            SweepOptions::default(),
        )
        .expect("fit");
        let steps = FittedStage::sweep(sweep, crate::Region::All, 1.0);
        assert!(steps.len() > 1);
        for phase in [1.0, 0.6, 0.25, 0.0] {
            p.set_phase(0, phase).expect("phase");
            let got = p.evaluate().expect("evaluate").to_vec();
            let stages: Vec<FittedStage> =
                steps.iter().map(|s| s.clone().with_phase(phase)).collect();
            let want = compose(&rest, &stages, Combine::Chain).expect("compose");
            let worst = got
                .iter()
                .zip(&want)
                .map(|(a, b)| a.distance(*b))
                .fold(0.0f32, f32::max);
            assert!(worst < 1e-6, "phase {phase}: {worst}");
        }
        assert_eq!(p.fitted_stages(0).map(|s| s.len()), Some(steps.len()));
        assert_eq!(p.to_replay().expect("replay").stages.len(), steps.len());
        // Back to the single map, and to the sweep again.
        p.set_phase(0, 1.0).expect("phase");
        p.set_sweep(0, None, Paths::default()).expect("single");
        let single = p.evaluate().expect("evaluate").to_vec();
        let plain = crate::Deformation::fit(&starts, &targets, options).expect("fit");
        let want = compose(&rest, &[FittedStage::new(plain)], Combine::Chain).expect("compose");
        assert!(single.iter().zip(&want).all(|(a, b)| a.distance(*b) < 1e-6));
        assert_eq!(p.fitted_stages(0).map(|s| s.len()), Some(1));
        p.set_sweep(0, Some(SweepOptions { steps: Some(5) }), Paths::default())
            .expect("sweep");
        p.evaluate().expect("evaluate");
        assert_eq!(p.fitted_stages(0).map(|s| s.len()), Some(5));
        // Stages that add cannot hold a sweep.
        p.set_combine(Combine::Add);
        assert!(matches!(
            p.evaluate(),
            Err(crate::Error::SweepAdded { stage: 0 })
        ));
    }
}
