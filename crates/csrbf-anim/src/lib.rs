//! Scenes of animated, deforming objects for csrbf: the papers' section 5.
//!
//! A [`Scene`] is read from a `*.scene.json` file ([`SceneFile`]): objects
//! with meshes and parts (colours, textures), each part with its CSRBF
//! deformations and their phase tracks ([`PhaseTrack`]); each object moving
//! along a Kochanek-Bartels [`Trajectory`] and turning by quaternion keys
//! ([`Orientation`]) about its centre of gravity. Deformations are fitted and
//! bound once; [`Scene::frame`] then costs a multiply-add per vertex and a
//! transform. Contact deformations (the papers' ball in a box) are rebuilt
//! and solved every frame.
//!
//! ```
//! use csrbf_anim::{PositionKey, Trajectory};
//! use glam::DVec3;
//!
//! let t = Trajectory::new(vec![
//!     PositionKey::new(0.0, DVec3::ZERO),
//!     PositionKey::new(1.0, DVec3::X),
//!     PositionKey::new(3.0, DVec3::new(1.0, 1.0, 0.0)),
//! ]);
//! assert_eq!(t.position(1.0), DVec3::X);
//! ```

// `unwrap` only in tests (clippy.toml allows it there); library code says
// why a value is there with `expect`, or handles its absence.
#![warn(clippy::unwrap_used)]

pub mod camera;
pub mod demos;
mod export;
mod file;
pub mod path;
mod rotation;
mod scene;
mod spline;
pub mod still;
mod track;

pub use camera::{Camera, CameraError, Projection, ViewPreset};
pub use export::{export_gltf, export_notes};
pub use file::*;
pub use rotation::{Interpolation, Orientation, OrientationKey};
pub use scene::{
    Animated, AssetError, Assets, BoundStage, Contact, DEFAULT_PART_COLOR, Frame, FrameObject,
    MAX_FPS, MAX_FRAMES, MAX_SIDE, Object, Part, RestLanes, Scene, Texture, TextureError,
    decode_texture, frame_count, load_texture,
};
pub use spline::{PositionKey, Trajectory};
pub use track::{Easing, PhaseTrack};

use std::path::PathBuf;

/// What can go wrong with a scene.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum AnimError {
    /// The scene file could not be read.
    #[error("{}: {message}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The system's message.
        message: String,
    },
    /// A problem in the scene, at a JSON path.
    #[error("{}: {at}: {message}", path.display())]
    Scene {
        /// The scene file.
        path: PathBuf,
        /// JSON path (`objects[0].trajectory[2].time`) or line and column.
        at: String,
        /// What is wrong.
        message: String,
    },
}

/// The crate's result type.
pub type Result<T, E = AnimError> = std::result::Result<T, E>;

#[cfg(test)]
mod tests;
