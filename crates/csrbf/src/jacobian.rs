//! The space map's Jacobian: where, and from which phase, a deformation
//! turns space inside out.
//!
//! At phase t the map is T(x) = x + t D(x), so its Jacobian is
//! J = I + t G with G = dD/dx, and det J = 1 + t tr G + t^2 E2(G) + t^3 det G
//! (E2 the sum of G's principal 2x2 minors): a cubic in t that is 1 at
//! t = 0. Where it reaches 0 the map folds: a neighbourhood of x is turned
//! inside out. [`fold_phase`] is its smallest root in (0, 1].
//!
//! G is analytic: each start adds alpha_j (phi'(r) / r) (x - s_j)^T / R^2
//! (r = |x - s_j| / R), and the polynomial part its constant gradient.

use glam::{DMat3, DVec3};

use crate::deformation::Deformation;
use crate::evaluate::{Blocks, PARALLEL_POINTS, Point, for_each_cell};
use crate::kernel::Kernel;

impl Kernel {
    /// phi'(r) / r, the factor of (x - s) / R^2 in grad phi(|x - s| / R);
    /// 0 at r = 0 for C0, whose cone has no gradient at its tip.
    #[inline]
    pub fn derivative_over_r(self, r: f64) -> f64 {
        if r >= 1.0 {
            return 0.0;
        }
        let s = 1.0 - r;
        match self {
            Kernel::C0 => {
                if r > 0.0 {
                    -2.0 * s / r
                } else {
                    0.0
                }
            }
            Kernel::C2 => -20.0 * s * s * s,
            Kernel::C4 => -56.0 * s.powi(5) * (5.0 * r + 1.0),
            Kernel::C6 => -22.0 * s.powi(7) * ((16.0 * r + 7.0) * r + 1.0),
        }
    }
}

impl Deformation {
    /// G(x) = dD/dx: column k is the derivative of the displacement along
    /// axis k. The Jacobian of the map at phase t is I + t G. NaN for a
    /// point with a non-finite coordinate.
    pub fn gradient_at(&self, x: DVec3) -> DMat3 {
        if !x.is_finite() {
            return DMat3::NAN;
        }
        let mut g = self.affine_gradient();
        let (kernel, radius) = (self.kernel(), self.radius());
        let inv2 = 1.0 / (radius * radius);
        let alpha = self.coefficients();
        let starts = self.starts();
        self.octree().for_each_within(x, radius, |j, d2| {
            let off = x - starts[j as usize];
            add_term(
                &mut g,
                alpha[j as usize],
                off,
                kernel.derivative_over_r(d2.sqrt() / radius) * inv2,
            );
        });
        g
    }

    /// The Jacobian of the map at phase t: I + t G(x).
    pub fn jacobian_at(&self, x: DVec3, phase: f64) -> DMat3 {
        DMat3::IDENTITY + self.gradient_at(x) * phase
    }

    /// D and G at every point (blocked and parallel, as
    /// [`Deformation::displacements`]).
    pub fn displacements_and_gradients<P: Point>(&self, points: &[P]) -> Vec<(DVec3, DMat3)> {
        let mut out = vec![(DVec3::ZERO, DMat3::ZERO); points.len()];
        for (i, d, g) in self.displacements_and_gradients_above(points, 0.0) {
            out[i as usize] = (d, g);
        }
        out
    }

    /// `(index, D, G)` of the points where they may matter for a fold, in
    /// no set order: points are evaluated by cells, and a cell where a bound
    /// of |G| (from the coefficients of the starts near it and max|phi'|,
    /// [`Kernel::max_derivative_from`]) is below `limit` is skipped. With
    /// `limit` <= 1 a skipped point cannot fold at any phase in [0, 1]:
    /// |t G| < 1 keeps I + t G invertible. A limit of 0 skips nothing.
    pub(crate) fn displacements_and_gradients_above<P: Point>(
        &self,
        points: &[P],
        limit: f64,
    ) -> Vec<(u32, DVec3, DMat3)> {
        // Skipping needs cells that are small in space, even with few starts
        // (runs of points in their own order can span the whole mesh).
        let blocks = if limit > 0.0 {
            Blocks::new(points, self.radius() * 0.5)
        } else {
            Blocks::for_starts(points, self.radius(), self.starts().len())
        };
        let mut chunks: Vec<Vec<(u32, DVec3, DMat3)>> = vec![Vec::new(); blocks.cells.len()];
        let (kernel, radius) = (self.kernel(), self.radius());
        let inv = 1.0 / radius;
        let inv2 = inv * inv;
        let alpha = self.coefficients();
        let g0 = self.affine_gradient();
        let g0_norm = self.affine_gradient_norm();
        // One output list per cell: split `chunks` as a buffer of one per cell.
        let one_each = Blocks {
            order: Vec::new(),
            cells: (0..chunks.len()).map(|c| (c, c + 1)).collect(),
            identity: false,
        };
        let parallel = points.len() >= PARALLEL_POINTS;
        for_each_cell(&one_each, &mut chunks, parallel, |(c, _), out, cand| {
            let (s, e) = blocks.cells[c];
            let idx = &blocks.order[s..e];
            cand.gather(
                self.octree(),
                idx.iter().map(|&i| points[i as usize].to_dvec3()),
                radius,
            );
            let finite = idx
                .iter()
                .all(|&i| points[i as usize].to_dvec3().is_finite());
            if limit > 0.0 && finite && g0_norm + cand.gradient_bound(alpha, kernel, radius) < limit
            {
                return; // no point of this cell can fold
            }
            let out = &mut out[0];
            out.reserve(idx.len());
            for &i in idx {
                let x = points[i as usize].to_dvec3();
                if !x.is_finite() {
                    out.push((i, DVec3::NAN, DMat3::NAN));
                    continue;
                }
                let mut d = self.affine().map_or(DVec3::ZERO, |a| a.eval(x));
                let mut g = g0;
                cand.for_each_offset(x, radius, |j, off| {
                    let a = alpha[j as usize];
                    let r = off.length() * inv;
                    d += a * kernel.eval(r);
                    add_term(&mut g, a, off, kernel.derivative_over_r(r) * inv2);
                });
                out.push((i, d, g));
            }
        });
        chunks.concat()
    }

    /// A bound of the polynomial part's gradient's spectral norm (its
    /// Frobenius norm).
    pub(crate) fn affine_gradient_norm(&self) -> f64 {
        let g = self.affine_gradient();
        (g.x_axis.length_squared() + g.y_axis.length_squared() + g.z_axis.length_squared()).sqrt()
    }

    /// The polynomial part's (constant) gradient; zero without one.
    fn affine_gradient(&self) -> DMat3 {
        match self.affine() {
            None => DMat3::ZERO,
            Some(a) => {
                let c = &a.coefficients;
                DMat3::from_cols(c[1], c[2], c[3]) * (1.0 / a.scale)
            }
        }
    }
}

/// g += alpha (f off)^T: one start's term of the gradient.
#[inline(always)]
fn add_term(g: &mut DMat3, alpha: DVec3, off: DVec3, f: f64) {
    let w = off * f;
    g.x_axis += alpha * w.x;
    g.y_axis += alpha * w.y;
    g.z_axis += alpha * w.z;
}

/// det(I + t G) as the coefficients (1, c1, c2, c3) of 1 + c1 t + c2 t^2 + c3 t^3.
pub fn det_cubic(g: DMat3) -> [f64; 3] {
    let tr = g.x_axis.x + g.y_axis.y + g.z_axis.z;
    let g2 = g * g;
    let tr2 = g2.x_axis.x + g2.y_axis.y + g2.z_axis.z;
    [tr, 0.5 * (tr * tr - tr2), g.determinant()]
}

/// The smallest phase t in (0, 1] at which det(I + t G) <= 0 (where the map
/// at that point starts to fold), or None when it stays positive on the
/// whole way. Exact up to bisection to 1e-12: the cubic is split at its
/// turning points into monotone pieces, and the first piece whose end is not
/// positive holds the root.
pub fn fold_phase(g: DMat3) -> Option<f64> {
    let [c1, c2, c3] = det_cubic(g);
    first_nonpositive([1.0, c1, c2, c3])
}

/// The smallest t in (0, 1] at which c0 + c1 t + c2 t^2 + c3 t^3 <= 0, for
/// c0 > 0; None when it stays positive on (0, 1] or a coefficient is not
/// finite (and Some(0) when c0 <= 0 already). Exact up to bisection to
/// 1e-12: the cubic is split at its turning points into monotone pieces, and
/// the first piece whose end is not positive holds the root. A corner of a
/// cell whose nodes move on straight lines has such a determinant.
pub fn first_nonpositive(c: [f64; 4]) -> Option<f64> {
    let [c0, c1, c2, c3] = c;
    if !c.iter().all(|v| v.is_finite()) {
        return None;
    }
    if c0 <= 0.0 {
        return Some(0.0);
    }
    let f = |t: f64| c0 + t * (c1 + t * (c2 + t * c3));
    // Turning points: roots of c1 + 2 c2 t + 3 c3 t^2 within (0, 1).
    let mut cuts = Vec::with_capacity(4);
    let (a, b, c) = (3.0 * c3, 2.0 * c2, c1);
    let tiny = 1e-300 * c0.max(1.0);
    if a.abs() > tiny {
        let disc = b * b - 4.0 * a * c;
        if disc >= 0.0 {
            let q = -0.5 * (b + b.signum() * disc.sqrt());
            for r in [q / a, if q != 0.0 { c / q } else { f64::NAN }] {
                if r > 0.0 && r < 1.0 {
                    cuts.push(r);
                }
            }
        }
    } else if b.abs() > tiny {
        let r = -c / b;
        if r > 0.0 && r < 1.0 {
            cuts.push(r);
        }
    }
    cuts.sort_by(f64::total_cmp);
    cuts.push(1.0);
    let mut lo = 0.0;
    for hi in cuts {
        if f(hi) <= 0.0 {
            // f(lo) > 0 (else an earlier piece held the root), monotone between.
            let (mut a, mut b) = (lo, hi);
            for _ in 0..60 {
                let m = 0.5 * (a + b);
                if f(m) <= 0.0 {
                    b = m;
                } else {
                    a = m;
                }
                if b - a < 1e-12 {
                    break;
                }
            }
            return Some(b);
        }
        lo = hi;
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::Rng;
    use crate::{FitOptions, Polynomial};

    fn scene(n: usize, seed: u64, scale: f64) -> (Vec<DVec3>, Vec<DVec3>) {
        let mut rng = Rng::new(seed);
        let s: Vec<DVec3> = (0..n).map(|_| rng.vec3()).collect();
        let t = s.iter().map(|p| *p + (rng.vec3() - 0.5) * scale).collect();
        (s, t)
    }

    /// Against central differences of the displacement, every kernel, with
    /// and without the polynomial part, and the batch against the single.
    #[test]
    fn gradients_match_central_differences() {
        for kernel in Kernel::ALL {
            for poly in [Polynomial::None, Polynomial::Linear] {
                let (s, t) = scene(70, 3 + kernel as u64, 0.2);
                let d = crate::Deformation::fit(
                    &s,
                    &t,
                    FitOptions::new(0.45)
                        .with_kernel(kernel)
                        .with_polynomial(poly),
                )
                .expect("fit");
                let mut rng = Rng::new(11);
                let pts: Vec<DVec3> = (0..300).map(|_| rng.vec3()).collect();
                let batch = d.displacements_and_gradients(&pts);
                // A bound of 0 skips nothing; a huge one skips everything.
                assert_eq!(
                    d.displacements_and_gradients_above(&pts, 0.0).len(),
                    pts.len()
                );
                assert!(
                    d.displacements_and_gradients_above(&pts, f64::INFINITY)
                        .is_empty()
                );
                // Any cell skipped under a limit of 1 holds only points with |G| < 1.
                let kept: Vec<u32> = d
                    .displacements_and_gradients_above(&pts, 1.0)
                    .iter()
                    .map(|v| v.0)
                    .collect();
                for (i, (_, g)) in batch.iter().enumerate() {
                    if !kept.contains(&(i as u32)) {
                        let frob = (g.x_axis.length_squared()
                            + g.y_axis.length_squared()
                            + g.z_axis.length_squared())
                        .sqrt();
                        // The spectral norm is at most the Frobenius one.
                        let spectral = (g.transpose() * *g)
                            .to_cols_array()
                            .iter()
                            .map(|x| x.abs())
                            .sum::<f64>()
                            .sqrt();
                        assert!(
                            frob.min(spectral) < 1.0 + 1e-9,
                            "{kernel}: skipped a point with |G| {frob}"
                        );
                    }
                }
                let h = 1e-6;
                for (p, (dd, g)) in pts.iter().zip(&batch) {
                    assert!((*dd - d.displacement_at(*p)).length() < 1e-12);
                    let single = d.gradient_at(*p);
                    for k in 0..3 {
                        let e = DVec3::AXES[k] * h;
                        let fd =
                            (d.displacement_at(*p + e) - d.displacement_at(*p - e)) / (2.0 * h);
                        let col = g.col(k);
                        // C0 is only continuous: its gradient jumps at a start.
                        let tol = 1e-6 * (1.0 + fd.length());
                        assert!(
                            (col - fd).length() < tol,
                            "{kernel} {poly:?} axis {k}: {col} vs {fd}"
                        );
                        assert!((single.col(k) - col).length() < 1e-12);
                    }
                }
            }
        }
    }

    /// The fold phase against a dense scan of det(I + t G) over t.
    #[test]
    fn fold_phase_is_the_first_root_of_the_determinant() {
        let mut rng = Rng::new(5);
        let mut folded = 0;
        for _ in 0..3000 {
            let g = DMat3::from_cols(
                (rng.vec3() - 0.5) * 6.0,
                (rng.vec3() - 0.5) * 6.0,
                (rng.vec3() - 0.5) * 6.0,
            );
            let det = |t: f64| (DMat3::IDENTITY + g * t).determinant();
            let scan = (1..=20000)
                .map(|i| i as f64 / 20000.0)
                .find(|&t| det(t) <= 0.0);
            match (fold_phase(g), scan) {
                (None, None) => {}
                (Some(a), Some(b)) => {
                    assert!((a - b).abs() <= 1e-4, "{a} vs {b}");
                    assert!(det(a) <= 1e-9);
                    folded += 1;
                }
                // A root that only touches zero between scan points.
                (a, b) => {
                    let t = a.or(b).expect("one found");
                    assert!(det(t).abs() < 1e-6, "{a:?} vs {b:?}: det {}", det(t));
                }
            }
        }
        assert!(folded > 300, "the random cases should fold often: {folded}");
        assert_eq!(fold_phase(DMat3::ZERO), None);
        // D = -2x along x: det(I + tG) = 1 - 2t, folds at one half.
        let g = DMat3::from_diagonal(DVec3::new(-2.0, 0.0, 0.0));
        assert!((fold_phase(g).expect("folds") - 0.5).abs() < 1e-12);
    }
}
