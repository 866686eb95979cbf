//! The polynomial block after elimination, from the forward half of a solve
//! alone: V = L^-1 P (A = L L^T in the factor's numbering) and
//! S^-1 = (V^T V)^-1 = (P^T A^-1 P)^-1.

use glam::{DMat4, DVec3, DVec4};

pub(crate) use crate::deformation::prow;
use crate::error::FitError;
use crate::solver::Factor;

/// The polynomial block after elimination: V = L^-1 P (in the factor's
/// numbering) and S^-1 = (V^T V)^-1, with P's rows (1, u) for u the starts
/// centred and scaled. A solve then needs one forward and one backward
/// pass, as without the block: [`super::System`]'s `solution`.
#[derive(Debug)]
pub(super) struct PolyBlock {
    pub(super) v: Vec<DVec4>,
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
    let v = factor.forward(&p);
    let mut s = DMat4::ZERO;
    for vi in &v {
        s += DMat4::from_cols(*vi * vi.x, *vi * vi.y, *vi * vi.z, *vi * vi.w);
    }
    // S = V^T V is symmetric positive definite when P has full rank.
    let det = s.determinant();
    let diag_product = s.x_axis.x * s.y_axis.y * s.z_axis.z * s.w_axis.w;
    if !(det > diag_product.abs() * 1e-14) || !det.is_finite() {
        return Err(FitError::CoplanarStarts);
    }
    Ok(PolyBlock {
        v,
        s_inv: s.inverse(),
        center,
        scale,
    })
}
