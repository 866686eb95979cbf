//! Profile (envelope, skyline) storage after Jennings (1966), and the
//! Cholesky factorisation that keeps its fill inside the envelope.
//!
//! Row `i` stores its entries from its first non-zero column `first[i]` up to,
//! not including, the diagonal; the diagonal is kept apart. A Cholesky factor
//! has exactly the same envelope as the matrix, so the factor overwrites it.

mod factor;
mod solve;

pub use factor::PivotError;
pub use solve::Rhs;

use crate::ordering::{Graph, inverse};

/// The shape of a profile: where each row starts. The symbolic part, shared by
/// every matrix with the same pattern.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Envelope {
    first: Vec<u32>,
    starts: Vec<usize>,
}

impl Envelope {
    /// The envelope of the matrix with pattern `graph` in the numbering
    /// `perm` (`perm[new] = old`).
    pub fn new(graph: &Graph, perm: &[u32]) -> Envelope {
        let inv = inverse(perm);
        let mut first = Vec::with_capacity(perm.len());
        let mut starts = Vec::with_capacity(perm.len() + 1);
        starts.push(0);
        for (new, &old) in perm.iter().enumerate() {
            let f = graph
                .neighbours(old as usize)
                .iter()
                .map(|&j| inv[j as usize] as usize)
                .filter(|&j| j < new)
                .min()
                .unwrap_or(new);
            first.push(f as u32);
            starts.push(starts[new] + (new - f));
        }
        Envelope { first, starts }
    }

    /// Dimension of the matrix.
    pub fn len(&self) -> usize {
        self.first.len()
    }

    /// Whether the matrix is 0 x 0.
    pub fn is_empty(&self) -> bool {
        self.first.is_empty()
    }

    /// Stored entries below the diagonal.
    pub fn off_diagonal(&self) -> usize {
        self.starts.last().copied().unwrap_or(0)
    }

    /// First stored column of row `i`.
    pub fn first(&self, i: usize) -> usize {
        self.first[i] as usize
    }

    /// Largest row width below the diagonal.
    pub fn bandwidth(&self) -> usize {
        (0..self.len())
            .map(|i| i - self.first(i))
            .max()
            .unwrap_or(0)
    }

    /// Bytes in the papers' accounting: 4-byte values for the diagonal and
    /// the envelope, and one 4-byte row start per row.
    pub fn paper_bytes(&self) -> usize {
        4 * (2 * self.len() + self.off_diagonal())
    }

    /// Multiply-adds of a Cholesky factorisation in this profile.
    pub fn factor_flops(&self) -> f64 {
        (0..self.len())
            .map(|i| {
                let w = (i - self.first(i)) as f64;
                w * (w + 1.0) * 0.5
            })
            .sum()
    }

    fn row(&self, i: usize) -> std::ops::Range<usize> {
        self.starts[i]..self.starts[i + 1]
    }
}

/// A symmetric matrix in profile storage. After [`Profile::factor`] it holds
/// its Cholesky factor L (A = L L^T) in the same storage.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Profile {
    envelope: Envelope,
    diag: Vec<f64>,
    off: Vec<f64>,
}

impl Profile {
    /// A zero matrix of the given shape.
    pub fn zeros(envelope: Envelope) -> Profile {
        Profile {
            diag: vec![0.0; envelope.len()],
            off: vec![0.0; envelope.off_diagonal()],
            envelope,
        }
    }

    /// The shape.
    pub fn envelope(&self) -> &Envelope {
        &self.envelope
    }

    /// Sets the entry at row `i`, column `j <= i`. An entry outside the
    /// envelope is ignored (it would be zero in a valid pattern).
    pub fn set(&mut self, i: usize, j: usize, value: f64) {
        if i == j {
            self.diag[i] = value;
        } else if j < i && j >= self.envelope.first(i) {
            let k = self.envelope.starts[i] + (j - self.envelope.first(i));
            self.off[k] = value;
        }
    }

    /// The entry at row `i`, column `j` (either triangle).
    pub fn get(&self, i: usize, j: usize) -> f64 {
        let (i, j) = if j > i { (j, i) } else { (i, j) };
        if i == j {
            self.diag[i]
        } else if j >= self.envelope.first(i) {
            self.off[self.envelope.starts[i] + (j - self.envelope.first(i))]
        } else {
            0.0
        }
    }

    /// Bytes the values take in memory (f64).
    pub fn value_bytes(&self) -> usize {
        8 * (self.diag.len() + self.off.len())
    }
}

#[cfg(test)]
pub(crate) mod tests;
