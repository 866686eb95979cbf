//! The interpolation system for a set of start points: neighbour graph,
//! ordering, profile, factor and the polynomial block. Built once per set of
//! starts and radius; solved again for every new set of destinations.

use glam::{DMat3, DMat4, DVec3, DVec4};
use rayon::prelude::*;

use crate::deformation::{Affine, Deformation};
use crate::error::{Error, Result};
use crate::kernel::{Kernel, Polynomial};
use crate::octree::Octree;
use crate::ordering::{self, Band, Graph, Ordering};
use crate::skyline::{Envelope, Profile};
use crate::solver::{Factor, LowerCsc, SolverChoice};

/// How to build a deformation. Plain data; `Default` is C2, R = 1, linear,
/// automatic ordering and solver.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub struct FitOptions {
    /// The Wendland kernel. Default C2.
    pub kernel: Kernel,
    /// Radius of support R, in the units of the points. Default 1.
    pub radius: f64,
    /// The polynomial term. Default none (local edits stay local).
    pub polynomial: Polynomial,
    /// Renumbering for the profile. Default automatic.
    pub ordering: Ordering,
    /// Factorisation. Default automatic (by estimated cost).
    pub solver: SolverChoice,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            kernel: Kernel::C2,
            radius: 1.0,
            polynomial: Polynomial::None,
            ordering: Ordering::Auto,
            solver: SolverChoice::Auto,
        }
    }
}

impl FitOptions {
    /// With this kernel.
    pub fn with_kernel(mut self, kernel: Kernel) -> Self {
        self.kernel = kernel;
        self
    }
    /// With this radius of support.
    pub fn with_radius(mut self, radius: f64) -> Self {
        self.radius = radius;
        self
    }
    /// With this polynomial term.
    pub fn with_polynomial(mut self, polynomial: Polynomial) -> Self {
        self.polynomial = polynomial;
        self
    }
    /// With this ordering.
    pub fn with_ordering(mut self, ordering: Ordering) -> Self {
        self.ordering = ordering;
        self
    }
    /// With this solver.
    pub fn with_solver(mut self, solver: SolverChoice) -> Self {
        self.solver = solver;
        self
    }
}

/// What the system looks like: the figures `csrbf info` reports.
#[derive(Clone, Debug, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct SystemStats {
    /// Number of control vectors N.
    pub controls: usize,
    /// Fewest neighbours (other starts within R) of any start.
    pub neighbours_min: usize,
    /// Mean neighbours per start.
    pub neighbours_mean: f64,
    /// Most neighbours of any start.
    pub neighbours_max: usize,
    /// Non-zeros of A (both triangles and the diagonal).
    pub nonzeros: usize,
    /// Bandwidth in the caller's order.
    pub bandwidth_before: usize,
    /// Envelope entries in the caller's order.
    pub envelope_before: usize,
    /// Bandwidth after ordering.
    pub bandwidth: usize,
    /// Envelope entries after ordering.
    pub envelope: usize,
    /// The ordering used.
    pub ordering: String,
    /// Bandwidth and envelope of every ordering tried.
    pub orderings: Vec<OrderingFigures>,
    /// Profile bytes in the papers' accounting (4-byte values and row starts).
    pub profile_bytes: usize,
    /// Dense N^2 bytes with 4-byte values, as in the papers.
    pub dense_bytes: usize,
    /// The solver used.
    pub solver: String,
    /// Estimated multiply-adds of the profile factorisation.
    pub skyline_flops: f64,
    /// Bytes the factor's f64 values take.
    pub factor_bytes: usize,
}

/// The band one ordering gives.
#[derive(Clone, Debug, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct OrderingFigures {
    /// `identity`, `breadth-first` or `rcm`.
    pub ordering: String,
    /// Largest distance of a non-zero from the diagonal.
    pub bandwidth: usize,
    /// Entries below the diagonal inside the profile.
    pub envelope: usize,
}

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
}

/// The polynomial block after elimination: W = A^-1 P and S^-1 = (P^T W)^-1,
/// with P's rows (1, u) for u the starts centred and scaled.
#[derive(Debug)]
struct PolyBlock {
    w: Vec<DVec4>,
    s_inv: DMat4,
    center: DVec3,
    scale: f64,
}

impl System {
    /// Builds and factors the system for these start points.
    ///
    /// Checks: at least one start, finite coordinates, a valid radius, no two
    /// starts at the same place, and for `linear` at least 4 starts not on one
    /// plane.
    pub fn new(starts: &[DVec3], options: FitOptions) -> Result<System> {
        validate(starts, &options)?;
        let radius = options.radius;
        let octree = Octree::new(starts);
        let (graph, close) = neighbour_graph(starts, &octree, radius, options.kernel);
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
        })
    }

    /// Solves for the coefficients that carry each start to its destination.
    /// Only the right-hand sides change: nothing is assembled or factored again.
    pub fn solve(&self, targets: &[DVec3]) -> Result<Deformation> {
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

fn validate(starts: &[DVec3], options: &FitOptions) -> Result<()> {
    if !(options.radius > 0.0 && options.radius.is_finite()) {
        return Err(Error::BadRadius(options.radius));
    }
    if starts.is_empty() {
        return Err(Error::NoControls);
    }
    if let Some(i) = starts.iter().position(|s| !s.is_finite()) {
        return Err(Error::NotFinite {
            index: i,
            what: "start",
        });
    }
    if options.polynomial == Polynomial::Linear {
        if starts.len() < 4 {
            return Err(Error::TooFewForLinear(starts.len()));
        }
        if coplanar(starts) {
            return Err(Error::CoplanarStarts);
        }
    }
    Ok(())
}

/// Whether the points lie (nearly) on one plane: the smallest principal
/// variance is negligible against the largest.
fn coplanar(points: &[DVec3]) -> bool {
    let n = points.len() as f64;
    let c = points.iter().copied().sum::<DVec3>() / n;
    let mut m = DMat3::ZERO;
    for p in points {
        let d = *p - c;
        m += DMat3::from_cols(d * d.x, d * d.y, d * d.z);
    }
    let scale = m.x_axis.x + m.y_axis.y + m.z_axis.z;
    if !(scale > 0.0) {
        return true;
    }
    let m = m * (1.0 / scale);
    // det = product of eigenvalues; with a trace of 1 the largest is >= 1/3.
    m.determinant() < 1e-12
}

/// A pair of starts that cannot be told apart: coincident, or so close that
/// the kernel's value differs from phi(0) by less than its rounding.
#[derive(Clone, Copy, Debug)]
struct ClosePair {
    first: usize,
    second: usize,
    d2: f64,
}

/// Neighbour lists within R (no self) and the first pair of starts too close
/// to tell apart.
fn neighbour_graph(
    starts: &[DVec3],
    octree: &Octree,
    radius: f64,
    kernel: Kernel,
) -> (Graph, Option<ClosePair>) {
    let phi0 = kernel.eval(0.0);
    let lists: Vec<(Vec<u32>, Option<ClosePair>)> = maybe_par_map(starts.len(), 256, |i| {
        let mut l = Vec::new();
        let mut close: Option<ClosePair> = None;
        octree.for_each_within(starts[i], radius, |j, d2| {
            let j = j as usize;
            if j == i {
                return;
            }
            if j < i
                && phi0 - kernel.eval(d2.sqrt() / radius) <= 1e-10 * phi0
                && close.is_none_or(|c| j < c.first)
            {
                close = Some(ClosePair {
                    first: j,
                    second: i,
                    d2,
                });
            }
            l.push(j as u32);
        });
        l.sort_unstable();
        (l, close)
    });
    let close = lists.iter().find_map(|(_, c)| *c);
    let mut offsets = Vec::with_capacity(starts.len() + 1);
    offsets.push(0);
    let mut flat = Vec::with_capacity(lists.iter().map(|(l, _)| l.len()).sum());
    for (l, _) in &lists {
        flat.extend_from_slice(l);
        offsets.push(flat.len());
    }
    (Graph::from_parts(offsets, flat), close)
}

fn neighbour_counts(graph: &Graph, stats: &mut SystemStats) {
    let n = graph.len().max(1);
    stats.neighbours_min = (0..graph.len()).map(|i| graph.degree(i)).min().unwrap_or(0);
    stats.neighbours_max = (0..graph.len()).map(|i| graph.degree(i)).max().unwrap_or(0);
    stats.neighbours_mean = graph.edge_entries() as f64 / n as f64;
}

/// Chooses and runs the factorisation.
fn factor(
    starts: &[DVec3],
    graph: &Graph,
    perm: Vec<u32>,
    envelope: Envelope,
    options: &FitOptions,
    _band: Band,
) -> Result<Factor> {
    let kernel = options.kernel;
    let inv_r = 1.0 / options.radius;
    let phi = |i: usize, j: usize| kernel.eval(starts[i].distance(starts[j]) * inv_r);
    let skyline_flops = envelope.factor_flops();
    let choice = match options.solver {
        SolverChoice::Auto => {
            // Below some 30 million multiply-adds the profile factor takes a few
            // milliseconds at most; beyond, compare with the supernodal fill.
            if skyline_flops < 3e7 {
                SolverChoice::Skyline
            } else {
                SolverChoice::Supernodal
            }
        }
        c => c,
    };
    if choice == SolverChoice::Supernodal {
        let a = lower_csc(graph, &phi, kernel.eval(0.0));
        let symbolic = Factor::supernodal_symbolic(&a)?;
        // The supernodal work is about sum over columns of count^2; the
        // profile's is its flops. Take the profile when it is not worse.
        let nnz_l = symbolic.len_val() as f64;
        let n = starts.len() as f64;
        let supernodal_flops = nnz_l * nnz_l / n * 0.5 + 2e5;
        if options.solver == SolverChoice::Auto && skyline_flops <= supernodal_flops {
            return Factor::skyline(
                assemble_profile(graph, &perm, envelope, &phi, kernel.eval(0.0)),
                perm,
            );
        }
        return Factor::supernodal(symbolic, &a);
    }
    Factor::skyline(
        assemble_profile(graph, &perm, envelope, &phi, kernel.eval(0.0)),
        perm,
    )
}

fn assemble_profile(
    graph: &Graph,
    perm: &[u32],
    envelope: Envelope,
    phi: &impl Fn(usize, usize) -> f64,
    diag: f64,
) -> Profile {
    let inv = ordering::inverse(perm);
    let mut p = Profile::zeros(envelope);
    for (new, &old) in perm.iter().enumerate() {
        p.set(new, new, diag);
        for &j in graph.neighbours(old as usize) {
            let nj = inv[j as usize] as usize;
            if nj < new {
                p.set(new, nj, phi(old as usize, j as usize));
            }
        }
    }
    p
}

fn lower_csc(graph: &Graph, phi: &impl Fn(usize, usize) -> f64, diag: f64) -> LowerCsc {
    let n = graph.len();
    let mut col_ptr = Vec::with_capacity(n + 1);
    let mut row_idx = Vec::with_capacity(n + graph.edge_entries() / 2);
    let mut values = Vec::with_capacity(row_idx.capacity());
    col_ptr.push(0u32);
    for j in 0..n {
        row_idx.push(j as u32);
        values.push(diag);
        // Neighbour lists are sorted, so rows below the diagonal come in order.
        for &i in graph.neighbours(j).iter().filter(|&&i| i as usize > j) {
            row_idx.push(i);
            values.push(phi(i as usize, j));
        }
        col_ptr.push(row_idx.len() as u32);
    }
    LowerCsc {
        n,
        col_ptr,
        row_idx,
        values,
    }
}

/// Row (1, u) of P for a start, with u = (s - centre) / scale.
#[inline]
pub(crate) fn prow(s: DVec3, center: DVec3, scale: f64) -> DVec4 {
    let u = (s - center) / scale;
    DVec4::new(1.0, u.x, u.y, u.z)
}

fn poly_block(starts: &[DVec3], factor: &Factor) -> Result<PolyBlock> {
    let n = starts.len() as f64;
    let center = starts.iter().copied().sum::<DVec3>() / n;
    let scale = starts
        .iter()
        .map(|s| s.distance(center))
        .fold(0.0, f64::max)
        .max(f64::MIN_POSITIVE);
    let p: Vec<DVec4> = starts.iter().map(|s| prow(*s, center, scale)).collect();
    let mut w = p.clone();
    factor.solve_in_place(&mut w);
    let mut s = DMat4::ZERO;
    for (pi, wi) in p.iter().zip(&w) {
        s += DMat4::from_cols(*wi * pi.x, *wi * pi.y, *wi * pi.z, *wi * pi.w);
    }
    // S is symmetric positive definite when P has full rank.
    let s = (s + s.transpose()) * 0.5;
    let det = s.determinant();
    let diag_product = s.x_axis.x * s.y_axis.y * s.z_axis.z * s.w_axis.w;
    if !(det > diag_product.abs() * 1e-14) || !det.is_finite() {
        return Err(Error::CoplanarStarts);
    }
    Ok(PolyBlock {
        w,
        s_inv: s.inverse(),
        center,
        scale,
    })
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
