//! `csrbf` for Python: the engine's calls with numpy arrays in and out.
//!
//! A thin layer, like the CLI: each function checks and converts its
//! arguments, makes one engine call with the GIL released
//! ([`Python::detach`]) and converts the result. No algorithm lives here:
//! fitting, evaluation, bindings and diagnostics are `csrbf`'s, meshes and
//! their files `csrbf-mesh`'s, control files applied to meshes
//! `csrbf-anim`'s. The Python-side parts (the PyVista accessor, type stubs)
//! are in `python/csrbf/`.
//!
//! - [`deformation`]: `fit` and `Deformation` (evaluate, deform, save, load, pickle);
//! - [`system`]: `System` (factor once, solve many), `Binding`, `deform_many`;
//! - [`mesh`]: `Mesh`, `read_mesh`, `write_mesh`, `deform_mesh` and its `Report`;
//! - [`arrays`]: numpy arguments read without a copy where the layout allows;
//!
//! Every engine, mesh-file and control-file error becomes `csrbf.Error` (a
//! `ValueError`) carrying the whole message chain; a wrong shape or length is
//! a plain `ValueError` naming the argument, non-numeric input a `TypeError`.

// `unwrap` only in tests (clippy.toml allows it there); library code says
// why a value is there with `expect`, or handles its absence.
#![warn(clippy::unwrap_used)]

use pyo3::prelude::*;

pub mod arrays;
mod cast;
mod controls;
pub mod deformation;
pub mod mesh;
mod session;
pub mod system;
pub mod volume;

pyo3::create_exception!(
    csrbf,
    Error,
    pyo3::exceptions::PyValueError,
    "What the engine refused, with its message: the file and line, the JSON path or the control's index."
);

/// `csrbf.Error` carrying `e`'s message and every source below it, joined by
/// `": "` (anyhow's `{:#}`).
pub(crate) fn error(e: &(dyn std::error::Error + 'static)) -> PyErr {
    Error::new_err(chain(e))
}

/// The message of `e` and of every source below it (the edit layer's).
pub(crate) fn chain(e: &(dyn std::error::Error + 'static)) -> String {
    csrbf_edit::error_chain(e)
}

/// The extension module `csrbf._csrbf`; `csrbf/__init__.py` re-exports it.
#[pymodule]
fn _csrbf(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("Error", m.py().get_type::<Error>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    // Benchmarks say which build they time: the tests' wheel is a dev
    // build (optimised less, with debug assertions), users' is release.
    let profile = if cfg!(debug_assertions) {
        "dev"
    } else {
        "release"
    };
    m.add("build_profile", profile)?;
    deformation::register(m)?;
    system::register(m)?;
    mesh::register(m)?;
    session::register(m)?;
    controls::register(m)?;
    volume::register(m)?;
    Ok(())
}
