//! The studio's window: the shell ([`StudioApp`], `studio.rs`) around two
//! rooms, each a struct that owns its state and draws its own panels and
//! viewport: the Picker (`picker.rs`, with `panel.rs`, `viewport.rs` and `pick_press.rs`)
//! and the Composer (`composer.rs`, with `scene_panel.rs`, `timeline.rs`,
//! `scene_view.rs` and `key_drag.rs`). Rooms ask the shell for what only it
//! can do through `request.rs`; the screen they share (`gpu.rs`) and the
//! file dialogs and recovery files (`files.rs`) and the keys-and-mouse help
//! (`help.rs`) are leaves. The shell's
//! own work on files is in `documents.rs` (meshes and control files) and
//! `scene_files.rs` (scenes and exports). No file below imports a file
//! that imports it: see ARCHITECTURE.md for the arrows.

mod composer;
mod documents;
mod files;
mod gpu;
mod help;
mod key_drag;
mod panel;
mod pick_press;
mod picker;
mod request;
mod scene_files;
mod scene_panel;
mod scene_view;
mod studio;
mod timeline;
mod viewport;

pub use composer::{KeyRef, Mode};
pub use files::{MESH_ENDINGS, Recovery, VOLUME_ENDINGS, state_dir};
pub use gpu::BIG_MESH_TRIANGLES;
pub use studio::{Args, StudioApp};
