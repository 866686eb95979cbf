//! Wendland's compactly supported radial functions.

use std::fmt;
use std::str::FromStr;

/// A Wendland function phi(r), zero for r >= 1, positive definite in R^3.
/// The default is [`Kernel::C2`] (smooth, the papers' bouncing ball).
///
/// The argument is the distance divided by the radius of support R, so a
/// kernel only ever sees r in [0, 1) where it is non-zero.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "lowercase"))]
#[non_exhaustive]
pub enum Kernel {
    /// psi_{2,0}: (1-r)^2, continuous only; the papers' face and fish.
    C0,
    /// psi_{3,1}: (1-r)^4 (4r+1), twice differentiable; the papers' bouncing ball.
    #[default]
    C2,
    /// (1-r)^6 (35r^2+18r+3), four times differentiable.
    C4,
    /// (1-r)^8 (32r^3+25r^2+8r+1), six times differentiable.
    C6,
}

impl Kernel {
    /// Every kernel, in order of smoothness.
    pub const ALL: [Kernel; 4] = [Kernel::C0, Kernel::C2, Kernel::C4, Kernel::C6];

    /// phi(r) for r >= 0: the kernel's value at distance r * R.
    #[inline]
    pub fn eval(self, r: f64) -> f64 {
        let s = 1.0 - r;
        // The polynomial first and the cut-off as a select, not a branch:
        // a loop over candidates then vectorises.
        let v = match self {
            Kernel::C0 => s * s,
            Kernel::C2 => {
                let s2 = s * s;
                s2 * s2 * (4.0 * r + 1.0)
            }
            Kernel::C4 => {
                let s2 = s * s;
                s2 * s2 * s2 * ((35.0 * r + 18.0) * r + 3.0)
            }
            Kernel::C6 => {
                let s2 = s * s;
                let s4 = s2 * s2;
                s4 * s4 * (((32.0 * r + 25.0) * r + 8.0) * r + 1.0)
            }
        };
        if r >= 1.0 { 0.0 } else { v }
    }

    /// dphi/dr for r >= 0 (zero for r >= 1).
    #[inline]
    pub fn derivative(self, r: f64) -> f64 {
        if r >= 1.0 {
            return 0.0;
        }
        let s = 1.0 - r;
        match self {
            Kernel::C0 => -2.0 * s,
            Kernel::C2 => -20.0 * r * s * s * s,
            Kernel::C4 => -56.0 * r * s.powi(5) * (5.0 * r + 1.0),
            Kernel::C6 => -22.0 * r * s.powi(7) * ((16.0 * r + 7.0) * r + 1.0),
        }
    }

    /// max |phi'(r)| over r in [r0, 1]: |phi'| rises to its peak (at r = 0
    /// for C0, 1/4 for C2, 0.23557 for C4, 0.21529 for C6) and then falls, so
    /// the maximum is at the peak or at r0 beyond it. A hair above the true
    /// value (a 1e-9 margin for the peaks' rounding), never below.
    pub fn max_derivative_from(self, r0: f64) -> f64 {
        if r0 >= 1.0 {
            return 0.0;
        }
        let peak = match self {
            Kernel::C0 => 0.0,
            Kernel::C2 => 0.25,
            Kernel::C4 => 0.235_571_372_6,
            Kernel::C6 => 0.215_286_038_9,
        };
        self.derivative(r0.max(peak)).abs() * (1.0 + 1e-9)
    }

    /// The fold-free bound, as a fraction of R: a single control vector
    /// shorter than `fold_free_ratio() * R` gives a map that folds nowhere.
    ///
    /// One vector d at start s gives T(x) = x + d phi(|x - s| / R) / phi(0),
    /// whose Jacobian I + d grad(phi)^T / phi(0) has determinant
    /// 1 + d . grad(phi) / phi(0) >= 1 - |d| max|phi'| / (R phi(0)). So T is
    /// one-to-one when |d| < R phi(0) / max|phi'|: C0 1/2 (phi' largest at
    /// r = 0), C2 64/135 = 0.474 (at r = 1/4), C4 0.400 (at r = 0.2356),
    /// C6 0.355 (at r = 0.2153). Several vectors add their gradients, so
    /// the bound is a guide there, not a proof; flipped faces are the check.
    pub fn fold_free_ratio(self) -> f64 {
        match self {
            Kernel::C0 => 0.5,
            Kernel::C2 => 64.0 / 135.0,
            Kernel::C4 => 0.400_033_78,
            Kernel::C6 => 0.354_723_01,
        }
    }

    /// The lower-case name used in control files: `c0`, `c2`, `c4` or `c6`.
    pub fn name(self) -> &'static str {
        match self {
            Kernel::C0 => "c0",
            Kernel::C2 => "c2",
            Kernel::C4 => "c4",
            Kernel::C6 => "c6",
        }
    }

    pub(crate) fn code(self) -> u8 {
        self as u8
    }

    pub(crate) fn from_code(code: u8) -> Option<Kernel> {
        Kernel::ALL.get(code as usize).copied()
    }
}

impl fmt::Display for Kernel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Kernel {
    type Err = crate::NameError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Kernel::ALL
            .into_iter()
            .find(|k| k.name().eq_ignore_ascii_case(s))
            .ok_or_else(|| crate::NameError::UnknownKernel(s.to_owned()))
    }
}

/// The polynomial term added to the radial sum.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "lowercase"))]
pub enum Polynomial {
    /// No polynomial (the default): displacements are interpolated and the
    /// map is exactly the identity farther than R from every start point, so
    /// an edit stays local.
    #[default]
    None,
    /// A linear polynomial with side conditions (the papers' choice): any
    /// affine map is reproduced exactly, but an affine part fitted to a
    /// local edit moves the whole model. Needs at least 4 start points not
    /// on one plane.
    Linear,
}

impl Polynomial {
    /// Both choices.
    pub const ALL: [Polynomial; 2] = [Polynomial::None, Polynomial::Linear];

    /// The lower-case name used in control files.
    pub fn name(self) -> &'static str {
        match self {
            Polynomial::None => "none",
            Polynomial::Linear => "linear",
        }
    }
}

impl fmt::Display for Polynomial {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Polynomial {
    type Err = crate::NameError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Polynomial::ALL
            .into_iter()
            .find(|p| p.name().eq_ignore_ascii_case(s))
            .ok_or_else(|| crate::NameError::UnknownPolynomial(s.to_owned()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kernels_match_their_formulas_and_vanish_at_one() {
        for i in 0..=100 {
            let r = i as f64 / 100.0;
            let s = 1.0 - r;
            let want = [
                s.powi(2),
                s.powi(4) * (4.0 * r + 1.0),
                s.powi(6) * (35.0 * r * r + 18.0 * r + 3.0),
                s.powi(8) * (32.0 * r.powi(3) + 25.0 * r * r + 8.0 * r + 1.0),
            ];
            for (k, w) in Kernel::ALL.into_iter().zip(want) {
                assert!(
                    (k.eval(r) - w).abs() <= 1e-14 * w.abs().max(1.0),
                    "{k} at {r}"
                );
            }
        }
        for k in Kernel::ALL {
            assert_eq!(k.eval(1.0), 0.0);
            assert_eq!(k.eval(1.5), 0.0);
        }
    }

    #[test]
    fn derivatives_and_fold_free_bounds_match_numbers() {
        for k in Kernel::ALL {
            let mut steepest: f64 = 0.0;
            for i in 0..=20000 {
                let r = i as f64 / 20000.0;
                steepest = steepest.max(k.derivative(r).abs());
                if i % 500 == 250 {
                    let h = 1e-6;
                    let numeric = (k.eval(r + h) - k.eval(r - h)) / (2.0 * h);
                    assert!((numeric - k.derivative(r)).abs() < 1e-6, "{k}' at {r}");
                }
            }
            let ratio = k.eval(0.0) / steepest;
            assert!((ratio - k.fold_free_ratio()).abs() < 1e-6, "{k}: {ratio}");
        }
    }

    #[test]
    fn a_vector_at_the_bound_does_not_fold_and_past_it_does() {
        // T(x) = x + d phi(|x| / R) / phi(0) along the line of d: monotone iff
        // |d| < bound.
        for k in Kernel::ALL {
            let bound = k.fold_free_ratio();
            let monotone = |len: f64| {
                let t = |x: f64| x + len * k.eval(x.abs()) / k.eval(0.0);
                (0..4000).all(|i| {
                    let x = -1.0 + i as f64 / 2000.0;
                    t(x + 1.0 / 2000.0) > t(x)
                })
            };
            assert!(monotone(bound * 0.99), "{k}");
            assert!(!monotone(bound * 1.05), "{k}");
        }
    }

    #[test]
    fn names_round_trip() {
        for k in Kernel::ALL {
            assert_eq!(k.name().parse::<Kernel>().ok(), Some(k));
        }
        assert!("c3".parse::<Kernel>().is_err());
        assert_eq!("none".parse::<Polynomial>().ok(), Some(Polynomial::None));
    }
}
