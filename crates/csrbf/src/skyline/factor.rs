use super::Profile;
use crate::simd::{dot, dot4};

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

    /// The plain row-by-row factorisation, one dot product an entry and
    /// no vector instructions: the reference [`Profile::factor`] is tested
    /// against (it sums in another order, so the two differ in the last bits).
    #[cfg(test)]
    pub(crate) fn factor_scalar(&mut self) -> Result<(), PivotError> {
        self.factor_impl::<false>()
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
    /// The plain bordering method: each entry of row `i` one dot product.
    #[cfg(test)]
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
    p.factor_blocked::<FMA>()
}

impl Profile {
    /// [`Profile::factor_impl`] with the entries of row `i` found four
    /// columns `j..j + 4` at a time: the part of their dot products over
    /// the columns all four rows share (`kc..j`) is summed in one pass that
    /// loads row `i` once ([`dot4`]); each row's own head before `kc` and
    /// the few columns `j..j + t` the block itself fills are added apart.
    #[inline(always)]
    fn factor_blocked<const FMA: bool>(&mut self) -> Result<(), PivotError> {
        let n = self.envelope.len();
        for i in 0..n {
            let fi = self.envelope.first(i);
            let ri = self.envelope.row(i);
            let mut j = fi;
            while j + 4 <= i {
                // Row t of the block is j + t; its products run over k0[t]..j + t.
                // (Arrays written out: `array::from_fn` was left uninlined
                // in this hot loop.)
                let first = |t: usize| fi.max(self.envelope.first(j + t));
                let k0 = [first(0), first(1), first(2), first(3)];
                let kc = k0.iter().copied().max().unwrap_or(j).min(j);
                let (off, env) = (&self.off, &self.envelope);
                // Row t's stored entry for column k.
                let at = |t: usize, k: usize| {
                    let r = j + t;
                    env.starts[r] + (k - env.first(r))
                };
                // When some row of the block starts after j, kc = j and
                // nothing is shared (nor is column kc stored in that row).
                let common = if kc < j {
                    let a = &off[ri.start + (kc - fi)..ri.start + (j - fi)];
                    let row = |t: usize| &off[at(t, kc)..at(t, j)];
                    dot4::<FMA>(a, [row(0), row(1), row(2), row(3)])
                } else {
                    [0.0; 4]
                };
                let mut sums = [0.0; 4];
                for t in 0..4 {
                    let head = if k0[t] < kc {
                        let a = &off[ri.start + (k0[t] - fi)..ri.start + (kc - fi)];
                        dot::<FMA>(a, &off[at(t, k0[t])..at(t, kc)])
                    } else {
                        0.0
                    };
                    sums[t] = head + common[t];
                }
                for t in 0..4 {
                    let jt = j + t;
                    let mut s = sums[t];
                    for k in j.max(k0[t])..jt {
                        s += self.off[ri.start + (k - fi)] * self.off[at(t, k)];
                    }
                    let e = ri.start + (jt - fi);
                    self.off[e] = (self.off[e] - s) / self.diag[jt];
                }
                j += 4;
            }
            for j in j..i {
                let fj = self.envelope.first(j);
                let k0 = fi.max(fj);
                let rj = self.envelope.row(j);
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
