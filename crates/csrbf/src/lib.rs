//! Space deformations by compactly supported radial basis functions (CSRBF).
//!
//! A user gives control vectors (a start point and a destination each) and a
//! radius of support R. The engine builds the smooth, local map
//! T(x) = x + D(x) with D(x) = sum_j alpha_j phi(|x - s_j| / R) [+ p(x)] that
//! carries every start exactly to its destination, following Kojekine,
//! Savchenko, Senin and Hagiwara (2002):
//!
//! - [`Kernel`]: the Wendland functions C0, C2, C4, C6;
//! - [`Octree`]: "all starts within R of q", for the neighbour graph and for evaluation;
//! - [`ordering`]: the papers' breadth-first renumbering and reverse Cuthill-McKee;
//! - [`skyline`]: profile (Jennings) storage and its Cholesky factor;
//! - [`System`]: symbolic and numeric work for one set of starts; solves
//!   again for new destinations without re-factoring;
//! - [`Deformation`]: the fitted map, evaluated anywhere, in parallel;
//! - [`Binding`]: per-point weights for repeated frames; [`frame`] gives v + t D(v);
//! - [`Pipeline`]: deformations composed in order, each on a [`Region`], lazily;
//! - [`mod@format`]: the compact `.csrbf` replay file.
//!
//! # Radius of support and locality
//!
//! phi vanishes beyond R, so a start moves only points closer than R. With
//! [`Polynomial::None`] the displacement is exactly zero farther than R from
//! every start. A larger R gives smoother, wider deformations and a denser
//! system (more neighbours per start, more memory and time).
//!
//! # The polynomial term
//!
//! The default, [`Polynomial::None`], keeps every edit local: what lies
//! farther than R from every start does not move. [`Polynomial::Linear`] (the
//! papers' choice) adds p(x) = b0 + B x with side conditions, so any affine
//! map given by the control vectors (a translation, rotation or scaling) is
//! reproduced exactly, even far from the starts; but an affine part fitted to
//! a local edit then moves the whole model ([`diagnose`] says so). It needs at
//! least 4 starts not on one plane.
//!
//! # Conditioning
//!
//! A is positive definite for distinct starts, but starts much closer than R
//! to each other make it nearly singular; a failing pivot names the control.
//!
//! # Phase
//!
//! The displacement D(v) of every vertex is computed once; the frame at phase
//! t in [0, 1] is v + t D(v).
//!
//! # Example
//!
//! ```
//! use csrbf::{Binding, Deformation, FitOptions, Kernel, Polynomial, frame};
//! use glam::{DVec3, Vec3};
//!
//! let starts = vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z, DVec3::ONE];
//! let targets: Vec<DVec3> = starts.iter().map(|s| *s + DVec3::new(0.0, 0.0, 0.1)).collect();
//! let opts = FitOptions::default()
//!     .with_kernel(Kernel::C2)
//!     .with_radius(2.0)
//!     .with_polynomial(Polynomial::Linear);
//! let d = Deformation::fit(&starts, &targets, opts)?;
//!
//! let mesh = vec![Vec3::new(0.5, 0.5, 0.5), Vec3::new(3.0, 3.0, 3.0)];
//! let binding = Binding::new(&d, &mesh);
//! let disp = binding.displacements(&d)?;
//! let mut half = vec![Vec3::ZERO; 2];
//! frame(&mesh, &disp, 0.5, &mut half)?;
//! // A pure translation is reproduced everywhere by the linear term.
//! assert!((half[1].z - 3.05).abs() < 1e-5);
//! # Ok::<(), csrbf::Error>(())
//! ```

mod binding;
#[cfg(feature = "serde")]
pub mod controls;
mod deformation;
mod diagnose;
mod error;
mod evaluate;
pub mod format;
pub mod handle;
mod kernel;
mod octree;
pub mod ordering;
mod pipeline;
mod region;
mod simd;
pub mod skyline;
mod solver;
pub mod synthetic;
mod system;

#[cfg(test)]
mod testing;
#[cfg(test)]
mod tests;

pub use binding::{Binding, frame};
pub use deformation::{Affine, Deformation};
pub use diagnose::{Diagnostics, Warning, compose_diagnosed, diagnose, vertices_within};
pub use error::{Error, Result};
pub use evaluate::Point;
pub use handle::{Handle, HandleControls, Rotation};
pub use kernel::{Kernel, Polynomial};
pub use octree::Octree;
pub use ordering::Ordering;
pub use pipeline::{Combine, Pipeline, Stage, Work, compose};
pub use region::Region;
pub use solver::SolverChoice;
pub use system::{
    DEFAULT_MEMORY_LIMIT, Estimate, FitOptions, OrderingFigures, System, SystemStats, estimate,
};
