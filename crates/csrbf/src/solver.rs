//! The two factorisations of A behind one interface: the papers' profile
//! Cholesky after a band-reducing ordering, and a supernodal sparse Cholesky
//! (faer) with a fill-reducing ordering for systems whose envelope grows too
//! wide.

use std::sync::Arc;

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::perm::PermRef;
use faer::sparse::linalg::cholesky::{
    LltRef, SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering, factorize_symbolic_cholesky,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, Mat, Par, Side};

use crate::error::{FitError, NameError, Result};
use crate::skyline::{Profile, Rhs};
use crate::triangular::Split;

/// Which factorisation to use.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[non_exhaustive]
pub enum SolverChoice {
    /// Estimate the cost of both and take the cheaper (default).
    #[default]
    Auto,
    /// Profile (skyline) Cholesky after the band-reducing ordering: the papers' solver.
    Skyline,
    /// Supernodal sparse Cholesky (faer) after a nested dissection of the
    /// starts by their coordinates.
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
        /// Its structure, shared by the factors of every matrix with the
        /// same pattern ([`crate::System::rebuild`]).
        symbolic: Arc<SymbolicCholesky<u32>>,
        values: Vec<f64>,
        /// Its subtrees cut in two for a factorisation and a solve on two
        /// threads (`None`: a small or simplicial factor, made on one).
        split: Option<Arc<Split>>,
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

/// faer's parallelism for a numeric factorisation of this much work: its
/// own threads only on a machine with more than two. On this project's
/// two-core machine the parallel factorisation was slower at every size
/// measured (`--example bench_fit`, quiet, medians of 3: 10k controls 92 -> 47 ms
/// on one thread, 40k 475 -> 345 ms); beyond two cores it is left to faer
/// (not measured here).
fn parallelism(work: f64) -> Par {
    if work > 2e6 && rayon::current_num_threads() > 2 {
        Par::rayon(0)
    } else {
        Par::Seq
    }
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

    /// Symbolic analysis (ordering, elimination tree, supernodes): with
    /// `order` (`order[new] = old`, a permutation of `0..a.n`) in that
    /// numbering, else after faer's approximate minimum degree.
    pub(crate) fn supernodal_symbolic(
        a: &LowerCsc,
        order: Option<&[u32]>,
    ) -> Result<SymbolicCholesky<u32>, FitError> {
        let pattern = SymbolicSparseColMatRef::new_checked(a.n, a.n, &a.col_ptr, None, &a.row_idx);
        let inverse;
        let ordering = match order {
            Some(order) if order.len() == a.n => {
                inverse = crate::ordering::inverse(order);
                SymmetricOrdering::Custom(PermRef::new_checked(order, &inverse, a.n))
            }
            _ => SymmetricOrdering::Amd,
        };
        factorize_symbolic_cholesky(pattern, Side::Lower, ordering, Default::default())
            .map_err(|e| FitError::Solver(format!("{e:?}")))
    }

    /// Multiply-adds of the numeric factorisation a symbolic analysis
    /// stands for: the sum over the columns of L of count^2 / 2 (a column
    /// of `c` entries updates about `c^2 / 2` entries of later columns).
    pub(crate) fn supernodal_flops(symbolic: &SymbolicCholesky<u32>) -> f64 {
        let column = |c: f64| c * (c + 1.0) * 0.5;
        match symbolic.raw() {
            SymbolicCholeskyRaw::Simplicial(s) => s
                .col_ptr()
                .windows(2)
                .map(|w| column((w[1] - w[0]) as f64))
                .sum(),
            SymbolicCholeskyRaw::Supernodal(s) => {
                let rows = s.col_ptr_for_row_idx();
                (0..s.n_supernodes())
                    .map(|k| {
                        let width = (s.supernode_end()[k] - s.supernode_begin()[k]) as usize;
                        let below = (rows[k + 1] - rows[k]) as f64;
                        // Column t of the supernode: its width - t diagonal
                        // block rows and the rows below.
                        (0..width)
                            .map(|t| column((width - t) as f64 + below))
                            .sum::<f64>()
                    })
                    .sum()
            }
        }
    }

    /// Numeric factorisation with a symbolic analysis already made.
    pub(crate) fn supernodal(
        symbolic: SymbolicCholesky<u32>,
        a: &LowerCsc,
    ) -> Result<Factor, FitError> {
        let split = match symbolic.raw() {
            SymbolicCholeskyRaw::Supernodal(s) => Split::of(s, symbolic.len_val()).map(Arc::new),
            SymbolicCholeskyRaw::Simplicial(_) => None,
        };
        Factor::supernodal_with(Arc::new(symbolic), split, a)
    }

    /// [`Factor::supernodal`] of a structure made before (shared with the
    /// factor it came from) and its cut.
    pub(crate) fn supernodal_with(
        symbolic: Arc<SymbolicCholesky<u32>>,
        split: Option<Arc<Split>>,
        a: &LowerCsc,
    ) -> Result<Factor, FitError> {
        let mut values = vec![0.0; symbolic.len_val()];
        let failed = match symbolic.raw() {
            // A supernodal structure is factored here, its two sets of
            // subtrees at once (`crate::supernodal`); a simplicial one (a
            // tiny system) by faer.
            SymbolicCholeskyRaw::Supernodal(s) => {
                let inverse = symbolic.perm().map(|p| p.arrays().1);
                crate::supernodal::factor(s, inverse, a, &mut values).err()
            }
            SymbolicCholeskyRaw::Simplicial(_) => {
                let pattern =
                    SymbolicSparseColMatRef::new_checked(a.n, a.n, &a.col_ptr, None, &a.row_idx);
                let matrix = SparseColMatRef::new(pattern, &a.values);
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
                match result {
                    Err(faer::linalg::solvers::LltError::NonPositivePivot { index }) => Some(index),
                    Ok(_) => None,
                }
            }
        };
        if let Some(column) = failed {
            let control = symbolic
                .perm()
                .map(|p| p.arrays().0[column.min(a.n - 1)] as usize)
                .unwrap_or(column);
            return Err(FitError::NotPositiveDefinite { control });
        }
        clear_upper_vector_state();
        Ok(Factor::Supernodal {
            symbolic,
            values,
            split,
        })
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
            Factor::Supernodal {
                symbolic,
                values,
                split,
            } => {
                if let SymbolicCholeskyRaw::Supernodal(s) = symbolic.raw()
                    && T::LANES <= crate::triangular::MAX_LANES
                {
                    let forward = symbolic.perm().map(|p| p.arrays().0);
                    crate::triangular::solve_in_place(s, forward, values, split.as_deref(), b);
                    return;
                }
                Self::solve_in_place_faer(symbolic, values, b);
            }
        }
    }

    /// [`Factor::solve_in_place`] through faer's solve (a simplicial
    /// factor, or more right-hand sides than [`crate::triangular`] takes);
    /// the reference of [`crate::triangular`]'s tests.
    pub(crate) fn solve_in_place_faer<T: Rhs>(
        symbolic: &SymbolicCholesky<u32>,
        values: &[f64],
        b: &mut [T],
    ) {
        let n = symbolic.nrows();
        let mut m = Mat::<f64>::from_fn(n, T::LANES, |i, k| b[i].lane(k));
        // One thread: the triangular solves with a few right-hand
        // sides read L once each way and are bound by memory; at 1m
        // (27 MB of L, 4 right-hand sides) rayon took 8.1-14.3 ms
        // where one thread took 6.9-11.2 ms, and `solve_many`
        // already runs its solves in parallel.
        let par = Par::Seq;
        let mut mem = MemBuffer::new(symbolic.solve_in_place_scratch::<f64>(T::LANES, par));
        LltRef::new(symbolic, values).solve_in_place_with_conj(
            Conj::No,
            m.as_mut(),
            par,
            MemStack::new(&mut mem),
        );
        // The solve ran on this thread alone: no need to wake the
        // pool's workers (`clear_upper_vector_state` would).
        clear_upper_vector_state_here();
        for (i, v) in b.iter_mut().enumerate().take(n) {
            for k in 0..T::LANES {
                v.set_lane(k, m[(i, k)]);
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

/// [`clear_upper_vector_state`] on the calling thread only, after faer ran
/// on it alone (`Par::Seq`).
fn clear_upper_vector_state_here() {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx") {
        zero_upper();
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

#[cfg(test)]
pub(crate) mod tests {
    use glam::DVec3;

    use super::*;
    use crate::kernel::Kernel;
    use crate::ordering::{Graph, geometric_dissection};
    use crate::testing::{Rng, assert_close};

    /// The lower triangle of A for random starts in a cube, and their graph.
    pub(crate) fn random_system(n: usize, radius: f64, seed: u64) -> (Vec<DVec3>, Graph, LowerCsc) {
        let mut rng = Rng::new(seed);
        let s: Vec<DVec3> = (0..n).map(|_| rng.vec3()).collect();
        let (g, a) = system_of(&s, radius);
        (s, g, a)
    }

    /// The graph and lower triangle of A (C2) for the starts `s`.
    pub(crate) fn system_of(s: &[DVec3], radius: f64) -> (Graph, LowerCsc) {
        let n = s.len();
        let lists: Vec<Vec<u32>> = (0..n)
            .map(|i| {
                (0..n)
                    .filter(|&j| j != i && s[i].distance(s[j]) < radius)
                    .map(|j| j as u32)
                    .collect()
            })
            .collect();
        let g = Graph::from_lists(&lists);
        let mut a = LowerCsc {
            n,
            col_ptr: vec![0],
            row_idx: Vec::new(),
            values: Vec::new(),
        };
        for j in 0..n {
            a.row_idx.push(j as u32);
            a.values.push(Kernel::C2.eval(0.0));
            for &i in g.neighbours(j).iter().filter(|&&i| i as usize > j) {
                a.row_idx.push(i);
                a.values
                    .push(Kernel::C2.eval(s[i as usize].distance(s[j]) / radius));
            }
            a.col_ptr.push(a.row_idx.len() as u32);
        }
        (g, a)
    }

    #[test]
    fn a_dissection_order_solves_as_amd_does() {
        for seed in 0..3 {
            let (s, g, a) = random_system(500 + 250 * seed as usize, 0.2, seed);
            let order = geometric_dissection(&g, &s, 0.2);
            let amd = Factor::supernodal(Factor::supernodal_symbolic(&a, None).unwrap(), &a)
                .expect("SPD");
            let nd = Factor::supernodal(Factor::supernodal_symbolic(&a, Some(&order)).unwrap(), &a)
                .expect("SPD");
            let mut rng = Rng::new(seed + 10);
            let b: Vec<DVec3> = (0..a.n).map(|_| rng.vec3()).collect();
            let (mut x1, mut x2) = (b.clone(), b);
            amd.solve_in_place(&mut x1);
            nd.solve_in_place(&mut x2);
            let scale = x1.iter().map(|v| v.abs().max_element()).fold(0.0, f64::max);
            for (u, v) in x1.iter().zip(&x2) {
                for k in 0..3 {
                    assert_close(v[k] / scale, u[k] / scale, 1e-9, "dissection vs AMD");
                }
            }
        }
    }

    /// The multiply-adds counted from faer's structure against a plain
    /// count: the column counts of L found by dense symbolic elimination.
    #[test]
    fn supernodal_flops_count_the_columns_of_l() {
        for (n, radius, seed) in [(40, 0.5, 1), (300, 0.25, 2), (600, 0.2, 3)] {
            let (s, g, a) = random_system(n, radius, seed);
            let order = geometric_dissection(&g, &s, radius);
            for order in [None, Some(&order[..])] {
                let symbolic = Factor::supernodal_symbolic(&a, order).unwrap();
                let perm: Vec<u32> = match symbolic.perm() {
                    Some(p) => p.arrays().0.to_vec(),
                    None => (0..n as u32).collect(),
                };
                let inv = crate::ordering::inverse(&perm);
                let mut m = vec![vec![false; n]; n];
                for i in 0..n {
                    m[i][i] = true;
                    for &j in g.neighbours(i) {
                        m[inv[i] as usize][inv[j as usize] as usize] = true;
                    }
                }
                let mut want = 0.0;
                for k in 0..n {
                    let below: Vec<usize> = (k + 1..n).filter(|&i| m[i][k]).collect();
                    for &i in &below {
                        for &j in &below {
                            m[i][j] = true;
                        }
                    }
                    let c = 1.0 + below.len() as f64;
                    want += c * (c + 1.0) * 0.5;
                }
                assert_eq!(Factor::supernodal_flops(&symbolic), want, "n {n}");
            }
        }
    }

    #[test]
    fn a_failed_pivot_names_the_control_under_a_given_order() {
        // Controls 0 and 2 couple too strongly; eliminated last, control 0
        // is where the pivot fails.
        let a = LowerCsc {
            n: 3,
            col_ptr: vec![0, 2, 3, 4],
            row_idx: vec![0, 2, 1, 2],
            values: vec![1.0, 3.0, 1.0, 1.0],
        };
        let symbolic = Factor::supernodal_symbolic(&a, Some(&[1, 2, 0])).unwrap();
        let err = Factor::supernodal(symbolic, &a).err();
        assert_eq!(err, Some(FitError::NotPositiveDefinite { control: 0 }));
    }
}
