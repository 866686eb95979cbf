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

/// Fits `specs` (handles resolved) with every plain deformation's radius
/// scaled by `scale` (or made a sweep) and counts the inside-out triangles
/// at the phases given times `phase`, with the time taken.
fn trial(
    rest: &[Vec3],
    triangles: &[[u32; 3]],
    specs: &[ControlSpec],
    combine: Combine,
    phase: f64,
    groups: &dyn Fn(&str) -> Option<Vec<u32>>,
    change: &dyn Fn(&mut ControlSpec),
) -> Result<(usize, usize, f64)> {
    let t = Instant::now();
    let mut stages: Vec<FittedStage> = Vec::new();
    for spec in specs {
        let mut spec = spec.clone();
        if spec.sweep.is_none() {
            change(&mut spec);
        }
        stages.extend(spec.fit()?.into_iter().map(|s| {
            let p = s.phase * phase;
            s.with_phase(p)
        }));
    }
    let moved = compose_with_groups(rest, &stages, combine, groups)?;
    let ms = t.elapsed().as_secs_f64() * 1e3;
    std::hint::black_box(moved);
    let found = crate::folds(rest, triangles, &stages, combine, groups)?;
    Ok((found.triangles.len(), stages.len(), ms))
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
    let scaled = |s: f64| {
        move |spec: &mut ControlSpec| {
            spec.options = spec.options.with_radius(spec.options.radius * s);
        }
    };
    let try_scale = |s: f64| trial(rest, triangles, specs, combine, phase, groups, &scaled(s));
    let (_, _, plain_ms) = try_scale(1.0)?;
    // Grow until nothing folds, then bisect between the last that folded
    // and the first that did not. A radius that the engine refuses (too
    // large a system) counts as not found.
    let mut lo = 1.0;
    let mut found = None;
    for s in [1.25, 1.5, 2.0, 3.0, MOST_SCALE] {
        match try_scale(s) {
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
            match try_scale(mid)? {
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
        match trial(rest, triangles, specs, combine, phase, groups, &swept) {
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
        let n = 30;
        let at = |i: usize, j: usize| (j * (n + 1) + i) as u32;
        let rest: Vec<Vec3> = (0..=n)
            .flat_map(|j| (0..=n).map(move |i| Vec3::new(i as f32, j as f32, 0.0) / n as f32))
            .collect();
        let tris: Vec<[u32; 3]> = (0..n)
            .flat_map(|j| {
                (0..n).flat_map(move |i| {
                    [
                        [at(i, j), at(i + 1, j), at(i + 1, j + 1)],
                        [at(i, j), at(i + 1, j + 1), at(i, j + 1)],
                    ]
                })
            })
            .collect();
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
        let fold_count = |s: f64| {
            trial(
                &rest,
                &tris,
                std::slice::from_ref(&spec),
                Combine::Chain,
                1.0,
                &none,
                &|sp: &mut ControlSpec| sp.options = sp.options.with_radius(sp.options.radius * s),
            )
            .expect("trial")
            .0
        };
        assert_eq!(fold_count(scale), 0);
        assert!(fold_count(scale / 1.05) > 0);
        let (steps, _) = r.sweep.expect("a sweep");
        assert!(steps > 1);
    }
}
