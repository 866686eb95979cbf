//! Volume meshes in Python: `VolumeMesh` (f64 nodes, cells, zones) from
//! `read_mesh` of a .vtk, .vtu or .msh file or from arrays, `morph_volume`
//! (the edit layer's morphs and cell checks) and its `VolumeReport`.

use std::path::{Path, PathBuf};

use csrbf_edit::volume::{VolumeMorph, VolumeReport};
use csrbf_mesh::volume::{CellKind, VolumeMesh, Zone};
use numpy::{PyArray1, PyArray2, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::deformation::{rows, vectors_f64};
use crate::error;
use crate::mesh::{PyMesh, json_value, py_json, warn};

/// A volume mesh: nodes (float64), cells of the linear kinds (tetra,
/// hexahedron, wedge, pyramid, and triangle, quad, line, vertex for
/// boundaries) in VTK's node order, and named zones (Gmsh's physical
/// groups).
///
/// >>> vm = csrbf.read_mesh("box.vtu")          # .vtk, .vtu, .msh
/// >>> vm.points.shape, vm.cells_dict["tetra"].shape, vm.zones
/// >>> moved, report = csrbf.morph_volume(vm, "morph.json")
/// >>> report.inverted_cells, report.min_scaled_jacobian_after
/// >>> csrbf.write_mesh(moved, "morphed.vtu")
#[pyclass(name = "VolumeMesh", module = "csrbf")]
#[derive(Clone)]
pub struct PyVolumeMesh {
    pub(crate) inner: VolumeMesh,
}

fn kind_named(name: &str) -> PyResult<CellKind> {
    CellKind::ALL
        .into_iter()
        .find(|k| k.name() == name)
        .ok_or_else(|| {
            PyValueError::new_err(format!(
                "unknown cell kind {name:?}: expected one of {}",
                CellKind::ALL.map(|k| k.name()).join(", ")
            ))
        })
}

#[pymethods]
impl PyVolumeMesh {
    /// A volume mesh from arrays.
    ///
    /// Args:
    ///     points: (N, 3) node positions (stored as float64).
    ///     cells: a list of (kind, (M, k) node indices) blocks, kinds as
    ///         meshio names them ("tetra", "hexahedron", "wedge",
    ///         "pyramid", "triangle", "quad", "line", "vertex"), or a dict
    ///         kind -> array.
    ///     cell_zones: the zone tag of every cell (0: none), in the blocks'
    ///         order, or None.
    ///     zones: {name: (tag, dim)} (meshio's field_data), or None.
    #[new]
    #[pyo3(signature = (points, cells, cell_zones = None, zones = None))]
    fn new(
        points: &Bound<'_, PyAny>,
        cells: &Bound<'_, PyAny>,
        cell_zones: Option<&Bound<'_, PyAny>>,
        zones: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<PyVolumeMesh> {
        let mut mesh = VolumeMesh {
            points: vectors_f64(points, "points")?,
            ..Default::default()
        };
        let blocks: Vec<(String, Bound<'_, PyAny>)> = if let Ok(d) = cells.cast::<PyDict>() {
            d.iter()
                .map(|(k, v)| Ok((k.extract::<String>()?, v)))
                .collect::<PyResult<_>>()?
        } else {
            cells
                .try_iter()
                .map_err(|_| {
                    PyTypeError::new_err(
                        "cells must be a list of (kind, array) or a dict kind -> array",
                    )
                })?
                .map(|b| {
                    let b = b?;
                    // meshio's CellBlock has .type and .data.
                    if let (Ok(t), Ok(d)) = (b.getattr("type"), b.getattr("data")) {
                        return Ok((t.extract::<String>()?, d));
                    }
                    let (k, v): (String, Bound<'_, PyAny>) = b.extract()?;
                    Ok((k, v))
                })
                .collect::<PyResult<_>>()?
        };
        let np = points.py().import("numpy")?;
        for (name, data) in blocks {
            let kind = kind_named(&name)?;
            let a = np.call_method1("ascontiguousarray", (data, "int64"))?;
            let a = a.cast_into::<PyArray2<i64>>().map_err(|_| {
                PyValueError::new_err(format!(
                    "cells[{name:?}] must be a 2D array of node indices"
                ))
            })?;
            let a = a.readonly();
            let shape = a.shape().to_vec();
            if shape[1] != kind.nodes() {
                return Err(PyValueError::new_err(format!(
                    "cells[{name:?}] has {} nodes a cell; a {name} has {}",
                    shape[1],
                    kind.nodes()
                )));
            }
            let flat = a.as_slice().unwrap_or(&[]);
            for (c, cell) in flat.chunks(kind.nodes().max(1)).enumerate() {
                let mut nodes = [0u32; 8];
                for (k, &v) in cell.iter().enumerate() {
                    nodes[k] = u32::try_from(v)
                        .ok()
                        .filter(|&v| (v as usize) < mesh.points.len())
                        .ok_or_else(|| {
                            PyValueError::new_err(format!(
                                "cells[{name:?}][{c}] names node {v}, but there are {} nodes",
                                mesh.points.len()
                            ))
                        })?;
                }
                mesh.cells.push(kind, &nodes[..kind.nodes()]);
            }
        }
        if let Some(z) = cell_zones.filter(|z| !z.is_none()) {
            let a = np.call_method1("ascontiguousarray", (z, "int32"))?;
            let a = a
                .cast_into::<PyArray1<i32>>()
                .map_err(|_| PyValueError::new_err("cell_zones must be a 1D array of zone tags"))?;
            mesh.cell_zones = a.readonly().as_slice().unwrap_or(&[]).to_vec();
        }
        if let Some(z) = zones.filter(|z| !z.is_none()) {
            let d = z
                .cast::<PyDict>()
                .map_err(|_| PyTypeError::new_err("zones must be a dict name -> (tag, dim)"))?;
            for (k, v) in d.iter() {
                let name: String = k.extract()?;
                let td: Vec<i64> = np
                    .call_method1("asarray", (v,))?
                    .call_method0("tolist")?
                    .extract()
                    .map_err(|_| {
                        PyValueError::new_err(format!("zones[{name:?}] must be (tag, dim)"))
                    })?;
                if td.len() != 2 || !(0..=3).contains(&td[1]) {
                    return Err(PyValueError::new_err(format!(
                        "zones[{name:?}] must be (tag, dim) with dim 0 to 3, got {td:?}"
                    )));
                }
                mesh.zones.push(Zone {
                    name,
                    tag: td[0] as i32,
                    dim: td[1] as u8,
                });
            }
        }
        mesh.check(Path::new("VolumeMesh")).map_err(|e| error(&e))?;
        Ok(PyVolumeMesh { inner: mesh })
    }

    /// (N, 3) float64 node positions (a copy; assign to move them).
    #[getter]
    fn points<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        rows(py, &self.inner.points)
    }

    #[setter]
    fn set_points(&mut self, points: &Bound<'_, PyAny>) -> PyResult<()> {
        let p = vectors_f64(points, "points")?;
        if p.len() != self.inner.points.len() {
            return Err(PyValueError::new_err(format!(
                "points has {} rows, the mesh {} nodes",
                p.len(),
                self.inner.points.len()
            )));
        }
        self.inner.points = p;
        Ok(())
    }

    /// Number of cells.
    fn __len__(&self) -> usize {
        self.inner.cells.len()
    }

    /// (C,) uint8 VTK cell type of every cell.
    #[getter]
    fn cell_types<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<u8>> {
        let v: Vec<u8> = self
            .inner
            .cells
            .kinds
            .iter()
            .map(|k| k.vtk_type())
            .collect();
        PyArray1::from_vec(py, v)
    }

    /// (C,) int32 zone tag of every cell (0: none; all 0 without zones).
    #[getter]
    fn cell_zones<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i32>> {
        let v = if self.inner.cell_zones.is_empty() {
            vec![0; self.inner.cells.len()]
        } else {
            self.inner.cell_zones.clone()
        };
        PyArray1::from_vec(py, v)
    }

    /// The cells as meshio's blocks: a list of (kind, (M, k) int64 node
    /// indices), one block per run of cells of one kind, in order.
    #[getter]
    fn cells<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        let list = PyList::empty(py);
        let c = &self.inner.cells;
        let mut start = 0;
        while start < c.len() {
            let kind = c.kinds[start];
            let mut end = start;
            while end < c.len() && c.kinds[end] == kind {
                end += 1;
            }
            let flat: Vec<i64> = c.nodes[c.offsets[start] as usize..c.offsets[end] as usize]
                .iter()
                .map(|&v| v as i64)
                .collect();
            let a = PyArray1::from_vec(py, flat).reshape([end - start, kind.nodes()])?;
            list.append((kind.name(), a))?;
            start = end;
        }
        Ok(list)
    }

    /// The cells by kind: {kind: (M, k) int64 node indices}, every cell of
    /// a kind in file order.
    #[getter]
    fn cells_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for (kind, count) in self.inner.cells.counts() {
            let flat: Vec<i64> = self
                .inner
                .cells
                .iter()
                .filter(|(k, _)| *k == kind)
                .flat_map(|(_, n)| n.iter().map(|&v| v as i64))
                .collect();
            d.set_item(
                kind.name(),
                PyArray1::from_vec(py, flat).reshape([count, kind.nodes()])?,
            )?;
        }
        Ok(d)
    }

    /// The zones: {name: (tag, dim)} (meshio's field_data form).
    #[getter]
    fn zones<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for z in &self.inner.zones {
            d.set_item(&z.name, (z.tag, z.dim))?;
        }
        Ok(d)
    }

    /// The node indices of a zone's cells, ascending (by name or tag).
    fn zone_nodes<'py>(
        &self,
        py: Python<'py>,
        zone: &Bound<'_, PyAny>,
    ) -> PyResult<Bound<'py, PyArray1<u32>>> {
        let name: String = zone.str()?.extract()?;
        let z = self.inner.zone(&name).ok_or_else(|| {
            crate::Error::new_err(format!("no zone {name:?}; {}", self.inner.zone_names()))
        })?;
        Ok(PyArray1::from_vec(py, self.inner.zone_nodes(z.tag)))
    }

    /// What the mesh holds (`csrbf info`): counts, zones, bounds, the
    /// least scaled Jacobian, cells already inside out.
    fn info<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let v = py.detach(|| csrbf_edit::volume::describe(&self.inner));
        json_value(py, &v)
    }

    /// The boundary surface as a `Mesh` (vertex i is node i; zones of
    /// boundary faces are its parts): to draw, or to place controls on.
    fn boundary(&self) -> PyMesh {
        PyMesh {
            inner: self.inner.surface(),
        }
    }

    fn __repr__(&self) -> String {
        let kinds: Vec<String> = self
            .inner
            .cells
            .counts()
            .iter()
            .map(|(k, n)| format!("{n} {}", k.name()))
            .collect();
        format!(
            "VolumeMesh({} nodes, {} cells: {}; {} zones)",
            self.inner.points.len(),
            self.inner.cells.len(),
            kinds.join(", "),
            self.inner.zones.len()
        )
    }
}

/// What `morph_volume` did: nodes moved, controls, the cells checked.
#[pyclass(name = "VolumeReport", module = "csrbf", frozen)]
pub struct PyVolumeReport {
    inner: VolumeReport,
}

#[pymethods]
impl PyVolumeReport {
    /// Nodes moved by more than 1e-9 of the diagonal.
    #[getter]
    fn moved(&self) -> usize {
        self.inner.moved
    }
    /// The largest move.
    #[getter]
    fn largest_move(&self) -> f64 {
        self.inner.largest_move
    }
    /// Control vectors the map was fitted to.
    #[getter]
    fn controls(&self) -> usize {
        self.inner.controls
    }
    /// 3D cells turned inside out (or flat) by the morph.
    #[getter]
    fn inverted_cells(&self) -> usize {
        self.inner.cells.inverted.len()
    }
    /// Their indices (uint32, ascending).
    #[getter]
    fn inverted<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<u32>> {
        PyArray1::from_vec(py, self.inner.cells.inverted.clone())
    }
    /// The first phase in (0, 1] at which a cell turns, or None.
    #[getter]
    fn first_inversion(&self) -> Option<f64> {
        self.inner.cells.first_inversion
    }
    /// The least scaled Jacobian at rest (1 ideal, 0 flat).
    #[getter]
    fn min_scaled_jacobian_before(&self) -> f64 {
        self.inner.cells.min_scaled_jacobian_before
    }
    /// The least scaled Jacobian after the morph.
    #[getter]
    fn min_scaled_jacobian_after(&self) -> f64 {
        self.inner.cells.min_scaled_jacobian_after
    }
    /// What to do about inverted cells, or "".
    #[getter]
    fn advice(&self) -> String {
        self.inner.advice.clone()
    }
    /// One line for people.
    fn summary(&self) -> String {
        self.inner.summary()
    }
    /// Everything, as `csrbf deform --json` prints it (zones, boundary
    /// figures, timings).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_value(py, &self.inner.to_json())
    }
    fn __repr__(&self) -> String {
        format!("VolumeReport({})", self.inner.summary())
    }
}

/// A control document or a boundary-driven morph, from a path or a dict
/// (the edit layer's `VolumeMorph`); a control file's unknown keys warn.
fn morph_arg(py: Python<'_>, controls: &Bound<'_, PyAny>) -> PyResult<VolumeMorph> {
    let morph = if controls.is_instance_of::<PyDict>() {
        VolumeMorph::from_value(&py_json(controls, "controls")?, Path::new("controls"))
    } else {
        let path: PathBuf = controls.extract().map_err(|_| {
            PyTypeError::new_err("controls must be a path to a control file or a dict in its form")
        })?;
        VolumeMorph::read(&path)
    }
    .map_err(|e| error(&e))?;
    for w in morph.warnings() {
        warn(py, w)?;
    }
    Ok(morph)
}

/// Morphs a volume mesh (`csrbf deform` of a .vtu/.msh/.vtk): a control
/// file moves every node by its map, or a boundary-driven morph (a
/// document with "boundary": zones moved by a translation, rotation,
/// scaling, a per-node file or a control file's map, others held) moves
/// the named boundary and the interior follows. Every cell is checked
/// exactly.
///
/// Args:
///     mesh: a VolumeMesh.
///     controls: a path or a dict (a control file or a boundary morph).
///     phase: in [0, 1].
///     allow_large: fit even a system estimated past the memory limit.
///
/// Returns:
///     (the morphed VolumeMesh, a VolumeReport); the input is not changed.
#[pyfunction]
#[pyo3(signature = (mesh, controls, phase = 1.0, *, allow_large = false))]
pub fn morph_volume(
    py: Python<'_>,
    mesh: PyRef<'_, PyVolumeMesh>,
    controls: &Bound<'_, PyAny>,
    phase: f64,
    allow_large: bool,
) -> PyResult<(PyVolumeMesh, PyVolumeReport)> {
    let morph = morph_arg(py, controls)?;
    let m = &mesh.inner;
    let mut notes = Vec::new();
    let result = py.detach(|| morph.run(m, phase, allow_large, &mut |n| notes.push(n)));
    for n in notes {
        if let csrbf_edit::Note::Warning(w) = n {
            warn(py, &w)?;
        }
    }
    let (points, report) = result.map_err(|e| error(&e))?;
    let mut out = m.clone();
    out.points = points;
    Ok((
        PyVolumeMesh { inner: out },
        PyVolumeReport { inner: report },
    ))
}

/// Reads a volume mesh file (for `read_mesh`).
pub(crate) fn read(py: Python<'_>, path: &Path) -> PyResult<PyVolumeMesh> {
    let inner = py
        .detach(|| csrbf_mesh::volume::read(path))
        .map_err(|e| error(&e))?;
    Ok(PyVolumeMesh { inner })
}

/// Writes a volume mesh file (for `write_mesh`).
pub(crate) fn write(py: Python<'_>, mesh: &PyVolumeMesh, path: &Path) -> PyResult<()> {
    py.detach(|| csrbf_mesh::volume::write(path, &mesh.inner))
        .map_err(|e| error(&e))
}

/// Adds the volume classes and functions to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyVolumeMesh>()?;
    m.add_class::<PyVolumeReport>()?;
    m.add_function(wrap_pyfunction!(morph_volume, m)?)?;
    Ok(())
}
