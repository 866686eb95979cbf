//! `csrbf.System` (factor once, solve many), `csrbf.Binding` (points bound
//! to a system's starts for repeated frames) and `csrbf.deform_many` (one point set, K
//! target sets, one call).

use std::sync::RwLock;

use csrbf::glam::{DVec3, Vec3};
use csrbf::{Binding, Deformation, System};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rayon::prelude::*;

use crate::arrays::{self, Dtype, View};
use crate::cast::vectors_mut;
use crate::deformation::{PyDeformation, check_lengths, options, rows, vectors_f64};
use crate::error;

/// The symbolic and numeric work of one set of starts, done once: the
/// neighbour graph, ordering and factor. `solve` gives a Deformation for new
/// destinations without refactoring (a drag, an optimisation step).
///
/// >>> s = csrbf.System(starts, radius=0.3)
/// >>> d = s.solve(new_targets)
#[pyclass(name = "System", module = "csrbf", frozen)]
pub struct PySystem {
    inner: System,
}

#[pymethods]
impl PySystem {
    /// Builds and factors the system of these starts.
    ///
    /// Args: as `csrbf.fit`, without the destinations.
    #[new]
    #[pyo3(signature = (starts, radius, kernel = "c2", polynomial = "none", *, allow_large = false))]
    fn new(
        py: Python<'_>,
        starts: &Bound<'_, PyAny>,
        radius: f64,
        kernel: &str,
        polynomial: &str,
        allow_large: bool,
    ) -> PyResult<PySystem> {
        let options = options(radius, kernel, polynomial, allow_large)?;
        let s = vectors_f64(starts, "starts")?;
        let inner = py
            .detach(|| System::new(&s, options))
            .map_err(|e| error(&e))?;
        Ok(PySystem { inner })
    }

    /// The deformation carrying the starts to `targets` ((M, 3), one per
    /// start); no refactoring.
    fn solve(&self, py: Python<'_>, targets: &Bound<'_, PyAny>) -> PyResult<PyDeformation> {
        let t = vectors_f64(targets, "targets")?;
        check_lengths(self.inner.starts().len(), t.len())?;
        let d = py.detach(|| self.inner.solve(&t)).map_err(|e| error(&e))?;
        Ok(PyDeformation { inner: d })
    }

    /// One deformation per target set: `targets` is (K, M, 3); solved in
    /// parallel. Returns a list of K Deformations.
    fn solve_many(
        &self,
        py: Python<'_>,
        targets: &Bound<'_, PyAny>,
    ) -> PyResult<Vec<PyDeformation>> {
        let sets = arrays::target_sets(targets, "targets")?;
        check_sets(self.inner.starts().len(), &sets)?;
        let ds = py
            .detach(|| self.inner.solve_many(&sets))
            .map_err(|e| error(&e))?;
        Ok(ds
            .into_iter()
            .map(|inner| PyDeformation { inner })
            .collect())
    }

    /// A Binding of `points` to these starts (for `Binding.displacements`
    /// of every deformation this system solves).
    fn bind(&self, py: Python<'_>, points: &Bound<'_, PyAny>) -> PyResult<PyBinding> {
        let p = arrays::points(points, "points")?;
        let view = p.view();
        let inner = py.detach(|| match view {
            View::F32(v) => self.inner.bind(v),
            View::F64(v) => self.inner.bind(v),
        });
        Ok(PyBinding::of(inner, p.dtype()))
    }

    /// The indices of the starts farther than R from every one of `points`
    /// ((N, 3)): they would move none of them. A list of int.
    fn starts_out_of_reach(
        &self,
        py: Python<'_>,
        points: &Bound<'_, PyAny>,
    ) -> PyResult<Vec<usize>> {
        let p = arrays::points(points, "points")?;
        let view = p.view();
        Ok(py.detach(|| match view {
            View::F32(v) => self.inner.starts_out_of_reach(v),
            View::F64(v) => self.inner.starts_out_of_reach(v),
        }))
    }

    /// The starts, an (M, 3) float64 array.
    #[getter]
    fn starts<'py>(&self, py: Python<'py>) -> Bound<'py, numpy::PyArray2<f64>> {
        rows(py, self.inner.starts())
    }

    /// The radius of support R.
    #[getter]
    fn radius(&self) -> f64 {
        self.inner.options().radius
    }

    /// The kernel's name.
    #[getter]
    fn kernel(&self) -> &'static str {
        self.inner.options().kernel.name()
    }

    /// The polynomial term's name.
    #[getter]
    fn polynomial(&self) -> &'static str {
        self.inner.options().polynomial.name()
    }

    /// What `csrbf info --controls` reports: controls, neighbours per start,
    /// non-zeros, bandwidth and envelope before and after ordering, the
    /// ordering and solver chosen, profile and dense bytes.
    #[getter]
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let s = self.inner.stats();
        let d = PyDict::new(py);
        d.set_item("controls", s.controls)?;
        d.set_item("neighbours_min", s.neighbours_min)?;
        d.set_item("neighbours_mean", s.neighbours_mean)?;
        d.set_item("neighbours_max", s.neighbours_max)?;
        d.set_item("nonzeros", s.nonzeros)?;
        d.set_item("bandwidth_before", s.bandwidth_before)?;
        d.set_item("envelope_before", s.envelope_before)?;
        d.set_item("bandwidth", s.bandwidth)?;
        d.set_item("envelope", s.envelope)?;
        d.set_item("ordering", &s.ordering)?;
        d.set_item("solver", &s.solver)?;
        d.set_item("profile_bytes", s.profile_bytes)?;
        d.set_item("dense_bytes", s.dense_bytes)?;
        d.set_item("factor_bytes", s.factor_bytes)?;
        Ok(d)
    }

    /// The number of control vectors.
    fn __len__(&self) -> usize {
        self.inner.starts().len()
    }

    fn __repr__(&self) -> String {
        let o = self.inner.options();
        let n = self.inner.starts().len();
        format!(
            "System({}, R={:?}, {n} control{}{}, {} solver)",
            o.kernel.name(),
            o.radius,
            if n == 1 { "" } else { "s" },
            if o.polynomial == csrbf::Polynomial::Linear {
                ", linear"
            } else {
                ""
            },
            self.inner.stats().solver
        )
    }
}

/// Every target set must have one row per start.
fn check_sets(starts: usize, sets: &[Vec<DVec3>]) -> PyResult<()> {
    match sets.first() {
        Some(s) if s.len() != starts => Err(PyValueError::new_err(format!(
            "targets must be (K, {starts}, 3), one row per start: got {} rows per set",
            s.len()
        ))),
        _ => Ok(()),
    }
}

/// Points bound to one set of starts, for repeated frames: the points sorted
/// into cells and each cell's starts in reach found once, so that a new
/// deformation of those starts (from `System.solve`) updates every point
/// with the kernel sums alone (no search of the starts).
///
/// >>> b = csrbf.Binding(s.solve(targets), vertices)   # or s.bind(vertices)
/// >>> b.displacements(s.solve(other_targets))
#[pyclass(name = "Binding", module = "csrbf", frozen)]
pub struct PyBinding {
    /// The binding and the dtype of its points: read by every product,
    /// written by `rebind` (with the GIL released either way).
    state: RwLock<(Binding, Dtype)>,
}

#[pymethods]
impl PyBinding {
    /// Binds `points` ((N, 3)) to the starts of `deformation` (a
    /// Deformation or a System). Results have the points' dtype (float32
    /// stays float32). It keeps the points sorted into cells and each cell's
    /// starts in reach (about 21 bytes a point at a million points, 33 with
    /// float64 points; more with fewer points a cell or more starts in
    /// reach), and sums the kernel in float32 lanes, for float64 points too:
    /// displacements agree with `Deformation.displacements` (float64) to the
    /// float32 sums' rounding,
    /// about 1e-7 of the sum of |coefficient| over the starts within R
    /// (1e-7 to 1e-6 of the largest move on real meshes; more where nearby
    /// starts pull in opposite directions, their coefficients exceeding the
    /// move: up to 5e-6 of it on the tests' scenes of starts 3-30 % of R
    /// apart).
    #[new]
    fn new(
        py: Python<'_>,
        deformation: &Bound<'_, PyAny>,
        points: &Bound<'_, PyAny>,
    ) -> PyResult<PyBinding> {
        if let Ok(s) = deformation.cast::<PySystem>() {
            return s.get().bind(py, points);
        }
        let d = deformation.cast::<PyDeformation>().map_err(|_| {
            pyo3::exceptions::PyTypeError::new_err(format!(
                "deformation must be a csrbf.Deformation or csrbf.System, got {}",
                deformation
                    .get_type()
                    .name()
                    .map(|n| n.to_string())
                    .unwrap_or_default()
            ))
        })?;
        let p = arrays::points(points, "points")?;
        let view = p.view();
        let d = &d.get().inner;
        let inner = py.detach(|| match view {
            View::F32(v) => Binding::new(d, v),
            View::F64(v) => Binding::new(d, v),
        });
        Ok(PyBinding::of(inner, p.dtype()))
    }

    /// Makes the binding anew for the starts of `deformation` (a
    /// Deformation) and `points` ((N, 3), any N; results then have their
    /// dtype), reusing the cells' arrays: the old and new binding never
    /// take memory at once (at a million points a rebind takes about as
    /// long as a new binding, a fraction of one evaluation).
    ///
    /// >>> b.rebind(s.solve(targets), moved_vertices)
    fn rebind(
        &self,
        py: Python<'_>,
        deformation: &Bound<'_, PyDeformation>,
        points: &Bound<'_, PyAny>,
    ) -> PyResult<()> {
        let p = arrays::points(points, "points")?;
        let (view, dtype) = (p.view(), p.dtype());
        let d = &deformation.get().inner;
        py.detach(|| {
            let mut state = self.state.write().unwrap_or_else(|e| e.into_inner());
            match view {
                View::F32(v) => state.0.rebind(d, v),
                View::F64(v) => state.0.rebind(d, v),
            }
            state.1 = dtype;
        });
        Ok(())
    }

    /// D of `deformation` (fitted to the same starts) at every bound point:
    /// an (N, 3) array of the points' dtype, or `out` filled in place.
    #[pyo3(signature = (deformation, out = None))]
    fn displacements<'py>(
        &self,
        py: Python<'py>,
        deformation: &Bound<'py, PyDeformation>,
        out: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let ds = std::slice::from_ref(&deformation.get().inner);
        self.many(py, ds, &[self.len(), 3], out)
    }

    /// The displacements of K deformations at every bound point, a
    /// (K, N, 3) array of the points' dtype (or `out` filled in place).
    #[pyo3(signature = (deformations, out = None))]
    fn displacements_many<'py>(
        &self,
        py: Python<'py>,
        deformations: Vec<Bound<'py, PyDeformation>>,
        out: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let ds: Vec<Deformation> = deformations.iter().map(|d| d.get().inner.clone()).collect();
        self.many(py, &ds, &[ds.len(), self.len(), 3], out)
    }

    /// The number of bound points.
    fn __len__(&self) -> usize {
        self.len()
    }

    /// Bytes the binding holds (the points' copy, their order, the cells'
    /// candidates).
    #[getter]
    fn nbytes(&self) -> usize {
        self.read().0.bytes()
    }

    fn __repr__(&self) -> String {
        let state = self.read();
        format!("Binding({} points, {})", state.0.len(), state.1.name())
    }
}

impl PyBinding {
    fn of(binding: Binding, dtype: Dtype) -> PyBinding {
        PyBinding {
            state: RwLock::new((binding, dtype)),
        }
    }

    /// The binding, read (a panic while it was written leaves it whole: a
    /// rebind either finished or left the old binding).
    fn read(&self) -> std::sync::RwLockReadGuard<'_, (Binding, Dtype)> {
        self.state.read().unwrap_or_else(|e| e.into_inner())
    }

    fn len(&self) -> usize {
        self.read().0.len()
    }

    /// Displacements of `ds` into a new or given array of `shape`.
    fn many<'py>(
        &self,
        py: Python<'py>,
        ds: &[Deformation],
        shape: &[usize],
        out: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let state = self.read();
        let (b, dtype) = (&state.0, state.1);
        let out = match out {
            Some(o) => {
                arrays::check_out(&o, dtype, shape)?;
                o
            }
            None => arrays::zeros(py, dtype, shape),
        };
        match dtype {
            Dtype::F32 => {
                let mut w = out_f32(&out, shape.len())?;
                let o = vectors_mut::<f32>(&mut w);
                py.detach(|| b.displacements_many(ds, o))
            }
            Dtype::F64 => {
                let mut w = out_f64(&out, shape.len())?;
                let o = vectors_mut::<f64>(&mut w);
                py.detach(|| {
                    let mut tmp = vec![Vec3::ZERO; o.len()];
                    b.displacements_many(ds, &mut tmp)?;
                    o.par_iter_mut()
                        .zip(tmp)
                        .for_each(|(o, t)| *o = t.as_dvec3());
                    Ok(())
                })
            }
        }
        .map_err(|e: csrbf::Error| error(&e))?;
        Ok(out)
    }
}

/// A checked float32 output array of 2 or 3 dimensions, as writeable data.
fn out_f32<'py>(out: &Bound<'py, PyAny>, dims: usize) -> PyResult<Writable<'py, f32>> {
    writable(out, dims)
}

/// A checked float64 output array of 2 or 3 dimensions, as writeable data.
fn out_f64<'py>(out: &Bound<'py, PyAny>, dims: usize) -> PyResult<Writable<'py, f64>> {
    writable(out, dims)
}

/// The data of a checked output array, borrowed for writing.
pub(crate) enum Writable<'py, T: numpy::Element> {
    Two(numpy::PyReadwriteArray2<'py, T>),
    Three(numpy::PyReadwriteArray3<'py, T>),
}

impl<T: numpy::Element> std::ops::Deref for Writable<'_, T> {
    type Target = [T];
    fn deref(&self) -> &[T] {
        match self {
            Writable::Two(a) => a.as_slice().unwrap_or(&[]),
            Writable::Three(a) => a.as_slice().unwrap_or(&[]),
        }
    }
}

impl<T: numpy::Element> std::ops::DerefMut for Writable<'_, T> {
    fn deref_mut(&mut self) -> &mut [T] {
        match self {
            Writable::Two(a) => arrays::data_mut(a),
            Writable::Three(a) => arrays::data_mut(a),
        }
    }
}

fn writable<'py, T: numpy::Element>(
    out: &Bound<'py, PyAny>,
    dims: usize,
) -> PyResult<Writable<'py, T>> {
    Ok(if dims == 2 {
        Writable::Two(arrays::write::<T, numpy::Ix2>(out, "an input")?)
    } else {
        Writable::Three(arrays::write::<T, numpy::Ix3>(out, "an input")?)
    })
}

/// Deforms one point set by K target sets of the same starts, in one call on
/// all cores (dataset augmentation): the system is factored once, the K
/// solves run in parallel, the points are bound once and every variant is
/// the kernel sums alone.
///
/// Args:
///     points: (N, 3) points (a mesh's vertices).
///     starts: (M, 3) starts.
///     targets: (K, M, 3), K sets of destinations.
///     radius, kernel, polynomial, allow_large: as `csrbf.fit`.
///     phase: in [0, 1], applied to every variant.
///     out: a (K, N, 3) array of the points' dtype to fill in place.
///
/// Returns:
///     (K, N, 3) positions, points + phase * D_k(points), in the points'
///     dtype (displacements are computed in float32, as a Binding does).
///
/// >>> variants = csrbf.deform_many(vertices, starts, targets, radius=0.1)
#[pyfunction]
#[pyo3(signature = (points, starts, targets, radius, kernel = "c2", polynomial = "none", phase = 1.0, *, out = None, allow_large = false))]
#[allow(clippy::too_many_arguments)]
pub fn deform_many<'py>(
    py: Python<'py>,
    points: &Bound<'py, PyAny>,
    starts: &Bound<'py, PyAny>,
    targets: &Bound<'py, PyAny>,
    radius: f64,
    kernel: &str,
    polynomial: &str,
    phase: f64,
    out: Option<Bound<'py, PyAny>>,
    allow_large: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let options = options(radius, kernel, polynomial, allow_large)?;
    let p = arrays::points(points, "points")?;
    let s = vectors_f64(starts, "starts")?;
    let sets = arrays::target_sets(targets, "targets")?;
    check_sets(s.len(), &sets)?;
    let (k, n) = (sets.len(), p.len());
    let out = match out {
        Some(o) => {
            arrays::check_out(&o, p.dtype(), &[k, n, 3])?;
            o
        }
        None => arrays::zeros(py, p.dtype(), &[k, n, 3]),
    };
    let view = p.view();
    // The engine's batch: factored once, K solves, bound once
    // (`System::displacements_many`); here only the dtypes are placed.
    let run = |o: OutVariants<'_>| -> csrbf::Result<()> {
        csrbf::check_phase(phase)?;
        let sys = System::new(&s, options)?;
        match (o, view) {
            (OutVariants::F32(o), View::F32(rest)) => {
                sys.displacements_many(rest, &sets, o)?;
                place(o, rest, phase, |p, d, t| *p + d * t as f32)
            }
            (OutVariants::F64(o), View::F64(rest)) => {
                let mut d = vec![Vec3::ZERO; o.len()];
                sys.displacements_many(rest, &sets, &mut d)?;
                o.par_iter_mut().zip(d).for_each(|(o, d)| *o = d.as_dvec3());
                place(o, rest, phase, |p, d, t| *p + d * t)
            }
            _ => unreachable!("out has the points' dtype"),
        }
    };
    match p.dtype() {
        Dtype::F32 => {
            let mut w = out_f32(&out, 3)?;
            let o = vectors_mut::<f32>(&mut w);
            py.detach(|| run(OutVariants::F32(o)))
        }
        Dtype::F64 => {
            let mut w = out_f64(&out, 3)?;
            let o = vectors_mut::<f64>(&mut w);
            py.detach(|| run(OutVariants::F64(o)))
        }
    }
    .map_err(|e| error(&e))?;
    Ok(out)
}

enum OutVariants<'a> {
    F32(&'a mut [Vec3]),
    F64(&'a mut [DVec3]),
}

/// Turns displacements (variant after variant) into positions at `phase`.
fn place<V: Copy + Send + Sync>(
    out: &mut [V],
    rest: &[V],
    phase: f64,
    f: impl Fn(&V, V, f64) -> V + Sync,
) -> csrbf::Result<()> {
    if rest.is_empty() {
        return Ok(());
    }
    out.par_chunks_mut(rest.len()).for_each(|o| {
        for (o, r) in o.iter_mut().zip(rest) {
            *o = f(r, *o, phase);
        }
    });
    Ok(())
}

/// Adds `System`, `Binding` and `deform_many` to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PySystem>()?;
    m.add_class::<PyBinding>()?;
    m.add_function(wrap_pyfunction!(deform_many, m)?)?;
    Ok(())
}
