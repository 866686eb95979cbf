//! A fitted deformation: the space map T(x) = x + D(x), as data. The
//! fitted values every other module reads (its evaluation is `displace`,
//! its bytes `format`, its checks `diagnose`, its fit `system`); this
//! module imports none of them.

use std::sync::Arc;

use glam::{DVec3, DVec4};

use crate::kernel::{Kernel, Polynomial};
use crate::octree::Octree;
use crate::options::FitOptions;

/// Row (1, u) of P for a start, with u = (s - centre) / scale.
#[inline]
pub(crate) fn prow(s: DVec3, center: DVec3, scale: f64) -> DVec4 {
    let u = (s - center) / scale;
    DVec4::new(1.0, u.x, u.y, u.z)
}

/// What every deformation a system solves shares with it: the starts, their
/// order and octree, and the fingerprint a [`crate::Binding`] checks.
#[derive(Debug)]
pub(crate) struct Shared {
    pub(crate) kernel: Kernel,
    pub(crate) radius: f64,
    pub(crate) starts: Arc<[DVec3]>,
    pub(crate) order: Arc<[u32]>,
    pub(crate) octree: Arc<Octree>,
    pub(crate) fingerprint: u64,
}

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
/// [`System`](crate::System) that solved it and with every other deformation it solves, so
/// a solve copies only the coefficients. A fingerprint of the starts, kernel
/// and radius, computed once when the system is built, tells a [`crate::Binding`]
/// whether a deformation is one it was made for.
#[derive(Clone, Debug)]
pub struct Deformation {
    pub(crate) kernel: Kernel,
    pub(crate) radius: f64,
    pub(crate) starts: Arc<[DVec3]>,
    pub(crate) coefficients: Vec<DVec3>,
    pub(crate) affine: Option<Affine>,
    pub(crate) order: Arc<[u32]>,
    pub(crate) octree: Arc<Octree>,
    pub(crate) fingerprint: u64,
    /// The largest move it makes at a start (destination less start): the
    /// scale against which f32 sums are judged ([`Deformation::f32_reach`]).
    pub(crate) moves: f64,
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

    /// The same map seen after every point is placed by x -> s R x (a
    /// uniform scale `scale` > 0 and a rotation `rotation`): the returned
    /// map D' has D'(s R x) = s R D(x) for every x, with starts s R c,
    /// radius s r, coefficients s R a and the linear part turned and scaled
    /// alike. A Wendland fit commutes with such a placement, so this is
    /// the deformation the placed controls would fit to (up to rounding),
    /// without a new fit. How a scene puts an object's mesh, edited in its
    /// own units and axes, at its scale and base rotation.
    pub fn placed(&self, scale: f64, rotation: glam::DQuat) -> Deformation {
        let r = glam::DMat3::from_quat(rotation.normalize());
        let sr = r * scale;
        let affine = self.affine.map(|a| {
            // p'(y) = s R p(R^T y / s): centre s R c, scale s |.|, c0 s R c0,
            // and the columns (c1 c2 c3) become s R C R^T.
            let c = glam::DMat3::from_cols(a.coefficients[1], a.coefficients[2], a.coefficients[3]);
            let turned = sr * c * r.transpose();
            Affine {
                center: sr * a.center,
                scale: scale * a.scale,
                coefficients: [
                    sr * a.coefficients[0],
                    turned.x_axis,
                    turned.y_axis,
                    turned.z_axis,
                ],
            }
        });
        Deformation::from_parts(
            self.kernel,
            self.radius * scale,
            self.starts.iter().map(|&c| sr * c).collect(),
            self.coefficients.iter().map(|&a| sr * a).collect(),
            affine,
            self.order.to_vec(),
        )
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
        shared: &Shared,
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
    /// equal for every deformation solved from one [`System`](crate::System).
    pub fn fingerprint(&self) -> u64 {
        self.fingerprint
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
}
