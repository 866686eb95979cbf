//! Mesh errors: each names the file and the line, element or index.

use std::path::PathBuf;

/// What went wrong reading, checking or writing a mesh.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MeshError {
    /// A mesh file could not be read (missing, a folder, not allowed). The
    /// system's error is the source, as for [`MeshError::Io`].
    #[error("cannot read mesh {}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// The system's error.
        source: std::io::Error,
    },
    /// A file could not be read or written. The system's error is the
    /// source (printed after this by error chains, not twice).
    #[error("{}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The system's error.
        source: std::io::Error,
    },
    /// The file's content is malformed.
    #[error("{}{}: {message}", path.display(), line.map(|l| format!(":{l}")).unwrap_or_default())]
    Parse {
        /// The file.
        path: PathBuf,
        /// 1-based line, for text formats.
        line: Option<usize>,
        /// What is wrong.
        message: String,
    },
    /// The mesh read fine but cannot be used: out-of-range indices, non-finite
    /// coordinates, no vertices.
    #[error("{}: {message}", path.display())]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong, naming the face or vertex.
        message: String,
    },
    /// The extension names no supported format.
    #[error("{}", unknown_format(path, ext))]
    UnknownFormat {
        /// The file.
        path: PathBuf,
        /// Its extension.
        ext: String,
    },
}

impl MeshError {
    /// The message with its cause (the system's error for I/O), for callers
    /// that keep errors as text.
    pub fn full(&self) -> String {
        match self {
            MeshError::Io { path, source } => format!("{}: {source}", path.display()),
            MeshError::Read { source, .. } => format!("{self}: {source}"),
            other => other.to_string(),
        }
    }

    pub(crate) fn parse(
        path: &std::path::Path,
        line: Option<usize>,
        message: impl Into<String>,
    ) -> MeshError {
        MeshError::Parse {
            path: path.to_owned(),
            line,
            message: message.into(),
        }
    }
}

/// The mesh crate's result type.
pub type Result<T, E = MeshError> = std::result::Result<T, E>;

/// [`MeshError::UnknownFormat`]'s message: a folder and a name without an
/// extension said as such (`unknown mesh format ""` told neither).
fn unknown_format(path: &std::path::Path, ext: &str) -> String {
    const SUPPORTED: &str = ".obj, .ply, .stl, .off, .gltf, .glb";
    let p = path.display();
    if path.is_dir() {
        format!("{p} is a folder: give a file name ending in one of {SUPPORTED}")
    } else if crate::volume::VolumeFormat::is_volume_path(path) {
        format!(
            "{p}: .{ext} holds a volume mesh (cells), and a surface is wanted here: give one of {SUPPORTED} (`csrbf deform` and `info` read volume meshes; `render` draws their boundary)"
        )
    } else if ext.is_empty() {
        format!("{p} has no extension to tell the mesh format by: end it in one of {SUPPORTED}")
    } else {
        format!("{p}: unknown mesh format {ext:?}; supported: {SUPPORTED}")
    }
}
