use super::Profile;

/// A pivot that did not stay positive: the row, in the profile's numbering.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PivotError {
    /// Row of the failed pivot.
    pub row: usize,
}

impl Profile {
    /// Factors the matrix in place into its Cholesky factor, row by row
    /// (Jennings' bordering method): fill stays inside the envelope.
    ///
    /// Fails at the first pivot that is not positive (relative to the
    /// diagonal entry it came from), naming its row.
    pub fn factor(&mut self) -> Result<(), PivotError> {
        let n = self.envelope.len();
        for i in 0..n {
            let fi = self.envelope.first(i);
            let ri = self.envelope.row(i);
            for j in fi..i {
                let fj = self.envelope.first(j);
                let k0 = fi.max(fj);
                let rj = self.envelope.row(j);
                // Columns k0..j of rows i and j.
                let a = &self.off[ri.start + (k0 - fi)..ri.start + (j - fi)];
                let b = &self.off[rj.start + (k0 - fj)..rj.end];
                let s = self.off[ri.start + (j - fi)] - dot(a, b);
                self.off[ri.start + (j - fi)] = s / self.diag[j];
            }
            let row = &self.off[ri];
            let d = self.diag[i] - dot(row, row);
            if !(d > self.diag[i].abs() * 1e-13) || !d.is_finite() {
                return Err(PivotError { row: i });
            }
            self.diag[i] = d.sqrt();
        }
        Ok(())
    }
}

/// Dot product with four accumulators, so the compiler can vectorise it.
#[inline]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut acc = [0.0f64; 4];
    let mut ca = a.chunks_exact(4);
    let mut cb = b.chunks_exact(4);
    for (x, y) in (&mut ca).zip(&mut cb) {
        for k in 0..4 {
            acc[k] += x[k] * y[k];
        }
    }
    let tail: f64 = ca
        .remainder()
        .iter()
        .zip(cb.remainder())
        .map(|(x, y)| x * y)
        .sum();
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}
