//! glTF 2.0 in (`.gltf` with embedded, data-URI or external buffers, and
//! `.glb`) and out. Reading flattens the default scene into one mesh in world
//! space: each primitive's vertices are appended in order (primitives that
//! share their accessors share their vertices), triangles become faces, and
//! meshes, nodes and materials become named parts. Writing makes one node
//! with one mesh, one primitive per material part, over one set of vertex
//! accessors; vertices are split where UVs have seams. The mesh's `csrbf`
//! extras keep the parts (groups, objects, materials) by triangle and the
//! source of every split vertex, so this reader gives back the vertex order
//! and count, the parts and the per-corner UVs it was given.

mod read;
mod write;

pub(crate) use read::parse;
pub(crate) use write::encode;
pub use write::{Builder, UvSplit, package, split_uv_seams};

/// Base64 for the tests' hand-made files.
#[cfg(test)]
pub(crate) fn encode_base64_for_tests(data: &[u8]) -> String {
    crate::base64::encode(data)
}
