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
mod poly;

use std::sync::Arc;

use glam::DVec3;
use rayon::prelude::*;

use crate::deformation::{Affine, Deformation, Shared};
use crate::error::{Error, FitError, Result};
use crate::evaluate::Point;
use crate::kernel::Polynomial;
use crate::octree::Octree;
use crate::ordering;
use crate::skyline::Envelope;
use crate::solver::Factor;

pub use crate::options::{
    DEFAULT_MEMORY_LIMIT, FitOptions, FitPhases, OrderingFigures, SystemStats,
};
pub use estimate::{Estimate, estimate};

use assemble::{Bands, factor};
use graph::{neighbour_counts, neighbour_graph, validate};
use poly::{PolyBlock, poly_block};

/// From this many starts the pairs within R are estimated before the graph
/// is built (64 samples against every start: well under 0.1 ms at 1,000
/// starts). Fewer starts fill [`graph::PARALLEL_PAIRS`] only when each
/// reaches more than a seventh of the others, a nearly dense system whose
/// factorisation dwarfs its graph: they are built on one thread.
const ESTIMATE_STARTS: usize = 1000;

/// From this many starts the supernodal solver's ordering is made beside
/// the band orderings (on the other core), before the choice between them.
const DISSECT_AHEAD: usize = 2000;

/// The symbolic and numeric state for one set of start points.
///
/// ```
/// use csrbf::{FitOptions, System};
/// use csrbf::glam::{DVec3, Vec3};
///
/// let starts = [DVec3::ZERO, DVec3::X];
/// let sys = System::new(&starts, FitOptions::new(0.8))?;
/// let points = vec![Vec3::ZERO, Vec3::X * 0.5];
/// let binding = sys.bind(&points); // no solve needed first
/// let mut d = sys.solve(&starts)?; // the identity
/// let mut shown = vec![Vec3::ZERO; 2];
/// for step in 1..=3 {
///     let targets = [DVec3::new(0.0, 0.1 * step as f64, 0.0), DVec3::X];
///     sys.solve_into(&targets, &mut d)?; // reuses d's buffers
///     binding.displacements_into(&d, &mut shown)?;
/// }
/// assert!((shown[0].y - 0.3).abs() < 1e-6);
/// # Ok::<(), csrbf::Error>(())
/// ```
#[derive(Debug)]
pub struct System {
    options: FitOptions,
    pub(crate) shared: Shared,
    factor: Factor,
    poly: Option<PolyBlock>,
    stats: SystemStats,
    /// Pairs of starts closer than [`graph::NEAR_FRACTION`] R.
    near: Vec<(u32, u32)>,
    /// The neighbour graph its structure was made for
    /// ([`System::rebuild`] compares it).
    graph: Arc<crate::ordering::Graph>,
}

impl System {
    /// Builds and factors the system for these start points.
    ///
    /// Checks: at least one start, finite coordinates, a valid radius, no two
    /// starts at the same place, and for `linear` at least 4 starts not on one
    /// plane.
    pub fn new<P: Point>(starts: &[P], options: FitOptions) -> Result<System, FitError> {
        let starts: Vec<DVec3> = starts.iter().map(|p| p.to_dvec3()).collect();
        System::build_awake(starts, options, None)
    }

    /// The system for `starts` and `options`, taking this one's ordering
    /// and symbolic factorisation when they fit: when the neighbour graph
    /// comes out the same (starts moved without a neighbour gained or
    /// lost, another kernel; the radius, solver and ordering asked alike).
    /// Then only the matrix is assembled and factored again: a start
    /// dragged costs the graph, assembly, numeric factorisation and
    /// polynomial block, not the orderings and symbolic analysis
    /// ([`SystemStats::reused`] says which was done). The result equals
    /// [`System::new`]'s.
    pub fn rebuild<P: Point>(&self, starts: &[P], options: FitOptions) -> Result<System, FitError> {
        let starts: Vec<DVec3> = starts.iter().map(|p| p.to_dvec3()).collect();
        System::build_awake(starts, options, Some(self))
    }

    /// [`System::build`], with the pool's other workers kept awake through
    /// it from [`DISSECT_AHEAD`] starts on, where its serial phases (the
    /// symbolic analysis) come between parallel ones (the dissection beside
    /// the band orderings, the factorisation's halves): see
    /// [`crate::awake`].
    fn build_awake(
        starts: Vec<DVec3>,
        options: FitOptions,
        previous: Option<&System>,
    ) -> Result<System, FitError> {
        if starts.len() >= DISSECT_AHEAD {
            crate::awake::with_the_pool_awake(|| System::build(starts, options, previous))
        } else {
            System::build(starts, options, previous)
        }
    }

    fn build(
        starts: Vec<DVec3>,
        options: FitOptions,
        previous: Option<&System>,
    ) -> Result<System, FitError> {
        let mut clock = Clock::start();
        let mut phases = FitPhases::default();
        validate(&starts, &options)?;
        let radius = options.radius;
        // The pairs within R, estimated from a sample of the starts: a
        // nearly dense system is refused before its graph is built, and a
        // graph of many pairs is built on both cores.
        let estimated = (starts.len() >= ESTIMATE_STARTS).then(|| estimate(&starts, radius));
        if let Some(e) = estimated.filter(|e| e.starts >= 2000)
            && e.bytes > options.memory_limit as f64
        {
            return Err(FitError::TooLarge {
                bytes: e.bytes,
                limit: options.memory_limit,
                neighbours: e.neighbours,
                starts: e.starts,
                radius,
                suggested_radius: estimate::radius_within(&starts, radius, options.memory_limit),
            });
        }
        let octree = Octree::new(&starts);
        phases.checks_ms = clock.lap();
        // Neighbour entries: each pair within R from both ends.
        let pairs = estimated.map(|e| e.neighbours * e.starts as f64);
        let (graph, close, near) = neighbour_graph(&starts, &octree, radius, options.kernel, pairs);
        phases.graph_ms = clock.lap();
        if let Some(c) = close {
            return Err(if c.d2 == 0.0 {
                FitError::DuplicateStart {
                    first: c.first,
                    second: c.second,
                }
            } else {
                FitError::StartsTooClose {
                    first: c.first,
                    second: c.second,
                    distance: c.d2.sqrt(),
                    radius,
                }
            });
        }
        let n = starts.len();
        if let Some(p) = previous.filter(|p| {
            p.options.radius == radius
                && p.options.solver == options.solver
                && p.options.ordering == options.ordering
                && *p.graph == graph
        }) {
            return System::refit(p, starts, options, octree, graph, near, clock, phases);
        }
        let identity: Vec<u32> = (0..n as u32).collect();
        // The band orderings (the profile solver's) and the envelope of the
        // one chosen. A large system likely to go to the supernodal solver
        // is dissected first, and these run beside its symbolic analysis.
        let bands = || {
            let before = ordering::band(&graph, &identity);
            let chosen = ordering::order_knowing(&graph, options.ordering, Some(before));
            let envelope = Envelope::new(&graph, &chosen.perm);
            Bands {
                before,
                chosen,
                envelope,
            }
        };
        let dissect_ahead =
            n >= DISSECT_AHEAD && options.solver != crate::solver::SolverChoice::Skyline;
        let mut factor_flops = 0.0;
        let (factor, bands) = factor(
            &starts,
            &graph,
            bands,
            dissect_ahead,
            &options,
            &mut phases,
            &mut factor_flops,
        )?;
        let Bands {
            before,
            chosen,
            envelope,
        } = bands;
        let mut stats = SystemStats {
            controls: n,
            nonzeros: n + graph.edge_entries(),
            bandwidth_before: before.bandwidth,
            envelope_before: before.envelope,
            bandwidth: chosen.band.bandwidth,
            envelope: chosen.band.envelope,
            ordering: chosen.ordering.name().to_owned(),
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
            skyline_flops: envelope.factor_flops(),
            factor_flops,
            ..SystemStats::default()
        };
        neighbour_counts(&graph, &mut stats);
        let perm = chosen.perm;
        clock.lap();
        stats.solver = factor.choice().name().to_owned();
        stats.factor_bytes = factor.value_bytes();
        let poly = match options.polynomial {
            Polynomial::None => None,
            Polynomial::Linear => Some(poly_block(&starts, &factor)?),
        };
        phases.polynomial_ms = clock.lap();
        stats.phases = phases;
        Ok(System {
            options,
            shared: Shared::new(&options, starts, perm.into(), octree),
            factor,
            poly,
            stats,
            near,
            graph: Arc::new(graph),
        })
    }

    /// [`System::build`]'s end when `previous` has the same graph: its
    /// ordering, structure and figures, new values.
    #[allow(clippy::too_many_arguments)] // the build's state, passed on once
    fn refit(
        previous: &System,
        starts: Vec<DVec3>,
        options: FitOptions,
        octree: Octree,
        graph: crate::ordering::Graph,
        near: Vec<(u32, u32)>,
        mut clock: Clock,
        mut phases: FitPhases,
    ) -> Result<System, FitError> {
        phases.ordering_ms = clock.lap();
        let factor = assemble::refactor(&previous.factor, &starts, &graph, &options, &mut phases)?;
        clock.lap();
        let poly = match options.polynomial {
            Polynomial::None => None,
            Polynomial::Linear => Some(poly_block(&starts, &factor)?),
        };
        phases.polynomial_ms = clock.lap();
        let mut stats = previous.stats.clone();
        stats.phases = phases;
        stats.reused = true;
        Ok(System {
            options,
            shared: Shared::new(&options, starts, previous.shared.order.clone(), octree),
            factor,
            poly,
            stats,
            near,
            graph: previous.graph.clone(),
        })
    }

    /// Solves for the coefficients that carry each start to its destination.
    /// Only the right-hand sides change: nothing is assembled or factored
    /// again, and the deformation shares the system's starts and octree.
    pub fn solve<P: Point>(&self, targets: &[P]) -> Result<Deformation, FitError> {
        let (y, affine, moves) = self.solution(targets)?;
        Ok(Deformation::from_shared(&self.shared, y, affine, moves))
    }

    /// Solves again into a deformation this system solved before, reusing
    /// its buffers (a drag loop). Fails when `deformation` came from other
    /// starts, kernel or radius (its fingerprint differs).
    pub fn solve_into<P: Point>(&self, targets: &[P], deformation: &mut Deformation) -> Result<()> {
        if deformation.fingerprint() != self.shared.fingerprint {
            return Err(Error::SystemMismatch);
        }
        let (y, affine, moves) = self.solution(targets)?;
        deformation.set_solution(&y, affine, moves);
        Ok(())
    }

    /// Solves for several sets of destinations at once, in parallel
    /// (dataset augmentation: one mesh, many edits).
    pub fn solve_many<T: AsRef<[DVec3]> + Sync>(
        &self,
        target_sets: &[T],
    ) -> Result<Vec<Deformation>, FitError> {
        target_sets
            .par_iter()
            .map(|t| self.solve(t.as_ref()))
            .collect()
    }

    /// The coefficients and polynomial part for these destinations, and the
    /// largest move (a destination less its start).
    fn solution<P: Point>(
        &self,
        targets: &[P],
    ) -> Result<(Vec<DVec3>, Option<Affine>, f64), FitError> {
        let starts = &self.shared.starts;
        if targets.len() != starts.len() {
            return Err(FitError::TargetCount {
                expected: starts.len(),
                got: targets.len(),
            });
        }
        let mut y: Vec<DVec3> = Vec::with_capacity(targets.len());
        for (i, (t, s)) in targets.iter().zip(starts.iter()).enumerate() {
            let t = t.to_dvec3();
            if !t.is_finite() {
                return Err(FitError::NotFinite {
                    index: i,
                    what: "destination",
                });
            }
            y.push(t - *s);
        }
        self.check_near_pairs(&y)?;
        let moves = y.iter().map(|m| m.length()).fold(0.0, f64::max);
        let affine = match &self.poly {
            None => {
                self.factor.solve_in_place(&mut y);
                None
            }
            Some(pb) => {
                // z = L^-1 f, r = V^T z (4 x 3), beta = S^-1 r, and the
                // coefficients alpha = L^-T (z - V beta) = A^-1 (f - P beta).
                let mut z = self.factor.forward(&y);
                let mut r = [DVec3::ZERO; 4];
                for (vi, zi) in pb.v.iter().zip(&z) {
                    for (k, rk) in r.iter_mut().enumerate() {
                        *rk += *zi * vi[k];
                    }
                }
                let mut beta = [DVec3::ZERO; 4];
                for (k, bk) in beta.iter_mut().enumerate() {
                    let row = pb.s_inv.row(k);
                    *bk = r[0] * row.x + r[1] * row.y + r[2] * row.z + r[3] * row.w;
                }
                for (zi, vi) in z.iter_mut().zip(&pb.v) {
                    *zi -= beta[0] * vi.x + beta[1] * vi.y + beta[2] * vi.z + beta[3] * vi.w;
                }
                self.factor.backward(z, &mut y);
                Some(Affine {
                    center: pb.center,
                    scale: pb.scale,
                    coefficients: beta,
                })
            }
        };
        Ok((y, affine, moves))
    }

    /// Starts nearly on top of each other (closer than 1 % of R) must move
    /// alike: moves that differ by more than their distance ask for a
    /// gradient no smooth map has, and the interpolant overshoots far away.
    /// `moves` are the destinations less the starts.
    fn check_near_pairs(&self, moves: &[DVec3]) -> Result<(), FitError> {
        let starts = &self.shared.starts;
        for &(a, b) in &self.near {
            let (a, b) = (a as usize, b as usize);
            if a >= moves.len() || b >= moves.len() {
                continue;
            }
            let distance = starts[a].distance(starts[b]);
            let difference = (moves[a] - moves[b]).length();
            if difference > distance {
                return Err(FitError::ConflictingStarts {
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
        &self.shared.starts
    }

    /// The fingerprint of its starts, kernel and radius, shared by every
    /// deformation it solves ([`Deformation::fingerprint`]).
    pub fn fingerprint(&self) -> u64 {
        self.shared.fingerprint
    }

    /// The figures of the system.
    pub fn stats(&self) -> &SystemStats {
        &self.stats
    }

    /// The ordering used (`order[new] = start index`).
    pub fn order(&self) -> &[u32] {
        &self.shared.order
    }
}

impl Shared {
    /// The block a system's deformations share, for these starts in the
    /// order `order`.
    fn new(options: &FitOptions, starts: Vec<DVec3>, order: Arc<[u32]>, octree: Octree) -> Shared {
        let fingerprint = crate::deformation::fingerprint(options.kernel, options.radius, &starts);
        Shared {
            kernel: options.kernel,
            radius: options.radius,
            starts: starts.into(),
            order,
            octree: Arc::new(octree),
            fingerprint,
        }
    }
}

/// A stopwatch for the phases of a build.
pub(crate) struct Clock(std::time::Instant);

impl Clock {
    pub(crate) fn start() -> Clock {
        Clock(std::time::Instant::now())
    }
    /// Milliseconds since the start or the last lap; starts the next lap.
    pub(crate) fn lap(&mut self) -> f64 {
        let now = std::time::Instant::now();
        let ms = (now - self.0).as_secs_f64() * 1e3;
        self.0 = now;
        ms
    }
}

impl Deformation {
    /// Fits the deformation carrying each start to its destination. Use
    /// [`System`] directly to solve again for new destinations cheaply.
    ///
    /// ```
    /// use csrbf::{Deformation, FitOptions, Kernel, Polynomial};
    /// use glam::DVec3;
    ///
    /// let starts = [DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z];
    /// let targets = [DVec3::new(0.0, 0.0, 0.1), DVec3::X, DVec3::Y, DVec3::Z];
    /// let opts = FitOptions::new(1.5).with_polynomial(Polynomial::None);
    /// let d = Deformation::fit(&starts, &targets, opts)?;
    /// assert!((d.map(DVec3::ZERO) - targets[0]).length() < 1e-12);
    /// assert_eq!(d.displacement_at(DVec3::splat(10.0)), DVec3::ZERO);
    /// # Ok::<(), csrbf::Error>(())
    /// ```
    pub fn fit<P: Point>(
        starts: &[P],
        targets: &[P],
        options: FitOptions,
    ) -> Result<Deformation, FitError> {
        if starts.len() != targets.len() {
            return Err(FitError::LengthMismatch {
                starts: starts.len(),
                targets: targets.len(),
            });
        }
        System::new(starts, options)?.solve(targets)
    }
}
