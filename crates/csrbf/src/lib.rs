//! Space deformations by compactly supported radial basis functions (CSRBF).
//!
//! A user gives control vectors (a start point and a destination each) and a
//! radius of support R. The engine builds the smooth, local map
//! T(x) = x + D(x) with D(x) = sum_j alpha_j phi(|x - s_j| / R) [+ p(x)] that
//! carries every start exactly to its destination, following Kojekine,
//! Savchenko, Senin and Hagiwara (2002):
//!
//! - [`Kernel`]: the Wendland functions C0, C2, C4, C6;
//! - an octree: "all starts within R of q", for the neighbour graph and for evaluation;
//! - [`ordering`]: the papers' breadth-first renumbering and reverse Cuthill-McKee;
//! - [`skyline`]: profile (Jennings) storage and its Cholesky factor;
//! - [`System`]: symbolic and numeric work for one set of starts; solves
//!   again for new destinations without re-factoring;
//! - [`Deformation`]: the fitted map, evaluated anywhere, in parallel;
//! - [`Binding`]: points bound to a system's starts for repeated frames; [`frame`] gives v + t D(v);
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
//! R is in the model's units and has no default ([`FitOptions::new`] takes
//! it). Choose it as a share of the model's size: 5-20 % of the bounding
//! box's diagonal for a local edit (a smile, a bent ear), more for a broad
//! one. With many control vectors, aim for a few to a few dozen other starts
//! within R of each start: [`System::stats`] (and `csrbf info --controls
//! C`) prints neighbours per start, the system's bandwidth and memory, and
//! `csrbf info --controls C --mesh M` the vertices within R of each start.
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
//! # Four ways in
//!
//! One-shot: fit, then evaluate anywhere (points may be `Vec3` or `DVec3`),
//! or move a buffer of points in place at a phase.
//!
//! ```
//! use csrbf::{Deformation, FitOptions};
//! use csrbf::glam::{DVec3, Vec3};
//!
//! let starts = [DVec3::ZERO, DVec3::X];
//! let targets = [DVec3::new(0.0, 0.2, 0.0), DVec3::X];
//! let d = Deformation::fit(&starts, &targets, FitOptions::new(0.8))?;
//! let moved = d.displacements_f32(&[Vec3::ZERO, Vec3::splat(5.0)]);
//! assert!((moved[0].y - 0.2).abs() < 1e-6 && moved[1] == Vec3::ZERO); // local
//! let mut vertices = vec![Vec3::ZERO, Vec3::splat(5.0)];
//! d.deform_in_place(&mut vertices, 0.5)?; // v + 0.5 D(v)
//! assert!((vertices[0].y - 0.1).abs() < 1e-6);
//! let saved = d.to_bytes(); // a .csrbf file's bytes: `csrbf apply` replays it
//! assert_eq!(Deformation::from_bytes(&saved)?, d);
//! # Ok::<(), csrbf::Error>(())
//! ```
//!
//! Factor once, solve many: a drag loop moves destinations without
//! re-factoring ([`System`]), and a [`Binding`] updates every vertex with the
//! kernel sums alone (the points' cells and the starts in reach found once).
//!
//! ```
//! use csrbf::{Binding, FitOptions, System};
//! use csrbf::glam::{DVec3, Vec3};
//!
//! let starts = [DVec3::ZERO, DVec3::X, DVec3::Y];
//! let mesh: Vec<Vec3> = (0..100).map(|i| Vec3::new(i as f32 * 0.01, 0.0, 0.0)).collect();
//! let sys = System::new(&starts, FitOptions::new(0.7))?;
//! let binding = Binding::new(&sys.solve(&starts)?, &mesh);
//! let mut shown = vec![Vec3::ZERO; mesh.len()];
//! for step in 1..=3 {
//!     let mut targets = starts;
//!     targets[0].z = 0.05 * step as f64; // the pointer moves
//!     binding.displacements_into(&sys.solve(&targets)?, &mut shown)?;
//! }
//! assert!((shown[0].z - 0.15).abs() < 1e-6);
//! # Ok::<(), csrbf::Error>(())
//! ```
//!
//! Frames: when only the phase changes, compute the displacement once and
//! blend with [`frame`] (v + t D(v): a multiply-add per vertex).
//!
//! ```
//! use csrbf::{Deformation, FitOptions, frame};
//! use csrbf::glam::{DVec3, Vec3};
//!
//! let d = Deformation::fit(&[DVec3::ZERO], &[DVec3::Z], FitOptions::new(1.0))?;
//! let rest = vec![Vec3::ZERO, Vec3::X * 0.5];
//! let full = d.displacements_f32(&rest);
//! let mut out = vec![Vec3::ZERO; 2];
//! frame(&rest, &full, 0.5, &mut out)?;
//! assert!((out[0].z - 0.5).abs() < 1e-6);
//! # Ok::<(), csrbf::Error>(())
//! ```
//!
//! Pipeline: several deformations, each on a [`Region`], recomputed lazily
//! ([`Pipeline`]; the one-shot form is [`compose`] over [`FittedStage`]s),
//! saved as one `.csrbf` file ([`format::Replay`]) that `csrbf apply`
//! replays.
//!
//! ```
//! use csrbf::{FitOptions, Pipeline, Region, Stage, format::Replay};
//! use csrbf::glam::{DVec3, Vec3};
//!
//! let rest = vec![Vec3::ZERO, Vec3::X * 3.0];
//! let mut p = Pipeline::new(rest.clone());
//! let opts = FitOptions::new(1.0);
//! p.push(Stage::new(vec![DVec3::ZERO], vec![DVec3::Y], opts));
//! p.push(Stage::new(vec![DVec3::X * 3.0], vec![DVec3::new(3.0, 0.0, 1.0)], opts)
//!     .with_region(Region::Vertices(vec![1]))
//!     .with_phase(0.5));
//! let out = p.evaluate()?.to_vec();
//! assert!((out[0].y - 1.0).abs() < 1e-6 && (out[1].z - 0.5).abs() < 1e-6);
//! let bytes = p.to_replay()?.to_bytes(); // a .csrbf file
//! let again = Replay::from_bytes(&bytes)?.compose(&rest, &|_| None)?;
//! assert!(again[1].distance(out[1]) < 1e-6);
//! # Ok::<(), csrbf::Error>(())
//! ```
//!
//! # Meshes and files
//!
//! The engine reads no mesh file. `csrbf-mesh` reads and writes OBJ, PLY,
//! STL, OFF and glTF (`csrbf_mesh::read(path)` gives a `Mesh` whose
//! `positions` are the `Vec3`s every call here takes), and
//! the edit layer `csrbf-edit` owns the JSON control file and the road from
//! it to a deformed mesh (handles sampled, regions resolved, fitted, composed,
//! checked, one report with its remedies). `.csrbf` files are [`mod@format`].
//!
//! # Speed in a debug build
//!
//! A plain `cargo build` compiles every dependency without optimisation, and
//! the hot loops live in dependencies: this crate's evaluation, binding and
//! assembly, and faer's supernodal factorisation. Optimising only `csrbf`
//! leaves the factorisation 1.3-3x slower than release; optimise every
//! dependency for release speed in debug builds (your own code stays quick
//! to build and debug). In your `Cargo.toml`:
//!
//! ```toml
//! [profile.dev.package."*"]
//! opt-level = 2
//! ```
//!
//! Measured on the 1M-point, 10k-control case: 4.7 s in a plain dev build,
//! 0.35 s in release or with the lines above.
//!
//! # Errors
//!
//! Every failure is a value saying what was wrong and where. Fitting
//! ([`System::new`], [`System::solve`], [`Deformation::fit`]) returns a
//! [`FitError`] (duplicate or too-close starts with their indices, a bad
//! radius, a failed pivot in your numbering, a system past the memory
//! limit with a radius that fits); names parse to [`NameError`]; `.csrbf`
//! files fail with [`FormatError`]; regions with [`RegionError`]; the rest
//! (a phase outside [0, 1], a buffer of the wrong length, a binding used
//! with another system's deformation) are variants of [`Error`], which
//! wraps all of them.
//!
//! # Non-finite input
//!
//! Starts, destinations, radii and regions are checked (a named error for
//! NaN or infinite values). Points you evaluate at are not refused: a point
//! with a non-finite coordinate gets a NaN displacement (with or without
//! the polynomial part), and the other points are not affected.

// `unwrap` only in tests (clippy.toml allows it there); library code says
// why a value is there with `expect`, or handles its absence.
#![warn(clippy::unwrap_used)]

pub use glam;

mod awake;
mod binding;
mod deformation;
mod dense;
mod diagnose;
mod displace;
mod error;
mod evaluate;
mod folds;
pub mod format;
#[cfg(any(test, feature = "fuzz"))]
pub mod fuzz;
pub mod handle;
mod jacobian;
mod kernel;
mod lanes;
mod octree;
mod options;
pub mod ordering;
mod pipeline;
mod region;
mod simd;
pub mod skyline;
mod solver;
mod stage;
mod stretch;
mod supernodal;
mod surface;
mod sweep;
mod symbolic;
pub mod synthetic;
mod system;
mod triangular;

#[cfg(test)]
mod layering_tests;
#[cfg(test)]
mod testing;
#[cfg(test)]
mod tests;

pub use binding::{Binding, frame};
pub use deformation::{Affine, Deformation};
pub use diagnose::{
    DiagnoseOptions, Diagnostics, Numbered, Numbering, Warning, compose_diagnosed,
    compose_diagnosed_with, diagnose, vertices_within,
};
pub use error::{
    Error, FitError, FormatError, NameError, RegionError, Result, check_phase,
    number as plain_number,
};
pub use evaluate::{Point, Points, PointsMut};
pub use folds::{Folds, folds};
pub use handle::{Handle, HandleControls, Rotation};
pub use jacobian::{det_cubic, first_nonpositive, fold_phase};
pub use kernel::{Kernel, Polynomial};
pub use lanes::{EvaluationCounts, Roofline};
pub use ordering::Ordering;
pub use pipeline::{Pipeline, Stage, Work};
pub use region::{Origin, Region};
pub use solver::SolverChoice;
pub use stage::{Combine, FittedStage, SweepStep, compose, compose_f64, compose_with_groups};
pub use stretch::{STRETCH_LIMIT, face_stretches};
pub use surface::Surface;
pub use sweep::{MAX_STEPS, Path, Paths, Sweep, SweepOptions, step_phase};
pub use system::{
    DEFAULT_MEMORY_LIMIT, Estimate, FitOptions, FitPhases, OrderingFigures, System, SystemStats,
    estimate,
};
