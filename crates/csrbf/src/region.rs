//! The part of an object a deformation acts on.

use glam::{DVec3, Vec3};

use crate::error::{RegionError, Result};

/// Where a deformation applies; points outside do not move.
#[derive(Clone, Debug, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "lowercase"))]
#[non_exhaustive]
pub enum Region {
    /// Every point (default).
    #[default]
    All,
    /// Points within `radius` of `center`.
    Sphere {
        /// Centre of the sphere.
        center: DVec3,
        /// Its radius.
        radius: f64,
    },
    /// Points inside the axis-aligned box.
    Box {
        /// Lower corner.
        min: DVec3,
        /// Upper corner.
        max: DVec3,
    },
    /// These point indices.
    Vertices(Vec<u32>),
    /// A named part of the mesh (group, object or material), resolved by the
    /// caller into point indices.
    Group(String),
    /// Another region with a smooth edge: points inside it move fully, points
    /// within `width` of it (of its surface for a sphere or box, of its
    /// nearest point for a list or part) move by a weight falling smoothly
    /// to zero, instead of a hard cut.
    Falloff {
        /// The region itself (not itself a falloff).
        inner: Box<Region>,
        /// Width of the blend, in the mesh's units.
        width: f64,
    },
}

impl std::fmt::Display for Region {
    /// In words: `everything`, `sphere at (x, y, z) of radius r`, ...
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let p = |v: &DVec3| format!("({}, {}, {})", v.x, v.y, v.z);
        match self {
            Region::All => f.write_str("everything"),
            Region::Sphere { center, radius } => {
                write!(f, "sphere at {} of radius {radius}", p(center))
            }
            Region::Box { min, max } => write!(f, "box from {} to {}", p(min), p(max)),
            Region::Vertices(v) => write!(f, "{} listed vertices", v.len()),
            Region::Group(name) => write!(f, "part {name:?}"),
            Region::Falloff { inner, width } => write!(f, "{inner}, blended over {width}"),
        }
    }
}

impl Region {
    /// Refuses a region no point could sensibly be in, naming the field: a
    /// sphere whose centre is not finite or whose radius is negative or not
    /// finite, a box with a corner not finite or `min` above `max` on an
    /// axis, a falloff whose width is not a finite number > 0 or that wraps
    /// another falloff. [`Region::select`] and [`Region::weights`] check.
    pub fn check(&self) -> Result<(), RegionError> {
        let bad = |m: String| Err(RegionError::Invalid(m));
        match self {
            Region::Sphere { center, radius } => {
                if !center.is_finite() {
                    return bad(format!("sphere.center {center} is not finite"));
                }
                if !(*radius >= 0.0 && radius.is_finite()) {
                    return bad(format!(
                        "sphere.radius must be a finite number >= 0, got {radius}"
                    ));
                }
            }
            Region::Box { min, max } => {
                if !min.is_finite() || !max.is_finite() {
                    return bad(format!("box.min {min} or box.max {max} is not finite"));
                }
                for (axis, (lo, hi)) in ["x", "y", "z"]
                    .iter()
                    .zip(min.to_array().into_iter().zip(max.to_array()))
                {
                    if lo > hi {
                        return bad(format!("box.min.{axis} {lo} is above box.max.{axis} {hi}"));
                    }
                }
            }
            Region::Falloff { inner, width } => {
                if matches!(**inner, Region::Falloff { .. }) {
                    return bad("a falloff cannot wrap another falloff".into());
                }
                if !(*width > 0.0 && width.is_finite()) {
                    return bad(format!(
                        "falloff width must be a finite number > 0, got {width}"
                    ));
                }
                inner.check()?;
            }
            Region::All | Region::Vertices(_) | Region::Group(_) => {}
        }
        Ok(())
    }

    /// The indices of the points in the region, ascending. `group` resolves a
    /// part name into point indices (None when there is no such part).
    pub fn select(
        &self,
        points: &[Vec3],
        group: &dyn Fn(&str) -> Option<Vec<u32>>,
    ) -> Result<Vec<u32>> {
        self.check()?;
        let n = points.len();
        let filter = |keep: &dyn Fn(DVec3) -> bool| -> Vec<u32> {
            (0..n as u32)
                .filter(|&i| keep(points[i as usize].as_dvec3()))
                .collect()
        };
        Ok(match self {
            Region::All => (0..n as u32).collect(),
            Region::Sphere { center, radius } => {
                filter(&|p| p.distance_squared(*center) <= radius * radius)
            }
            Region::Box { min, max } => filter(&|p| p.cmpge(*min).all() && p.cmple(*max).all()),
            Region::Vertices(v) => {
                if let Some(&bad) = v.iter().find(|&&i| i as usize >= n) {
                    return Err(RegionError::Index {
                        index: bad as usize,
                        count: n,
                    }
                    .into());
                }
                let mut v = v.clone();
                v.sort_unstable();
                v.dedup();
                v
            }
            Region::Group(name) => {
                let mut v = group(name).ok_or_else(|| RegionError::UnknownGroup(name.clone()))?;
                v.retain(|&i| (i as usize) < n);
                v.sort_unstable();
                v.dedup();
                v
            }
            Region::Falloff { .. } => self.weights(points, group)?.0,
        })
    }

    /// The points the region moves, ascending, with the weight of each (1
    /// inside, smoothly less in a falloff's blend, never 0).
    pub fn weights(
        &self,
        points: &[Vec3],
        group: &dyn Fn(&str) -> Option<Vec<u32>>,
    ) -> Result<(Vec<u32>, Vec<f32>)> {
        let Region::Falloff { inner, width } = self else {
            let v = self.select(points, group)?;
            let w = vec![1.0; v.len()];
            return Ok((v, w));
        };
        self.check()?;
        let width = *width;
        // Distance of a point outside the inner region to it.
        let inside = inner.select(points, group)?;
        let outside_distance: Box<dyn Fn(DVec3) -> f64 + Sync> = match &**inner {
            Region::All => return Ok((inside.clone(), vec![1.0; inside.len()])),
            Region::Sphere { center, radius } => {
                let (c, r) = (*center, *radius);
                Box::new(move |p: DVec3| (p.distance(c) - r).max(0.0))
            }
            Region::Box { min, max } => {
                let (lo, hi) = (*min, *max);
                Box::new(move |p: DVec3| (lo - p).max(p - hi).max(DVec3::ZERO).length())
            }
            _ => {
                let pts: Vec<DVec3> = inside
                    .iter()
                    .map(|&i| points[i as usize].as_dvec3())
                    .collect();
                let tree = crate::octree::Octree::new(&pts);
                Box::new(move |p: DVec3| {
                    let mut best = f64::INFINITY;
                    tree.for_each_within(p, width, |_, d2| best = best.min(d2));
                    best.sqrt()
                })
            }
        };
        let mut is_in = vec![false; points.len()];
        for &i in &inside {
            is_in[i as usize] = true;
        }
        let mut out = Vec::new();
        let mut w = Vec::new();
        for (i, p) in points.iter().enumerate() {
            if is_in[i] {
                out.push(i as u32);
                w.push(1.0);
                continue;
            }
            let d = outside_distance(p.as_dvec3());
            if d < width {
                let s = 1.0 - d / width;
                out.push(i as u32);
                w.push((s * s * (3.0 - 2.0 * s)) as f32);
            }
        }
        Ok((out, w))
    }

    /// The size of the region across (a sphere's diameter, a box's largest
    /// side), for checking a falloff; None for lists and parts.
    pub fn size(&self) -> Option<f64> {
        match self {
            Region::Sphere { radius, .. } => Some(2.0 * radius),
            Region::Box { min, max } => Some((*max - *min).max_element()),
            Region::Falloff { inner, .. } => inner.size(),
            _ => None,
        }
    }

    /// Grows (positive) or shrinks (negative) a sphere or box by `amount`;
    /// lists and groups are returned unchanged.
    pub fn grown(&self, amount: f64) -> Region {
        match self {
            Region::Sphere { center, radius } => Region::Sphere {
                center: *center,
                radius: (radius + amount).max(0.0),
            },
            Region::Box { min, max } => {
                let d = DVec3::splat(amount);
                let (lo, hi) = (*min - d, *max + d);
                Region::Box {
                    min: lo.min(hi),
                    max: hi.max(lo),
                }
            }
            Region::Falloff { inner, width } => Region::Falloff {
                inner: Box::new(inner.grown(amount)),
                width: *width,
            },
            other => other.clone(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn points() -> Vec<Vec3> {
        (0..10).map(|i| Vec3::new(i as f32, 0.0, 0.0)).collect()
    }

    #[test]
    fn falloffs_blend_smoothly_to_zero() {
        let none = |_: &str| None;
        let p = points();
        let s = Region::Sphere {
            center: DVec3::new(4.0, 0.0, 0.0),
            radius: 1.5,
        };
        let f = Region::Falloff {
            inner: Box::new(s.clone()),
            width: 2.0,
        };
        let (v, w) = f.weights(&p, &none).expect("weights");
        // 3, 4, 5 inside; 2 and 6 at 0.5 past the edge; 1 and 7 at 1.5.
        assert_eq!(v, vec![1, 2, 3, 4, 5, 6, 7]);
        assert_eq!(&w[2..5], &[1.0, 1.0, 1.0]);
        assert!((w[1] - 0.84375).abs() < 1e-6 && w[1] == w[5], "{w:?}");
        assert!((w[0] - 0.15625).abs() < 1e-6 && w[0] == w[6], "{w:?}");
        assert_eq!(f.select(&p, &none), Ok(v));
        // Lists blend by distance to their nearest point.
        let list = Region::Falloff {
            inner: Box::new(Region::Vertices(vec![0])),
            width: 2.0,
        };
        let (v, w) = list.weights(&p, &none).expect("weights");
        assert_eq!(v, vec![0, 1]);
        assert_eq!(w[0], 1.0);
        assert!((w[1] - 0.5).abs() < 1e-6);
        // A plain region weighs 1 everywhere it selects.
        assert_eq!(s.weights(&p, &none).expect("w").1, vec![1.0; 3]);
        let bad = Region::Falloff {
            inner: Box::new(s),
            width: -1.0,
        };
        assert!(bad.weights(&p, &none).is_err());
    }

    #[test]
    fn regions_select_and_grow() {
        let none = |_: &str| None;
        let p = points();
        let s = Region::Sphere {
            center: DVec3::new(4.0, 0.0, 0.0),
            radius: 1.5,
        };
        assert_eq!(s.select(&p, &none), Ok(vec![3, 4, 5]));
        assert_eq!(s.grown(1.0).select(&p, &none), Ok(vec![2, 3, 4, 5, 6]));
        assert_eq!(s.grown(-2.0).select(&p, &none), Ok(vec![4]));
        let b = Region::Box {
            min: DVec3::new(0.5, -1.0, -1.0),
            max: DVec3::new(2.5, 1.0, 1.0),
        };
        assert_eq!(b.select(&p, &none), Ok(vec![1, 2]));
        assert_eq!(b.grown(1.0).select(&p, &none), Ok(vec![0, 1, 2, 3]));
        assert_eq!(
            Region::Vertices(vec![7, 2, 7]).select(&p, &none),
            Ok(vec![2, 7])
        );
        assert_eq!(
            Region::Vertices(vec![10]).select(&p, &none),
            Err(RegionError::Index {
                index: 10,
                count: 10
            }
            .into())
        );
        let groups = |n: &str| (n == "tip").then(|| vec![9, 8]);
        assert_eq!(
            Region::Group("tip".into()).select(&p, &groups),
            Ok(vec![8, 9])
        );
        assert_eq!(
            Region::Group("toe".into()).select(&p, &groups),
            Err(RegionError::UnknownGroup("toe".into()).into())
        );
        assert_eq!(Region::All.select(&p, &none).map(|v| v.len()), Ok(10));
    }
}
