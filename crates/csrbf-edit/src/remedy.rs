//! Helping the user fix a fold: the smallest radius of support that would
//! not fold the mesh, and the fold-free sweep, each with its cost.
//!
//! Both are measured on the mesh, not guessed: every radius tried is
//! fitted, composed and checked by [`csrbf::folds`] at the phases given,
//! and the sweep is fitted and checked the same way (it is certified, so
//! the check only confirms it). The cost of each is the time its fit and
//! deformation took here, next to the plain edit's.
//!
//! The search is bounded ([`RemedySearch::Bounded`], the default): it
//! starts no trial past the time the edit's own fit and deformation took
//! (or [`RemedySearch::FLOOR_MS`], when that is less): radii growing from
//! 1.25x, then the bisection to 2 %. What it found by then is true (the
//! radius named folds no face), only perhaps not the smallest;
//! [`Remedies::complete`] says. The sweep (certified, so it cannot fold) is
//! named without a trial: its steps can cost seconds where a radius costs
//! the edit's own time; a full search ([`RemedySearch::Full`]) times it.

use std::time::{Duration, Instant};

use glam::Vec3;

use crate::controls::ControlSpec;
use csrbf::Result;
use csrbf::{Combine, FittedStage, compose_with_groups};

/// The largest factor of the radii tried.
const MOST_SCALE: f64 = 4.0;

/// How far to search for remedies when an edit folds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[non_exhaustive]
pub enum RemedySearch {
    /// No search.
    Off,
    /// At most the edit's own fit and deformation time, or
    /// [`RemedySearch::FLOOR_MS`] when that is less (the default).
    #[default]
    Bounded,
    /// To the end: the smallest radius to 2 %, and the sweep.
    Full,
}

impl RemedySearch {
    /// The least time a bounded search is given, in milliseconds: on a small
    /// mesh the whole search takes less.
    pub const FLOOR_MS: f64 = 200.0;

    /// The time a search may take after an edit whose fit and deformation
    /// took `spent_ms`; None for no bound.
    pub fn budget(self, spent_ms: f64) -> Option<Duration> {
        match self {
            RemedySearch::Off => Some(Duration::ZERO),
            RemedySearch::Bounded => {
                Some(Duration::from_secs_f64(spent_ms.max(Self::FLOOR_MS) / 1e3))
            }
            RemedySearch::Full => None,
        }
    }

    /// `off`, `bounded` or `full`, as the command line and Python take it.
    pub fn parse(s: &str) -> Option<RemedySearch> {
        match s {
            "off" => Some(RemedySearch::Off),
            "bounded" | "auto" => Some(RemedySearch::Bounded),
            "full" => Some(RemedySearch::Full),
            _ => None,
        }
    }
}

/// What would keep an edit from folding, as [`remedies`] measured it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Remedies {
    /// A factor of every plain deformation's radius that folds no face (the
    /// smallest, to 2 %, when the search was complete), and the
    /// milliseconds its fit and deformation took; None when none was found
    /// (even 4x folds, or the search stopped first).
    pub radius_scale: Option<(f64, f64)>,
    /// The plain deformations' radii, in order, that the factor scales.
    pub radii: Vec<f64>,
    /// With `"sweep": true` on every plain deformation: the steps taken in
    /// all, and the milliseconds its fit and deformation took; None when a
    /// sweep cannot be made (paths that meet, `"combine": "add"`) or was not
    /// tried.
    pub sweep: Option<(usize, f64)>,
    /// Whether a sweep, which cannot fold, could be made but was not tried
    /// (a bounded search leaves it out: its steps can cost far more than
    /// the edit). Not said of an edit with a region, whose cut edge a
    /// sweep does not keep from folding: only a full search's trial can.
    pub sweep_untried: bool,
    /// The milliseconds of the plain edit's fit and deformation, timed as
    /// the trials are (without the checks), for comparison; the edit's own
    /// time when the search had none for it.
    pub plain_ms: f64,
    /// The milliseconds the search took.
    pub searched_ms: f64,
    /// Whether the search ran to its end (else it stopped at its budget).
    pub complete: bool,
}

impl Remedies {
    /// Whether anything was found.
    pub fn found(&self) -> bool {
        self.radius_scale.is_some() || self.sweep.is_some()
    }

    /// The advice as one sentence for people, or "" when nothing was found
    /// and the search was complete: "to keep it from folding: a radius
    /// 2.28x as large (0.1 -> 0.228) folds no face (fit + deform 3.1 ms), or
    /// "sweep": true cannot fold (4 step(s), fit + deform 9.0 ms); the edit
    /// as it is takes 2.0 ms".
    pub fn advice(&self) -> String {
        let mut ways = Vec::new();
        if let Some((scale, ms)) = self.radius_scale {
            let radii: Vec<String> = self
                .radii
                .iter()
                .map(|r| format!("{r:.4} -> {:.4}", r * scale))
                .collect();
            ways.push(format!(
                "a radius {scale:.2}x as large ({}) folds no face (fit + deform {ms:.2} ms)",
                radii.join(", ")
            ));
        }
        if let Some((steps, ms)) = self.sweep {
            ways.push(format!(
                "\"sweep\": true cannot fold ({steps} step(s), fit + deform {ms:.2} ms)"
            ));
        } else if self.sweep_untried {
            ways.push(
                "\"sweep\": true, which cannot fold (not timed; `--remedies full` or remedies=\"full\" times it)"
                    .to_owned(),
            );
        }
        let cut = if self.complete {
            String::new()
        } else {
            format!(
                " (searched {:.0} ms, the edit's own time; a full search, `--remedies full` or remedies=\"full\", may find a smaller radius)",
                self.searched_ms
            )
        };
        if ways.is_empty() {
            if self.complete && !self.sweep_untried {
                return String::new();
            }
            return format!("no remedy found in time{cut}");
        }
        format!(
            "to keep it from folding: {}; the edit as it is takes {:.2} ms{cut}",
            ways.join(", or "),
            self.plain_ms
        )
    }
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
            // Layers without controls move nothing, whatever their radius.
            if spec.sweep.is_none() && !spec.starts.is_empty() {
                change(&mut spec);
            }
            stages.extend(crate::fit_spec(&spec)?.stages.into_iter().map(|s| {
                let p = s.phase * self.phase;
                s.with_phase(p)
            }));
        }
        let moved = compose_with_groups(self.rest, &stages, self.combine, self.groups)?;
        let ms = t.elapsed().as_secs_f64() * 1e3;
        std::hint::black_box(moved);
        let found = csrbf::folds(
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

/// A clock for the search: whether another trial fits in the budget, judged
/// by the last trial's time.
struct Clock {
    start: Instant,
    budget: Option<Duration>,
    last: Duration,
    stopped: bool,
}

impl Clock {
    fn another(&mut self) -> bool {
        let Some(b) = self.budget else {
            return true;
        };
        let fits = self.start.elapsed() + self.last <= b;
        self.stopped |= !fits;
        fits
    }

    fn ran(&mut self, started: Instant) {
        self.last = started.elapsed();
    }
}

/// What would keep `specs` (resolved on `rest`) from turning faces of the
/// mesh inside out at `phase`: a radius factor that folds none (the
/// smallest, given time) and the sweep, each with its cost, searched within
/// `search`'s budget after an edit whose fit and deformation took
/// `spent_ms`. Call it when an edit folds.
#[allow(clippy::too_many_arguments)]
pub fn remedies(
    rest: &[Vec3],
    triangles: &[[u32; 3]],
    specs: &[ControlSpec],
    combine: Combine,
    phase: f64,
    groups: &dyn Fn(&str) -> Option<Vec<u32>>,
    search: RemedySearch,
    spent_ms: f64,
) -> Result<Remedies> {
    let edit = Edit {
        rest,
        triangles,
        specs,
        combine,
        phase,
        groups,
    };
    let mut clock = Clock {
        start: Instant::now(),
        budget: search.budget(spent_ms),
        // The first trial costs about what the edit did.
        last: Duration::from_secs_f64(spent_ms / 1e3),
        stopped: false,
    };
    // The plain edit timed as the trials are (fit and composition, without
    // the checks the edit's own time includes), so the costs compare.
    let mut plain_ms = spent_ms;
    if clock.another() {
        let t = Instant::now();
        if let Ok((_, _, ms)) = edit.scaled(1.0) {
            plain_ms = ms;
        }
        clock.ran(t);
    }
    // Grow until nothing folds, then bisect between the last that folded
    // and the first that did not. A radius that the engine refuses (too
    // large a system) counts as not found.
    let mut lo = 1.0;
    let mut found = None;
    for s in [1.25, 1.5, 2.0, 3.0, MOST_SCALE] {
        if !clock.another() {
            break;
        }
        let t = Instant::now();
        let tried = edit.scaled(s);
        clock.ran(t);
        match tried {
            Ok((0, _, ms)) => {
                found = Some((s, ms));
                break;
            }
            Ok(_) => lo = s,
            Err(_) => break,
        }
    }
    if let Some((mut hi, mut ms)) = found {
        while hi - lo > 0.02 * lo && clock.another() {
            let mid = 0.5 * (lo + hi);
            let t = Instant::now();
            let tried = edit.scaled(mid);
            clock.ran(t);
            match tried {
                Ok((0, _, t)) => {
                    hi = mid;
                    ms = t;
                }
                Ok(_) => lo = mid,
                // A radius the engine refuses: keep the one found.
                Err(_) => break,
            }
        }
        found = Some((hi, ms));
    }
    // The sweep last, and only in a full search: one trial, but its steps
    // (hundreds for a handle's turn) can cost seconds where a radius costs
    // the edit's own time. A bounded search names it untimed.
    let mut sweep = None;
    // A sweep is certified over all of space; a region's cut edge can still
    // fold, so with a region only a trial that folds nothing counts.
    let regions = specs
        .iter()
        .any(|s| !s.starts.is_empty() && s.region != csrbf::Region::All);
    let sweep_possible = combine == Combine::Chain;
    if sweep_possible && search == RemedySearch::Full {
        let swept = |spec: &mut ControlSpec| spec.sweep = Some(csrbf::SweepOptions::default());
        sweep = edit
            .trial(&swept)
            .ok()
            .filter(|(folded, _, _)| *folded == 0)
            .map(|(_, steps, ms)| (steps, ms));
    }
    Ok(Remedies {
        radius_scale: found,
        radii: specs
            .iter()
            .filter(|s| s.sweep.is_none() && !s.starts.is_empty())
            .map(|s| s.options.radius)
            .collect(),
        sweep,
        sweep_untried: sweep_possible && !regions && search != RemedySearch::Full,
        plain_ms,
        searched_ms: clock.start.elapsed().as_secs_f64() * 1e3,
        complete: !clock.stopped,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use csrbf::{FitOptions, Kernel};
    use glam::DVec3;

    #[test]
    fn a_folding_pull_is_fixed_by_a_larger_radius_or_a_sweep() {
        // A 30 x 30 grid of triangles pulled hard at its middle.
        let (rest, tris) = csrbf::synthetic::grid(30);
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
            RemedySearch::Full,
            1.0,
        )
        .expect("remedies");
        assert!(r.complete);
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
