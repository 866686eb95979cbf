//! numpy arguments: any (N, 3) array-like of numbers in, arrays of the
//! caller's dtype out.
//!
//! float32 and float64 arrays in C order are read in place; views, other
//! numeric dtypes (taken as float64) and lists are converted once by numpy.
//! A wrong shape is a `ValueError` naming the argument and its shape,
//! non-numeric input a `TypeError`.

use numpy::{PyArray2, PyArray3, PyArrayMethods, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{IntoPyDict, PyTuple};

use crate::cast::{Triple, vectors};

/// A read-only (N, 3) array of points, float32 or float64, C order.
pub enum Points<'py> {
    /// float32 in.
    F32(PyReadonlyArray2<'py, f32>),
    /// float64 in (and every other numeric dtype).
    F64(PyReadonlyArray2<'py, f64>),
}

impl Points<'_> {
    /// Number of rows.
    pub fn len(&self) -> usize {
        match self {
            Points::F32(a) => a.shape()[0],
            Points::F64(a) => a.shape()[0],
        }
    }

    /// Whether there are no rows.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The points as vectors, whichever the dtype.
    pub fn view(&self) -> View<'_> {
        match self {
            Points::F32(a) => View::F32(vectors(slice(a))),
            Points::F64(a) => View::F64(vectors(slice(a))),
        }
    }

    /// The numpy dtype name of the points.
    pub fn dtype(&self) -> Dtype {
        match self {
            Points::F32(_) => Dtype::F32,
            Points::F64(_) => Dtype::F64,
        }
    }
}

/// Points borrowed as glam vectors.
#[derive(Clone, Copy)]
pub enum View<'a> {
    /// float32.
    F32(&'a [csrbf::glam::Vec3]),
    /// float64.
    F64(&'a [csrbf::glam::DVec3]),
}

/// float32 or float64.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dtype {
    /// float32.
    F32,
    /// float64.
    F64,
}

impl Dtype {
    /// numpy's name.
    pub fn name(self) -> &'static str {
        match self {
            Dtype::F32 => "float32",
            Dtype::F64 => "float64",
        }
    }
}

/// The data of a C-ordered array (the readers below only make those).
fn slice<'a, T: Triple + numpy::Element>(a: &'a PyReadonlyArray2<'_, T>) -> &'a [T] {
    // ascontiguousarray gave C order, so this cannot fail; an empty slice
    // stands in should it ever.
    a.as_slice().unwrap_or(&[])
}

/// The shape of an array as Python writes it: `(5, 2)`.
pub fn shape_text(a: &Bound<'_, PyAny>) -> String {
    a.getattr("shape")
        .and_then(|s| s.str().map(|s| s.to_string()))
        .unwrap_or_else(|_| "?".into())
}

/// `obj` as a numpy array (a list, tuple or anything numpy takes); a ragged
/// list is a `ValueError` naming `name`.
pub fn as_ndarray<'py>(obj: &Bound<'py, PyAny>, name: &str) -> PyResult<Bound<'py, PyAny>> {
    let py = obj.py();
    let np = py.import("numpy")?;
    if obj.is_instance(&np.getattr("ndarray")?)? {
        return Ok(obj.clone());
    }
    np.call_method1("asarray", (obj,)).map_err(|e| {
        if e.is_instance_of::<PyTypeError>(py) {
            PyTypeError::new_err(format!(
                "{name} must be an array of numbers: {}",
                e.value(py)
            ))
        } else {
            PyValueError::new_err(format!(
                "{name} must be an (N, 3) array of numbers: {}",
                e.value(py)
            ))
        }
    })
}

/// The dtype kind an array must be converted from: `Some(F32)`/`Some(F64)`
/// for float32/float64, `None` for other numbers (taken as float64); a
/// `TypeError` for what is not a number.
fn kind_of(arr: &Bound<'_, PyAny>, name: &str) -> PyResult<Option<Dtype>> {
    let dtype = arr.getattr("dtype")?;
    let kind: String = dtype.getattr("kind")?.extract()?;
    let size: usize = dtype.getattr("itemsize")?.extract()?;
    match (kind.as_str(), size) {
        ("f", 4) => Ok(Some(Dtype::F32)),
        ("f", 8) => Ok(Some(Dtype::F64)),
        ("f" | "i" | "u" | "b", _) => Ok(None),
        // Python objects: numbers only (numpy would take None as NaN and
        // "1.5" as 1.5).
        ("O", _) => {
            let real = arr.py().import("numbers")?.getattr("Real")?;
            for x in arr.call_method0("ravel")?.try_iter()? {
                let x = x?;
                if !x.is_instance(&real)? {
                    return Err(PyTypeError::new_err(format!(
                        "{name} must be an array of real numbers, got {}",
                        x.repr()?
                    )));
                }
            }
            Ok(None)
        }
        _ => Err(PyTypeError::new_err(format!(
            "{name} must be an array of real numbers, got dtype {}",
            dtype.str()?
        ))),
    }
}

/// `arr` in C order with this dtype (no copy when it already is).
fn contiguous<'py>(
    arr: &Bound<'py, PyAny>,
    dtype: Dtype,
    name: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let py = arr.py();
    let np = py.import("numpy")?;
    let kw = [("dtype", dtype.name())].into_py_dict(py)?;
    np.call_method("ascontiguousarray", (arr,), Some(&kw))
        .map_err(|e| {
            PyTypeError::new_err(format!(
                "{name} must be an array of real numbers: {}",
                e.value(py)
            ))
        })
}

/// Reads an (N, 3) array-like of numbers named `name`; float32 stays
/// float32, everything else becomes float64.
pub fn points<'py>(obj: &Bound<'py, PyAny>, name: &str) -> PyResult<Points<'py>> {
    let arr = as_ndarray(obj, name)?;
    let kind = kind_of(&arr, name)?;
    check_shape(&arr, name, &[None, Some(3)], "(N, 3)")?;
    let dtype = kind.unwrap_or(Dtype::F64);
    let arr = contiguous(&arr, dtype, name)?;
    Ok(match dtype {
        Dtype::F32 => Points::F32(arr.cast_into::<PyArray2<f32>>()?.readonly()),
        Dtype::F64 => Points::F64(arr.cast_into::<PyArray2<f64>>()?.readonly()),
    })
}

/// Reads an (N, 3) array-like as float64 (starts, destinations).
pub fn points_f64<'py>(
    obj: &Bound<'py, PyAny>,
    name: &str,
) -> PyResult<PyReadonlyArray2<'py, f64>> {
    let arr = as_ndarray(obj, name)?;
    kind_of(&arr, name)?;
    check_shape(&arr, name, &[None, Some(3)], "(N, 3)")?;
    Ok(contiguous(&arr, Dtype::F64, name)?
        .cast_into::<PyArray2<f64>>()?
        .readonly())
}

/// A (K, M, 3) array-like as float64, one row of K per target set.
pub fn target_sets<'py>(
    obj: &Bound<'py, PyAny>,
    name: &str,
) -> PyResult<Vec<Vec<csrbf::glam::DVec3>>> {
    let arr = as_ndarray(obj, name)?;
    kind_of(&arr, name)?;
    check_shape(&arr, name, &[None, None, Some(3)], "(K, M, 3)")?;
    let arr = contiguous(&arr, Dtype::F64, name)?.cast_into::<PyArray3<f64>>()?;
    let arr = arr.readonly();
    let data = arr
        .as_slice()
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    let m = arr.shape()[1];
    let v = vectors(data);
    Ok(if m == 0 {
        vec![Vec::new(); arr.shape()[0]]
    } else {
        v.chunks(m).map(<[_]>::to_vec).collect()
    })
}

/// Checks `arr`'s shape against `want` (None: any length), naming the
/// argument and the shape it has.
pub fn check_shape(
    arr: &Bound<'_, PyAny>,
    name: &str,
    want: &[Option<usize>],
    text: &str,
) -> PyResult<()> {
    let shape: Vec<usize> = arr.getattr("shape")?.extract()?;
    let ok = shape.len() == want.len()
        && shape
            .iter()
            .zip(want)
            .all(|(s, w)| w.is_none_or(|w| *s == w));
    if ok {
        Ok(())
    } else {
        Err(PyValueError::new_err(format!(
            "{name} must be an {text} array, got shape {}",
            shape_text(arr)
        )))
    }
}

/// A new (N, 3) array of this dtype, zeros.
pub fn zeros<'py>(py: Python<'py>, dtype: Dtype, shape: &[usize]) -> Bound<'py, PyAny> {
    match (dtype, shape) {
        (Dtype::F32, [n, m]) => PyArray2::<f32>::zeros(py, [*n, *m], false).into_any(),
        (Dtype::F64, [n, m]) => PyArray2::<f64>::zeros(py, [*n, *m], false).into_any(),
        (Dtype::F32, [k, n, m]) => PyArray3::<f32>::zeros(py, [*k, *n, *m], false).into_any(),
        (Dtype::F64, [k, n, m]) => PyArray3::<f64>::zeros(py, [*k, *n, *m], false).into_any(),
        _ => unreachable!("2 or 3 dimensions"),
    }
}

/// An output array given as `out=`: a writeable, C-ordered array of this
/// dtype and shape, else a `TypeError` (dtype) or `ValueError` (shape,
/// order) naming `out`.
pub fn check_out(out: &Bound<'_, PyAny>, dtype: Dtype, shape: &[usize]) -> PyResult<()> {
    let np = out.py().import("numpy")?;
    if !out.is_instance(&np.getattr("ndarray")?)? {
        return Err(PyTypeError::new_err(format!(
            "out must be a numpy array, got {}",
            out.get_type().name()?
        )));
    }
    let got: String = out.getattr("dtype")?.str()?.to_string();
    if got != dtype.name() {
        return Err(PyTypeError::new_err(format!(
            "out must be a {} array (the dtype of the result), got dtype {got}",
            dtype.name()
        )));
    }
    let have: Vec<usize> = out.getattr("shape")?.extract()?;
    if have != shape {
        let want = PyTuple::new(out.py(), shape)?.str()?.to_string();
        return Err(PyValueError::new_err(format!(
            "out must have shape {want}, got shape {}",
            shape_text(out)
        )));
    }
    let flags = out.getattr("flags")?;
    let c: bool = flags.getattr("c_contiguous")?.extract()?;
    let w: bool = flags.getattr("writeable")?.extract()?;
    if !c || !w {
        return Err(PyValueError::new_err(
            "out must be a writeable array in C order (np.ascontiguousarray gives one)",
        ));
    }
    Ok(())
}

/// Borrows a checked `out=` array of scalar `T` for writing; an overlap with
/// an array borrowed for reading is a `ValueError`.
pub fn write<'py, T: numpy::Element, D: numpy::ndarray::Dimension>(
    out: &Bound<'py, PyAny>,
    what: &str,
) -> PyResult<numpy::PyReadwriteArray<'py, T, D>> {
    let arr = out.cast::<numpy::PyArray<T, D>>()?;
    arr.try_readwrite().map_err(|_| {
        PyValueError::new_err(format!(
            "out shares memory with {what}; give a separate array{}",
            if what == "points" {
                " (deform(points, out=points) moves points in place)"
            } else {
                ""
            }
        ))
    })
}

/// The mutable data of a borrowed C-ordered array.
pub fn data_mut<'a, T: numpy::Element, D: numpy::ndarray::Dimension>(
    a: &'a mut numpy::PyReadwriteArray<'_, T, D>,
) -> &'a mut [T] {
    // check_out (or zeros) made sure of C order, so this cannot fail.
    a.as_slice_mut().unwrap_or(&mut [])
}
