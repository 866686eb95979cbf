//! Pictures and movies of csrbf scenes, headless.
//!
//! [`Renderer`] draws [`View`]s (meshes with parts, colours and textures,
//! lines, a control-vector overlay) with wgpu into its own multisampled
//! colour and depth textures and reads them back as an [`Image`]: on a GPU
//! where there is one, else on Mesa's software Vulkan driver (lavapipe).
//! [`movie`] writes frames as MP4 (through ffmpeg), GIF (pure Rust) or a
//! folder of PNGs, whole or not at all. No numerics live here.

// `unwrap` only in tests (clippy.toml allows it there); library code says
// why a value is there with `expect`, or handles its absence.
#![warn(clippy::unwrap_used)]

pub mod image;
pub mod movie;
mod renderer;
mod scene_view;

pub use image::Image;
pub use renderer::{
    Camera, DrawMesh, DrawOptions, DrawPart, Light, Line, Renderer, TextureId, View,
};
pub use scene_view::{
    Overlay, SceneOptions, SceneRenderer, StandInDraw, axis_gizmo, camera_lines, circle_lines,
    control_lines, default_lights, sphere_lines,
};

/// What can go wrong while rendering or writing pictures.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RenderError {
    /// No graphics adapter: neither a GPU nor a software Vulkan/GL driver.
    #[error(
        "no graphics adapter found ({0}); on Linux without a GPU install Mesa's software driver (Debian: apt-get install mesa-vulkan-drivers libvulkan1)"
    )]
    NoAdapter(String),
    /// A picture size of 0 or beyond the limit.
    #[error(
        "picture size {width} x {height} is not valid: each side must be within 1..={} pixels",
        csrbf_anim::MAX_SIDE
    )]
    BadSize {
        /// Width asked for.
        width: u32,
        /// Height asked for.
        height: u32,
    },
    /// A texture of inconsistent size.
    #[error("texture is not valid: {0}")]
    BadTexture(String),
    /// The GPU failed while drawing or reading back.
    #[error("graphics error: {0}")]
    Gpu(String),
    /// Encoding a picture or movie failed.
    #[error("encoding failed: {0}")]
    Encode(String),
    /// A file could not be written.
    #[error("{}: {message}", path.display())]
    Io {
        /// The file.
        path: std::path::PathBuf,
        /// What went wrong.
        message: String,
    },
    /// The caller stopped the work; nothing was left on disk.
    #[error("cancelled")]
    Cancelled,
    /// ffmpeg is not installed (not on the PATH).
    #[error(
        "ffmpeg was not found, so MP4 cannot be written: {FFMPEG_HINT}, or write a GIF (--out movie.gif) or frames (--out frames/)"
    )]
    NoFfmpeg,
}

/// How to get ffmpeg, on this platform.
const FFMPEG_HINT: &str = if cfg!(windows) {
    "put ffmpeg.exe in a folder on the PATH (builds at ffmpeg.org/download.html), or name it with the CSRBF_FFMPEG variable"
} else {
    "install it (Debian: apt-get install ffmpeg)"
};

/// The crate's result type.
pub type Result<T, E = RenderError> = std::result::Result<T, E>;
