use super::Profile;
use crate::simd::dot;

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
        #[cfg(target_arch = "x86_64")]
        if let Some(cpu) = crate::simd::Avx2Fma::detect() {
            return factor_with(cpu, self);
        }
        factor_body::<false>(self)
    }

    /// [`Profile::factor`] without vector instructions: what a CPU without
    /// AVX2 runs (tested against the vector code on one with it).
    #[cfg(test)]
    pub(crate) fn factor_scalar(&mut self) -> Result<(), PivotError> {
        factor_body::<false>(self)
    }
}

#[cfg(target_arch = "x86_64")]
fn factor_with(_cpu: crate::simd::Avx2Fma, p: &mut Profile) -> Result<(), PivotError> {
    // SAFETY: an `Avx2Fma` exists only when the CPU has AVX2 and FMA.
    #[allow(unsafe_code)]
    unsafe {
        factor_avx2(p)
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn factor_avx2(p: &mut Profile) -> Result<(), PivotError> {
    factor_body::<true>(p)
}

impl Profile {
    #[inline(always)]
    fn factor_impl<const FMA: bool>(&mut self) -> Result<(), PivotError> {
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
                let s = self.off[ri.start + (j - fi)] - dot::<FMA>(a, b);
                self.off[ri.start + (j - fi)] = s / self.diag[j];
            }
            let row = &self.off[ri];
            let d = self.diag[i] - dot::<FMA>(row, row);
            if !(d > self.diag[i].abs() * 1e-13) || !d.is_finite() {
                return Err(PivotError { row: i });
            }
            self.diag[i] = d.sqrt();
        }
        Ok(())
    }
}

#[inline(always)]
fn factor_body<const FMA: bool>(p: &mut Profile) -> Result<(), PivotError> {
    p.factor_impl::<FMA>()
}
