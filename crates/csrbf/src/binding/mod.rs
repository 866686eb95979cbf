//! A deformation's starts bound to a fixed set of points: the points sorted
//! into cells and each cell's candidate starts found once, so that new
//! destinations update every point without a search of the starts.
//!
//! `build` makes a binding (one parallel pass over groups of cells, each
//! group into arrays of its own); `product` is what a new deformation
//! costs: each cell's coefficients into lanes, then the evaluation's f32
//! kernel sum for each of its points.

mod build;
mod product;

use std::sync::{Arc, OnceLock};

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use crate::deformation::Deformation;
use crate::deformation::Shared;
use crate::error::{Error, Result};
use crate::evaluate::{PARALLEL_POINTS, Point};
use crate::kernel::Kernel;
use crate::octree::Octree;
use crate::system::System;

/// A set of points bound to the starts of one [`crate::System`]: what does
/// not change when only the destinations do, found once.
///
/// It pays when destinations change and the points do not (a drag loop, a
/// Picker): each new solve costs the kernel sums alone, without sorting
/// the points or searching the starts. When only the phase changes
/// (playback), compute the displacement once and call [`frame`] instead.
///
/// The points are sorted into cells about R/2 wide and copied in that
/// order, and each cell keeps its candidate starts (those within R of the
/// cell), by index and by coordinate (f32, in units of R about the cell's
/// centre), as [`Deformation::displacements_f32`] gathers them. A new
/// deformation then costs, per cell, its candidates' coefficients put in
/// lanes, and per point the evaluation's kernel sum (eight or sixteen
/// points at a time, in f32): the weights are computed again, not stored.
/// So a binding
/// gives [`Deformation::displacements_f32`]'s displacements bit for bit
/// (its error against [`Deformation::displacements`] is the f32
/// evaluation's; a cell whose coefficients would cancel in f32 is summed
/// in f64 by both). It costs the points' copy (12 bytes a point, 24 with
/// f64 points), their order (4) and per cell 16 bytes a candidate and the
/// centre of its frame (a product computes its points' frame from it a
/// chunk at a time, as the evaluation does): about 21 bytes a point at 1M
/// points on a sphere with 43 starts in reach of each (cells of about 240
/// points and 76 candidates), more with fewer points a cell or more starts
/// in reach.
///
/// Measured at 1M points and 10,000 starts (about 43 in reach of each
/// point, `csrbf bench --scene 1m`): a bind costs less than one
/// evaluation, a product about half of one.
///
/// A binding remembers the fingerprint of the starts, kernel and radius it
/// was made for and refuses any other deformation
/// ([`Error::BindingMismatch`]). A point with a non-finite coordinate gets
/// a NaN displacement.
#[derive(Clone, Debug)]
pub struct Binding {
    kernel: Kernel,
    radius: f64,
    starts: usize,
    fingerprint: u64,
    /// The starts' octree (shared with the system): the f64 sums and
    /// [`Binding::pairs`] search it.
    octree: Arc<Octree>,
    /// The cells, in the order their points are stored.
    cells: Vec<Cell>,
    /// The arrays of each group of consecutive cells (one task made each).
    groups: Vec<Group>,
    /// The points in cell order.
    rest: Rest,
    /// The point at each place of cell order (a permutation); `None` when
    /// cell order is the points' own order.
    order: Option<Vec<u32>>,
    /// Point-start pairs within R, counted when first asked.
    pairs: OnceLock<usize>,
}

/// The arrays of a group of consecutive cells.
#[derive(Clone, Debug, Default)]
struct Group {
    /// Each cell's candidate starts.
    ids: Vec<u32>,
    /// Their coordinates, in units of R about their cell's centre
    /// ([`crate::lanes`]), beside `ids`.
    xyz: [Vec<f32>; 3],
}

/// One cell of points: its group, where its candidates start in the
/// group's arrays, and the centre of its lanes' frame.
#[derive(Clone, Copy, Debug)]
struct Cell {
    /// First point (cell order).
    point: usize,
    /// Points.
    points: usize,
    /// Its group.
    group: usize,
    /// First candidate in `ids` and `xyz`.
    id: usize,
    /// Candidates.
    candidates: usize,
    /// The centre of its lanes' frame (its points' frame is computed from
    /// it a chunk at a time, as the evaluation computes it).
    centre: DVec3,
    /// Whether the kernel sum may run in f32 lanes (the cell is narrow:
    /// see [`crate::lanes`]); else in f64, as the evaluation does.
    narrow: bool,
}

/// The bound points, of the kind they were given in.
#[derive(Clone, Debug)]
enum Rest {
    F32(Vec<Vec3>),
    F64(Vec<DVec3>),
}

impl Rest {
    fn len(&self) -> usize {
        match self {
            Rest::F32(p) => p.len(),
            Rest::F64(p) => p.len(),
        }
    }

    fn bytes(&self) -> usize {
        match self {
            Rest::F32(p) => size_of_val(p.as_slice()),
            Rest::F64(p) => size_of_val(p.as_slice()),
        }
    }

    /// Point `k` (cell order).
    #[inline]
    fn at(&self, k: usize) -> DVec3 {
        match self {
            Rest::F32(p) => p[k].to_dvec3(),
            Rest::F64(p) => p[k],
        }
    }
}

/// What a binding is made from: the starts' octree, kernel, radius and
/// fingerprint.
struct Support<'a> {
    octree: &'a Arc<Octree>,
    kernel: Kernel,
    radius: f64,
    starts: usize,
    fingerprint: u64,
}

impl<'a> Support<'a> {
    /// The support of a deformation's starts.
    fn of(deformation: &'a Deformation) -> Support<'a> {
        Support {
            octree: deformation.octree_shared(),
            kernel: deformation.kernel(),
            radius: deformation.radius(),
            starts: deformation.starts().len(),
            fingerprint: deformation.fingerprint(),
        }
    }
}

impl Binding {
    /// Sorts `points` into cells and finds each cell's candidate starts
    /// among those of `deformation`. Only the starts, kernel and R matter: any deformation solved
    /// from the same [`crate::System`] can then be applied through it
    /// ([`crate::System::bind`] binds without a solve).
    pub fn new<P: Point>(deformation: &Deformation, points: &[P]) -> Binding {
        build::dispatch(&Support::of(deformation), points, Vec::new())
    }

    /// Makes this binding anew for the starts of `deformation` and `points`,
    /// as [`Binding::new`] does, reusing the arrays of its cells'
    /// candidates, so that a re-bind after the control set changed (a
    /// studio's edit, a [`crate::Pipeline`]'s stage) never holds two
    /// bindings at once.
    pub fn rebind<P: Point>(&mut self, deformation: &Deformation, points: &[P]) {
        let groups = std::mem::take(&mut self.groups);
        // The rest goes first (only the groups are reused), and nothing of
        // the old binding is left to read should the build panic.
        self.rest = Rest::F32(Vec::new());
        self.order = None;
        self.cells = Vec::new();
        self.pairs = OnceLock::from(0);
        *self = build::dispatch(&Support::of(deformation), points, groups);
    }

    /// Binds to a system's starts ([`crate::System::bind`]).
    pub(crate) fn of_shared<P: Point>(shared: &Shared, points: &[P]) -> Binding {
        let support = Support {
            octree: &shared.octree,
            kernel: shared.kernel,
            radius: shared.radius,
            starts: shared.starts.len(),
            fingerprint: shared.fingerprint,
        };
        build::dispatch(&support, points, Vec::new())
    }

    /// Number of points bound.
    pub fn len(&self) -> usize {
        self.rest.len()
    }

    /// Whether no point is bound.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Point-start pairs within R: the nonzero terms of a point's sum,
    /// over all points. Counted (a search of the starts for every point)
    /// when first asked, then remembered.
    pub fn pairs(&self) -> usize {
        *self.pairs.get_or_init(|| {
            let (octree, radius) = (&*self.octree, self.radius);
            let count = |k: usize| {
                let x = self.rest.at(k);
                let mut n = 0;
                if x.is_finite() {
                    octree.for_each_within(x, radius, |_, _| n += 1);
                }
                n
            };
            if self.len() >= PARALLEL_POINTS {
                (0..self.len()).into_par_iter().map(count).sum()
            } else {
                (0..self.len()).map(count).sum()
            }
        })
    }

    /// Bytes the binding holds (its octree, shared with the system, not
    /// counted).
    pub fn bytes(&self) -> usize {
        let groups: usize = self
            .groups
            .iter()
            .map(|g| size_of_val(g.ids.as_slice()) + 3 * size_of_val(g.xyz[0].as_slice()))
            .sum();
        size_of_val(self.cells.as_slice())
            + groups
            + self.rest.bytes()
            + self.order.as_ref().map_or(0, |s| size_of_val(s.as_slice()))
    }

    /// Writes D of `deformation` at every bound point into `out` (point order).
    ///
    /// Fails when the deformation has other starts, kernel or radius than
    /// the one the binding was made for (by their fingerprint, computed once
    /// per system: no comparison of the starts per call), or `out` has the
    /// wrong length.
    pub fn displacements_into(&self, deformation: &Deformation, out: &mut [Vec3]) -> Result<()> {
        if deformation.fingerprint() != self.fingerprint {
            return Err(Error::BindingMismatch {
                bound_starts: self.starts,
                bound_kernel: self.kernel,
                bound_radius: self.radius,
                starts: deformation.starts().len(),
                kernel: deformation.kernel(),
                radius: deformation.radius(),
            });
        }
        if out.len() != self.len() {
            return Err(Error::PointCount {
                what: "displacement buffer",
                expected: self.len(),
                got: out.len(),
            });
        }
        product::displacements(self, deformation, out);
        Ok(())
    }

    /// D of `deformation` at every bound point (point order).
    pub fn displacements(&self, deformation: &Deformation) -> Result<Vec<Vec3>> {
        let mut out = vec![Vec3::ZERO; self.len()];
        self.displacements_into(deformation, &mut out)?;
        Ok(out)
    }

    /// D of several deformations of this binding's system at every bound
    /// point: `out` holds one block of `len()` vectors per deformation, in
    /// their order (dataset augmentation: one mesh, many edits). The
    /// deformations run in parallel; each is checked as
    /// [`Binding::displacements_into`] checks it.
    pub fn displacements_many(&self, deformations: &[Deformation], out: &mut [Vec3]) -> Result<()> {
        let n = self.len();
        if out.len() != n * deformations.len() {
            return Err(Error::PointCount {
                what: "displacement buffer (points x deformations)",
                expected: n * deformations.len(),
                got: out.len(),
            });
        }
        if n == 0 {
            // Nothing to write, but a deformation of other starts is refused
            // as with points.
            for d in deformations {
                self.displacements_into(d, &mut [])?;
            }
            return Ok(());
        }
        out.par_chunks_mut(n)
            .zip(deformations.par_iter())
            .try_for_each(|(o, d)| self.displacements_into(d, o))
    }
}

/// Positions at phase `t`: `out[i] = rest[i] + t * displacement[i]`.
pub fn frame(rest: &[Vec3], displacement: &[Vec3], phase: f64, out: &mut [Vec3]) -> Result<()> {
    crate::error::check_phase(phase)?;
    if displacement.len() != rest.len() || out.len() != rest.len() {
        return Err(Error::PointCount {
            what: "frame buffers",
            expected: rest.len(),
            got: displacement.len().min(out.len()),
        });
    }
    let t = phase as f32;
    let kernel = |(o, (r, d)): (&mut [Vec3], (&[Vec3], &[Vec3]))| {
        for ((o, r), d) in o.iter_mut().zip(r).zip(d) {
            *o = *r + *d * t;
        }
    };
    const CHUNK: usize = 1 << 15;
    if rest.len() >= 4 * CHUNK {
        out.par_chunks_mut(CHUNK)
            .zip(rest.par_chunks(CHUNK).zip(displacement.par_chunks(CHUNK)))
            .for_each(kernel);
    } else {
        kernel((out, (rest, displacement)));
    }
    Ok(())
}

impl System {
    /// One point set deformed by K sets of destinations of these starts, in
    /// one call on all cores (dataset augmentation: one mesh, many edits):
    /// the K solves in parallel, the points bound once, every variant the
    /// kernel sums alone. `out` holds K blocks of `points.len()`
    /// displacements (the f32 evaluation's, as [`Binding`] gives them); the
    /// positions at a phase t are points + t D (see [`frame`]).
    pub fn displacements_many<P: Point, T: AsRef<[DVec3]> + Sync>(
        &self,
        points: &[P],
        target_sets: &[T],
        out: &mut [Vec3],
    ) -> Result<()> {
        let ds = self.solve_many(target_sets)?;
        self.bind(points).displacements_many(&ds, out)
    }

    /// Binds these points to the system's starts: their cells and the starts
    /// in reach, found once, serve every deformation the system solves.
    pub fn bind<P: Point>(&self, points: &[P]) -> Binding {
        Binding::of_shared(&self.shared, points)
    }
}

#[cfg(test)]
mod tests;
