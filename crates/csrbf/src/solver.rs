//! The two factorisations of A behind one interface: the papers' profile
//! Cholesky after a band-reducing ordering, and a supernodal sparse Cholesky
//! (faer) with a fill-reducing ordering for systems whose envelope grows too
//! wide.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::cholesky::{
    LltRef, SymbolicCholesky, SymmetricOrdering, factorize_symbolic_cholesky,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, Mat, Par, Side};

use crate::error::{FitError, NameError, Result};
use crate::skyline::{Profile, Rhs};

/// Which factorisation to use.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[non_exhaustive]
pub enum SolverChoice {
    /// Estimate the cost of both and take the cheaper (default).
    #[default]
    Auto,
    /// Profile (skyline) Cholesky after the band-reducing ordering: the papers' solver.
    Skyline,
    /// Supernodal sparse Cholesky with an approximate-minimum-degree ordering.
    Supernodal,
}

impl SolverChoice {
    /// The lower-case name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            SolverChoice::Auto => "auto",
            SolverChoice::Skyline => "skyline",
            SolverChoice::Supernodal => "supernodal",
        }
    }
}

impl SolverChoice {
    /// Every choice.
    pub const ALL: [SolverChoice; 3] = [
        SolverChoice::Auto,
        SolverChoice::Skyline,
        SolverChoice::Supernodal,
    ];
}

impl std::fmt::Display for SolverChoice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for SolverChoice {
    type Err = NameError;
    fn from_str(s: &str) -> Result<Self, NameError> {
        SolverChoice::ALL
            .into_iter()
            .find(|c| c.name().eq_ignore_ascii_case(s))
            .ok_or_else(|| NameError::UnknownSolver(s.to_owned()))
    }
}

/// A factor of A, solving in the caller's numbering of the starts.
#[derive(Debug)]
pub(crate) enum Factor {
    /// Profile factor in the numbering `perm` (`perm[new] = old`).
    Skyline { profile: Profile, perm: Vec<u32> },
    /// faer's supernodal (or simplicial, for tiny systems) factor; it keeps
    /// its own fill-reducing permutation.
    Supernodal {
        symbolic: SymbolicCholesky<u32>,
        values: Vec<f64>,
    },
}

/// The lower triangle of A by columns: `col_ptr`, sorted `row_idx` (each
/// column starting with its diagonal) and `values`.
pub(crate) struct LowerCsc {
    pub(crate) n: usize,
    pub(crate) col_ptr: Vec<u32>,
    pub(crate) row_idx: Vec<u32>,
    pub(crate) values: Vec<f64>,
}

fn parallelism(work: f64) -> Par {
    if work > 2e6 { Par::rayon(0) } else { Par::Seq }
}

impl Factor {
    /// Factors the profile; a failed pivot is reported by control index.
    pub(crate) fn skyline(mut profile: Profile, perm: Vec<u32>) -> Result<Factor, FitError> {
        profile
            .factor()
            .map_err(|e| FitError::NotPositiveDefinite {
                control: perm[e.row] as usize,
            })?;
        Ok(Factor::Skyline { profile, perm })
    }

    /// Symbolic analysis (AMD ordering, elimination tree, supernodes).
    pub(crate) fn supernodal_symbolic(a: &LowerCsc) -> Result<SymbolicCholesky<u32>, FitError> {
        let pattern = SymbolicSparseColMatRef::new_checked(a.n, a.n, &a.col_ptr, None, &a.row_idx);
        factorize_symbolic_cholesky(
            pattern,
            Side::Lower,
            SymmetricOrdering::Amd,
            Default::default(),
        )
        .map_err(|e| FitError::Solver(format!("{e:?}")))
    }

    /// Numeric factorisation with a symbolic analysis already made.
    pub(crate) fn supernodal(
        symbolic: SymbolicCholesky<u32>,
        a: &LowerCsc,
    ) -> Result<Factor, FitError> {
        let pattern = SymbolicSparseColMatRef::new_checked(a.n, a.n, &a.col_ptr, None, &a.row_idx);
        let matrix = SparseColMatRef::new(pattern, &a.values);
        let mut values = vec![0.0; symbolic.len_val()];
        let par = parallelism(values.len() as f64 * 50.0);
        let mut mem = MemBuffer::try_new(
            symbolic.factorize_numeric_llt_scratch::<f64>(par, Default::default()),
        )
        .map_err(|e| FitError::Solver(format!("{e:?}")))?;
        let result = symbolic.factorize_numeric_llt(
            &mut values,
            matrix,
            Side::Lower,
            Default::default(),
            par,
            MemStack::new(&mut mem),
            Default::default(),
        );
        if let Err(faer::linalg::solvers::LltError::NonPositivePivot { index }) = result {
            let control = symbolic
                .perm()
                .map(|p| p.arrays().0[index.min(a.n - 1)] as usize)
                .unwrap_or(index);
            return Err(FitError::NotPositiveDefinite { control });
        }
        clear_upper_vector_state();
        Ok(Factor::Supernodal { symbolic, values })
    }

    /// Solves A x = b in place; `b` is in the caller's numbering.
    pub(crate) fn solve_in_place<T: Rhs>(&self, b: &mut [T]) {
        match self {
            Factor::Skyline { profile, perm } => {
                let mut x: Vec<T> = perm.iter().map(|&o| b[o as usize]).collect();
                profile.solve_in_place(&mut x);
                for (new, &old) in perm.iter().enumerate() {
                    b[old as usize] = x[new];
                }
            }
            Factor::Supernodal { symbolic, values } => {
                let n = symbolic.nrows();
                let mut m = Mat::<f64>::from_fn(n, T::LANES, |i, k| b[i].lane(k));
                let par = parallelism(values.len() as f64 * T::LANES as f64);
                let mut mem = MemBuffer::new(symbolic.solve_in_place_scratch::<f64>(T::LANES, par));
                LltRef::new(symbolic, values).solve_in_place_with_conj(
                    Conj::No,
                    m.as_mut(),
                    par,
                    MemStack::new(&mut mem),
                );
                clear_upper_vector_state();
                for (i, v) in b.iter_mut().enumerate().take(n) {
                    for k in 0..T::LANES {
                        v.set_lane(k, m[(i, k)]);
                    }
                }
            }
        }
    }

    /// Which solver this is.
    pub(crate) fn choice(&self) -> SolverChoice {
        match self {
            Factor::Skyline { .. } => SolverChoice::Skyline,
            Factor::Supernodal { .. } => SolverChoice::Supernodal,
        }
    }

    /// Bytes the factor's values take (f64).
    pub(crate) fn value_bytes(&self) -> usize {
        match self {
            Factor::Skyline { profile, .. } => profile.value_bytes(),
            Factor::Supernodal { values, .. } => 8 * values.len(),
        }
    }
}

/// faer's dense kernels use 512- and 256-bit vector instructions and can
/// leave the upper halves of the vector registers dirty on the threads that
/// ran them. Later legacy-SSE code on those threads (everything this crate
/// compiles to for baseline x86-64) then pays a transition penalty on every
/// vector instruction: measured here, evaluation on the rayon workers ran
/// 2.5x slower after a supernodal factorisation. Clearing the state on every
/// worker afterwards removes the penalty.
pub(crate) fn clear_upper_vector_state() {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx") {
            rayon::broadcast(|_| zero_upper());
            zero_upper();
        }
    }
}

#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)] // one instruction with no memory effects, behind a runtime AVX check
fn zero_upper() {
    #[target_feature(enable = "avx")]
    unsafe fn inner() {
        core::arch::x86_64::_mm256_zeroupper();
    }
    // SAFETY: callers check that the CPU supports AVX.
    unsafe { inner() }
}
