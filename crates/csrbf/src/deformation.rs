//! A fitted deformation: the space map T(x) = x + D(x), evaluated anywhere.

use std::sync::Arc;

use glam::{DVec3, Vec3};

use crate::error::{Error, FitError, Result};
use crate::evaluate::{Blocks, PARALLEL_POINTS, Point, Points, PointsMut, for_each_cell};
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

    /// The same map as c0 + M (x - center), M = [c1 c2 c3] / scale: no
    /// division a point (the loops over many points use it).
    pub(crate) fn linear(&self) -> Linear {
        let c = &self.coefficients;
        Linear {
            center: self.center,
            c0: c[0],
            m: glam::DMat3::from_cols(c[1], c[2], c[3]) * (1.0 / self.scale),
        }
    }
}

/// [`Affine`] as c0 + M (x - center) ([`Affine::linear`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Linear {
    center: DVec3,
    c0: DVec3,
    m: glam::DMat3,
}

impl Linear {
    /// The map that is 0 at every finite point (+0.0, as no polynomial
    /// part: c0 is +0, so c0 + M (x - center) is +0 whatever the signs of
    /// M's zero products).
    pub(crate) const ZERO: Linear = Linear {
        center: DVec3::ZERO,
        c0: DVec3::ZERO,
        m: glam::DMat3::ZERO,
    };

    /// p(x).
    #[inline]
    pub(crate) fn eval(&self, x: DVec3) -> DVec3 {
        self.c0 + self.m * (x - self.center)
    }

    /// p(x) + `sums` rounded to f32 at each of a chunk's points (given by
    /// coordinate, `x[axis][k]`), into `out` likewise: [`Linear::eval`]'s
    /// operations in its order (so the same values), over arrays the
    /// compiler vectorises. NaN at a point not finite.
    #[inline(always)]
    pub(crate) fn eval_plus<const N: usize>(
        &self,
        x: &[[f64; N]; 3],
        sums: &[[f32; N]; 3],
        out: &mut [[f32; N]; 3],
    ) {
        let (c, c0) = (self.center.to_array(), self.c0.to_array());
        let m = [self.m.x_axis, self.m.y_axis, self.m.z_axis].map(|v| v.to_array());
        for k in 0..N {
            let d = [0, 1, 2].map(|a| x[a][k] - c[a]);
            // x * 0 sums to 0 exactly when every coordinate is finite.
            let finite = x[0][k] * 0.0 + x[1][k] * 0.0 + x[2][k] * 0.0 == 0.0;
            for a in 0..3 {
                let v = c0[a] + ((m[0][a] * d[0] + m[1][a] * d[1]) + m[2][a] * d[2]);
                let v = (v + f64::from(sums[a][k])) as f32;
                out[a][k] = if finite { v } else { f32::NAN };
            }
        }
    }
}

/// A deformation: everything needed to replay it (kernel, R, starts,
/// coefficients, the polynomial part and the order after sorting), plus an
/// octree over the starts for evaluation.
///
/// The starts and the octree are shared (reference-counted) with the
/// [`System`] that solved it and with every other deformation it solves, so
/// a solve copies only the coefficients. A fingerprint of the starts, kernel
/// and radius, computed once when the system is built, tells a [`crate::Binding`]
/// whether a deformation is one it was made for.
#[derive(Clone, Debug)]
pub struct Deformation {
    kernel: Kernel,
    radius: f64,
    starts: Arc<[DVec3]>,
    coefficients: Vec<DVec3>,
    affine: Option<Affine>,
    order: Arc<[u32]>,
    octree: Arc<Octree>,
    fingerprint: u64,
    /// The largest move it makes at a start (destination less start): the
    /// scale against which f32 sums are judged ([`Deformation::f32_reach`]).
    moves: f64,
}

/// How many times the largest move the coefficients within reach of a
/// cell of points may sum to before that cell is summed in f64: f32 rounds
/// each term by about 6e-8 of it, so past this the f32 sum could be off by
/// more than about 1e-4 of the move. Well-posed edits stay far below (the
/// coefficients of starts 1 % of R apart pulling apart sum to a few hundred
/// times the move); a radius thousands of times the model's size (nearly
/// singular: coefficients 1e8 times the move that cancel) goes past it.
const F32_REACH: f64 = 1000.0;

/// A 64-bit fingerprint of what per-point kernel weights depend on: the
/// kernel, the radius and every start, bit for bit. Two sets of starts that
/// differ anywhere give different fingerprints but for a 2^-64 chance.
pub(crate) fn fingerprint(kernel: Kernel, radius: f64, starts: &[DVec3]) -> u64 {
    // A multiply-xorshift mix per word (splitmix64's finaliser), chained.
    let mix = |mut h: u64, w: u64| {
        h ^= w.wrapping_add(0x9e37_79b9_7f4a_7c15);
        h = (h ^ (h >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        h = (h ^ (h >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        h ^ (h >> 31)
    };
    let mut h = mix(
        mix(kernel.code() as u64, radius.to_bits()),
        starts.len() as u64,
    );
    for s in starts {
        h = mix(mix(mix(h, s.x.to_bits()), s.y.to_bits()), s.z.to_bits());
    }
    h
}

impl PartialEq for Deformation {
    fn eq(&self, o: &Self) -> bool {
        self.fingerprint == o.fingerprint
            && self.kernel == o.kernel
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

    /// Puts a deformation together from its stored parts (the replay file):
    /// the octree and fingerprint are computed here.
    pub(crate) fn from_parts(
        kernel: Kernel,
        radius: f64,
        starts: Vec<DVec3>,
        coefficients: Vec<DVec3>,
        affine: Option<Affine>,
        order: Vec<u32>,
    ) -> Deformation {
        let octree = Arc::new(Octree::new(&starts));
        let fingerprint = fingerprint(kernel, radius, &starts);
        let mut d = Deformation {
            kernel,
            radius,
            starts: starts.into(),
            coefficients,
            affine,
            order: order.into(),
            octree,
            fingerprint,
            moves: 0.0,
        };
        // The moves it makes at its starts, in f64 (what it was fitted to).
        d.moves = d
            .displacements(&d.starts)
            .iter()
            .map(|m| m.length())
            .fold(0.0, f64::max);
        d
    }

    /// The map that moves nothing: a layer with no control vectors yet (work
    /// in progress in an editor), kept so that later layers keep their
    /// numbers.
    pub fn identity(options: FitOptions) -> Deformation {
        Deformation::from_parts(
            options.kernel,
            options.radius,
            Vec::new(),
            Vec::new(),
            None,
            Vec::new(),
        )
    }

    /// A deformation of a system's shared starts and octree (no copy).
    pub(crate) fn from_shared(
        shared: &crate::system::Shared,
        coefficients: Vec<DVec3>,
        affine: Option<Affine>,
        moves: f64,
    ) -> Deformation {
        Deformation {
            kernel: shared.kernel,
            radius: shared.radius,
            starts: shared.starts.clone(),
            coefficients,
            affine,
            order: shared.order.clone(),
            octree: shared.octree.clone(),
            fingerprint: shared.fingerprint,
            moves,
        }
    }

    /// Replaces the coefficients and polynomial part (a new solve of the
    /// same system), keeping every allocation.
    pub(crate) fn set_solution(
        &mut self,
        coefficients: &[DVec3],
        affine: Option<Affine>,
        moves: f64,
    ) {
        self.coefficients.clear();
        self.coefficients.extend_from_slice(coefficients);
        self.affine = affine;
        self.moves = moves;
    }

    /// The starts farther than R from every one of `points`, by index: they
    /// move none of them (the diagnostics' `StartsFarFromMesh`, for a
    /// caller that checks before fitting or posing). f32 or f64 points,
    /// compared as they are.
    pub fn starts_out_of_reach<P: Point>(&self, points: &[P]) -> Vec<usize> {
        crate::diagnose::out_of_reach(&self.octree, self.starts.len(), self.radius, points)
    }

    /// The largest move it makes at a start (a destination less its
    /// start): the scale its coefficients are judged against.
    pub fn largest_move(&self) -> f64 {
        self.moves
    }

    /// The largest sum of coefficient sizes (|x| + |y| + |z|) over the
    /// starts a cell's points may reach for which an f32 sum is close
    /// enough (see [`F32_REACH`]); a cell past it is summed in f64.
    pub(crate) fn f32_reach(&self) -> f64 {
        F32_REACH * self.moves
    }

    /// The fingerprint of its starts, kernel and radius (see [`Deformation`]):
    /// equal for every deformation solved from one [`System`].
    pub fn fingerprint(&self) -> u64 {
        self.fingerprint
    }

    /// Encodes it alone as a `.csrbf` file's bytes (over every point, at
    /// full phase): what `csrbf fit` writes for a file of one deformation.
    pub fn to_bytes(&self) -> Vec<u8> {
        crate::format::encode(
            &[crate::FittedStage::new(self.clone())],
            crate::Combine::Chain,
        )
    }

    /// Decodes a `.csrbf` file of one deformation over every point at full
    /// phase (what [`Deformation::to_bytes`] writes). A file of several
    /// deformations, or of one with a region or another phase, is refused:
    /// read it with [`crate::format::decode`].
    pub fn from_bytes(bytes: &[u8]) -> Result<Deformation> {
        let replay = crate::format::decode(bytes)?;
        let n = replay.stages.len();
        let mut stages = replay.stages.into_iter();
        match (stages.next(), n) {
            (Some(s), 1) if s.region == crate::Region::All && s.phase == 1.0 => Ok(s.deformation),
            (Some(s), 1) => Err(crate::error::FormatError::NotSingle(format!(
                "its deformation has region {} and phase {}",
                s.region, s.phase
            ))
            .into()),
            _ => Err(
                crate::error::FormatError::NotSingle(format!("it holds {n} deformations")).into(),
            ),
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
    pub(crate) fn octree(&self) -> &Octree {
        &self.octree
    }

    /// The octree over the starts, shared (a [`crate::Binding`] keeps it).
    pub(crate) fn octree_shared(&self) -> &Arc<Octree> {
        &self.octree
    }

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
        crate::error::check_phase(phase)?;
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

/// `Ok` when a buffer has the length its points need.
pub(crate) fn check_len(what: &'static str, expected: usize, got: usize) -> Result<()> {
    if expected == got {
        Ok(())
    } else {
        Err(Error::PointCount {
            what,
            expected,
            got,
        })
    }
}
