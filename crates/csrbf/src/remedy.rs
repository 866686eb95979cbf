//! Helping the user fix a fold: the smallest radius of support that would
//! not fold the mesh, and the fold-free sweep, each with its cost.
//!
//! Both are measured on the mesh, not guessed: every radius tried is
//! fitted, composed and checked by [`crate::folds`] at the phases given,
//! and the sweep is fitted and checked the same way (it is certified, so
//! the check only confirms it). The cost of each is the time its fit and
//! deformation took here, next to the plain edit's.

use std::time::Instant;

use glam::Vec3;

use crate::controls::ControlSpec;
use crate::error::Result;
use crate::pipeline::{Combine, FittedStage, compose_with_groups};

/// The largest factor of the radii tried.
const MOST_SCALE: f64 = 4.0;

/// What would keep an edit from folding, as [`remedies`] measured it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Remedies {
    /// The smallest factor of every plain deformation's radius (to 2 %)
    /// that folds no face, and the milliseconds its fit and deformation
    /// took; None when even 4x folds.
    pub radius_scale: Option<(f64, f64)>,
    /// With `"sweep": true` on every plain deformation: the steps taken in
    /// all, and the milliseconds its fit and deformation took; None when a
    /// sweep cannot be made (paths that meet, `"combine": "add"`).
    pub sweep: Option<(usize, f64)>,
    /// The milliseconds of the plain edit's fit and deformation, measured
    /// the same way, for comparison.
    pub plain_ms: f64,
}

/// An edit as [`remedies`] tries it.
struct Edit<'a> {
    rest: &'a [Vec3],
    triangles: &'a [[u32; 3]],
    specs: &'a [ControlSpec],
    combine: Combine,
    phase: f64,
    groups: &'a dyn Fn(&str) -> Option<Vec<u32>>,
}

impl Edit<'_> {
    /// Fits the specs (handles resolved) with every plain deformation
    /// changed by `change` (its radius scaled, or made a sweep), and gives
    /// the inside-out triangles at the phases given times `phase`, the
    /// stages fitted and the milliseconds the fit and deformation took.
    fn trial(&self, change: &dyn Fn(&mut ControlSpec)) -> Result<(usize, usize, f64)> {
        let t = Instant::now();
        let mut stages: Vec<FittedStage> = Vec::new();
        for spec in self.specs {
            let mut spec = spec.clone();
            if spec.sweep.is_none() {
                change(&mut spec);
            }
            stages.extend(spec.fit()?.into_iter().map(|s| {
                let p = s.phase * self.phase;
                s.with_phase(p)
            }));
        }
        let moved = compose_with_groups(self.rest, &stages, self.combine, self.groups)?;
        let ms = t.elapsed().as_secs_f64() * 1e3;
        std::hint::black_box(moved);
        let found = crate::folds(
            self.rest,
            self.triangles,
            &stages,
            self.combine,
            self.groups,
        )?;
        Ok((found.triangles.len(), stages.len(), ms))
    }

    /// [`Edit::trial`] with every plain radius times `s`.
    fn scaled(&self, s: f64) -> Result<(usize, usize, f64)> {
        self.trial(&|spec: &mut ControlSpec| {
            spec.options = spec.options.with_radius(spec.options.radius * s);
        })
    }
}

/// What would keep `specs` (resolved on `rest`) from turning faces of the
/// mesh inside out at `phase`: the smallest radius factor that folds none,
/// and the sweep, each with its cost. Call it when an edit folds.
pub fn remedies(
    rest: &[Vec3],
    triangles: &[[u32; 3]],
    specs: &[ControlSpec],
    combine: Combine,
    phase: f64,
    groups: &dyn Fn(&str) -> Option<Vec<u32>>,
) -> Result<Remedies> {
    let edit = Edit {
        rest,
        triangles,
        specs,
        combine,
        phase,
        groups,
    };
    let (_, _, plain_ms) = edit.scaled(1.0)?;
    // Grow until nothing folds, then bisect between the last that folded
    // and the first that did not. A radius that the engine refuses (too
    // large a system) counts as not found.
    let mut lo = 1.0;
    let mut found = None;
    for s in [1.25, 1.5, 2.0, 3.0, MOST_SCALE] {
        match edit.scaled(s) {
            Ok((0, _, ms)) => {
                found = Some((s, ms));
                break;
            }
            Ok(_) => lo = s,
            Err(_) => break,
        }
    }
    if let Some((mut hi, mut ms)) = found {
        while hi - lo > 0.02 * lo {
            let mid = 0.5 * (lo + hi);
            match edit.scaled(mid)? {
                (0, _, t) => {
                    hi = mid;
                    ms = t;
                }
                _ => lo = mid,
            }
        }
        found = Some((hi, ms));
    }
    let sweep = if combine == Combine::Chain {
        let swept = |spec: &mut ControlSpec| spec.sweep = Some(crate::SweepOptions::default());
        match edit.trial(&swept) {
            Ok((_, steps, ms)) => Some((steps, ms)),
            Err(_) => None,
        }
    } else {
        None
    };
    Ok(Remedies {
        radius_scale: found,
        sweep,
        plain_ms,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{FitOptions, Kernel};
    use glam::DVec3;

    #[test]
    fn a_folding_pull_is_fixed_by_a_larger_radius_or_a_sweep() {
        // A 30 x 30 grid of triangles pulled hard at its middle.
        let (rest, tris) = crate::testing::grid(30);
        let spec = ControlSpec::new(
            vec![DVec3::new(0.5, 0.5, 0.0)],
            vec![DVec3::new(0.8, 0.5, 0.0)],
            FitOptions::new(0.25).with_kernel(Kernel::C2),
        );
        let none = |_: &str| None;
        let r = remedies(
            &rest,
            &tris,
            std::slice::from_ref(&spec),
            Combine::Chain,
            1.0,
            &none,
        )
        .expect("remedies");
        let (scale, _) = r.radius_scale.expect("a radius that does not fold");
        // One vector folds nowhere below 64/135 R (the kernel's bound), and
        // does fold well past it: the smallest radius lies between.
        assert!(
            scale * 0.25 >= 0.5 && scale * 0.25 <= 0.3 / (64.0 / 135.0) * 1.05,
            "{scale}"
        );
        // Checked: at that radius nothing folds, a little below something does.
        let edit = Edit {
            rest: &rest,
            triangles: &tris,
            specs: std::slice::from_ref(&spec),
            combine: Combine::Chain,
            phase: 1.0,
            groups: &none,
        };
        assert_eq!(edit.scaled(scale).expect("trial").0, 0);
        assert!(edit.scaled(scale / 1.05).expect("trial").0 > 0);
        let (steps, _) = r.sweep.expect("a sweep");
        assert!(steps > 1);
    }
}
