//! `csrbf.fit` and `csrbf.Deformation`: the fitted map, evaluated and applied
//! anywhere, saved as the CLI's `.csrbf`, pickled through the same bytes.

use std::path::PathBuf;

use csrbf::glam::{DVec3, Vec3};
use csrbf::{Deformation, FitOptions, Kernel, Polynomial};
use numpy::{PyArray2, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyType};

use crate::arrays::{self, Dtype, View};
use crate::cast::{vectors, vectors_mut};
use crate::error;

/// A fitted deformation D: x -> x + D(x), from control vectors (start ->
/// destination) and a radius of support R.
///
/// Make one with `csrbf.fit(starts, targets, radius)`, `System.solve` or
/// `Deformation.load`. It is immutable, thread-safe and picklable (through
/// its `.csrbf` bytes), so it can be shipped to multiprocessing, Dask or
/// Ray workers.
///
/// >>> d = csrbf.fit([[0, 0, 0]], [[0, 0.1, 0]], radius=1.0)
/// >>> d.displacements([[0, 0, 0], [5, 5, 5]])
/// array([[0. , 0.1, 0. ],
///        [0. , 0. , 0. ]])
#[pyclass(name = "Deformation", module = "csrbf", frozen)]
pub struct PyDeformation {
    pub(crate) inner: Deformation,
}

/// Parses a kernel name (`c0`, `c2`, `c4`, `c6`).
pub(crate) fn kernel(name: &str) -> PyResult<Kernel> {
    name.parse().map_err(|e: csrbf::NameError| error(&e))
}

/// Parses a polynomial name (`none`, `linear`).
pub(crate) fn polynomial(name: &str) -> PyResult<Polynomial> {
    name.parse().map_err(|e: csrbf::NameError| error(&e))
}

/// Fit options from the Python arguments; `allow_large` lifts the memory limit.
pub(crate) fn options(
    radius: f64,
    kernel: &str,
    polynomial: &str,
    allow_large: bool,
) -> PyResult<FitOptions> {
    let o = FitOptions::new(radius)
        .with_kernel(self::kernel(kernel)?)
        .with_polynomial(self::polynomial(polynomial)?);
    Ok(if allow_large {
        o.with_memory_limit(u64::MAX)
    } else {
        o
    })
}

/// Starts and destinations as float64 vectors, of equal lengths.
pub(crate) fn vectors_f64(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Vec<DVec3>> {
    let a = arrays::points_f64(obj, name)?;
    Ok(vectors(a.as_slice().unwrap_or(&[])).to_vec())
}

/// Fits the deformation that carries every start to its destination.
///
/// Args:
///     starts: (M, 3) start points of the control vectors.
///     targets: (M, 3) destinations, one per start.
///     radius: radius of support R, in the units of the points: a start
///         moves only what lies closer than R. Start from 5-15 % of the
///         model's bounding-box diagonal for local edits, 30 % and more for
///         broad bends. There is no default.
///     kernel: Wendland function, "c0", "c2" (default), "c4" or "c6".
///     polynomial: "none" (default: exactly zero displacement farther than R
///         from every start) or "linear" (adds an affine part: reproduces any
///         affine map, but a local edit then moves the whole model).
///     allow_large: fit even a system estimated past the 4 GiB memory limit.
///
/// Returns:
///     A Deformation.
///
/// Raises:
///     csrbf.Error: what the engine refused (a NaN coordinate, duplicate
///         starts, radius <= 0, no controls), with the control's index.
///     ValueError: an array of the wrong shape, or lengths that differ.
///
/// >>> d = csrbf.fit(starts, targets, radius=0.3)
#[pyfunction]
#[pyo3(signature = (starts, targets, radius, kernel = "c2", polynomial = "none", *, allow_large = false))]
pub fn fit(
    py: Python<'_>,
    starts: &Bound<'_, PyAny>,
    targets: &Bound<'_, PyAny>,
    radius: f64,
    kernel: &str,
    polynomial: &str,
    allow_large: bool,
) -> PyResult<PyDeformation> {
    let options = options(radius, kernel, polynomial, allow_large)?;
    let s = vectors_f64(starts, "starts")?;
    let t = vectors_f64(targets, "targets")?;
    check_lengths(s.len(), t.len())?;
    let d = py
        .detach(|| Deformation::fit(&s, &t, options))
        .map_err(|e| error(&e))?;
    Ok(PyDeformation { inner: d })
}

/// starts and targets must pair up.
pub(crate) fn check_lengths(starts: usize, targets: usize) -> PyResult<()> {
    if starts == targets {
        Ok(())
    } else {
        Err(pyo3::exceptions::PyValueError::new_err(format!(
            "targets must have one row per start: starts has {starts} rows, targets {targets}"
        )))
    }
}

/// D at `points` into `out`, whichever the dtypes (the caller made them
/// equal). float32 points go through the engine's f32 lanes
/// (`Deformation::displacements_f32`, what `csrbf bench` and a `Binding`
/// run): their sums agree with the f64 evaluation to about 1e-7 of the sum
/// of |alpha| within R of a point; float64 points keep f64.
fn displacements_into(
    d: &Deformation,
    points: View<'_>,
    out: &mut OutData<'_>,
) -> csrbf::Result<()> {
    match (points, out) {
        (View::F32(p), OutData::F32(o)) => d.displacements_f32_into(p, o),
        (View::F64(p), OutData::F64(o)) => d.displacements_into(p, o),
        (View::F64(p), OutData::F32(o)) => rounded(o, |wide| d.displacements_into(p, wide)),
        (View::F32(p), OutData::F64(o)) => d.displacements_into(p, o),
    }
}

/// D evaluated in f64 (by `fill`) and rounded once into `out` (float64
/// points with a float32 output).
fn rounded(
    out: &mut [Vec3],
    fill: impl FnOnce(&mut [DVec3]) -> csrbf::Result<()>,
) -> csrbf::Result<()> {
    let mut wide = vec![DVec3::ZERO; out.len()];
    fill(&mut wide)?;
    for (o, w) in out.iter_mut().zip(&wide) {
        *o = w.as_vec3();
    }
    Ok(())
}

/// An output buffer seen as vectors.
pub(crate) enum OutData<'a> {
    F32(&'a mut [Vec3]),
    F64(&'a mut [DVec3]),
}

/// Runs `f` on the data of `out` (a checked float32 or float64 array of this
/// dtype), borrowed for writing.
pub(crate) fn with_out<R>(
    out: &Bound<'_, PyAny>,
    dtype: Dtype,
    clash: &str,
    f: impl FnOnce(OutData<'_>) -> R,
) -> PyResult<R> {
    Ok(match dtype {
        Dtype::F32 => {
            let mut w = arrays::write::<f32, numpy::Ix2>(out, clash)?;
            f(OutData::F32(vectors_mut(arrays::data_mut(&mut w))))
        }
        Dtype::F64 => {
            let mut w = arrays::write::<f64, numpy::Ix2>(out, clash)?;
            f(OutData::F64(vectors_mut(arrays::data_mut(&mut w))))
        }
    })
}

/// Whether `a` and `b` are the same numpy array object.
fn same(a: &Bound<'_, PyAny>, b: &Bound<'_, PyAny>) -> bool {
    a.is(b)
}

#[pymethods]
impl PyDeformation {
    /// D(x) at every point: an (N, 3) array of the points' dtype (float32
    /// stays float32, float64 and other numbers give float64).
    ///
    /// Args:
    ///     points: (N, 3) array-like; views and lists are accepted (copied
    ///         once when not C-ordered float32/float64).
    ///     out: an (N, 3) array of that dtype, C-ordered, filled in place
    ///         and returned (not the points themselves).
    ///
    /// A point with a NaN or infinite coordinate gets a NaN displacement
    /// (the others are unaffected); points farther than R from every start
    /// get zero (with polynomial "none").
    #[pyo3(signature = (points, out = None))]
    fn displacements<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
        out: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let p = arrays::points(points, "points")?;
        let out = match out {
            Some(o) => {
                arrays::check_out(&o, p.dtype(), &[p.len(), 3])?;
                o
            }
            None => arrays::zeros(py, p.dtype(), &[p.len(), 3]),
        };
        let view = p.view();
        let d = &self.inner;
        with_out(&out, p.dtype(), "points", |o| {
            let mut o = o;
            py.detach(|| displacements_into(d, view, &mut o))
        })?
        .map_err(|e| error(&e))?;
        Ok(out)
    }

    /// The points moved to `phase`: points + phase * D(points), an (N, 3)
    /// array of the points' dtype. A point with a NaN or infinite
    /// coordinate comes out NaN (no error: `deform_mesh` refuses such a
    /// mesh instead).
    ///
    /// Args:
    ///     points: (N, 3) array-like.
    ///     phase: in [0, 1]: 0 the rest shape, 1 the full deformation.
    ///     out: where to write; may be `points` itself (a C-ordered float32
    ///         or float64 array) to move the points in place.
    ///
    /// >>> d.deform(vertices, phase=0.5, out=vertices)   # in place
    #[pyo3(signature = (points, phase = 1.0, out = None))]
    fn deform<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
        phase: f64,
        out: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let d = &self.inner;
        let target = match out {
            Some(o) if same(&o, points) => {
                // In place: the points are the output.
                let dtype = match o.cast::<PyArray2<f32>>() {
                    Ok(_) => Dtype::F32,
                    Err(_) => Dtype::F64,
                };
                let n = o
                    .getattr("shape")
                    .ok()
                    .and_then(|s| s.get_item(0).ok()?.extract().ok())
                    .unwrap_or(0);
                arrays::check_out(&o, dtype, &[n, 3]).map_err(|e| in_place_hint(py, e))?;
                o
            }
            Some(o) => {
                let p = arrays::points(points, "points")?;
                arrays::check_out(&o, p.dtype(), &[p.len(), 3])?;
                let view = p.view();
                with_out(&o, p.dtype(), "points", |out| copy_into(view, out))?;
                o
            }
            None => {
                let p = arrays::points(points, "points")?;
                let o = arrays::zeros(py, p.dtype(), &[p.len(), 3]);
                let view = p.view();
                with_out(&o, p.dtype(), "points", |out| copy_into(view, out))?;
                o
            }
        };
        let dtype = if target.cast::<PyArray2<f32>>().is_ok() {
            Dtype::F32
        } else {
            Dtype::F64
        };
        with_out(&target, dtype, "points", |o| {
            py.detach(|| match o {
                OutData::F32(p) => d.deform_in_place(p, phase),
                OutData::F64(p) => d.deform_in_place(p, phase),
            })
        })?
        .map_err(|e| error(&e))?;
        Ok(target)
    }

    /// D at one point, as a tuple (dx, dy, dz).
    fn displacement_at(&self, point: (f64, f64, f64)) -> (f64, f64, f64) {
        let v = self
            .inner
            .displacement_at(DVec3::new(point.0, point.1, point.2));
        (v.x, v.y, v.z)
    }

    /// Saves the deformation as a `.csrbf` file (the CLI's format: `csrbf
    /// apply --deformation PATH` replays it), written whole or not at all.
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        let bytes = self.inner.to_bytes();
        py.detach(|| csrbf_mesh::write_atomic(&path, &bytes))
            .map_err(|e| error(&e))
    }

    /// Loads a `.csrbf` file holding one deformation (as `save` or `csrbf
    /// fit` writes for a control file of one deformation without a region).
    #[classmethod]
    fn load(_cls: &Bound<'_, PyType>, py: Python<'_>, path: PathBuf) -> PyResult<PyDeformation> {
        let bytes = py
            .detach(|| std::fs::read(&path))
            .map_err(|e| crate::Error::new_err(format!("{}: {e}", path.display())))?;
        let d = Deformation::from_bytes(&bytes).map_err(|e| {
            crate::Error::new_err(format!("{}: {}", path.display(), crate::chain(&e)))
        })?;
        Ok(PyDeformation { inner: d })
    }

    /// The `.csrbf` bytes of this deformation.
    fn to_bytes<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        PyBytes::new(py, &self.inner.to_bytes())
    }

    /// The deformation of `.csrbf` bytes (see `to_bytes`).
    #[classmethod]
    fn from_bytes(_cls: &Bound<'_, PyType>, data: &[u8]) -> PyResult<PyDeformation> {
        let d = Deformation::from_bytes(data).map_err(|e| error(&e))?;
        Ok(PyDeformation { inner: d })
    }

    /// Pickling goes through the `.csrbf` bytes (bit-exact).
    fn __reduce__<'py>(
        slf: &Bound<'py, Self>,
    ) -> PyResult<(Bound<'py, PyAny>, (Bound<'py, PyBytes>,))> {
        let py = slf.py();
        let ctor = slf.get_type().getattr("from_bytes")?;
        Ok((ctor, (PyBytes::new(py, &slf.get().inner.to_bytes()),)))
    }

    /// The kernel's name: "c0", "c2", "c4" or "c6".
    #[getter]
    fn kernel(&self) -> &'static str {
        self.inner.kernel().name()
    }

    /// The radius of support R.
    #[getter]
    fn radius(&self) -> f64 {
        self.inner.radius()
    }

    /// The polynomial term: "none" or "linear".
    #[getter]
    fn polynomial(&self) -> &'static str {
        self.inner.polynomial().name()
    }

    /// The indices of the starts farther than R from every one of `points`
    /// ((N, 3)): they move none of them. A list of int.
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
    fn starts<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        rows(py, self.inner.starts())
    }

    /// The coefficients alpha of the kernels, an (M, 3) float64 array.
    #[getter]
    fn coefficients<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        rows(py, self.inner.coefficients())
    }

    /// The number of control vectors.
    fn __len__(&self) -> usize {
        self.inner.starts().len()
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other
            .cast::<PyDeformation>()
            .is_ok_and(|o| o.get().inner == self.inner)
    }

    fn __repr__(&self) -> String {
        describe(&self.inner)
    }
}

/// `Deformation(c2, R=0.3, 92 controls)`, "linear" added when it is.
fn describe(d: &Deformation) -> String {
    let n = d.starts().len();
    format!(
        "Deformation({}, R={:?}, {n} control{}{})",
        d.kernel().name(),
        d.radius(),
        if n == 1 { "" } else { "s" },
        if d.polynomial() == Polynomial::Linear {
            ", linear"
        } else {
            ""
        },
    )
}

/// An (M, 3) float64 array of vectors (a copy).
pub(crate) fn rows<'py>(py: Python<'py>, v: &[DVec3]) -> Bound<'py, PyArray2<f64>> {
    let a = PyArray2::<f64>::zeros(py, [v.len(), 3], false);
    let mut w = a.readwrite();
    vectors_mut(arrays::data_mut(&mut w)).copy_from_slice(v);
    drop(w);
    a
}

/// Copies points into an output buffer of the same dtype.
fn copy_into(p: View<'_>, out: OutData<'_>) {
    match (p, out) {
        (View::F32(p), OutData::F32(o)) => o.copy_from_slice(p),
        (View::F64(p), OutData::F64(o)) => o.copy_from_slice(p),
        (View::F32(p), OutData::F64(o)) => o.iter_mut().zip(p).for_each(|(o, p)| *o = p.as_dvec3()),
        (View::F64(p), OutData::F32(o)) => o.iter_mut().zip(p).for_each(|(o, p)| *o = p.as_vec3()),
    }
}

/// The error of an `out=points` that cannot be written in place, with how to.
fn in_place_hint(py: Python<'_>, e: PyErr) -> PyErr {
    let text = e.value(py).to_string();
    let kind = e.get_type(py);
    let msg = format!(
        "{text} (deform in place needs points to be a float32 or float64 (N, 3) array in C order)"
    );
    if kind.is(py.get_type::<pyo3::exceptions::PyTypeError>()) {
        pyo3::exceptions::PyTypeError::new_err(msg)
    } else {
        pyo3::exceptions::PyValueError::new_err(msg)
    }
}

/// Adds `fit` and `Deformation` to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyDeformation>()?;
    m.add_function(wrap_pyfunction!(fit, m)?)?;
    Ok(())
}
