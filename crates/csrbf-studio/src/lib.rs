//! `csrbf-studio`, the Picker and the Composer in a window: the eframe/egui
//! app ([`app`]) over the window-free cores of `csrbf-studio-core`, which
//! this crate re-exports (so `csrbf_studio::Document` is the core's).

// `unwrap` only in tests (clippy.toml allows it there); library code says
// why a value is there with `expect`, or handles its absence.
#![warn(clippy::unwrap_used)]

pub mod app;

pub use csrbf_studio_core::*;
pub use csrbf_studio_core::{
    command, compose, gizmo, live, orbit, preview, state, symmetry, tools,
};
