//! Handles: a rigid or scaled motion of part of a model (rotate an ear,
//! lower a head, twist a leg), turned into control vectors.
//!
//! The selection is sampled by farthest-point sampling (its extremes first,
//! then evenly spread: up to [`DEFAULT_HANDLE_SAMPLES`], never closer than
//! R/20, so the system stays well conditioned), each sample moved by the handle's
//! motion; the anchor is sampled the same way, nearest the selection first,
//! each sample a pin (a control vector of zero length). Fitting those vectors
//! gives a map that moves the selection as asked, keeps the anchor in place
//! and blends smoothly in between.
//!
//! ```
//! use csrbf::{Handle, Region, Rotation, Polynomial};
//! use glam::{DVec3, Vec3};
//!
//! // A row of points along X; turn the far half by 90 degrees about Z at x = 5.
//! let points: Vec<Vec3> = (0..=100).map(|i| Vec3::new(i as f32 * 0.1, 0.0, 0.0)).collect();
//! let handle = Handle::new(Region::Box { min: DVec3::new(6.0, -1.0, -1.0), max: DVec3::splat(11.0) })
//!     .with_rotation(Rotation::new(DVec3::Z, 90.0).with_pivot(DVec3::new(5.0, 0.0, 0.0)));
//! let anchor = Region::Box { min: DVec3::splat(-1.0), max: DVec3::new(4.0, 1.0, 1.0) };
//! let v = handle.controls(&points, Some(&anchor), 3.0, Polynomial::None, &|_| None)?;
//! assert!(v.moving > 0 && v.starts.len() > v.moving);
//! // The tip (10, 0, 0) goes to (5, 5, 0).
//! let tip = v.starts.iter().position(|s| s.x == 10.0).unwrap();
//! assert!(v.targets[tip].distance(DVec3::new(5.0, 5.0, 0.0)) < 1e-9);
//! # Ok::<(), csrbf::Error>(())
//! ```

use glam::{DAffine3, DMat3, DQuat, DVec3, Vec3};
use rayon::prelude::*;

use crate::error::{Error, FitError, Result};
use crate::kernel::Polynomial;
use crate::octree::Octree;
use crate::region::Region;

/// Most samples a handle or an anchor makes when not told otherwise.
pub const DEFAULT_HANDLE_SAMPLES: usize = 256;
/// Samples never come closer than this fraction of R (conditioning).
pub const MIN_SAMPLE_SPACING: f64 = 1.0 / 20.0;

/// A rotation about an axis through a pivot.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[non_exhaustive]
pub struct Rotation {
    /// Axis (any length but zero).
    pub axis: DVec3,
    /// Angle in degrees, counter-clockwise looking down the axis.
    pub angle_deg: f64,
    /// Point the axis goes through. Default: the centroid of the selection.
    pub pivot: Option<DVec3>,
}

impl Rotation {
    /// A rotation about `axis` through the selection's centroid.
    pub fn new(axis: DVec3, angle_deg: f64) -> Rotation {
        Rotation {
            axis,
            angle_deg,
            pivot: None,
        }
    }

    /// The same rotation about an axis through `pivot`.
    pub fn with_pivot(mut self, pivot: DVec3) -> Rotation {
        self.pivot = Some(pivot);
        self
    }
}

/// A motion of the selected part of a model: scale, then rotate about the
/// pivot, then translate.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[non_exhaustive]
pub struct Handle {
    /// The points that move rigidly (or scaled).
    pub select: Region,
    /// Rotation. Default none.
    pub rotate: Option<Rotation>,
    /// Uniform scale about the pivot. Default 1.
    pub scale: Option<f64>,
    /// Translation after rotating and scaling. Default none.
    pub translate: Option<DVec3>,
    /// Most samples of the selection (and of the anchor). Default
    /// [`DEFAULT_HANDLE_SAMPLES`]; fewer are taken where the selection is
    /// small for R.
    pub samples: Option<usize>,
}

/// The control vectors a handle makes.
#[derive(Clone, Debug, PartialEq)]
pub struct HandleControls {
    /// Start points: the selection's samples first, then the pins.
    pub starts: Vec<DVec3>,
    /// Destinations (pins stay put).
    pub targets: Vec<DVec3>,
    /// How many of the vectors move (the rest are pins).
    pub moving: usize,
    /// The pivot used.
    pub pivot: DVec3,
    /// Vertices selected.
    pub selected: usize,
}

impl Handle {
    /// A handle on `select` that does not move yet.
    pub fn new(select: Region) -> Handle {
        Handle {
            select,
            rotate: None,
            scale: None,
            translate: None,
            samples: None,
        }
    }

    /// With a rotation.
    pub fn with_rotation(mut self, rotation: Rotation) -> Handle {
        self.rotate = Some(rotation);
        self
    }

    /// With a uniform scale about the pivot.
    pub fn with_scale(mut self, scale: f64) -> Handle {
        self.scale = Some(scale);
        self
    }

    /// With a translation.
    pub fn with_translation(mut self, t: DVec3) -> Handle {
        self.translate = Some(t);
        self
    }

    /// With at most `n` samples.
    pub fn with_samples(mut self, n: usize) -> Handle {
        self.samples = Some(n);
        self
    }

    /// Checks the numbers: a non-zero finite axis, finite angle, scale > 0,
    /// finite translation and pivot, at least one sample.
    pub fn check(&self) -> Result<()> {
        let bad = |m: String| Err(Error::BadHandle(m));
        if let Some(r) = &self.rotate {
            if !r.axis.is_finite() || !(r.axis.length() > 0.0) {
                return bad(format!(
                    "rotate.axis {:?} must be a finite, non-zero vector",
                    r.axis.to_array()
                ));
            }
            if !r.angle_deg.is_finite() {
                return bad(format!(
                    "rotate.angle_deg {} must be a finite number",
                    r.angle_deg
                ));
            }
            if r.pivot.is_some_and(|p| !p.is_finite()) {
                return bad("rotate.pivot must be finite".into());
            }
        }
        if let Some(s) = self.scale
            && !(s > 0.0 && s.is_finite())
        {
            return bad(format!("scale {s} must be a finite number > 0"));
        }
        if self.translate.is_some_and(|t| !t.is_finite()) {
            return bad("translate must be finite".into());
        }
        if self.samples == Some(0) {
            return bad("samples must be at least 1".into());
        }
        Ok(())
    }

    /// The point the handle turns and scales about: the rotation's own
    /// pivot, else the centroid of the selection among `points` (as
    /// [`Handle::controls`] takes it). `groups` resolves part names.
    pub fn pivot(
        &self,
        points: &[Vec3],
        groups: &dyn Fn(&str) -> Option<Vec<u32>>,
    ) -> Result<DVec3> {
        if let Some(p) = self.rotate.and_then(|r| r.pivot) {
            return Ok(p);
        }
        let selected = self.selection(points, groups)?;
        let sum: DVec3 = selected
            .iter()
            .map(|&i| points[i as usize].as_dvec3())
            .sum();
        Ok(sum / selected.len() as f64)
    }

    /// The points `select` holds; none is refused.
    fn selection(
        &self,
        points: &[Vec3],
        groups: &dyn Fn(&str) -> Option<Vec<u32>>,
    ) -> Result<Vec<u32>> {
        let selected = self.select.select(points, groups)?;
        if selected.is_empty() {
            return Err(Error::BadHandle(format!(
                "select ({}) holds none of the {} points",
                self.select,
                points.len()
            )));
        }
        Ok(selected)
    }

    /// The motion as an affine map, about `pivot` (the rotation's own pivot
    /// when it has one).
    pub fn motion(&self, pivot: DVec3) -> DAffine3 {
        let pivot = self.rotate.and_then(|r| r.pivot).unwrap_or(pivot);
        let rot = self
            .rotate
            .map(|r| DQuat::from_axis_angle(r.axis.normalize(), r.angle_deg.to_radians()))
            .unwrap_or(DQuat::IDENTITY);
        let s = self.scale.unwrap_or(1.0);
        let lin = DMat3::from_quat(rot) * DMat3::from_diagonal(DVec3::splat(s));
        let t = pivot - lin * pivot + self.translate.unwrap_or(DVec3::ZERO);
        DAffine3::from_mat3_translation(lin, t)
    }

    /// The control vectors for `points` (selection and anchor chosen on
    /// them), with pins on `anchor` if given. `radius` is the deformation's R:
    /// samples never come closer than R/20. With [`Polynomial::None`] only
    /// anchor points within R of a moving sample are pinned (the others
    /// cannot feel the handle); with `Linear` the whole anchor is sampled so
    /// the affine part stays put. `groups` resolves part names.
    pub fn controls(
        &self,
        points: &[Vec3],
        anchor: Option<&Region>,
        radius: f64,
        polynomial: Polynomial,
        groups: &dyn Fn(&str) -> Option<Vec<u32>>,
    ) -> Result<HandleControls> {
        self.check()?;
        if !(radius > 0.0 && radius.is_finite()) {
            return Err(FitError::BadRadius(radius).into());
        }
        let selected = self.selection(points, groups)?;
        let sel: Vec<DVec3> = selected
            .iter()
            .map(|&i| points[i as usize].as_dvec3())
            .collect();
        if sel.iter().any(|p| !p.is_finite()) {
            return Err(Error::BadHandle(
                "the selection has a point that is not finite".into(),
            ));
        }
        let centroid = sel.iter().copied().sum::<DVec3>() / sel.len() as f64;
        let pivot = self.rotate.and_then(|r| r.pivot).unwrap_or(centroid);
        let motion = self.motion(pivot);
        let cap = self.samples.unwrap_or(DEFAULT_HANDLE_SAMPLES);
        let spacing = radius * MIN_SAMPLE_SPACING;
        // The extreme of the selection farthest from the pivot first (a tip).
        let seed = farthest_from(&sel, pivot);
        let picks = farthest_point_samples(&sel, seed, cap, spacing);
        let mut starts: Vec<DVec3> = picks.iter().map(|&k| sel[k]).collect();
        let mut targets: Vec<DVec3> = starts.iter().map(|&s| motion.transform_point3(s)).collect();
        let moving = starts.len();

        if let Some(anchor) = anchor {
            let mut pinned = anchor.select(points, groups)?;
            if pinned.is_empty() {
                return Err(Error::BadHandle(format!(
                    "anchor ({anchor}) holds none of the {} points",
                    points.len()
                )));
            }
            let overlap = count_shared(&selected, &pinned);
            if overlap > 0 {
                return Err(Error::BadHandle(format!(
                    "anchor and select share {overlap} points: a point cannot both move and stay; make them disjoint"
                )));
            }
            let tree = Octree::new(&starts);
            if polynomial == Polynomial::None {
                pinned.retain(|&i| {
                    let mut near = false;
                    tree.for_each_within(points[i as usize].as_dvec3(), radius, |_, _| near = true);
                    near
                });
            }
            let anc: Vec<DVec3> = pinned
                .iter()
                .map(|&i| points[i as usize].as_dvec3())
                .collect();
            if !anc.is_empty() {
                // Nearest the selection first.
                let seed = anc
                    .par_iter()
                    .enumerate()
                    .map(|(k, p)| (nearest_distance2(&starts, *p), k))
                    .min_by(|a, b| a.0.total_cmp(&b.0))
                    .map(|x| x.1)
                    .unwrap_or(0);
                for k in farthest_point_samples(&anc, seed, cap, spacing) {
                    starts.push(anc[k]);
                    targets.push(anc[k]);
                }
            }
        }
        Ok(HandleControls {
            starts,
            targets,
            moving,
            pivot,
            selected: selected.len(),
        })
    }
}

fn count_shared(a: &[u32], b: &[u32]) -> usize {
    // Both ascending (Region::select).
    let (mut i, mut j, mut n) = (0, 0, 0);
    while i < a.len() && j < b.len() {
        match a[i].cmp(&b[j]) {
            std::cmp::Ordering::Less => i += 1,
            std::cmp::Ordering::Greater => j += 1,
            std::cmp::Ordering::Equal => {
                n += 1;
                i += 1;
                j += 1;
            }
        }
    }
    n
}

fn farthest_from(points: &[DVec3], q: DVec3) -> usize {
    points
        .iter()
        .enumerate()
        .map(|(k, p)| (p.distance_squared(q), k))
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .map(|x| x.1)
        .unwrap_or(0)
}

fn nearest_distance2(points: &[DVec3], q: DVec3) -> f64 {
    points
        .iter()
        .map(|p| p.distance_squared(q))
        .fold(f64::INFINITY, f64::min)
}

/// Farthest-point sampling: starts at `seed`, then repeatedly takes the point
/// farthest from those taken, until `max` are taken or the farthest is
/// closer than `spacing`. Returns indices into `points`.
pub fn farthest_point_samples(
    points: &[DVec3],
    seed: usize,
    max: usize,
    spacing: f64,
) -> Vec<usize> {
    if points.is_empty() || max == 0 {
        return Vec::new();
    }
    let mut dist = vec![f64::INFINITY; points.len()];
    let mut out = vec![seed];
    let mut last = points[seed];
    let s2 = spacing * spacing;
    while out.len() < max {
        let (d, k) = dist
            .par_iter_mut()
            .zip(points.par_iter())
            .enumerate()
            .map(|(k, (d, p))| {
                *d = d.min(p.distance_squared(last));
                (*d, k)
            })
            .reduce(|| (-1.0, 0), |a, b| if b.0 > a.0 { b } else { a });
        if !(d >= s2) || d == 0.0 {
            break;
        }
        out.push(k);
        last = points[k];
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Deformation, FitOptions, Kernel};

    /// A tube of radius 0.5 along X from 0 to 10 (rings every 0.1).
    fn tube() -> Vec<Vec3> {
        let mut p = Vec::new();
        for i in 0..=100 {
            for k in 0..16 {
                let a = k as f32 / 16.0 * std::f32::consts::TAU;
                p.push(Vec3::new(i as f32 * 0.1, 0.5 * a.cos(), 0.5 * a.sin()));
            }
        }
        p
    }

    fn bx(x0: f64, x1: f64) -> Region {
        Region::Box {
            min: DVec3::new(x0, -1.0, -1.0),
            max: DVec3::new(x1, 1.0, 1.0),
        }
    }

    #[test]
    fn a_limb_turned_90_degrees_turns_as_a_rigid_body() {
        let points = tube();
        let pivot = DVec3::new(5.0, 0.0, 0.0);
        let handle = Handle::new(bx(6.0, 11.0))
            .with_rotation(Rotation::new(DVec3::Z, 90.0).with_pivot(pivot));
        let radius = 3.0;
        for polynomial in [Polynomial::None, Polynomial::Linear] {
            let v = handle
                .controls(&points, Some(&bx(-1.0, 4.0)), radius, polynomial, &|_| None)
                .expect("controls");
            let opts = FitOptions::new(radius)
                .with_kernel(Kernel::C2)
                .with_polynomial(polynomial);
            let d = Deformation::fit(&v.starts, &v.targets, opts).expect("fit");
            // The tip ring's centre (not a sample) and every selected point.
            let tip: Vec<DVec3> = points
                .iter()
                .filter(|p| p.x > 9.95)
                .map(|p| d.map(p.as_dvec3()))
                .collect();
            let centre = tip.iter().copied().sum::<DVec3>() / tip.len() as f64;
            let arm = centre - pivot;
            let angle = DVec3::X.angle_between(arm).to_degrees();
            assert!(
                (angle - 90.0).abs() < 2.0,
                "{polynomial}: tip angle {angle}"
            );
            assert!(
                (arm.length() - 5.0).abs() < 0.15,
                "{polynomial}: length {}",
                arm.length()
            );
            let m = handle.motion(pivot);
            let worst = points
                .iter()
                .filter(|p| p.x >= 6.0)
                .map(|p| {
                    d.map(p.as_dvec3())
                        .distance(m.transform_point3(p.as_dvec3()))
                })
                .fold(0.0, f64::max);
            assert!(
                worst < 0.05 * 5.0,
                "{polynomial}: selection off the rotation by {worst}"
            );
            // The anchor stays put.
            let drift = points
                .iter()
                .filter(|p| p.x <= 4.0)
                .map(|p| d.displacement_at(p.as_dvec3()).length())
                .fold(0.0, f64::max);
            assert!(drift < 0.05, "{polynomial}: anchor moved {drift}");
        }
    }

    #[test]
    fn the_pivot_is_the_one_the_controls_turn_about() {
        let points = tube();
        let centroid = Handle::new(bx(6.0, 11.0)).with_scale(2.0);
        let own = Handle::new(bx(6.0, 11.0))
            .with_rotation(Rotation::new(DVec3::Z, 30.0).with_pivot(DVec3::new(5.0, 0.0, 0.0)));
        for h in [centroid, own] {
            let v = h
                .controls(&points, None, 2.0, Polynomial::None, &|_| None)
                .expect("controls");
            let p = h.pivot(&points, &|_| None).expect("pivot");
            assert!(p.distance(v.pivot) < 1e-9, "{p} vs {}", v.pivot);
        }
        let empty = Handle::new(bx(50.0, 60.0));
        assert!(matches!(
            empty.pivot(&points, &|_| None),
            Err(Error::BadHandle(_))
        ));
    }

    #[test]
    fn scale_and_translate_about_the_centroid() {
        let points = tube();
        let h = Handle::new(bx(6.0, 11.0))
            .with_scale(2.0)
            .with_translation(DVec3::Y);
        let v = h
            .controls(&points, None, 2.0, Polynomial::None, &|_| None)
            .expect("controls");
        assert_eq!(v.moving, v.starts.len());
        assert!(v.pivot.distance(DVec3::new(8.0, 0.0, 0.0)) < 1e-6);
        for (s, t) in v.starts.iter().zip(&v.targets) {
            let want = v.pivot + (*s - v.pivot) * 2.0 + DVec3::Y;
            assert!(t.distance(want) < 1e-9);
        }
    }

    #[test]
    fn samples_are_spread_and_capped() {
        let points = tube();
        let h = Handle::new(bx(6.0, 11.0)).with_translation(DVec3::Y);
        for radius in [1.0, 20.0] {
            let v = h
                .controls(&points, None, radius, Polynomial::None, &|_| None)
                .expect("controls");
            assert!(v.starts.len() <= DEFAULT_HANDLE_SAMPLES);
            for (i, a) in v.starts.iter().enumerate() {
                for b in &v.starts[..i] {
                    assert!(a.distance(*b) >= radius * MIN_SAMPLE_SPACING - 1e-9);
                }
            }
        }
        let v = h
            .with_samples(5)
            .controls(&points, None, 1.0, Polynomial::None, &|_| None)
            .expect("controls");
        assert_eq!(v.starts.len(), 5);
    }

    #[test]
    fn bad_handles_are_named() {
        let points = tube();
        let cases = [
            (
                Handle::new(bx(6.0, 11.0)).with_rotation(Rotation::new(DVec3::ZERO, 90.0)),
                None,
                "axis",
            ),
            (
                Handle::new(bx(6.0, 11.0)).with_rotation(Rotation::new(DVec3::Z, f64::NAN)),
                None,
                "angle_deg",
            ),
            (Handle::new(bx(6.0, 11.0)).with_scale(0.0), None, "scale"),
            (Handle::new(bx(60.0, 61.0)).with_scale(2.0), None, "select"),
            (
                Handle::new(bx(6.0, 11.0)).with_scale(2.0),
                Some(bx(5.0, 7.0)),
                "share",
            ),
            (
                Handle::new(bx(6.0, 11.0)).with_scale(2.0),
                Some(bx(50.0, 70.0)),
                "anchor",
            ),
        ];
        for (h, anchor, want) in cases {
            let e = h
                .controls(&points, anchor.as_ref(), 1.0, Polynomial::None, &|_| None)
                .expect_err(want)
                .to_string();
            assert!(e.contains(want), "{e:?} does not name {want}");
        }
    }
}
