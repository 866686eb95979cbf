//! The interpolation system for a set of start points: neighbour graph,
//! ordering, profile, factor and the polynomial block. Built once per set of
//! starts and radius; solved again for every new set of destinations.
//!
//! Split by operation: `options` (what to build), `graph` (validation and
//! the neighbour graph), `assemble` (the matrix and the solver's choice),
//! `poly` (the polynomial block).

mod assemble;
mod estimate;
mod graph;
mod options;
mod poly;

use glam::DVec3;
use rayon::prelude::*;

use crate::deformation::{Affine, Deformation};
use crate::error::{Error, Result};
use crate::evaluate::Point;
use crate::kernel::Polynomial;
use crate::octree::Octree;
use crate::ordering;
use crate::skyline::Envelope;
use crate::solver::Factor;

pub use estimate::{Estimate, estimate};
pub use options::{DEFAULT_MEMORY_LIMIT, FitOptions, OrderingFigures, SystemStats};
pub(crate) use poly::prow;

use assemble::factor;
use graph::{neighbour_counts, neighbour_graph, validate};
use poly::{PolyBlock, poly_block};

/// The symbolic and numeric state for one set of start points.
#[derive(Debug)]
pub struct System {
    options: FitOptions,
    starts: Vec<DVec3>,
    octree: Octree,
    order: Vec<u32>,
    factor: Factor,
    poly: Option<PolyBlock>,
    stats: SystemStats,
    /// Pairs of starts closer than [`graph::NEAR_FRACTION`] R.
    near: Vec<(u32, u32)>,
}

impl System {
    /// Builds and factors the system for these start points.
    ///
    /// Checks: at least one start, finite coordinates, a valid radius, no two
    /// starts at the same place, and for `linear` at least 4 starts not on one
    /// plane.
    pub fn new<P: Point>(starts: &[P], options: FitOptions) -> Result<System> {
        let starts: Vec<DVec3> = starts.iter().map(|p| p.to_dvec3()).collect();
        System::build(&starts, options)
    }

    fn build(starts: &[DVec3], options: FitOptions) -> Result<System> {
        validate(starts, &options)?;
        let radius = options.radius;
        // A nearly dense system is refused before its graph is built.
        if starts.len() >= 2000 {
            let e = estimate(starts, radius);
            if e.bytes > options.memory_limit as f64 {
                return Err(Error::TooLarge {
                    bytes: e.bytes,
                    limit: options.memory_limit,
                    neighbours: e.neighbours,
                    starts: e.starts,
                    radius,
                    suggested_radius: e.radius_for(radius, options.memory_limit),
                });
            }
        }
        let octree = Octree::new(starts);
        let (graph, close, near) = neighbour_graph(starts, &octree, radius, options.kernel);
        if let Some(c) = close {
            return Err(if c.d2 == 0.0 {
                Error::DuplicateStart {
                    first: c.first,
                    second: c.second,
                }
            } else {
                Error::StartsTooClose {
                    first: c.first,
                    second: c.second,
                    distance: c.d2.sqrt(),
                    radius,
                }
            });
        }
        let n = starts.len();
        let identity: Vec<u32> = (0..n as u32).collect();
        let before = ordering::band(&graph, &identity);
        let chosen = ordering::order(&graph, options.ordering);
        let (perm, after, used) = (chosen.perm, chosen.band, chosen.ordering);
        let envelope = Envelope::new(&graph, &perm);
        let skyline_flops = envelope.factor_flops();

        let mut stats = SystemStats {
            controls: n,
            nonzeros: n + graph.edge_entries(),
            bandwidth_before: before.bandwidth,
            envelope_before: before.envelope,
            bandwidth: after.bandwidth,
            envelope: after.envelope,
            ordering: used.name().to_owned(),
            orderings: chosen
                .tried
                .iter()
                .map(|(o, b)| OrderingFigures {
                    ordering: o.name().to_owned(),
                    bandwidth: b.bandwidth,
                    envelope: b.envelope,
                })
                .collect(),
            profile_bytes: envelope.paper_bytes(),
            dense_bytes: 4 * n * n,
            skyline_flops,
            ..SystemStats::default()
        };
        neighbour_counts(&graph, &mut stats);

        let factor = factor(starts, &graph, perm.clone(), envelope, &options, after)?;
        stats.solver = factor.choice().name().to_owned();
        stats.factor_bytes = factor.value_bytes();
        let poly = match options.polynomial {
            Polynomial::None => None,
            Polynomial::Linear => Some(poly_block(starts, &factor)?),
        };
        Ok(System {
            options,
            starts: starts.to_vec(),
            octree,
            order: perm,
            factor,
            poly,
            stats,
            near,
        })
    }

    /// Solves for the coefficients that carry each start to its destination.
    /// Only the right-hand sides change: nothing is assembled or factored again.
    pub fn solve<P: Point>(&self, targets: &[P]) -> Result<Deformation> {
        let targets: Vec<DVec3> = targets.iter().map(|p| p.to_dvec3()).collect();
        self.solve_f64(&targets)
    }

    fn solve_f64(&self, targets: &[DVec3]) -> Result<Deformation> {
        self.check_near_pairs(targets)?;
        if targets.len() != self.starts.len() {
            return Err(Error::TargetCount {
                expected: self.starts.len(),
                got: targets.len(),
            });
        }
        if let Some(i) = targets.iter().position(|t| !t.is_finite()) {
            return Err(Error::NotFinite {
                index: i,
                what: "destination",
            });
        }
        let mut y: Vec<DVec3> = targets
            .iter()
            .zip(&self.starts)
            .map(|(t, s)| *t - *s)
            .collect();
        self.factor.solve_in_place(&mut y);
        let affine = match &self.poly {
            None => None,
            Some(pb) => {
                // r = P^T y (4 x 3), beta = S^-1 r, alpha = y - W beta.
                let mut r = [DVec3::ZERO; 4];
                for (s, yi) in self.starts.iter().zip(&y) {
                    let p = prow(*s, pb.center, pb.scale);
                    for (k, rk) in r.iter_mut().enumerate() {
                        *rk += *yi * p[k];
                    }
                }
                let mut beta = [DVec3::ZERO; 4];
                for (k, bk) in beta.iter_mut().enumerate() {
                    let row = pb.s_inv.row(k);
                    *bk = r[0] * row.x + r[1] * row.y + r[2] * row.z + r[3] * row.w;
                }
                for (yi, wi) in y.iter_mut().zip(&pb.w) {
                    *yi -= beta[0] * wi.x + beta[1] * wi.y + beta[2] * wi.z + beta[3] * wi.w;
                }
                Some(Affine {
                    center: pb.center,
                    scale: pb.scale,
                    coefficients: beta,
                })
            }
        };
        Ok(Deformation::from_parts(
            self.options.kernel,
            self.options.radius,
            self.starts.clone(),
            y,
            affine,
            self.order.clone(),
            Some(self.octree.clone()),
        ))
    }

    /// Starts nearly on top of each other (closer than 1 % of R) must move
    /// alike: moves that differ by more than their distance ask for a
    /// gradient no smooth map has, and the interpolant overshoots far away.
    fn check_near_pairs(&self, targets: &[DVec3]) -> Result<()> {
        for &(a, b) in &self.near {
            let (a, b) = (a as usize, b as usize);
            if a >= targets.len() || b >= targets.len() {
                continue;
            }
            let distance = self.starts[a].distance(self.starts[b]);
            let difference =
                ((targets[a] - self.starts[a]) - (targets[b] - self.starts[b])).length();
            if difference > distance {
                return Err(Error::ConflictingStarts {
                    first: a,
                    second: b,
                    distance,
                    difference,
                    radius: self.options.radius,
                });
            }
        }
        Ok(())
    }

    /// The options it was built with.
    pub fn options(&self) -> &FitOptions {
        &self.options
    }

    /// The start points.
    pub fn starts(&self) -> &[DVec3] {
        &self.starts
    }

    /// The figures of the system.
    pub fn stats(&self) -> &SystemStats {
        &self.stats
    }

    /// The ordering used (`order[new] = start index`).
    pub fn order(&self) -> &[u32] {
        &self.order
    }
}

/// `(0..n).map(f)`, in parallel when `n` is large enough to pay for it.
pub(crate) fn maybe_par_map<T: Send>(
    n: usize,
    threshold: usize,
    f: impl Fn(usize) -> T + Sync + Send,
) -> Vec<T> {
    if n >= threshold {
        (0..n).into_par_iter().map(f).collect()
    } else {
        (0..n).map(f).collect()
    }
}
