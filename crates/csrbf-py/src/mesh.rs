//! `csrbf.Mesh`, `read_mesh`, `write_mesh` and `deform_mesh`: the CLI's mesh
//! formats and control files, from Python.

use std::path::PathBuf;

use csrbf_edit::controls::ControlFile;
use csrbf_mesh::{Faces, Mesh};
use numpy::{PyArray1, PyArray2, PyArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};

use crate::arrays;
use crate::cast::vectors_mut;
use crate::error;

/// A polygon mesh: vertices (float32), polygon faces, and what its file
/// carried (named parts, normals, UVs, colours, materials), kept when it is
/// written again.
///
/// >>> mesh = csrbf.read_mesh("head.off")
/// >>> mesh.vertices.shape, mesh.triangles.shape
/// ((1487, 3), (2918, 3))
/// >>> csrbf.Mesh(vertices, triangles)          # from arrays
#[pyclass(name = "Mesh", module = "csrbf")]
#[derive(Clone)]
pub struct PyMesh {
    pub(crate) inner: Mesh,
}

#[pymethods]
impl PyMesh {
    /// A mesh from arrays.
    ///
    /// Args:
    ///     vertices: (N, 3) positions (stored as float32).
    ///     triangles: (M, 3) vertex indices, or None.
    ///     faces: instead of triangles, a sequence of polygons (each a
    ///         sequence of 3 or more vertex indices), e.g. quads.
    #[new]
    #[pyo3(signature = (vertices, triangles = None, *, faces = None))]
    fn new(
        vertices: &Bound<'_, PyAny>,
        triangles: Option<&Bound<'_, PyAny>>,
        faces: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<PyMesh> {
        let positions = positions(vertices, "vertices")?;
        let n = positions.len();
        let mut f = Faces::new();
        match (triangles, faces) {
            (Some(_), Some(_)) => {
                return Err(PyValueError::new_err("give triangles or faces, not both"));
            }
            (Some(t), None) => {
                let t = indices(t, "triangles", n)?;
                for (i, tri) in t.chunks(3).enumerate() {
                    check_corners(tri, n, "triangles", i)?;
                    f.push(tri);
                }
            }
            (None, Some(faces)) => {
                for (i, face) in faces.try_iter()?.enumerate() {
                    let face: Vec<i64> = face?.extract().map_err(|_| {
                        PyTypeError::new_err(format!(
                            "faces[{i}] must be a sequence of vertex indices"
                        ))
                    })?;
                    let corners = face
                        .iter()
                        .map(|&c| u32::try_from(c).map_err(|_| bad_index("faces", i, c, n)))
                        .collect::<PyResult<Vec<u32>>>()?;
                    if corners.len() < 3 {
                        return Err(PyValueError::new_err(format!(
                            "faces[{i}] has {} corners; a face needs at least 3",
                            corners.len()
                        )));
                    }
                    check_corners(&corners, n, "faces", i)?;
                    f.push(&corners);
                }
            }
            (None, None) => {}
        }
        Ok(PyMesh {
            inner: Mesh {
                positions,
                faces: f,
                ..Mesh::default()
            },
        })
    }

    /// The vertex positions, an (N, 3) float32 array (a copy). Assigning an
    /// (N, 3) array of the same N moves the vertices.
    #[getter]
    fn vertices<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f32>> {
        vec3_rows(py, &self.inner.positions)
    }

    #[setter]
    fn set_vertices(&mut self, vertices: &Bound<'_, PyAny>) -> PyResult<()> {
        let p = positions(vertices, "vertices")?;
        if p.len() != self.inner.positions.len() {
            return Err(PyValueError::new_err(format!(
                "vertices must keep the mesh's {} rows, got {}",
                self.inner.positions.len(),
                p.len()
            )));
        }
        self.inner.positions = p;
        Ok(())
    }

    /// The faces as triangles (polygons fanned), an (M, 3) uint32 array.
    #[getter]
    fn triangles<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<u32>> {
        let t = self.inner.faces.triangles();
        let a = PyArray2::<u32>::zeros(py, [t.len(), 3], false);
        {
            let mut w = a.readwrite();
            for (o, t) in arrays::data_mut(&mut w).chunks_mut(3).zip(&t) {
                o.copy_from_slice(t);
            }
        }
        a
    }

    /// The polygon faces, a list of lists of vertex indices.
    #[getter]
    fn faces<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        PyList::new(py, self.inner.faces.iter().map(<[u32]>::to_vec))
    }

    /// Named parts (groups, objects, materials): a dict of name -> the
    /// uint32 indices of the part's vertices.
    #[getter]
    fn parts<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for (name, v) in self.inner.part_table() {
            d.set_item(name, PyArray1::from_vec(py, v))?;
        }
        Ok(d)
    }

    /// Per-vertex normals, an (N, 3) float32 array, or None.
    #[getter]
    fn normals<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f32>>> {
        self.inner.normals.as_deref().map(|n| vec3_rows(py, n))
    }

    /// Per-vertex colours (linear RGBA in [0, 1]), an (N, 4) float32 array,
    /// or None.
    #[getter]
    fn colors<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyArray2<f32>>>> {
        self.inner
            .colors
            .as_ref()
            .map(|c| PyArray2::from_vec2(py, &c.iter().map(|c| c.to_vec()).collect::<Vec<_>>()))
            .transpose()
            .map_err(|e| PyValueError::new_err(e.to_string()))
    }

    /// Texture coordinates, one per vertex: an (N, 2) float32 array, or
    /// None when the mesh has none or its coordinates differ between the
    /// corners of a vertex (a UV seam: see `corner_uvs`).
    #[getter]
    fn uvs<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f32>>> {
        let m = &self.inner;
        let per_vertex = m.uvs.as_ref()?.per_vertex(&m.faces, m.positions.len())?;
        Some(vec2_rows(py, per_vertex.into_iter()))
    }

    /// Texture coordinates, one per face corner (the corners of `faces` in
    /// order, flattened): a (C, 2) float32 array, or None when the mesh has
    /// none. Unlike `uvs`, it keeps seams.
    #[getter]
    fn corner_uvs<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f32>>> {
        let m = &self.inner;
        let t = m.uvs.as_ref()?;
        Some(match &t.corners {
            Some(c) => vec2_rows(
                py,
                c.iter()
                    .map(|&k| t.values.get(k as usize).copied().unwrap_or_default()),
            ),
            None => vec2_rows(
                py,
                m.faces
                    .indices
                    .iter()
                    .map(|&v| t.values.get(v as usize).copied().unwrap_or_default()),
            ),
        })
    }

    /// The diagonal of the bounding box: the scale to choose a radius by
    /// (5-15 % of it for local edits).
    #[getter]
    fn diagonal(&self) -> f64 {
        let p = &self.inner.positions;
        if p.is_empty() {
            return 0.0;
        }
        let (lo, hi) = p
            .iter()
            .fold((p[0], p[0]), |(lo, hi), &v| (lo.min(v), hi.max(v)));
        (hi - lo).as_dvec3().length()
    }

    /// A deep copy.
    fn copy(&self) -> PyMesh {
        self.clone()
    }

    /// The number of vertices.
    fn __len__(&self) -> usize {
        self.inner.positions.len()
    }

    fn __repr__(&self) -> String {
        let m = &self.inner;
        let parts = m.part_table().len();
        format!(
            "Mesh({} vertices, {} faces{})",
            m.positions.len(),
            m.faces.len(),
            if parts > 0 {
                format!(", {parts} parts")
            } else {
                String::new()
            }
        )
    }
}

fn bad_index(what: &str, face: usize, corner: i64, n: usize) -> PyErr {
    PyValueError::new_err(format!(
        "{what}[{face}] refers to vertex {corner}, but vertices has {n} rows"
    ))
}

fn check_corners(corners: &[u32], n: usize, what: &str, face: usize) -> PyResult<()> {
    match corners.iter().find(|&&c| c as usize >= n) {
        Some(&c) => Err(bad_index(what, face, c as i64, n)),
        None => Ok(()),
    }
}

/// (N, 3) numbers as float32 vectors.
pub(crate) fn positions(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Vec<csrbf::glam::Vec3>> {
    Ok(match arrays::points(obj, name)?.view() {
        arrays::View::F32(v) => v.to_vec(),
        arrays::View::F64(v) => v.iter().map(|p| p.as_vec3()).collect(),
    })
}

/// (M, 3) non-negative integers (indices into `n` vertices: a negative one
/// is refused naming `n`).
fn indices(obj: &Bound<'_, PyAny>, name: &str, n: usize) -> PyResult<Vec<u32>> {
    let a = arrays::as_ndarray(obj, name)?;
    let kind: String = a.getattr("dtype")?.getattr("kind")?.extract()?;
    if kind != "i" && kind != "u" {
        return Err(PyTypeError::new_err(format!(
            "{name} must be an array of integers (vertex indices), got dtype {}",
            a.getattr("dtype")?.str()?
        )));
    }
    arrays::check_shape(&a, name, &[None, Some(3)], "(M, 3)")?;
    let np = obj.py().import("numpy")?;
    let a = np.call_method1("ascontiguousarray", (a, "int64"))?;
    let a = a.cast_into::<PyArray2<i64>>()?;
    let a = a.readonly();
    let corners = a.as_slice().unwrap_or(&[]);
    corners
        .iter()
        .enumerate()
        .map(|(i, &c)| u32::try_from(c).map_err(|_| bad_index(name, i / 3, c, n)))
        .collect()
}

/// An (N, 2) float32 array of texture coordinates (a copy).
fn vec2_rows<'py>(
    py: Python<'py>,
    v: impl ExactSizeIterator<Item = csrbf::glam::Vec2>,
) -> Bound<'py, PyArray2<f32>> {
    let a = PyArray2::<f32>::zeros(py, [v.len(), 2], false);
    {
        let mut w = a.readwrite();
        for (o, uv) in arrays::data_mut(&mut w).chunks_mut(2).zip(v) {
            o.copy_from_slice(&uv.to_array());
        }
    }
    a
}

/// An (N, 3) float32 array of vectors (a copy).
pub(crate) fn vec3_rows<'py>(
    py: Python<'py>,
    v: &[csrbf::glam::Vec3],
) -> Bound<'py, PyArray2<f32>> {
    let a = PyArray2::<f32>::zeros(py, [v.len(), 3], false);
    {
        let mut w = a.readwrite();
        vectors_mut(arrays::data_mut(&mut w)).copy_from_slice(v);
    }
    a
}

/// Reads a mesh file: OBJ (with its material library and textures), PLY,
/// STL, OFF, glTF (.gltf, .glb), by extension.
///
/// Raises csrbf.Error naming the file and line when it cannot be read;
/// warns (UserWarning) of what looked wrong without being an error (an OBJ's
/// material library or texture missing, a text file cut off) and of what
/// the file holds that a mesh does not keep (an OBJ's polylines and points,
/// a PLY's other elements and properties, an OFF's face colours).
///
/// A volume mesh (.vtk, .vtu, .msh) comes back as a VolumeMesh: nodes,
/// cells and zones.
#[pyfunction]
pub fn read_mesh(py: Python<'_>, path: PathBuf) -> PyResult<Py<PyAny>> {
    if csrbf_mesh::volume::VolumeFormat::is_volume_path(&path) {
        return Ok(Py::new(py, crate::volume::read(py, &path)?)?.into_any());
    }
    let loaded = py
        .detach(|| csrbf_mesh::load(&path))
        .map_err(|e| error(&e))?;
    for w in &loaded.warnings {
        warn(py, w)?;
    }
    Ok(Py::new(py, PyMesh { inner: loaded.mesh })?.into_any())
}

/// Writes a mesh file (a Mesh, or a VolumeMesh as .vtk, .vtu or .msh),
/// the format by extension, whole or not at all
/// (temporary files renamed). Warns (UserWarning) when the format cannot
/// keep everything (STL: no vertex order, parts, UVs or colours), and when
/// a file beside an OBJ (its material library, a texture) that csrbf did
/// not write is left alone; `force=True` replaces such files.
#[pyfunction]
#[pyo3(signature = (mesh, path, *, force = false))]
pub fn write_mesh(
    py: Python<'_>,
    mesh: &Bound<'_, PyAny>,
    path: PathBuf,
    force: bool,
) -> PyResult<()> {
    if let Ok(v) = mesh.cast::<crate::volume::PyVolumeMesh>() {
        if !csrbf_mesh::volume::VolumeFormat::is_volume_path(&path) {
            return Err(crate::Error::new_err(format!(
                "{}: a VolumeMesh is written as one of {} (its boundary surface: mesh.boundary())",
                path.display(),
                csrbf_mesh::volume::VolumeFormat::EXTENSIONS
            )));
        }
        return crate::volume::write(py, &v.borrow(), &path);
    }
    let mesh: PyRef<'_, PyMesh> = mesh.extract()?;
    let m = &mesh.inner;
    let format = csrbf_mesh::Format::from_path(&path).map_err(|e| error(&e))?;
    if let Some(lost) = format.loses(m) {
        warn(py, &format!("{}: {lost}", path.display()))?;
    }
    let options = csrbf_mesh::WriteOptions::default().with_force(force);
    let written = py
        .detach(|| csrbf_mesh::write_with(&path, m, &options))
        .map_err(|e| error(&e))?;
    for w in &written.warnings {
        warn(py, w)?;
    }
    Ok(())
}

pub(crate) fn warn(py: Python<'_>, text: &str) -> PyResult<()> {
    PyErr::warn(
        py,
        &py.get_type::<pyo3::exceptions::PyUserWarning>(),
        &std::ffi::CString::new(text)?,
        2,
    )
}

/// What `deform_mesh` did: the edit layer's one report, as `csrbf deform`
/// prints it (`to_dict()` is its `--json` form), remedies included.
#[pyclass(name = "Report", module = "csrbf", frozen)]
pub struct PyReport {
    pub(crate) inner: csrbf_edit::Report,
}

#[pymethods]
impl PyReport {
    /// Number of vertices.
    #[getter]
    fn vertices(&self) -> usize {
        self.inner.vertices
    }

    /// Vertices that moved (by more than 1e-6 of the rest diagonal).
    #[getter]
    fn moved(&self) -> usize {
        self.inner.diagnostics.moved
    }

    /// The largest move.
    #[getter]
    fn largest_move(&self) -> f64 {
        self.inner.diagnostics.largest_move
    }

    /// The vertex that moved most, or None.
    #[getter]
    fn largest_move_vertex(&self) -> Option<u32> {
        self.inner.diagnostics.largest_move_vertex
    }

    /// The phase (of the one asked for) at which the first face folds, or
    /// None when none does.
    #[getter]
    fn fold_phase(&self) -> Option<f64> {
        self.inner.fold_phase()
    }

    /// The largest stretch of a triangle: the largest singular value of the
    /// map from its rest shape to its deformed one, in its plane (1 when
    /// none grew).
    #[getter]
    fn largest_stretch(&self) -> f64 {
        self.inner.diagnostics.largest_stretch
    }

    /// The triangle stretched most, or None.
    #[getter]
    fn largest_stretch_face(&self) -> Option<u32> {
        self.inner.diagnostics.largest_stretch_face
    }

    /// The limit `stretched` was judged by (`stretch_limit=`).
    #[getter]
    fn stretch_limit(&self) -> f64 {
        self.inner.diagnostics.stretch_limit
    }

    /// What to worry about, one sentence each (past the fold-free bound,
    /// starts out of reach, empty regions, seams, a polynomial that moved
    /// the whole model).
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.inner.warnings()
    }

    /// A stable name for each warning, in the same order, to filter on:
    /// "empty_region", "past_fold_free_bound", "ill_conditioned",
    /// "starts_far_from_mesh",
    /// "support_crosses_region", "polynomial_leak", "flipped_faces",
    /// "inside_out", "stretched", "self_intersecting".
    #[getter]
    fn warning_kinds(&self) -> Vec<&'static str> {
        self.inner
            .diagnostics
            .warnings
            .iter()
            .map(|w| w.kind())
            .collect()
    }

    /// The controls each warning names (its first few, indices into the
    /// layer's control vectors), in the same order as `warnings`; None for
    /// a warning about faces or the whole map.
    #[getter]
    fn warning_controls(&self) -> Vec<Option<Vec<usize>>> {
        self.inner
            .diagnostics
            .warnings
            .iter()
            .map(|w| csrbf_edit::warning_controls(w).map(<[usize]>::to_vec))
            .collect()
    }

    /// When the edit folds: what would keep it from folding, as one
    /// sentence (a radius that folds no face, or a sweep, each with its
    /// cost), the line `csrbf deform` prints; "" otherwise.
    #[getter]
    fn advice(&self) -> String {
        self.inner.advice()
    }

    /// When the edit folds, the remedies as a dict (radius_scale,
    /// radius_ms, sweep_steps, sweep_ms, plain_ms, searched_ms, complete,
    /// advice), else None: `to_dict()["remedies"]`.
    #[getter]
    fn remedies<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_value(py, &self.inner.to_json()["remedies"])
    }

    /// Triangles the map turns inside out (det J <= 0 at their centroid;
    /// indices into `Mesh.triangles`), uint32: the folds.
    #[getter]
    fn inside_out<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<u32>> {
        PyArray1::from_slice(py, &self.inner.diagnostics.inside_out)
    }

    /// How many triangles are inside out.
    #[getter]
    fn inside_out_faces(&self) -> usize {
        self.inner.diagnostics.inside_out.len()
    }

    /// Triangles turned against their neighbours where the map does not
    /// fold (creases; indices into `Mesh.triangles`), uint32.
    #[getter]
    fn flipped<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<u32>> {
        PyArray1::from_slice(py, &self.inner.diagnostics.flipped)
    }

    /// How many triangles turned over.
    #[getter]
    fn flipped_faces(&self) -> usize {
        self.inner.diagnostics.flipped.len()
    }

    /// Triangles stretched more than `stretch_limit` (indices into
    /// `Mesh.triangles`), uint32.
    #[getter]
    fn stretched<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<u32>> {
        PyArray1::from_slice(py, &self.inner.diagnostics.stretched)
    }

    /// How many triangles are stretched more than `stretch_limit`.
    #[getter]
    fn stretched_faces(&self) -> usize {
        self.inner.diagnostics.stretched.len()
    }

    /// Pairs of triangles (indices into `Mesh.triangles`, one pair a row,
    /// uint32 of shape (n, 2)) that pass through each other in the deformed
    /// mesh but not at rest; None when not looked for (`self_intersections=`).
    #[getter]
    fn self_intersections<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<u32>>> {
        self.inner.diagnostics.self_intersections.as_ref().map(|p| {
            let a = PyArray2::<u32>::zeros(py, [p.len(), 2], false);
            {
                let mut w = a.readwrite();
                for (o, pair) in arrays::data_mut(&mut w).chunks_mut(2).zip(p) {
                    o.copy_from_slice(pair);
                }
            }
            a
        })
    }

    /// The report's one serialised form, as `csrbf deform --json` prints it
    /// (without the output's files): the figures, the warnings and their
    /// kinds, the remedies, the times.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_value(py, &self.inner.to_json())
    }

    fn __repr__(&self) -> String {
        let d = &self.inner.diagnostics;
        format!(
            "Report({} vertices, {} moved, largest move {:.6}{}, {} face(s) inside out{}, largest stretch {:.2}x, {} warning(s){})",
            self.inner.vertices,
            d.moved,
            d.largest_move,
            d.largest_move_vertex
                .map(|v| format!(" (vertex {v})"))
                .unwrap_or_default(),
            d.inside_out.len(),
            self.inner
                .fold_phase()
                .map(|p| format!(", folds from phase {p:.2} on"))
                .unwrap_or_default(),
            d.largest_stretch,
            d.warnings.len(),
            if self.inner.advice().is_empty() {
                ""
            } else {
                ", advice"
            }
        )
    }
}

/// A JSON value as Python objects (dicts, lists, ints, floats, strings,
/// booleans, None), built directly.
pub(crate) fn json_value<'py>(
    py: Python<'py>,
    v: &serde_json::Value,
) -> PyResult<Bound<'py, PyAny>> {
    use pyo3::IntoPyObjectExt;
    use serde_json::Value;
    Ok(match v {
        Value::Null => py.None().into_bound(py),
        Value::Bool(b) => b.into_bound_py_any(py)?,
        Value::Number(n) => match (n.as_i64(), n.as_u64()) {
            (Some(i), _) => i.into_bound_py_any(py)?,
            (None, Some(u)) => u.into_bound_py_any(py)?,
            _ => n.as_f64().unwrap_or(f64::NAN).into_bound_py_any(py)?,
        },
        Value::String(s) => s.into_bound_py_any(py)?,
        Value::Array(a) => {
            let list = PyList::empty(py);
            for x in a {
                list.append(json_value(py, x)?)?;
            }
            list.into_any()
        }
        Value::Object(o) => {
            let dict = PyDict::new(py);
            for (k, x) in o {
                dict.set_item(k, json_value(py, x)?)?;
            }
            dict.into_any()
        }
    })
}

/// The checks `stretch_limit=` and `self_intersections=` ask for.
pub(crate) fn checks(
    stretch_limit: f64,
    self_intersections: Option<bool>,
) -> PyResult<csrbf_edit::Checks> {
    let checks = csrbf_edit::Checks::default()
        .with_stretch_limit(stretch_limit)
        .with_self_intersections(self_intersections);
    checks
        .diagnose
        .check()
        .map_err(|e| PyValueError::new_err(format!("stretch_limit: {e}")))?;
    Ok(checks)
}

/// The search `remedies=` asks for.
pub(crate) fn remedy_search(remedies: &str) -> PyResult<csrbf_edit::RemedySearch> {
    csrbf_edit::RemedySearch::parse(remedies).ok_or_else(|| {
        PyValueError::new_err(format!(
            "remedies must be \"bounded\", \"full\" or \"off\", got {remedies:?}"
        ))
    })
}

/// A mesh given as a `csrbf.Mesh` or a path, with finite positions.
pub(crate) fn mesh_arg(py: Python<'_>, mesh: &Bound<'_, PyAny>) -> PyResult<Mesh> {
    let m = match mesh.cast::<PyMesh>() {
        Ok(m) => m.borrow().inner.clone(),
        Err(_) => {
            let path: PathBuf = mesh.extract().map_err(|_| {
                PyTypeError::new_err("mesh must be a csrbf.Mesh or a path to a mesh file")
            })?;
            if csrbf_mesh::volume::VolumeFormat::is_volume_path(&path) {
                return Err(PyTypeError::new_err(format!(
                    "{} is a volume mesh: morph it with csrbf.morph_volume",
                    path.display()
                )));
            }
            let loaded = py
                .detach(|| csrbf_mesh::load(&path))
                .map_err(|e| error(&e))?;
            for w in &loaded.warnings {
                warn(py, w)?;
            }
            loaded.mesh
        }
    };
    if let Some(i) = m.positions.iter().position(|p| !p.is_finite()) {
        return Err(PyValueError::new_err(format!(
            "mesh: vertex {i} has a coordinate that is not finite ({}): a mesh to deform needs finite positions",
            m.positions[i]
        )));
    }
    Ok(m)
}

/// A control file, from a path or a dict in the file's form; its unknown
/// keys are warned about.
/// A Python value in a control file's form (dicts with string keys, lists
/// and tuples, numbers, strings, booleans, None) as JSON, walked directly
/// (a live pose sends one every frame: no text in between). numpy numbers
/// and arrays (a radius from a computation, a start from a mesh's
/// vertices) are the numbers they hold; a number that is not finite, a key
/// that is not a string or any other type is refused by its path
/// (`controls.controls[2].to[1]`).
pub(crate) fn py_json(value: &Bound<'_, PyAny>, at: &str) -> PyResult<serde_json::Value> {
    use pyo3::types::{PyBool, PyFloat, PyInt, PyString};
    use serde_json::Value;
    if value.is_none() {
        return Ok(Value::Null);
    }
    if let Ok(b) = value.cast::<PyBool>() {
        return Ok(Value::Bool(b.is_true()));
    }
    if value.is_instance_of::<PyInt>() {
        if let Ok(i) = value.extract::<i64>() {
            return Ok(i.into());
        }
        if let Ok(u) = value.extract::<u64>() {
            return Ok(u.into());
        }
        let x: f64 = value.extract()?;
        return finite(x, at);
    }
    if let Ok(f) = value.cast::<PyFloat>() {
        return finite(f.value(), at);
    }
    if let Ok(s) = value.cast::<PyString>() {
        return Ok(Value::String(s.to_cow()?.into_owned()));
    }
    if let Ok(d) = value.cast::<PyDict>() {
        let mut map = serde_json::Map::with_capacity(d.len());
        for (k, v) in d.iter() {
            let key: String = k.extract().map_err(|_| {
                PyTypeError::new_err(format!(
                    "{at}: a key must be a string, got {}",
                    k.repr().map(|r| r.to_string()).unwrap_or_default()
                ))
            })?;
            let here = format!("{at}.{key}");
            let v = py_json(&v, &here)?;
            map.insert(key, v);
        }
        return Ok(Value::Object(map));
    }
    if value.is_instance_of::<PyList>() || value.is_instance_of::<PyTuple>() {
        let mut out = Vec::with_capacity(value.len()?);
        for (k, item) in value.try_iter()?.enumerate() {
            out.push(py_json(&item?, &format!("{at}[{k}]"))?);
        }
        return Ok(Value::Array(out));
    }
    if value.hasattr("tolist")? {
        // numpy arrays and numbers: their Python lists and numbers.
        return py_json(&value.call_method0("tolist")?, at);
    }
    Err(PyTypeError::new_err(format!(
        "{at}: a value of type {} cannot be part of a control file (give numbers, lists of numbers, strings and dicts)",
        value.get_type().name()?
    )))
}

fn finite(x: f64, at: &str) -> PyResult<serde_json::Value> {
    serde_json::Number::from_f64(x)
        .map(serde_json::Value::Number)
        .ok_or_else(|| crate::Error::new_err(format!("{at}: not a finite number ({x})")))
}

pub(crate) fn control_file(py: Python<'_>, controls: &Bound<'_, PyAny>) -> PyResult<ControlFile> {
    if controls.is_instance_of::<PyDict>() {
        let file = ControlFile::from_value(&py_json(controls, "controls")?)
            .map_err(|e| crate::Error::new_err(format!("controls: {}", crate::chain(&e))))?;
        for w in &file.warnings {
            warn(py, &format!("controls: {w}"))?;
        }
        return Ok(file);
    }
    let (text, name) = {
        let path: PathBuf = controls.extract().map_err(|_| {
            PyTypeError::new_err("controls must be a path to a control file or a dict in its form")
        })?;
        let text = std::fs::read_to_string(&path).map_err(|e| {
            crate::Error::new_err(format!("cannot read control file {}: {e}", path.display()))
        })?;
        (text, path.display().to_string())
    };
    let file = ControlFile::parse(&text)
        .map_err(|e| crate::Error::new_err(format!("{name}: {}", crate::chain(&e))))?;
    for w in &file.warnings {
        warn(py, &format!("{name}: {w}"))?;
    }
    Ok(file)
}

/// Deforms a mesh by a control file (the CLI's `csrbf deform`): handles
/// sampled on the mesh, every deformation fitted on its region and combined
/// as the file says, normals carried (the file's own, turned with the
/// surface; computed when it had none).
///
/// Args:
///     mesh: a Mesh, or a path to a mesh file.
///     controls: a path to a control file (JSON), or a dict in its form
///         ({"radius": 0.3, "controls": [{"from": [..], "to": [..]}]}).
///     phase: in [0, 1], times each deformation's own phase.
///     allow_large: fit even systems estimated past the 4 GiB limit.
///     stretch_limit: triangles stretched more than this (a finite number
///         >= 1) are listed in `Report.stretched` and warned of.
///     self_intersections: look for faces passing through each other that
///         did not at rest: None (meshes of at most 2M triangles), True or
///         False.
///     remedies: when a face folds, search for a radius and a sweep that
///         would not: "bounded" (at most the edit's own time, or 0.2 s),
///         "full" (to the smallest radius) or "off".
///
/// Returns:
///     (the deformed Mesh, a Report: moved, largest_move, inside_out,
///     largest_stretch, stretched, self_intersections, warnings, advice,
///     remedies); the input mesh is not changed.
///
/// >>> out, report = csrbf.deform_mesh(mesh, "smile.json", phase=1.0)
/// >>> report.moved, report.warnings
// Each argument is a keyword of the Python function.
#[allow(clippy::too_many_arguments)]
#[pyfunction]
#[pyo3(signature = (mesh, controls, phase = 1.0, *, allow_large = false, stretch_limit = csrbf::STRETCH_LIMIT, self_intersections = None, remedies = "bounded"))]
pub fn deform_mesh(
    py: Python<'_>,
    mesh: &Bound<'_, PyAny>,
    controls: &Bound<'_, PyAny>,
    phase: f64,
    allow_large: bool,
    stretch_limit: f64,
    self_intersections: Option<bool>,
    remedies: &str,
) -> PyResult<(PyMesh, PyReport)> {
    let checks = checks(stretch_limit, self_intersections)?;
    let mut m = mesh_arg(py, mesh)?;
    let file = control_file(py, controls)?;
    let search = remedy_search(remedies)?;
    // The edit layer's road: resolved, fitted, deformed, checked, one
    // report; its notes' warnings become Python warnings.
    let mut notes = Vec::new();
    let result = py.detach(|| {
        let edit = csrbf_edit::fit(&file, "controls", Some(&m), allow_large, &mut |n| {
            notes.push(n)
        })?;
        let (moved, report) = edit.deform(&m, phase, &checks, search)?;
        m.move_vertices(moved);
        Ok::<_, csrbf_edit::EditError>(report)
    });
    for n in notes {
        if let csrbf_edit::Note::Warning(w) = n {
            warn(py, &w)?;
        }
    }
    let report = result.map_err(|e| error(&e))?;
    Ok((PyMesh { inner: m }, PyReport { inner: report }))
}

/// Adds the mesh classes and functions to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyMesh>()?;
    m.add_class::<PyReport>()?;
    m.add_function(wrap_pyfunction!(read_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(write_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(deform_mesh, m)?)?;
    Ok(())
}
