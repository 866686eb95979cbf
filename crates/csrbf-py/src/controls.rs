//! `csrbf.control_file`: a control file's dict made by the edit layer (its
//! one writer), so a front end (Blender's panel) builds none by hand.

use csrbf_edit::controls::{ControlFile, ControlSpec, parse_region};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use crate::deformation::{check_lengths, options, vectors_f64};
use crate::mesh::json_value;

/// A control file of one deformation, as a dict in the file's form (what
/// `deform_mesh`, `Session` and `csrbf deform` read), written by the edit
/// layer and checked as a file is: every problem named by its JSON path.
///
/// Args:
///     starts: (M, 3) start points of the control vectors.
///     targets: (M, 3) destinations, one per start.
///     radius: radius of support R.
///     kernel: "c0", "c2" (default), "c4" or "c6".
///     polynomial: "none" (default) or "linear".
///     region: where it acts, in the file's form ({"group": name},
///         {"vertices": [...]}, {"sphere": {...}}, {"box": {...}},
///         {"connected": {...}}, with "falloff" beside), or None (the whole
///         mesh).
///     phase: the deformation's own phase, in [0, 1].
///     sweep: a fold-free sweep instead of the single map.
///     name: a name for people.
///
/// >>> spec = csrbf.control_file(starts, targets, 0.3, region={"group": "lips"})
/// >>> out, report = csrbf.deform_mesh(mesh, spec)
#[pyfunction]
#[pyo3(signature = (starts, targets, radius, *, kernel = "c2", polynomial = "none", region = None, phase = 1.0, sweep = false, name = None))]
#[allow(clippy::too_many_arguments)] // each is a keyword of the Python function
pub fn control_file<'py>(
    py: Python<'py>,
    starts: &Bound<'py, PyAny>,
    targets: &Bound<'py, PyAny>,
    radius: f64,
    kernel: &str,
    polynomial: &str,
    region: Option<&Bound<'py, PyAny>>,
    phase: f64,
    sweep: bool,
    name: Option<String>,
) -> PyResult<Bound<'py, PyAny>> {
    let s = vectors_f64(starts, "starts")?;
    let t = vectors_f64(targets, "targets")?;
    check_lengths(s.len(), t.len())?;
    let mut spec = ControlSpec::new(s, t, options(radius, kernel, polynomial, false)?);
    if let Some(r) = region {
        let text: String = py.import("json")?.call_method1("dumps", (r,))?.extract()?;
        let value: serde_json::Value = serde_json::from_str(&text)
            .map_err(|e| PyValueError::new_err(format!("region: {e}")))?;
        spec.region =
            parse_region(&value, "region").map_err(|e| crate::Error::new_err(e.to_string()))?;
    }
    spec.phase = phase;
    spec.sweep = sweep.then(csrbf::SweepOptions::default);
    spec.name = name;
    let value = ControlFile::new(vec![spec], csrbf::Combine::Chain).to_json();
    // Read back as any file is: a radius, a phase or a point the reader
    // refuses is refused here, by its JSON path.
    ControlFile::parse(&value.to_string())
        .map_err(|e| crate::Error::new_err(format!("controls: {e}")))?;
    json_value(py, &value)
}

/// Adds `control_file` to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(control_file, m)?)
}
