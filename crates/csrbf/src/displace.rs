//! The evaluation of a [`Deformation`] at many points: D(x) at one point,
//! in f64 by the blocked evaluation, in f32 by the lanes
//! ([`crate::lanes`]), in place at a phase. The deformation is data
//! (`deformation`); this module reads it.

use glam::{DVec3, Vec3};

use crate::deformation::Deformation;
use crate::error::{Result, check_len, check_phase};
use crate::evaluate::{Blocks, PARALLEL_POINTS, Point, Points, PointsMut, for_each_cell};

impl Deformation {
    /// The displacement D(x) = sum alpha_j phi(|x - s_j| / R) + p(x); NaN
    /// for a point with a non-finite coordinate.
    pub fn displacement_at(&self, x: DVec3) -> DVec3 {
        if !x.is_finite() {
            return DVec3::NAN;
        }
        let mut d = self.affine.map_or(DVec3::ZERO, |a| a.eval(x));
        let inv = 1.0 / self.radius;
        self.octree.for_each_within(x, self.radius, |j, d2| {
            d += self.coefficients[j as usize] * self.kernel.eval(d2.sqrt() * inv);
        });
        d
    }

    /// The mapped point T(x) = x + D(x).
    pub fn map(&self, x: DVec3) -> DVec3 {
        x + self.displacement_at(x)
    }

    /// D at every point, in parallel for large inputs. A point with a
    /// non-finite coordinate gets a NaN displacement (NaN in, NaN out), with
    /// or without the polynomial part; the other points are not affected.
    pub fn displacements<P: Point>(&self, points: &[P]) -> Vec<DVec3> {
        let mut out = vec![DVec3::ZERO; points.len()];
        self.fill_f64(P::slice(points), &mut out);
        out
    }

    /// D at every point as f32 vectors, for vertex buffers. Where points are
    /// sorted into cells (more than a few dozen starts), the kernel sum runs
    /// in f32 eight or sixteen points at a time: it agrees with
    /// [`Deformation::displacements`] to about 1e-7 of the sum of |alpha_j|
    /// over the starts within R (the tests allow 2e-6); the polynomial part
    /// is added in f64. A cell whose starts in reach have coefficients
    /// summing past 1000 times [`Deformation::largest_move`] (a nearly
    /// singular system) is summed in f64: f32 would keep only the rounding
    /// of coefficients that cancel.
    /// [`Deformation::evaluation_counts`] says how much work it does.
    pub fn displacements_f32<P: Point>(&self, points: &[P]) -> Vec<Vec3> {
        let mut out = vec![Vec3::ZERO; points.len()];
        self.fill_f32(P::slice(points), &mut out);
        out
    }

    /// D at every point written into `out` (no allocation when the points
    /// are evaluated in their own order, one buffer of `out`'s size when
    /// they are sorted into cells). Fails when the lengths differ.
    pub fn displacements_into<P: Point>(&self, points: &[P], out: &mut [DVec3]) -> Result<()> {
        check_len("displacement buffer", points.len(), out.len())?;
        self.fill_f64(P::slice(points), out);
        Ok(())
    }

    /// [`Deformation::displacements_into`] with f32 vectors.
    pub fn displacements_f32_into<P: Point>(&self, points: &[P], out: &mut [Vec3]) -> Result<()> {
        check_len("displacement buffer", points.len(), out.len())?;
        self.fill_f32(P::slice(points), out);
        Ok(())
    }

    /// Moves every point to x + phase * D(x), in place. The displacements
    /// are evaluated at the points as given (into one temporary buffer) and
    /// then added, so the result does not depend on the order of the points.
    ///
    /// ```
    /// use csrbf::{Deformation, FitOptions};
    /// use csrbf::glam::Vec3;
    ///
    /// let d = Deformation::fit(&[Vec3::ZERO], &[Vec3::Z], FitOptions::new(1.0))?;
    /// let mut mesh = vec![Vec3::ZERO, Vec3::X * 2.0];
    /// d.deform_in_place(&mut mesh, 0.5)?;
    /// assert!((mesh[0].z - 0.5).abs() < 1e-6 && mesh[1] == Vec3::X * 2.0);
    /// # Ok::<(), csrbf::Error>(())
    /// ```
    pub fn deform_in_place<P: Point>(&self, points: &mut [P], phase: f64) -> Result<()> {
        check_phase(phase)?;
        match P::slice_mut(points) {
            PointsMut::F32(p) => {
                let mut d = vec![Vec3::ZERO; p.len()];
                self.fill_f32(Points::F32(p), &mut d);
                let t = phase as f32;
                for (p, d) in p.iter_mut().zip(d) {
                    *p += d * t;
                }
            }
            PointsMut::F64(p) => {
                let mut d = vec![DVec3::ZERO; p.len()];
                self.fill_f64(Points::F64(p), &mut d);
                for (p, d) in p.iter_mut().zip(d) {
                    *p += d * phase;
                }
            }
        }
        Ok(())
    }

    // The hot loops, compiled here (not in the caller's crate) for each kind.
    fn fill_f64(&self, points: Points<'_>, out: &mut [DVec3]) {
        match points {
            Points::F32(p) => self.f64_of_f32(p, out),
            Points::F64(p) => self.f64_of_f64(p, out),
        }
    }

    fn fill_f32(&self, points: Points<'_>, out: &mut [Vec3]) {
        match points {
            Points::F32(p) => self.f32_of_f32(p, out),
            Points::F64(p) => self.f32_of_f64(p, out),
        }
    }

    #[inline(never)]
    fn f64_of_f32(&self, points: &[Vec3], out: &mut [DVec3]) {
        self.displacements_sorted(points, out, |d, _| d, |_| {});
    }

    #[inline(never)]
    fn f64_of_f64(&self, points: &[DVec3], out: &mut [DVec3]) {
        self.displacements_sorted(points, out, |d, _| d, |_| {});
    }

    #[inline(never)]
    fn f32_of_f32(&self, points: &[Vec3], out: &mut [Vec3]) {
        crate::lanes::displacements(self, points, out);
    }

    #[inline(never)]
    fn f32_of_f64(&self, points: &[DVec3], out: &mut [Vec3]) {
        crate::lanes::displacements(self, points, out);
    }

    /// D at every point as f32 vectors, with what the diagnostics need from
    /// the same pass: whether each point lies within R of some start, and
    /// whether each start lies within R of some point.
    pub(crate) fn displacements_reach(&self, points: &[Vec3]) -> (Vec<Vec3>, Vec<bool>, Vec<bool>) {
        use std::sync::atomic::{AtomicBool, Ordering};
        let touched: Vec<AtomicBool> = self.starts.iter().map(|_| AtomicBool::new(false)).collect();
        let mut out = vec![(Vec3::ZERO, false); points.len()];
        self.displacements_sorted(
            points,
            &mut out,
            |d, near| (d.as_vec3(), near),
            |j| {
                // A read first: a start hit by many points is written once.
                let t = &touched[j as usize];
                if !t.load(Ordering::Relaxed) {
                    t.store(true, Ordering::Relaxed);
                }
            },
        );
        let (d, near) = out.into_iter().unzip();
        (
            d,
            near,
            touched.into_iter().map(AtomicBool::into_inner).collect(),
        )
    }

    /// Evaluates by cells and writes `conv(D, near)` into `out` (point
    /// order), `near` telling whether any start lay within R; `hit(j)` is
    /// called for every start within R of a point.
    fn displacements_sorted<P: Point, T: Copy + Send + Sync + Default>(
        &self,
        points: &[P],
        out: &mut [T],
        conv: impl Fn(DVec3, bool) -> T + Sync + Send,
        hit: impl Fn(u32) + Sync + Send,
    ) {
        let blocks = Blocks::for_starts(points, self.radius, self.starts.len());
        let mut buffer = Vec::new();
        let sorted = if blocks.identity {
            &mut *out
        } else {
            buffer.resize(points.len(), T::default());
            &mut buffer[..]
        };
        let (kernel, radius) = (self.kernel, self.radius);
        for_each_cell(
            &blocks,
            sorted,
            points.len() >= PARALLEL_POINTS,
            |(s, e), out, cand| {
                let idx = &blocks.order[s..e];
                cand.gather(
                    &self.octree,
                    idx.iter().map(|&i| points[i as usize].to_dvec3()),
                    radius,
                );
                for (o, &i) in out.iter_mut().zip(idx) {
                    let x = points[i as usize].to_dvec3();
                    if !x.is_finite() {
                        *o = conv(DVec3::NAN, false);
                        continue;
                    }
                    let mut d = self.affine.map_or(DVec3::ZERO, |a| a.eval(x));
                    let mut near = false;
                    cand.for_each_weight(x, kernel, radius, |j, w| {
                        d += self.coefficients[j as usize] * w;
                        near = true;
                        hit(j);
                    });
                    *o = conv(d, near);
                }
            },
        );
        if !blocks.identity {
            for (k, &i) in blocks.order.iter().enumerate() {
                out[i as usize] = buffer[k];
            }
        }
    }
}
