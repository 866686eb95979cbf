//! A fitted deformation: the space map T(x) = x + D(x), evaluated anywhere.

use glam::{DVec3, Vec3};

use crate::error::{Error, Result};
use crate::evaluate::{Blocks, PARALLEL_POINTS, Point, Points, for_each_cell};
use crate::kernel::{Kernel, Polynomial};
use crate::octree::Octree;
use crate::system::{FitOptions, System, prow};

/// The linear part p(x) = c0 + c1 u.x + c2 u.y + c3 u.z, with
/// u = (x - center) / scale (centred and scaled for conditioning).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Affine {
    /// Centre of the starts.
    pub center: DVec3,
    /// Largest distance of a start from the centre.
    pub scale: f64,
    /// Coefficients of 1, u.x, u.y, u.z; each a vector for x, y, z.
    pub coefficients: [DVec3; 4],
}

impl Affine {
    /// p(x).
    #[inline]
    pub fn eval(&self, x: DVec3) -> DVec3 {
        let p = prow(x, self.center, self.scale);
        let c = &self.coefficients;
        c[0] * p.x + c[1] * p.y + c[2] * p.z + c[3] * p.w
    }
}

/// A deformation: everything needed to replay it (kernel, R, starts,
/// coefficients, the polynomial part and the order after sorting), plus an
/// octree over the starts for evaluation.
#[derive(Clone, Debug)]
pub struct Deformation {
    kernel: Kernel,
    radius: f64,
    starts: Vec<DVec3>,
    coefficients: Vec<DVec3>,
    affine: Option<Affine>,
    order: Vec<u32>,
    octree: Octree,
}

impl PartialEq for Deformation {
    fn eq(&self, o: &Self) -> bool {
        self.kernel == o.kernel
            && self.radius.to_bits() == o.radius.to_bits()
            && self.starts == o.starts
            && self.coefficients == o.coefficients
            && self.affine == o.affine
            && self.order == o.order
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
    /// let opts = FitOptions::default().with_radius(1.5).with_polynomial(Polynomial::None);
    /// let d = Deformation::fit(&starts, &targets, opts)?;
    /// assert!((d.map(DVec3::ZERO) - targets[0]).length() < 1e-12);
    /// assert_eq!(d.displacement_at(DVec3::splat(10.0)), DVec3::ZERO);
    /// # Ok::<(), csrbf::Error>(())
    /// ```
    pub fn fit<P: Point>(starts: &[P], targets: &[P], options: FitOptions) -> Result<Deformation> {
        if starts.len() != targets.len() {
            return Err(Error::LengthMismatch {
                starts: starts.len(),
                targets: targets.len(),
            });
        }
        System::new(starts, options)?.solve(targets)
    }

    /// Puts a deformation together from its stored parts (the replay file).
    /// The octree is rebuilt when not given.
    pub(crate) fn from_parts(
        kernel: Kernel,
        radius: f64,
        starts: Vec<DVec3>,
        coefficients: Vec<DVec3>,
        affine: Option<Affine>,
        order: Vec<u32>,
        octree: Option<Octree>,
    ) -> Deformation {
        let octree = octree.unwrap_or_else(|| Octree::new(&starts));
        Deformation {
            kernel,
            radius,
            starts,
            coefficients,
            affine,
            order,
            octree,
        }
    }

    /// The kernel.
    pub fn kernel(&self) -> Kernel {
        self.kernel
    }
    /// The radius of support R.
    pub fn radius(&self) -> f64 {
        self.radius
    }
    /// The polynomial term.
    pub fn polynomial(&self) -> Polynomial {
        if self.affine.is_some() {
            Polynomial::Linear
        } else {
            Polynomial::None
        }
    }
    /// The start points.
    pub fn starts(&self) -> &[DVec3] {
        &self.starts
    }
    /// The radial coefficients alpha, one vector per start.
    pub fn coefficients(&self) -> &[DVec3] {
        &self.coefficients
    }
    /// The polynomial part, if any.
    pub fn affine(&self) -> Option<&Affine> {
        self.affine.as_ref()
    }
    /// The order after sorting (`order[new] = start index`).
    pub fn order(&self) -> &[u32] {
        &self.order
    }
    /// The octree over the starts.
    pub fn octree(&self) -> &Octree {
        &self.octree
    }

    /// The displacement D(x) = sum alpha_j phi(|x - s_j| / R) + p(x).
    pub fn displacement_at(&self, x: DVec3) -> DVec3 {
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

    /// D at every point, in parallel for large inputs. A non-finite point
    /// gets a non-finite displacement (NaN in, NaN out); check inputs first
    /// where that matters.
    pub fn displacements<P: Point>(&self, points: &[P]) -> Vec<DVec3> {
        match P::slice(points) {
            Points::F32(p) => self.displacements_of_f32(p),
            Points::F64(p) => self.displacements_of_f64(p),
        }
    }

    /// D at every point as f32 vectors, for vertex buffers.
    pub fn displacements_f32<P: Point>(&self, points: &[P]) -> Vec<Vec3> {
        match P::slice(points) {
            Points::F32(p) => self.displacements_f32_of_f32(p),
            Points::F64(p) => self.displacements_f32_of_f64(p),
        }
    }

    // The hot loops, compiled here (not in the caller's crate) for each kind.
    #[inline(never)]
    fn displacements_of_f32(&self, points: &[Vec3]) -> Vec<DVec3> {
        let mut out = vec![DVec3::ZERO; points.len()];
        self.displacements_sorted(points, &mut out, |d, _| d, |_| {});
        out
    }

    #[inline(never)]
    fn displacements_of_f64(&self, points: &[DVec3]) -> Vec<DVec3> {
        let mut out = vec![DVec3::ZERO; points.len()];
        self.displacements_sorted(points, &mut out, |d, _| d, |_| {});
        out
    }

    #[inline(never)]
    fn displacements_f32_of_f32(&self, points: &[Vec3]) -> Vec<Vec3> {
        let mut out = vec![Vec3::ZERO; points.len()];
        self.displacements_sorted(points, &mut out, |d, _| d.as_vec3(), |_| {});
        out
    }

    #[inline(never)]
    fn displacements_f32_of_f64(&self, points: &[DVec3]) -> Vec<Vec3> {
        let mut out = vec![Vec3::ZERO; points.len()];
        self.displacements_sorted(points, &mut out, |d, _| d.as_vec3(), |_| {});
        out
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
