//! The part of an object a deformation acts on.

use glam::{DVec3, Vec3};

use crate::error::{Error, Result};

/// Where a deformation applies; points outside do not move.
#[derive(Clone, Debug, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "lowercase"))]
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
        }
    }
}

impl Region {
    /// The indices of the points in the region, ascending. `group` resolves a
    /// part name into point indices (None when there is no such part).
    pub fn select(
        &self,
        points: &[Vec3],
        group: &dyn Fn(&str) -> Option<Vec<u32>>,
    ) -> Result<Vec<u32>> {
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
                    return Err(Error::RegionIndex {
                        index: bad as usize,
                        count: n,
                    });
                }
                let mut v = v.clone();
                v.sort_unstable();
                v.dedup();
                v
            }
            Region::Group(name) => {
                let mut v = group(name).ok_or_else(|| Error::UnknownGroup(name.clone()))?;
                v.retain(|&i| (i as usize) < n);
                v.sort_unstable();
                v.dedup();
                v
            }
        })
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
            Err(Error::RegionIndex {
                index: 10,
                count: 10
            })
        );
        let groups = |n: &str| (n == "tip").then(|| vec![9, 8]);
        assert_eq!(
            Region::Group("tip".into()).select(&p, &groups),
            Ok(vec![8, 9])
        );
        assert_eq!(
            Region::Group("toe".into()).select(&p, &groups),
            Err(Error::UnknownGroup("toe".into()))
        );
        assert_eq!(Region::All.select(&p, &none).map(|v| v.len()), Ok(10));
    }
}
