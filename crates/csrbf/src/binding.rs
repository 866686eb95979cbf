//! A deformation's starts bound to a fixed set of points: each point's
//! neighbouring starts and kernel weights, found once, so that new
//! destinations update every point with one sparse product.

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use crate::deformation::Deformation;
use crate::error::{Error, Result};
use crate::evaluate::{Blocks, PARALLEL_POINTS, Point, Points, for_each_cell};
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
/// Weights are kept in f32 to halve the memory (about 8 bytes per
/// point-start pair); a displacement through a binding agrees with
/// [`Deformation::displacements`] to about 1e-7 relative (6e-8 of the
/// displacement's size was the largest difference seen on the bundled
/// models), so a [`crate::Pipeline`], which binds, and [`crate::compose`],
/// which does not, differ by that much.
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
    points: usize,
    chunks: Vec<Chunk>,
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

/// The rows of one cell of points.
#[derive(Clone, Debug, Default)]
struct Chunk {
    /// Point indices of the rows.
    rows: Vec<u32>,
    /// The points, for the polynomial part.
    positions: Vec<DVec3>,
    /// Row `r` spans `offsets[r]..offsets[r + 1]` of `ids`/`weights`.
    offsets: Vec<u32>,
    ids: Vec<u32>,
    weights: Vec<f32>,
}

impl Binding {
    /// Finds, for every point, the starts of `deformation` within R and their
    /// weights. Only the starts, kernel and R matter: any deformation solved
    /// from the same [`crate::System`] can then be applied through it
    /// ([`crate::System::bind`] binds without a solve).
    pub fn new<P: Point>(deformation: &Deformation, points: &[P]) -> Binding {
        let support = Support {
            octree: deformation.octree(),
            kernel: deformation.kernel(),
            radius: deformation.radius(),
            starts: deformation.starts().len(),
            fingerprint: deformation.fingerprint(),
        };
        Binding::dispatch(&support, points)
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
        Binding::dispatch(&support, points)
    }

    fn dispatch<P: Point>(support: &Support<'_>, points: &[P]) -> Binding {
        match P::slice(points) {
            Points::F32(p) => Binding::of_f32(support, p),
            Points::F64(p) => Binding::of_f64(support, p),
        }
    }

    // The hot loop, compiled here (not in the caller's crate) for each kind.
    #[inline(never)]
    fn of_f32(support: &Support<'_>, points: &[Vec3]) -> Binding {
        Binding::build(support, points)
    }

    #[inline(never)]
    fn of_f64(support: &Support<'_>, points: &[DVec3]) -> Binding {
        Binding::build(support, points)
    }

    fn build<P: Point>(support: &Support<'_>, points: &[P]) -> Binding {
        let blocks = Blocks::for_starts(points, support.radius, support.starts);
        let mut chunks = vec![Chunk::default(); blocks.cells.len()];
        let (kernel, radius) = (support.kernel, support.radius);
        let parallel = points.len() >= PARALLEL_POINTS;
        // One chunk per cell: split `chunks` like a per-point buffer of length 1 per cell.
        let one_each = Blocks {
            order: Vec::new(),
            cells: (0..chunks.len()).map(|c| (c, c + 1)).collect(),
            identity: false,
        };
        for_each_cell(&one_each, &mut chunks, parallel, |(c, _), out, cand| {
            let (s, e) = blocks.cells[c];
            let idx = &blocks.order[s..e];
            cand.gather(
                support.octree,
                idx.iter().map(|&i| points[i as usize].to_dvec3()),
                radius,
            );
            let chunk = &mut out[0];
            chunk.rows = idx.to_vec();
            chunk.offsets.reserve(idx.len() + 1);
            chunk.offsets.push(0);
            for &i in idx {
                let x = points[i as usize].to_dvec3();
                chunk.positions.push(x);
                if x.is_finite() {
                    cand.for_each_weight(x, kernel, radius, |j, w| {
                        chunk.ids.push(j);
                        chunk.weights.push(w as f32);
                    });
                }
                chunk.offsets.push(chunk.ids.len() as u32);
            }
        });
        Binding {
            kernel,
            radius,
            starts: support.starts,
            fingerprint: support.fingerprint,
            points: points.len(),
            chunks,
        }
    }

    /// Number of points bound.
    pub fn len(&self) -> usize {
        self.points
    }

    /// Whether no point is bound.
    pub fn is_empty(&self) -> bool {
        self.points == 0
    }

    /// Stored point-start pairs.
    pub fn pairs(&self) -> usize {
        self.chunks.iter().map(|c| c.ids.len()).sum()
    }

    /// Bytes the binding holds.
    pub fn bytes(&self) -> usize {
        self.chunks
            .iter()
            .map(|c| {
                4 * c.rows.len() + 24 * c.positions.len() + 4 * c.offsets.len() + 8 * c.ids.len()
            })
            .sum()
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
        if out.len() != self.points {
            return Err(Error::PointCount {
                what: "displacement buffer",
                expected: self.points,
                got: out.len(),
            });
        }
        let alpha = deformation.coefficients();
        let affine = deformation.affine();
        let eval = |chunk: &Chunk| -> Vec<Vec3> {
            (0..chunk.rows.len())
                .map(|r| {
                    let (s, e) = (chunk.offsets[r] as usize, chunk.offsets[r + 1] as usize);
                    let x = chunk.positions[r];
                    if !x.is_finite() {
                        return Vec3::NAN;
                    }
                    let mut d = affine.map_or(DVec3::ZERO, |a| a.eval(x));
                    for (&j, &w) in chunk.ids[s..e].iter().zip(&chunk.weights[s..e]) {
                        d += alpha[j as usize] * w as f64;
                    }
                    d.as_vec3()
                })
                .collect()
        };
        let values: Vec<Vec<Vec3>> = if self.points >= PARALLEL_POINTS {
            self.chunks.par_iter().map(eval).collect()
        } else {
            self.chunks.iter().map(eval).collect()
        };
        for (chunk, v) in self.chunks.iter().zip(values) {
            for (&i, d) in chunk.rows.iter().zip(v) {
                out[i as usize] = d;
            }
        }
        Ok(())
    }

    /// D of `deformation` at every bound point (point order).
    pub fn displacements(&self, deformation: &Deformation) -> Result<Vec<Vec3>> {
        let mut out = vec![Vec3::ZERO; self.points];
        self.displacements_into(deformation, &mut out)?;
        Ok(out)
    }

    /// D of several deformations of this binding's system at every bound
    /// point: `out` holds one block of `len()` vectors per deformation, in
    /// their order (dataset augmentation: one mesh, many edits). The
    /// deformations run in parallel; each is checked as
    /// [`Binding::displacements_into`] checks it.
    pub fn displacements_many(&self, deformations: &[Deformation], out: &mut [Vec3]) -> Result<()> {
        let n = self.points;
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
