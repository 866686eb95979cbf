//! The document the studio edits: a mesh and its control file.

use std::path::PathBuf;
use std::sync::Arc;

use csrbf::glam::Vec3;
use csrbf::{Combine, FitOptions};
use csrbf_edit::controls::{ControlFile, ControlSpec};
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
    /// The rest mesh's diagonal, measured once (the panel asks it several
    /// times a frame: a scan of every vertex, 1 ms at 1M vertices).
    diagonal: f64,
    /// Its bounding box, measured once as well.
    bounds: Option<(Vec3, Vec3)>,
}

impl Document {
    /// A document on `mesh` with one empty layer of radius `radius`.
    pub fn new(mesh: Mesh, mesh_path: PathBuf, radius: f64) -> Document {
        let layer = ControlSpec::new(Vec::new(), Vec::new(), FitOptions::new(radius));
        let diagonal = mesh.diagonal() as f64;
        let bounds = mesh.bounds();
        Document {
            mesh: Arc::new(mesh),
            mesh_path,
            controls: ControlFile::new(vec![layer], Combine::Chain),
            selection: Selection::default(),
            active_layer: 0,
            phase: 1.0,
            dirty: false,
            diagonal,
            bounds,
        }
    }

    /// The length of the rest mesh's bounding-box diagonal (radii are shown
    /// as a share of it), measured when the document was made (a new mesh
    /// is a new document).
    pub fn diagonal(&self) -> f64 {
        self.diagonal
    }

    /// The rest mesh's bounding box (None without vertices), measured when
    /// the document was made.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        self.bounds
    }

    /// The control file as the CLI reads it (what "save" writes).
    pub fn to_text(&self) -> String {
        self.controls.to_text()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Issue 23, bug 1: what "save" writes for a document whose layer has no
    /// control vector yet reads back with its radius, kernel and region, and
    /// deforms (to nothing) in the CLI's library call.
    #[test]
    fn an_empty_layer_saves_and_reads_back_whole() {
        let mesh = csrbf_mesh::shapes::uv_sphere(1.0, 8, 16);
        let mut doc = Document::new(mesh, PathBuf::from("s.obj"), 0.37);
        doc.controls.deformations[0].options = doc.controls.deformations[0]
            .options
            .with_kernel(csrbf::Kernel::C6);
        doc.controls.deformations[0].region = csrbf::Region::Sphere {
            center: csrbf::glam::DVec3::ZERO,
            radius: 0.5,
        };
        let back = ControlFile::parse(&doc.to_text()).expect("the studio's own file");
        assert_eq!(back.deformations, doc.controls.deformations);
        assert_eq!(back.warnings.len(), 1, "{:?}", back.warnings);
        let mut moved = (*doc.mesh).clone();
        csrbf_edit::apply::deform_mesh(&mut moved, &back, 1.0).expect("deform");
        assert_eq!(moved.positions, doc.mesh.positions);
    }
}
