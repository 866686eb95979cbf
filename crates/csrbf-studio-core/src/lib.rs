//! The window-free cores of `csrbf-studio` (the papers' Picker and
//! Animation Composer): everything the app does, as plain types that tests
//! drive without a window, and that build without egui, eframe or wgpu (the
//! CLI's tests use them). The egui app (`csrbf-studio`) only reads a
//! [`Document`] or a [`compose::SceneDoc`] and sends [`Command`]s or
//! [`compose::SceneEdit`]s.
//!
//! - [`state`]: the [`Document`]: the mesh, its control file (one layer per
//!   deformation), the selection, and whether it was saved;
//! - [`command`]: every edit a value that applies itself and returns its
//!   inverse; [`History`] keeps them for undo and redo, merging a drag into
//!   one step;
//! - [`tools`]: pointer events in, commands out: a click on the surface adds
//!   a control vector there (ray against the mesh through the renderer's
//!   [`csrbf_anim::Camera`]), a drag moves its destination on the plane
//!   facing the camera, optionally along one axis;
//! - [`compose`]: the Composer's scene document, its edits (keys at the
//!   playhead kept in time order, TCB, timing, objects), their undo, and
//!   real-time playback (`Playback`: the fps kept, dropped frames counted);
//! - [`gizmo`]: the rotate gizmo's rings (one size on screen for the Picker
//!   and the Composer), which one is under the pointer, and turns;
//! - [`live`]: the preview: each layer's system is factored once and solved
//!   again when only destinations move; the deformed positions, their
//!   diagnostics, and a picking tree refitted to them.
//!
//! ```
//! use csrbf_studio_core::{Command, Document, History};
//! use csrbf::glam::DVec3;
//!
//! let mesh = csrbf_mesh::shapes::uv_sphere(1.0, 12, 24);
//! let mut doc = Document::new(mesh, "sphere.obj".into(), 0.5);
//! let mut history = History::default();
//! history.apply(&mut doc, Command::add(0, DVec3::Y, DVec3::Y * 1.2))?;
//! assert_eq!(doc.controls.deformations[0].starts.len(), 1);
//! history.undo(&mut doc)?;
//! assert!(doc.controls.deformations[0].starts.is_empty());
//! # Ok::<(), csrbf_studio_core::EditError>(())
//! ```

// `unwrap` only in tests (clippy.toml allows it there); library code says
// why a value is there with `expect`, or handles its absence.
#![warn(clippy::unwrap_used)]

pub mod command;
pub mod compose;
pub mod gizmo;
pub mod live;
pub mod orbit;
pub mod preview;
pub mod state;
pub use csrbf_edit::symmetry;
pub mod tools;

pub use command::{Command, History};
pub use live::{Live, LiveError};
pub use orbit::Orbit;
pub use preview::{Preview, PreviewFrame};
pub use state::{Document, Selection};
pub use tools::{
    DragTool, End, MarkerHit, SurfacePoint, pick_marker, pick_surface, pick_surface_on,
    swept_angle, vertices_in_box,
};

/// An edit that cannot be made, and why.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum EditError {
    /// No layer of that index.
    #[error("layer {0} does not exist")]
    NoLayer(usize),
    /// No control of that index in the layer.
    #[error("layer {layer} has no control {index}")]
    NoControl {
        /// The layer.
        layer: usize,
        /// The control asked for.
        index: usize,
    },
    /// A value the engine would refuse (a radius <= 0, a non-finite point).
    #[error("{0}")]
    Invalid(String),
    /// Nothing to undo or redo.
    #[error("nothing to {0}")]
    Nothing(&'static str),
}
