//! The edit layer of csrbf: the one road from a control document to a
//! deformed mesh, which every front end (the `csrbf` command, the studio,
//! the Python package and through it Blender) goes through and only
//! translates.
//!
//! - [`controls`]: the JSON control file ([`ControlFile`], one
//!   [`ControlSpec`] a deformation), read and written, every problem named
//!   by its JSON path;
//! - [`fit()`]: the document resolved on a mesh (handles sampled on it,
//!   anchors pinned, connected regions measured along it, regions checked
//!   against its parts and vertices) and each deformation fitted, a single
//!   map or a fold-free sweep ([`fit_spec`]), as an [`Edit`]; what it did
//!   is said through [`Note`]s;
//! - [`Edit::deform`]: the stages composed at a phase and checked (moves,
//!   folds, stretch, faces passing through each other: [`Checks`]), with
//!   the remedies of a fold searched within a budget ([`RemedySearch`]);
//! - [`Report`]: what a deformation did, with one serialised form
//!   ([`Report::to_json`]) that `csrbf deform --json`, Python's
//!   `Report.to_dict()` and Blender's panel all read;
//! - [`Session`]: a live edit (the studio's preview, Blender's Live,
//!   Python's `Session`): each layer's factored system and binding kept, a
//!   destination move a solve and the sums, a start or radius a refit;
//! - [`apply`]: replay files by path and the checks of a region against a
//!   mesh;
//! - [`symmetry`]: the plane a model is mirror-symmetric about, where a
//!   mirror puts the images of control vectors (the studio's Mirror,
//!   Python's `symmetry_plane`, Blender's Mirror Controls).
//!
//! ```
//! use csrbf_edit::{ControlFile, Checks, RemedySearch};
//! use csrbf_mesh::{Faces, Mesh};
//! use glam::Vec3;
//!
//! // A strip of two triangles, its far corner pulled up.
//! let mut faces = Faces::new();
//! faces.push(&[0, 1, 2]);
//! faces.push(&[1, 3, 2]);
//! let mesh = Mesh {
//!     positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0)],
//!     faces,
//!     ..Mesh::default()
//! };
//! let file = ControlFile::parse(
//!     r#"{"radius": 0.8, "controls": [{"from": [1, 1, 0], "to": [1, 1, 0.2]}]}"#,
//! )?;
//! let edit = csrbf_edit::fit(&file, "pull.json", Some(&mesh), false, &mut |_| {})?;
//! let (moved, report) = edit.deform(&mesh, 1.0, &Checks::default(), RemedySearch::Bounded)?;
//! assert!((moved[3].z - 0.2).abs() < 1e-6 && moved[0] == Vec3::ZERO);
//! assert_eq!(report.diagnostics.moved, 1);
//! println!("{}", report.to_json()); // what `csrbf deform --json` prints of it
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

#![warn(clippy::unwrap_used)]

pub mod apply;
pub mod controls;
mod error;
mod fit;
pub mod json;
mod remedy;
mod report;
mod session;
pub mod symmetry;
pub mod volume;

#[cfg(test)]
mod connected_tests;
#[cfg(test)]
mod tests;

pub use apply::{Checks, SELF_INTERSECTION_TRIANGLES, compose_checked};
pub use controls::{ControlError, ControlFile, ControlSpec};
pub use error::{EditError, error_chain};
pub use fit::{Edit, FittedSpec, Note, SweepFigures, fit, fit_spec, resolve};
pub use remedy::{Remedies, RemedySearch, remedies};
pub use report::{Report, warning_controls};
pub use session::{Session, SessionError};
