//! What to build: the options of a fit, and the figures a built system reports.

use crate::kernel::{Kernel, Polynomial};
use crate::ordering::Ordering;
use crate::solver::SolverChoice;

/// How to build a deformation. Plain data: [`FitOptions::new`] takes the
/// radius of support, the one parameter with no sensible default (it is in
/// the model's units); the rest default to C2, no polynomial, automatic
/// ordering and solver.
///
/// Choosing R: a share of the model's size (5-20 % of its bounding box's
/// diagonal for a local edit), or so that each start has some neighbours
/// within R (`csrbf info --controls C` prints neighbours per start and the
/// system's memory; [`System::stats`](crate::System::stats) gives the same
/// figures). A larger R gives smoother, wider edits and a denser system.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub struct FitOptions {
    /// The Wendland kernel. Default C2.
    pub kernel: Kernel,
    /// Radius of support R, in the units of the points. No default: given
    /// to [`FitOptions::new`].
    pub radius: f64,
    /// The polynomial term. Default none (local edits stay local).
    pub polynomial: Polynomial,
    /// Renumbering for the profile. Default automatic.
    pub ordering: Ordering,
    /// Factorisation. Default automatic (by estimated cost).
    pub solver: SolverChoice,
    /// Most memory the neighbour graph and factor may take, estimated
    /// before either is built: past it the fit is refused (see
    /// [`crate::FitError::TooLarge`]). Default [`DEFAULT_MEMORY_LIMIT`];
    /// `u64::MAX` lifts it.
    pub memory_limit: u64,
}

/// The default [`FitOptions::memory_limit`]: 4 GiB, a sixth of the 24 GiB
/// machines csrbf is built on, so a nearly dense system is refused before it
/// swaps or aborts.
pub const DEFAULT_MEMORY_LIMIT: u64 = 4 << 30;

impl FitOptions {
    /// Options with this radius of support R (in the points' units; checked
    /// when fitting: finite and > 0) and the defaults for the rest.
    ///
    /// ```
    /// use csrbf::{FitOptions, Kernel};
    /// let o = FitOptions::new(0.3).with_kernel(Kernel::C4);
    /// assert_eq!((o.radius, o.kernel), (0.3, Kernel::C4));
    /// ```
    ///
    /// There is no `Default`: a radius must be chosen for the model's size
    /// (a radius that does not fit the model moves all of it or none).
    ///
    /// ```compile_fail
    /// let o = csrbf::FitOptions::default();
    /// ```
    pub fn new(radius: f64) -> FitOptions {
        FitOptions {
            kernel: Kernel::C2,
            radius,
            polynomial: Polynomial::None,
            ordering: Ordering::Auto,
            solver: SolverChoice::Auto,
            memory_limit: DEFAULT_MEMORY_LIMIT,
        }
    }

    /// With this kernel.
    pub fn with_kernel(mut self, kernel: Kernel) -> Self {
        self.kernel = kernel;
        self
    }
    /// With this memory limit (`u64::MAX`: none).
    pub fn with_memory_limit(mut self, bytes: u64) -> Self {
        self.memory_limit = bytes;
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
    /// Multiply-adds of the numeric factorisation made (the profile's, or
    /// the supernodal factor's counted from its structure): what
    /// [`FitPhases::numeric_ms`] is measured against.
    pub factor_flops: f64,
    /// Bytes the factor's f64 values take.
    pub factor_bytes: usize,
    /// The ordering and symbolic factorisation were taken from the system
    /// before ([`crate::System::rebuild`]: its neighbour graph was the
    /// same); the figures above are its.
    pub reused: bool,
    /// Where building the system spent its time.
    pub phases: FitPhases,
}

/// Where [`crate::System::new`] spent its time, in milliseconds, phase by
/// phase (wall clock of this build; `csrbf bench --json` reports them).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct FitPhases {
    /// Checking the starts, the size estimate and the octree.
    pub checks_ms: f64,
    /// The neighbour graph (starts within R of each other).
    pub graph_ms: f64,
    /// The orderings: the band-reducing ones and the envelope, or, for a
    /// system of 2,000 starts or more bound for the supernodal solver, the
    /// dissection (the band orderings then run beside the symbolic
    /// analysis, and are timed with it).
    pub ordering_ms: f64,
    /// Kernel values into the profile or the compressed columns (zero from
    /// 2,000 starts: A is then made beside the symbolic analysis, and timed
    /// with it).
    pub assembly_ms: f64,
    /// The supernodal solver's symbolic analysis (its elimination tree,
    /// column counts and supernodes; from 2,000 starts, until it, the band
    /// orderings beside it and A are all done, also when the profile solver
    /// is then taken); zero for the profile solver below 2,000 starts.
    pub symbolic_ms: f64,
    /// The numeric Cholesky factorisation.
    pub numeric_ms: f64,
    /// The polynomial block (the forward half of a solve with four
    /// right-hand sides).
    pub polynomial_ms: f64,
}

impl FitPhases {
    /// The sum of the phases.
    pub fn total_ms(&self) -> f64 {
        self.checks_ms
            + self.graph_ms
            + self.ordering_ms
            + self.assembly_ms
            + self.symbolic_ms
            + self.numeric_ms
            + self.polynomial_ms
    }
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
