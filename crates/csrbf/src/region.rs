//! The part of an object a deformation acts on.

use glam::{DVec3, Vec3};

use crate::error::{RegionError, Result};
use crate::surface::Surface;

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
    /// Points within `distance` along the mesh's surface of where the
    /// deformation takes hold ([`Origin`]): a limb's edit then leaves the
    /// torso beside it alone, however near in space, and other pieces of
    /// the mesh never move. It needs the mesh's faces:
    /// the edit layer (`csrbf_edit::controls::ControlSpec::resolve_on`) turns it into
    /// [`Region::Weights`] (see [`Region::on_surface`]); in a
    /// [`Region::Falloff`] the blend is measured along the surface too.
    Connected {
        /// How far along the surface, in the mesh's units (>= 0).
        distance: f64,
        /// Where distances are measured from.
        from: Origin,
    },
    /// Points with a weight each in (0, 1]: what a connected region is on a
    /// given mesh, or a painted weight map. Each listed point moves by its
    /// weight times the displacement.
    Weights {
        /// Point indices.
        vertices: Vec<u32>,
        /// The weight of each, in [0, 1] (0 is the same as not listed).
        weights: Vec<f32>,
    },
}

/// Where a [`Region::Connected`] measures its distances from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "lowercase"))]
#[non_exhaustive]
pub enum Origin {
    /// The starts of the control vectors that move (pins do not count),
    /// each entering the surface at its nearest vertex (default without a
    /// handle).
    #[default]
    Starts,
    /// Every vertex of the deformation's handle's selection (default with
    /// a handle).
    Handle,
}

impl Origin {
    /// `starts` or `handle`, as a control file writes it.
    pub fn name(self) -> &'static str {
        match self {
            Origin::Starts => "starts",
            Origin::Handle => "handle",
        }
    }
}

impl std::fmt::Display for Region {
    /// In words: `everything`, `sphere at (x, y, z) of radius r`, ...
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        use crate::error::number;
        let p = |v: &DVec3| format!("({}, {}, {})", number(v.x), number(v.y), number(v.z));
        match self {
            Region::All => f.write_str("everything"),
            Region::Sphere { center, radius } => {
                write!(f, "sphere at {} of radius {}", p(center), number(*radius))
            }
            Region::Box { min, max } => write!(f, "box from {} to {}", p(min), p(max)),
            Region::Vertices(v) => write!(f, "{} listed vertices", v.len()),
            Region::Group(name) => write!(f, "part {name:?}"),
            Region::Falloff { inner, width } => {
                write!(f, "{inner}, blended over {}", number(*width))
            }
            Region::Connected { distance, from } => write!(
                f,
                "within {} along the surface of the {}",
                number(*distance),
                match from {
                    Origin::Starts => "starts",
                    Origin::Handle => "handle's selection",
                }
            ),
            Region::Weights { vertices, .. } => write!(f, "{} weighted vertices", vertices.len()),
        }
    }
}

impl Region {
    /// Whether it lists vertices by index (a vertex list or weights, or a
    /// falloff around one): such a region means something on one mesh only.
    pub fn lists_vertices(&self) -> bool {
        match self {
            Region::Vertices(_) | Region::Weights { .. } => true,
            Region::Falloff { inner, .. } => inner.lists_vertices(),
            _ => false,
        }
    }

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
                if matches!(**inner, Region::Weights { .. }) {
                    return bad("a falloff cannot wrap weights: they blend as they are".into());
                }
                if !(*width > 0.0 && width.is_finite()) {
                    return bad(format!(
                        "falloff width must be a finite number > 0, got {width}"
                    ));
                }
                inner.check()?;
            }
            Region::Connected { distance, .. } => {
                if !(*distance >= 0.0 && distance.is_finite()) {
                    return bad(format!(
                        "connected.distance must be a finite number >= 0, got {distance}"
                    ));
                }
            }
            Region::Weights { vertices, weights } => {
                if vertices.len() != weights.len() {
                    return bad(format!(
                        "weights: {} vertices but {} weights",
                        vertices.len(),
                        weights.len()
                    ));
                }
                if let Some(w) = weights.iter().find(|w| !(0.0..=1.0).contains(*w)) {
                    return bad(format!("weights: each must be within [0, 1], got {w}"));
                }
            }
            Region::All | Region::Vertices(_) | Region::Group(_) => {}
        }
        Ok(())
    }

    /// Whether the region is measured along the mesh's surface (a connected
    /// region, or a falloff around one): it must be resolved on the mesh
    /// ([`Region::on_surface`]) before it can select points.
    pub fn needs_surface(&self) -> bool {
        match self {
            Region::Connected { .. } => true,
            Region::Falloff { inner, .. } => inner.needs_surface(),
            _ => false,
        }
    }

    /// Where a connected region (or a falloff around one) measures from.
    pub fn origin(&self) -> Option<Origin> {
        match self {
            Region::Connected { from, .. } => Some(*from),
            Region::Falloff { inner, .. } => inner.origin(),
            _ => None,
        }
    }

    /// A connected region (alone or in a falloff) on a mesh: the vertices of
    /// `surface` within its distance along the surface of `seeds` (each a
    /// vertex and the distance already travelled to it) weigh 1, those
    /// within the falloff's width beyond it blend smoothly to 0, and nothing
    /// else (another piece of the mesh, or farther) is listed. Any other
    /// region is returned as it is.
    pub fn on_surface(&self, surface: &Surface, seeds: &[(u32, f64)]) -> Result<Region> {
        self.check()?;
        let (distance, width) = match self {
            Region::Connected { distance, .. } => (*distance, 0.0),
            Region::Falloff { inner, width } => match **inner {
                Region::Connected { distance, .. } => (distance, *width),
                _ => return Ok(self.clone()),
            },
            _ => return Ok(self.clone()),
        };
        // Strictly beyond the distance with no falloff: weight 0.
        let limit = distance + width;
        let reached = if width > 0.0 {
            surface.distances(seeds, limit)
        } else {
            let mut r = surface.distances(seeds, next_up(limit));
            r.retain(|&(_, d)| d <= distance);
            r
        };
        let (vertices, weights) = reached
            .into_iter()
            .map(|(v, d)| {
                let w = if d <= distance {
                    1.0
                } else {
                    blend(d - distance, width)
                };
                (v, w)
            })
            .filter(|&(_, w)| w > 0.0)
            .unzip();
        Ok(Region::Weights { vertices, weights })
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
            Region::Falloff { .. } | Region::Weights { .. } => self.weights(points, group)?.0,
            Region::Connected { .. } => return Err(RegionError::NeedsSurface.into()),
        })
    }

    /// The points the region moves, ascending, with the weight of each (1
    /// inside, smoothly less in a falloff's blend, never 0).
    pub fn weights(
        &self,
        points: &[Vec3],
        group: &dyn Fn(&str) -> Option<Vec<u32>>,
    ) -> Result<(Vec<u32>, Vec<f32>)> {
        if let Region::Weights { vertices, weights } = self {
            self.check()?;
            let n = points.len();
            let mut pairs: Vec<(u32, f32)> = vertices
                .iter()
                .copied()
                .zip(weights.iter().copied())
                .filter(|&(_, w)| w > 0.0)
                .collect();
            if let Some(&(bad, _)) = pairs.iter().find(|&&(i, _)| i as usize >= n) {
                return Err(RegionError::Index {
                    index: bad as usize,
                    count: n,
                }
                .into());
            }
            pairs.sort_by_key(|&(i, _)| i);
            pairs.dedup_by_key(|&mut (i, _)| i);
            return Ok(pairs.into_iter().unzip());
        }
        if self.needs_surface() {
            return Err(RegionError::NeedsSurface.into());
        }
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
                out.push(i as u32);
                w.push(blend(d, width));
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

/// The weight at `d` past a region's edge in a blend `width` wide: smooth
/// from 1 at the edge to 0 at the width (0 beyond; 1 for a zero width at 0).
fn blend(d: f64, width: f64) -> f32 {
    if d <= 0.0 {
        return 1.0;
    }
    if !(d < width) {
        return 0.0;
    }
    let s = 1.0 - d / width;
    (s * s * (3.0 - 2.0 * s)) as f32
}

/// The least f64 above `x` (the limit that still reaches distance `x`).
fn next_up(x: f64) -> f64 {
    if x.is_finite() {
        x + x.abs().max(f64::MIN_POSITIVE) * f64::EPSILON
    } else {
        x
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
