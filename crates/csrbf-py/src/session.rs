//! `csrbf.Session`: the edit layer's live session from Python (Blender's
//! Live goes through it): each layer's factored system and binding kept, a
//! destination move a solve and the sums.

use csrbf_mesh::Mesh;
use numpy::PyArray2;
use pyo3::prelude::*;

use crate::error;
use crate::mesh::{PyReport, checks, control_file, mesh_arg, remedy_search, vec3_rows};

/// A control file deformed live on one mesh: give it the file again after
/// each change (a path, or a dict in the file's form), and it does only
/// the work the change needs: a moved destination costs one solve and the
/// kernel sums through each layer's binding; a moved start, a new radius or
/// kernel refits that layer. Handles, regions, phases and sweeps are
/// applied as `deform_mesh` applies them, to the same positions.
///
/// >>> s = csrbf.Session(mesh)
/// >>> report = s.update({"radius": 0.3, "controls": [...]})   # checked
/// >>> s.update_positions(moved_controls)                      # a drag step
/// >>> s.factorisations                                        # still 1
#[pyclass(name = "Session", module = "csrbf")]
pub struct PySession {
    mesh: Mesh,
    inner: csrbf_edit::Session,
    allow_large: bool,
}

#[pymethods]
impl PySession {
    /// A session on `mesh` (a csrbf.Mesh or a path to a mesh file), at rest;
    /// `allow_large` fits even systems estimated past the 4 GiB limit.
    #[new]
    #[pyo3(signature = (mesh, *, allow_large = false))]
    fn new(py: Python<'_>, mesh: &Bound<'_, PyAny>, allow_large: bool) -> PyResult<PySession> {
        let mesh = mesh_arg(py, mesh)?;
        let inner = csrbf_edit::Session::new(&mesh);
        Ok(PySession {
            mesh,
            inner,
            allow_large,
        })
    }

    /// Deforms the mesh by `controls` at `phase`, checks the result as
    /// `deform_mesh` does and returns the Report (remedies searched as
    /// `remedies=` says when a face folds). On error (csrbf.Error naming
    /// the layer) the previous positions stay.
    #[pyo3(signature = (controls, phase = 1.0, *, stretch_limit = csrbf::STRETCH_LIMIT, self_intersections = None, remedies = "bounded"))]
    fn update(
        &mut self,
        py: Python<'_>,
        controls: &Bound<'_, PyAny>,
        phase: f64,
        stretch_limit: f64,
        self_intersections: Option<bool>,
        remedies: &str,
    ) -> PyResult<PyReport> {
        let checks = checks(stretch_limit, self_intersections)?;
        let search = remedy_search(remedies)?;
        let file = self.file(py, controls)?;
        let (mesh, inner) = (&self.mesh, &mut self.inner);
        let report = py
            .detach(|| inner.update(mesh, &file, phase, &checks, search).cloned())
            .map_err(|e| error(&e))?;
        Ok(PyReport { inner: report })
    }

    /// Deforms the mesh by `controls` at `phase` without the checks (a
    /// drag's steps; call `update` on release) and returns the positions,
    /// an (N, 3) float32 array.
    #[pyo3(signature = (controls, phase = 1.0))]
    fn update_positions<'py>(
        &mut self,
        py: Python<'py>,
        controls: &Bound<'py, PyAny>,
        phase: f64,
    ) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let file = self.file(py, controls)?;
        let (mesh, inner) = (&self.mesh, &mut self.inner);
        py.detach(|| inner.update_positions(mesh, &file, phase).map(|_| ()))
            .map_err(|e| error(&e))?;
        Ok(vec3_rows(py, self.inner.positions()))
    }

    /// The deformed positions of the last update (the rest ones before
    /// it), an (N, 3) float32 array (a copy).
    #[getter]
    fn vertices<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f32>> {
        vec3_rows(py, self.inner.positions())
    }

    /// The last `update`'s Report, or None after `update_positions`.
    #[getter]
    fn report(&self) -> Option<PyReport> {
        self.inner.report().map(|r| PyReport { inner: r.clone() })
    }

    /// How many systems were factored so far (moving destinations adds
    /// none).
    #[getter]
    fn factorisations(&self) -> usize {
        self.inner.factorisations()
    }

    /// How many control vectors the last update used (a handle's included).
    #[getter]
    fn controls(&self) -> usize {
        self.inner.controls()
    }

    fn __repr__(&self) -> String {
        format!(
            "Session({} vertices, {} control vectors, {} factorisation(s))",
            self.mesh.positions.len(),
            self.inner.controls(),
            self.inner.factorisations()
        )
    }
}

impl PySession {
    /// The control file, with the memory limit lifted when the session
    /// allows large systems.
    fn file(
        &self,
        py: Python<'_>,
        controls: &Bound<'_, PyAny>,
    ) -> PyResult<csrbf_edit::ControlFile> {
        let mut file = control_file(py, controls)?;
        if self.allow_large {
            for spec in &mut file.deformations {
                spec.options = spec.options.with_memory_limit(u64::MAX);
            }
        }
        Ok(file)
    }
}

/// Adds `Session` to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PySession>()
}
