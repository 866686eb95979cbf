//! The studio's integration tests, one binary (as every crate of the
//! workspace has):
//!
//! - `app`: the Picker driven as a person would, headless (egui_kittest):
//!   clicks and drags in the viewport, the side panel, keys, files;
//! - `compose`: the Composer the same way: a scene built by clicks and read
//!   back by the CLI's loader, playback, export, bad scene files, recovery;
//! - `snapshots`: the viewport's picture on the software Vulkan driver
//!   against the PNGs in `tests/snapshots/`;
//! - `window`: the real binary in a real window under Xvfb, driven by
//!   xdotool.

mod app;
mod compose;
mod snapshots;
mod support;
mod window;
