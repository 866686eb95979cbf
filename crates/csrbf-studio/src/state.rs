//! The document the studio edits: a mesh and its control file.

use std::path::PathBuf;
use std::sync::Arc;

use csrbf::controls::{ControlFile, ControlSpec};
use csrbf::{Combine, FitOptions};
use csrbf_mesh::Mesh;

/// Which control vectors are selected: (layer, index) pairs, in order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Selection(pub Vec<(usize, usize)>);

impl Selection {
    /// Whether this control is selected.
    pub fn contains(&self, layer: usize, index: usize) -> bool {
        self.0.contains(&(layer, index))
    }
}

/// A mesh and the deformations the user is building on it.
#[derive(Clone, Debug)]
pub struct Document {
    /// The mesh at rest (shared: the preview's worker reads the same one).
    pub mesh: Arc<Mesh>,
    /// Where it came from (control files name meshes by path).
    pub mesh_path: PathBuf,
    /// The control file: one layer per deformation, in the CLI's format.
    pub controls: ControlFile,
    /// The selected controls.
    pub selection: Selection,
    /// The layer new controls go to.
    pub active_layer: usize,
    /// The phase shown, in [0, 1].
    pub phase: f64,
    /// Changes since the last save.
    pub dirty: bool,
}

impl Document {
    /// A document on `mesh` with one empty layer of radius `radius`.
    pub fn new(mesh: Mesh, mesh_path: PathBuf, radius: f64) -> Document {
        let layer = ControlSpec::new(Vec::new(), Vec::new(), FitOptions::new(radius));
        Document {
            mesh: Arc::new(mesh),
            mesh_path,
            controls: ControlFile::new(vec![layer], Combine::Chain),
            selection: Selection::default(),
            active_layer: 0,
            phase: 1.0,
            dirty: false,
        }
    }

    /// The length of the rest mesh's bounding-box diagonal (radii are shown
    /// as a share of it).
    pub fn diagonal(&self) -> f64 {
        self.mesh.diagonal() as f64
    }

    /// The control file as the CLI reads it (what "save" writes).
    pub fn to_text(&self) -> String {
        self.controls.to_text()
    }
}
