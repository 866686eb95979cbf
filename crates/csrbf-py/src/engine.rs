//! The engine calls this crate makes, each in one place.
//!
//! The functions marked `until issue 21 lands` stand in for engine calls
//! that are planned (issue 21: `displacements_into`, `deform_in_place`,
//! `to_bytes`/`from_bytes`, `System::bind`, `System::solve_many`,
//! `Binding::displacements_many`, `FitOptions::new`); each becomes a one-line
//! call of the engine when they land.

use csrbf::glam::{DVec3, Vec3};
use csrbf::{Binding, Combine, Deformation, FitOptions, Kernel, Point, Polynomial, Region, System};
use rayon::prelude::*;

/// What an engine call failed with.
pub type Error = csrbf::Error;

/// Fit options for this radius, kernel and polynomial; `allow_large` lifts
/// the memory limit.
pub fn options(
    radius: f64,
    kernel: Kernel,
    polynomial: Polynomial,
    allow_large: bool,
) -> FitOptions {
    // until issue 21 lands: FitOptions::new(radius)
    let o = FitOptions::default()
        .with_radius(radius)
        .with_kernel(kernel)
        .with_polynomial(polynomial);
    if allow_large {
        o.with_memory_limit(u64::MAX)
    } else {
        o
    }
}

/// D at every point, into `out` (same length).
pub fn displacements_into<P: Point>(
    d: &Deformation,
    points: &[P],
    out: &mut [DVec3],
) -> Result<(), Error> {
    // until issue 21 lands: d.displacements_into(points, out)
    out.copy_from_slice(&d.displacements(points));
    Ok(())
}

/// D at every point as f32 vectors, into `out` (same length).
pub fn displacements_f32_into<P: Point>(
    d: &Deformation,
    points: &[P],
    out: &mut [Vec3],
) -> Result<(), Error> {
    // until issue 21 lands: d.displacements_f32_into(points, out)
    out.copy_from_slice(&d.displacements_f32(points));
    Ok(())
}

/// Points a deformation can move in place.
pub trait Movable: Point + Copy + Send + Sync {
    /// `self + t d`.
    fn moved(self, d: DVec3, t: f64) -> Self;
}
impl Movable for Vec3 {
    fn moved(self, d: DVec3, t: f64) -> Self {
        (self.as_dvec3() + t * d).as_vec3()
    }
}
impl Movable for DVec3 {
    fn moved(self, d: DVec3, t: f64) -> Self {
        self + t * d
    }
}

/// `points[i] += phase * D(points[i])`.
pub fn deform_in_place<P: Movable>(
    d: &Deformation,
    points: &mut [P],
    phase: f64,
) -> Result<(), Error> {
    // until issue 21 lands: d.deform_in_place(points, phase)
    csrbf::frame(&[], &[], phase, &mut [])?; // the engine's check of the phase
    let disp = d.displacements(points);
    points
        .par_iter_mut()
        .zip(disp)
        .for_each(|(p, v)| *p = p.moved(v, phase));
    Ok(())
}

/// The one-stage `.csrbf` bytes of `d` (what `csrbf fit` writes for a file
/// of one deformation).
pub fn to_bytes(d: &Deformation) -> Vec<u8> {
    // until issue 21 lands: d.to_bytes()
    csrbf::format::encode(&[(d.clone(), Region::All, 1.0)], Combine::Chain)
}

/// The deformation of one-stage `.csrbf` bytes.
pub fn from_bytes(bytes: &[u8]) -> Result<Deformation, FromBytesError> {
    // until issue 21 lands: Deformation::from_bytes(bytes)
    let replay = csrbf::format::decode(bytes).map_err(FromBytesError::Engine)?;
    let n = replay.stages.len();
    match replay.stages.into_iter().next() {
        Some((d, Region::All, phase)) if n == 1 && phase == 1.0 => Ok(d),
        _ => Err(FromBytesError::NotOne(n)),
    }
}

/// Why bytes are not one deformation.
#[derive(Debug)]
pub enum FromBytesError {
    /// The engine refused them.
    Engine(csrbf::Error),
    /// A file of several stages, or one with a region or phase of its own.
    NotOne(usize),
}

impl std::fmt::Display for FromBytesError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            FromBytesError::Engine(e) => e.fmt(f),
            FromBytesError::NotOne(n) => write!(
                f,
                "the file holds {n} deformation(s) with regions or phases; Deformation.load reads one whole-space deformation (deform_mesh applies a whole file)"
            ),
        }
    }
}

impl std::error::Error for FromBytesError {}

/// The binding of `points` to `sys`'s starts, without a solve of one's own.
pub fn bind<P: Point>(sys: &System, points: &[P]) -> Result<Binding, Error> {
    // until issue 21 lands: sys.bind(points)
    Ok(Binding::new(&sys.solve(sys.starts())?, points))
}

/// One deformation per target set, in parallel.
pub fn solve_many(sys: &System, targets: &[Vec<DVec3>]) -> Result<Vec<Deformation>, Error> {
    // until issue 21 lands: sys.solve_many(targets)
    targets.par_iter().map(|t| sys.solve(t)).collect()
}

/// The displacements of every deformation at the bound points, variant
/// after variant (`out` holds `ds.len() * binding.len()` vectors).
pub fn displacements_many(b: &Binding, ds: &[Deformation], out: &mut [Vec3]) -> Result<(), Error> {
    // until issue 21 lands: b.displacements_many(ds, out)
    let n = b.len();
    if n == 0 {
        return Ok(());
    }
    ds.iter()
        .zip(out.chunks_mut(n))
        .try_for_each(|(d, o)| b.displacements_into(d, o))
}
