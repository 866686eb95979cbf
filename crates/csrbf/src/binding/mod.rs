//! A deformation's starts bound to a fixed set of points: each point's
//! neighbouring starts and kernel weights, found once, so that new
//! destinations update every point with one sparse product.
//!
//! `build` makes a binding (one parallel pass over groups of cells, each
//! group into arrays of its own) with `weights` (a point's hits and kernel weights,
//! eight candidates at a time); `product` is the sum a new deformation
//! costs.

mod build;
mod product;
mod weights;

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use crate::deformation::Deformation;
use crate::error::{Error, Result};
use crate::evaluate::Point;
use crate::kernel::Kernel;
use crate::octree::Octree;
use crate::system::Shared;

/// Per-point kernel weights of one set of starts (one [`crate::System`]).
///
/// It pays when destinations change and the points do not (a drag loop, a
/// Picker): each new solve costs one sparse product instead of a search of
/// the starts. When only the phase changes (playback), compute the
/// displacement once and call [`frame`] instead.
///
/// Points are grouped in cells about R/2 wide, and the points of a cell
/// share one list of candidate starts (those within R of the cell). A point
/// keeps one bit per candidate (whether the start is within R) and the
/// kernel weights of the starts that are, each in three bytes: about 3.3
/// bytes a point-start pair and 15 a point (27 with f64 points), so a
/// dense binding (hundreds of pairs a point) costs about 3.3 bytes a pair
/// and a sparse one (a few) mostly its points. A weight is stored as its level,
/// phi / phi(0) in 24-bit fixed point (the f64 kernel rounded to the
/// nearest of 2^24 - 1 steps), so every weight is within 3e-8 of phi(0) of
/// the kernel's value, as f32 weights were for the largest. A displacement
/// through a binding (its sums in f32 lanes) agrees with
/// [`Deformation::displacements`] to about 1e-7 of the sum of
/// |coefficient| over the starts within R (unweighted: a weight's error is
/// absolute, so a point near the edge of every support may get 0 where the
/// f64 value is 1e-10), so a [`crate::Pipeline`], which binds, and
/// [`crate::compose`], which does not, differ by that much. Relative to the
/// largest move that is 1e-7 to 1e-6 on real meshes, and it grows with the
/// coefficients where nearby starts pull in opposite directions: about 1e-5
/// with two starts 3 % of R apart, 7e-5 at 1 % (coefficients 400 times the
/// move). A cell whose starts in reach have coefficients summing past 1000
/// times the largest move (a nearly singular system, typically a radius
/// thousands of times the model) is computed in f64 as
/// [`Deformation::displacements`] computes it: there the f32 sums and the
/// levels would keep only the rounding of coefficients that cancel.
///
/// A binding remembers the fingerprint of the starts, kernel and radius it
/// was made for and refuses any other deformation
/// ([`Error::BindingMismatch`]): its weights would give wrong displacements.
/// A point with a non-finite coordinate gets a NaN displacement.
#[derive(Clone, Debug)]
pub struct Binding {
    kernel: Kernel,
    radius: f64,
    starts: usize,
    fingerprint: u64,
    /// The cells, in the order their points are stored.
    cells: Vec<Cell>,
    /// The arrays of each group of consecutive cells (one task made each).
    groups: Vec<Group>,
    /// The points in cell order (the polynomial part needs them).
    rest: Rest,
    /// The point at each place of cell order (a permutation); `None` when
    /// cell order is the points' own order.
    order: Option<Vec<u32>>,
    /// The places (cell order) of the points with a non-finite coordinate,
    /// ascending: they have no hits, and get NaN.
    nonfinite: Vec<u32>,
    /// Weights before the zeros.
    pairs: usize,
}

/// Candidates per mask byte.
const BLOCK: usize = 8;

/// Bytes a stored weight (a level) takes.
const LEVEL_BYTES: usize = 3;

/// Bytes past a row's last level that its vector loads and stores may
/// touch (a 32-byte access starting within the row).
const LEVEL_TAIL: usize = 32;

/// How a kernel's weights are stored: `phi * per_weight`, rounded to the
/// nearest integer (ties to even), is a level between 0 and 2^24 - 1 (phi
/// is largest at 0); a level times `per_level` is the weight again, within
/// half a step (`per_level / 2`, 3e-8 of phi(0)).
#[derive(Clone, Copy, Debug)]
struct Levels {
    per_weight: f64,
    per_level: f64,
}

impl Levels {
    const STEPS: f64 = ((1u32 << 24) - 1) as f64;

    fn of(kernel: Kernel) -> Levels {
        let top = kernel.eval(0.0);
        Levels {
            per_weight: Self::STEPS / top,
            per_level: top / Self::STEPS,
        }
    }
}

/// The arrays of a group of consecutive cells.
#[derive(Clone, Debug, Default)]
struct Group {
    /// Each cell's candidate starts, padded to a multiple of eight.
    ids: Vec<u32>,
    /// Per point, one byte per eight candidates of its cell: bit `k` of byte
    /// `b` is set when candidate `8 b + k` is within R.
    masks: Vec<u8>,
    /// The levels of the set bits' weights, three bytes each, point after
    /// point, then zeros (eight levels per mask byte of the longest row, and
    /// [`LEVEL_TAIL`] bytes), so that a row's vector loads stay inside.
    levels: Vec<u8>,
}

/// One cell of points: its group, and where its rows start in the group's
/// arrays.
#[derive(Clone, Copy, Debug, Default)]
struct Cell {
    /// First point (cell order).
    point: usize,
    /// Points.
    points: usize,
    /// Its group.
    group: usize,
    /// First candidate in `ids`.
    id: usize,
    /// Mask bytes per point (candidates / 8, rounded up).
    blocks: usize,
    /// First mask byte.
    mask: usize,
    /// First byte of its levels.
    level: usize,
}

/// The bound points, of the kind they were given in.
#[derive(Clone, Debug)]
enum Rest {
    F32(Vec<Vec3>),
    F64(Vec<DVec3>),
}

/// What a binding is made from: the starts' octree, kernel, radius and
/// fingerprint.
struct Support<'a> {
    octree: &'a Octree,
    kernel: Kernel,
    radius: f64,
    starts: usize,
    fingerprint: u64,
}

impl<'a> Support<'a> {
    /// The support of a deformation's starts.
    fn of(deformation: &'a Deformation) -> Support<'a> {
        Support {
            octree: deformation.octree(),
            kernel: deformation.kernel(),
            radius: deformation.radius(),
            starts: deformation.starts().len(),
            fingerprint: deformation.fingerprint(),
        }
    }
}

impl Binding {
    /// Finds, for every point, the starts of `deformation` within R and their
    /// weights. Only the starts, kernel and R matter: any deformation solved
    /// from the same [`crate::System`] can then be applied through it
    /// ([`crate::System::bind`] binds without a solve).
    pub fn new<P: Point>(deformation: &Deformation, points: &[P]) -> Binding {
        build::dispatch(&Support::of(deformation), points, Vec::new())
    }

    /// Makes this binding anew for the starts of `deformation` and `points`,
    /// as [`Binding::new`] does, reusing its memory: the arrays of weights
    /// stay allocated (their pages in memory), so a re-bind after the
    /// control set changed (a studio's edit, a [`crate::Pipeline`]'s stage)
    /// does not fault fresh memory in, and two bindings never coexist.
    pub fn rebind<P: Point>(&mut self, deformation: &Deformation, points: &[P]) {
        let groups = std::mem::take(&mut self.groups);
        // The points' copy and order go first: only the groups are reused.
        self.rest = Rest::F32(Vec::new());
        self.order = None;
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
        match &self.rest {
            Rest::F32(p) => p.len(),
            Rest::F64(p) => p.len(),
        }
    }

    /// Whether no point is bound.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Stored point-start pairs.
    pub fn pairs(&self) -> usize {
        self.pairs
    }

    /// Bytes the binding holds.
    pub fn bytes(&self) -> usize {
        let rest = match &self.rest {
            Rest::F32(p) => size_of_val(p.as_slice()),
            Rest::F64(p) => size_of_val(p.as_slice()),
        };
        let groups: usize = self
            .groups
            .iter()
            .map(|g| size_of_val(g.ids.as_slice()) + g.masks.len() + g.levels.len())
            .sum();
        size_of_val(self.cells.as_slice())
            + groups
            + rest
            + self.order.as_ref().map_or(0, |s| size_of_val(s.as_slice()))
            + size_of_val(self.nonfinite.as_slice())
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

#[cfg(test)]
mod tests;
