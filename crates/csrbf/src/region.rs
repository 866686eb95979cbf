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
