//! The two factorisations of A behind one interface: the papers' profile
//! Cholesky after a band-reducing ordering, and a supernodal sparse Cholesky
//! (faer) with a fill-reducing ordering for systems whose envelope grows too
//! wide.

use std::sync::Arc;

use crate::error::{FitError, NameError, Result};
use crate::ordering::Graph;
use crate::skyline::{Profile, Rhs};
use crate::symbolic::{Permuted, Structure};
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
    /// A supernodal factor in faer's layout; its structure keeps the
    /// fill-reducing numbering.
    Supernodal {
        /// Its structure, shared by the factors of every matrix with the
        /// same pattern ([`crate::System::rebuild`]).
        symbolic: Arc<Structure>,
        values: Vec<f64>,
        /// Its subtrees cut in two for a factorisation and a solve on two
        /// threads (`None`: a small factor, made on one).
        split: Option<Arc<Split>>,
    },
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

    /// Symbolic analysis (elimination tree, column counts, supernodes) of
    /// A, whose pattern is `graph` and the diagonal: with `order`
    /// (`order[new] = old`, a permutation of the graph's nodes) in that
    /// numbering, else after faer's approximate minimum degree.
    pub(crate) fn supernodal_symbolic(
        graph: &Graph,
        order: Option<&[u32]>,
    ) -> Result<Structure, FitError> {
        match order {
            Some(order) => Structure::new(graph, order.to_vec()),
            None => Structure::amd(graph),
        }
    }

    /// Multiply-adds of the numeric factorisation a symbolic analysis
    /// stands for: the sum over the columns of L of count^2 / 2 (a column
    /// of `c` entries updates about `c^2 / 2` entries of later columns).
    pub(crate) fn supernodal_flops(symbolic: &Structure) -> f64 {
        let column = |c: f64| c * (c + 1.0) * 0.5;
        let s = symbolic.supernodal();
        let rows = s.col_ptr_for_row_idx();
        (0..s.n_supernodes())
            .map(|k| {
                let width = (s.supernode_end()[k] - s.supernode_begin()[k]) as usize;
                let below = (rows[k + 1] - rows[k]) as f64;
                // Column t of the supernode: its width - t diagonal block
                // rows and the rows below.
                (0..width)
                    .map(|t| column((width - t) as f64 + below))
                    .sum::<f64>()
            })
            .sum()
    }

    /// Numeric factorisation with a symbolic analysis already made.
    pub(crate) fn supernodal(symbolic: Structure, a: &Permuted) -> Result<Factor, FitError> {
        let split = Split::of(symbolic.supernodal(), symbolic.len_val()).map(Arc::new);
        Factor::supernodal_with(Arc::new(symbolic), split, a)
    }

    /// [`Factor::supernodal`] of a structure made before (shared with the
    /// factor it came from) and its cut.
    pub(crate) fn supernodal_with(
        symbolic: Arc<Structure>,
        split: Option<Arc<Split>>,
        a: &Permuted,
    ) -> Result<Factor, FitError> {
        // Its subtrees on the pool as they come free (`crate::supernodal`).
        let values = crate::supernodal::factor(symbolic.supernodal(), a).map_err(|column| {
            let order = symbolic.order();
            FitError::NotPositiveDefinite {
                control: order[column.min(order.len() - 1)] as usize,
            }
        })?;
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
            } => crate::triangular::solve_in_place(
                symbolic.supernodal(),
                Some(symbolic.order()),
                values,
                split.as_deref(),
                b,
            ),
        }
    }

    /// The forward half of [`Factor::solve_in_place`]: y with L y = b for
    /// `b` in the caller's numbering, y in the factor's.
    pub(crate) fn forward<T: Rhs>(&self, b: &[T]) -> Vec<T> {
        match self {
            Factor::Skyline { profile, perm } => {
                let mut y: Vec<T> = perm.iter().map(|&o| b[o as usize]).collect();
                profile.forward_in_place(&mut y);
                y
            }
            Factor::Supernodal {
                symbolic,
                values,
                split,
            } => crate::triangular::forward_solve(
                symbolic.supernodal(),
                symbolic.order(),
                values,
                split.as_deref(),
                b,
            ),
        }
    }

    /// The backward half of [`Factor::solve_in_place`]: x with L^T x = y
    /// for `y` in the factor's numbering (as [`Factor::forward`] gives
    /// it), into `b` in the caller's.
    pub(crate) fn backward<T: Rhs>(&self, mut y: Vec<T>, b: &mut [T]) {
        match self {
            Factor::Skyline { profile, perm } => {
                profile.backward_in_place(&mut y);
                for (new, &old) in perm.iter().enumerate() {
                    b[old as usize] = y[new];
                }
            }
            Factor::Supernodal {
                symbolic,
                values,
                split,
            } => crate::triangular::backward_solve(
                symbolic.supernodal(),
                symbolic.order(),
                values,
                split.as_deref(),
                &y,
                b,
            ),
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

#[cfg(test)]
pub(crate) mod tests {
    use glam::DVec3;

    use super::*;
    use crate::kernel::Kernel;
    use crate::ordering::geometric_dissection;
    use crate::symbolic::LowerCsc;
    use crate::testing::{Rng, assert_close};

    /// The supernodal factor of `a` (the lower triangle in the caller's
    /// numbering) with the structure `symbolic`.
    pub(crate) fn supernodal_of(symbolic: Structure, a: &LowerCsc) -> Result<Factor, FitError> {
        let permuted = Permuted::new(a, symbolic.inverse());
        Factor::supernodal(symbolic, &permuted)
    }

    /// Solves A x = b in place through faer's supernodal solve: the
    /// reference of [`crate::triangular`]'s tests.
    pub(crate) fn solve_with_faer<T: Rhs>(symbolic: &Structure, values: &[f64], b: &mut [T]) {
        use faer::dyn_stack::{MemBuffer, MemStack};
        use faer::sparse::linalg::cholesky::supernodal::SupernodalLltRef;
        use faer::{Conj, Mat, Par};
        let order = symbolic.order();
        let mut m = Mat::<f64>::from_fn(order.len(), T::LANES, |i, k| b[order[i] as usize].lane(k));
        let s = symbolic.supernodal();
        let mut mem = MemBuffer::new(s.solve_in_place_scratch::<f64>(T::LANES, Par::Seq));
        SupernodalLltRef::new(s, values).solve_in_place_with_conj(
            Conj::No,
            m.as_mut(),
            Par::Seq,
            MemStack::new(&mut mem),
        );
        for (i, &old) in order.iter().enumerate() {
            for k in 0..T::LANES {
                b[old as usize].set_lane(k, m[(i, k)]);
            }
        }
    }

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
            let amd =
                supernodal_of(Factor::supernodal_symbolic(&g, None).unwrap(), &a).expect("SPD");
            let nd = supernodal_of(Factor::supernodal_symbolic(&g, Some(&order)).unwrap(), &a)
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

    /// The multiply-adds counted from the structure against a plain count.
    /// Dense symbolic elimination gives each column of L its rows; each
    /// supernode's rows below it must be the union of its columns' (faer
    /// merges small supernodes, their zeros included), and its column `t`
    /// then costs (its width - t + those rows) squared over two.
    #[test]
    fn supernodal_flops_count_the_columns_of_l() {
        let column = |c: f64| c * (c + 1.0) * 0.5;
        for (n, radius, seed) in [(40, 0.5, 1), (300, 0.25, 2), (600, 0.2, 3)] {
            let (s, g, _) = random_system(n, radius, seed);
            let order = geometric_dissection(&g, &s, radius);
            for order in [None, Some(&order[..])] {
                let symbolic = Factor::supernodal_symbolic(&g, order).unwrap();
                let inv = symbolic.inverse();
                let mut m = vec![vec![false; n]; n];
                for i in 0..n {
                    m[i][i] = true;
                    for &j in g.neighbours(i) {
                        m[inv[i] as usize][inv[j as usize] as usize] = true;
                    }
                }
                let mut exact = 0.0;
                for k in 0..n {
                    let below: Vec<usize> = (k + 1..n).filter(|&i| m[i][k]).collect();
                    for &i in &below {
                        for &j in &below {
                            m[i][j] = true;
                        }
                    }
                    exact += column(1.0 + below.len() as f64);
                }
                let sn = symbolic.supernodal();
                let mut want = 0.0;
                for k in 0..sn.n_supernodes() {
                    let (b, e) = (
                        sn.supernode_begin()[k] as usize,
                        sn.supernode_end()[k] as usize,
                    );
                    let rows: Vec<usize> = (e..n).filter(|&i| (b..e).any(|c| m[i][c])).collect();
                    let pattern: Vec<usize> = sn
                        .supernode(k)
                        .pattern()
                        .iter()
                        .map(|&i| i as usize)
                        .collect();
                    assert_eq!(pattern, rows, "n {n} supernode {k}: its rows below");
                    want += (0..e - b)
                        .map(|t| column((e - b - t + rows.len()) as f64))
                        .sum::<f64>();
                }
                let flops = Factor::supernodal_flops(&symbolic);
                assert_eq!(flops, want, "n {n}");
                assert!(flops >= exact, "n {n}: {flops} below L's own {exact}");
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
        let g = Graph::from_lists(&[vec![2], vec![], vec![0]]);
        let symbolic = Factor::supernodal_symbolic(&g, Some(&[1, 2, 0])).unwrap();
        let err = supernodal_of(symbolic, &a).err();
        assert_eq!(err, Some(FitError::NotPositiveDefinite { control: 0 }));
    }
}
