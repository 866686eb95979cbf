//! What can go wrong on the road from a control document to a mesh.

use std::path::PathBuf;

/// An edit that could not be made, saying which deformation of which
/// document and why.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum EditError {
    /// The engine refused (`at` names the document and deformation:
    /// `smile.json: deformations[1]`).
    #[error("{at}")]
    Engine {
        /// Where: the document, and the deformation when it has several.
        at: String,
        /// Why.
        source: csrbf::Error,
    },
    /// The composition at a phase or its checks refused (a phase outside
    /// [0, 1], a region the mesh cannot resolve).
    #[error(transparent)]
    Deform(csrbf::Error),
    /// A region that does not fit the mesh (a part it lacks, a vertex
    /// past its end).
    #[error("{at}: region: {message}")]
    Region {
        /// Where.
        at: String,
        /// What is wrong.
        message: String,
    },
    /// A handle or a connected region without a mesh to resolve it on.
    #[error("{at}: {what}")]
    NeedsMesh {
        /// Where.
        at: String,
        /// What needs it, and what to give.
        what: &'static str,
    },
    /// A volume morph that cannot be made: a zone the mesh lacks, a
    /// displacement file or morph document at fault (the message names the
    /// file and the line or JSON path).
    #[error("{0}")]
    Morph(String),
    /// Reading or writing a file.
    #[error(transparent)]
    Mesh(#[from] csrbf_mesh::MeshError),
    /// A replay file that does not decode.
    #[error("{}", path.display())]
    Replay {
        /// The file.
        path: PathBuf,
        /// Why.
        source: csrbf::Error,
    },
}

/// The message of `e` and of every source below it, as one line (`smile.json:
/// deformations[1]: radius of support must be ...`): what a front end that
/// has no error chain of its own (Python, a scene's loader) shows.
pub fn error_chain(e: &dyn std::error::Error) -> String {
    let mut text = e.to_string();
    let mut source = e.source();
    while let Some(s) = source {
        let more = s.to_string();
        // Some errors print their source themselves; do not say it twice.
        if !text.contains(&more) {
            text.push_str(": ");
            text.push_str(&more);
        }
        source = s.source();
    }
    text
}
