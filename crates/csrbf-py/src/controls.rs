//! `csrbf.control_file`: a control file's dict made by the edit layer (its
//! one writer), so a front end (Blender's panel) builds none by hand.

use csrbf_edit::controls::{ControlFile, ControlSpec, UNKNOWN_KEY};
use numpy::{PyArray1, PyArray2, PyArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use crate::deformation::{check_lengths, options, vectors_f64};
use crate::mesh::{PyMesh, json_value, py_json};

/// A control file of one deformation, as a dict in the file's form (what
/// `deform_mesh`, `Session` and `csrbf deform` read), written by the edit
/// layer and checked as a file is: every problem named by its JSON path.
///
/// Args:
///     starts: (M, 3) start points of the control vectors ((0, 3) for a
///         handle alone).
///     targets: (M, 3) destinations, one per start.
///     radius: radius of support R.
///     kernel: "c0", "c2" (default), "c4" or "c6".
///     polynomial: "none" (default) or "linear".
///     region: where it acts, in the file's form ({"group": name},
///         {"vertices": [...]}, {"weights": {...}}, {"sphere": {...}},
///         {"box": {...}}, {"connected": {...}}, with "falloff" beside), or
///         None (the whole mesh).
///     phase: the deformation's own phase, in [0, 1].
///     sweep: a fold-free sweep instead of the single map.
///     name: a name for people.
///     handle: a part that moves as one, in the file's form
///         ({"select": <region>, "rotate": {"axis": [..], "angle_deg": a,
///         "pivot": [..]}, "scale": s, "translate": [..]}), or None.
///     anchor: with a handle, a part held still (a region), or None.
///
/// >>> spec = csrbf.control_file(starts, targets, 0.3, region={"group": "lips"})
/// >>> out, report = csrbf.deform_mesh(mesh, spec)
#[pyfunction]
#[pyo3(signature = (starts, targets, radius, *, kernel = "c2", polynomial = "none", region = None, phase = 1.0, sweep = false, name = None, handle = None, anchor = None))]
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
    handle: Option<&Bound<'py, PyAny>>,
    anchor: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    // No controls may be given as [] (a handle alone), not only as (0, 3).
    let vectors = |v: &Bound<'py, PyAny>, name| match v.len() {
        Ok(0) => Ok(Vec::new()),
        _ => vectors_f64(v, name),
    };
    let s = vectors(starts, "starts")?;
    let t = vectors(targets, "targets")?;
    check_lengths(s.len(), t.len())?;
    // Named here, where the arrays are the caller's (a file cannot hold a
    // NaN, so the reader would only see a null).
    for (name, v) in [("starts", &s), ("targets", &t)] {
        if let Some(i) = v.iter().position(|p| !p.is_finite()) {
            return Err(crate::Error::new_err(format!(
                "{name}[{i}]: not a finite number ({}, {}, {})",
                v[i].x, v[i].y, v[i].z
            )));
        }
    }
    let mut spec = ControlSpec::new(s, t, options(radius, kernel, polynomial, false)?);
    spec.phase = phase;
    spec.sweep = sweep.then(csrbf::SweepOptions::default);
    spec.name = name;
    let mut value = ControlFile::new(vec![spec], csrbf::Combine::Chain).to_json();
    // The region, handle and anchor go in as the file has them, and the
    // whole is read back as any file is: a radius, a phase, a point or a
    // part the reader refuses is refused here, by its JSON path.
    for (key, part) in [("region", region), ("handle", handle), ("anchor", anchor)] {
        if let Some(part) = part.filter(|p| !p.is_none()) {
            value[key] = py_json(part, key)?;
        }
    }
    let file = ControlFile::from_value(&value)
        .map_err(|e| crate::Error::new_err(format!("controls: {e}")))?;
    // A key a file would only be warned of (in a region or a handle) is a
    // mistake in the caller's code here: refused.
    if let Some(w) = file.warnings.iter().find(|w| w.ends_with(UNKNOWN_KEY)) {
        return Err(crate::Error::new_err(format!("controls: {w}")));
    }
    json_value(py, &file.to_json())
}

/// The plane normal to an axis that a model is most nearly mirror-symmetric
/// about (found from its vertices, as the studio's Mirror finds it: extra
/// parts such as a tail or a prop do not pull it off): its offset along the
/// axis, so the plane is `x = offset` for axis "x".
///
/// Args:
///     mesh: a Mesh, or (N, 3) points.
///     axis: "x" (default), "y" or "z".
///
/// Raises:
///     csrbf.Error: no finite point.
///
/// >>> x = csrbf.symmetry_plane(mesh)  # mirror a start s: (2 * x - s[0], s[1], s[2])
#[pyfunction]
#[pyo3(signature = (mesh, axis = "x"))]
pub fn symmetry_plane(mesh: &Bound<'_, PyAny>, axis: &str) -> PyResult<f64> {
    let k = match axis {
        "x" | "X" => 0,
        "y" | "Y" => 1,
        "z" | "Z" => 2,
        other => {
            return Err(PyValueError::new_err(format!(
                "axis: expected \"x\", \"y\" or \"z\", got {other:?}"
            )));
        }
    };
    let points = mesh_points(mesh)?;
    csrbf_edit::symmetry::symmetry_plane(&points, k)
        .ok_or_else(|| crate::Error::new_err("symmetry_plane: the mesh has no finite point"))
}

/// Two arrays a function returns.
type Pair<'py, A> = (Bound<'py, A>, Bound<'py, A>);
/// A float64 vector.
type F64s<'py> = Bound<'py, PyArray1<f64>>;

/// The plane of any orientation a model is most nearly mirror-symmetric
/// about, found from its vertices (a scan turned in its frame included):
/// (a point on it, its unit normal), two float64 arrays of 3.
///
/// Args:
///     mesh: a Mesh, or (N, 3) points.
///
/// Raises:
///     csrbf.Error: no finite point.
///
/// >>> point, normal = csrbf.find_symmetry(mesh)
#[pyfunction]
pub fn find_symmetry<'py>(
    py: Python<'py>,
    mesh: &Bound<'py, PyAny>,
) -> PyResult<Pair<'py, PyArray1<f64>>> {
    let points = mesh_points(mesh)?;
    let plane = py
        .detach(|| csrbf_edit::symmetry::find_plane(&points))
        .ok_or_else(|| crate::Error::new_err("find_symmetry: the mesh has no finite point"))?;
    Ok((
        PyArray1::from_slice(py, &plane.point.to_array()),
        PyArray1::from_slice(py, &plane.normal.to_array()),
    ))
}

/// The mirror images of points across a plane, each put on the mesh's
/// surface (its nearest point), as a mirror of control vectors places
/// their starts: (the images on the surface, (K, 3) float64; how far each
/// was from its exact image, (K,) float64: more than a few percent of R
/// says the model is not symmetric there).
///
/// Args:
///     mesh: a Mesh with faces.
///     points: (K, 3) points (starts) to mirror.
///     point, normal: the plane (as `find_symmetry` gives it; the normal
///         of any length but zero).
///
/// >>> images, gaps = csrbf.mirror_onto_surface(mesh, starts, *csrbf.find_symmetry(mesh))
#[pyfunction]
pub fn mirror_onto_surface<'py>(
    py: Python<'py>,
    mesh: &Bound<'py, PyMesh>,
    points: &Bound<'py, PyAny>,
    point: &Bound<'py, PyAny>,
    normal: &Bound<'py, PyAny>,
) -> PyResult<(Bound<'py, PyArray2<f64>>, F64s<'py>)> {
    let pts = vectors_f64(points, "points")?;
    let one = |v: &Bound<'py, PyAny>, name: &str| -> PyResult<glam::DVec3> {
        let a: Vec<f64> = v
            .extract()
            .map_err(|_| PyValueError::new_err(format!("{name}: expected three numbers")))?;
        match a[..] {
            [x, y, z] => Ok(glam::DVec3::new(x, y, z)),
            _ => Err(PyValueError::new_err(format!(
                "{name}: expected three numbers, got {}",
                a.len()
            ))),
        }
    };
    let plane = csrbf_edit::symmetry::Plane::new(one(point, "point")?, one(normal, "normal")?)
        .ok_or_else(|| {
            PyValueError::new_err("the plane needs a finite point and a non-zero finite normal")
        })?;
    let (positions, triangles) = {
        let m = mesh.borrow();
        if m.inner.faces.is_empty() {
            return Err(crate::Error::new_err(
                "mirror_onto_surface: the mesh has no faces to put the images on",
            ));
        }
        (m.inner.positions.clone(), m.inner.faces.triangles())
    };
    let images =
        py.detach(|| csrbf_edit::symmetry::mirror_onto(&positions, &triangles, &plane, &pts));
    let mut out = Vec::with_capacity(images.len() * 3);
    let mut gaps = Vec::with_capacity(images.len());
    for (k, im) in images.iter().enumerate() {
        let im = im.ok_or_else(|| {
            crate::Error::new_err(format!(
                "points[{k}]: not finite, or no surface to put it on"
            ))
        })?;
        out.extend(im.on_surface.to_array());
        gaps.push(im.gap);
    }
    let out = PyArray1::from_vec(py, out).reshape([images.len(), 3])?;
    Ok((out, PyArray1::from_vec(py, gaps)))
}

/// The plane's points, from a Mesh or an (N, 3) array.
fn mesh_points(mesh: &Bound<'_, PyAny>) -> PyResult<Vec<glam::Vec3>> {
    Ok(match mesh.cast::<PyMesh>() {
        Ok(m) => m.borrow().inner.positions.clone(),
        Err(_) => vectors_f64(mesh, "mesh")?
            .iter()
            .map(|p| p.as_vec3())
            .collect(),
    })
}

/// Adds `control_file`, `symmetry_plane`, `find_symmetry` and
/// `mirror_onto_surface` to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(control_file, m)?)?;
    m.add_function(wrap_pyfunction!(symmetry_plane, m)?)?;
    m.add_function(wrap_pyfunction!(find_symmetry, m)?)?;
    m.add_function(wrap_pyfunction!(mirror_onto_surface, m)?)
}
