//! The polynomial block after elimination: W = A^-1 P and S^-1 = (P^T W)^-1.

use glam::{DMat4, DVec3, DVec4};

pub(crate) use crate::deformation::prow;
use crate::error::FitError;
use crate::solver::Factor;

/// The polynomial block after elimination: W = A^-1 P and S^-1 = (P^T W)^-1,
/// with P's rows (1, u) for u the starts centred and scaled.
#[derive(Debug)]
pub(super) struct PolyBlock {
    pub(super) w: Vec<DVec4>,
    pub(super) s_inv: DMat4,
    pub(super) center: DVec3,
    pub(super) scale: f64,
}

pub(super) fn poly_block(starts: &[DVec3], factor: &Factor) -> Result<PolyBlock, FitError> {
    let n = starts.len() as f64;
    let center = starts.iter().copied().sum::<DVec3>() / n;
    let scale = starts
        .iter()
        .map(|s| s.distance(center))
        .fold(0.0, f64::max)
        .max(f64::MIN_POSITIVE);
    let p: Vec<DVec4> = starts.iter().map(|s| prow(*s, center, scale)).collect();
    let mut w = p.clone();
    factor.solve_in_place(&mut w);
    let mut s = DMat4::ZERO;
    for (pi, wi) in p.iter().zip(&w) {
        s += DMat4::from_cols(*wi * pi.x, *wi * pi.y, *wi * pi.z, *wi * pi.w);
    }
    // S is symmetric positive definite when P has full rank.
    let s = (s + s.transpose()) * 0.5;
    let det = s.determinant();
    let diag_product = s.x_axis.x * s.y_axis.y * s.z_axis.z * s.w_axis.w;
    if !(det > diag_product.abs() * 1e-14) || !det.is_finite() {
        return Err(FitError::CoplanarStarts);
    }
    Ok(PolyBlock {
        w,
        s_inv: s.inverse(),
        center,
        scale,
    })
}
