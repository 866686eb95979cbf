use std::ops::{AddAssign, Div, Mul, SubAssign};

use glam::{DVec3, DVec4};

use super::Profile;

/// A right-hand side value: a scalar, or several right-hand sides solved
/// together (`DVec3` for x, y, z; `DVec4` for the polynomial block).
pub trait Rhs:
    Copy + Default + AddAssign + SubAssign + Mul<f64, Output = Self> + Div<f64, Output = Self>
{
    /// How many scalar right-hand sides one value carries.
    const LANES: usize;
    /// Lane `k` of the value.
    fn lane(&self, k: usize) -> f64;
    /// Sets lane `k` of the value.
    fn set_lane(&mut self, k: usize, v: f64);
}

impl Rhs for f64 {
    const LANES: usize = 1;
    fn lane(&self, _: usize) -> f64 {
        *self
    }
    fn set_lane(&mut self, _: usize, v: f64) {
        *self = v;
    }
}

impl Rhs for DVec3 {
    const LANES: usize = 3;
    fn lane(&self, k: usize) -> f64 {
        self[k]
    }
    fn set_lane(&mut self, k: usize, v: f64) {
        self[k] = v;
    }
}

impl Rhs for DVec4 {
    const LANES: usize = 4;
    fn lane(&self, k: usize) -> f64 {
        self[k]
    }
    fn set_lane(&mut self, k: usize, v: f64) {
        self[k] = v;
    }
}

impl Profile {
    /// Solves A x = b in place, given the factor from [`Profile::factor`]:
    /// forward substitution with L, then back substitution with L^T.
    pub fn solve_in_place<T: Rhs>(&self, b: &mut [T]) {
        self.forward_in_place(b);
        self.backward_in_place(b);
    }

    /// L y = b in place, row by row: the first half of
    /// [`Profile::solve_in_place`].
    pub fn forward_in_place<T: Rhs>(&self, b: &mut [T]) {
        let n = self.envelope.len().min(b.len());
        for i in 0..n {
            let fi = self.envelope.first(i);
            let row = &self.off[self.envelope.row(i)];
            let mut s = b[i];
            for (l, y) in row.iter().zip(&b[fi..i]) {
                s -= *y * *l;
            }
            b[i] = s / self.diag[i];
        }
    }

    /// L^T x = y in place, column by column from the last: the second half
    /// of [`Profile::solve_in_place`].
    pub fn backward_in_place<T: Rhs>(&self, b: &mut [T]) {
        let n = self.envelope.len().min(b.len());
        for i in (0..n).rev() {
            let xi = b[i] / self.diag[i];
            b[i] = xi;
            let fi = self.envelope.first(i);
            let row = &self.off[self.envelope.row(i)];
            for (l, y) in row.iter().zip(&mut b[fi..i]) {
                *y -= xi * *l;
            }
        }
    }
}
