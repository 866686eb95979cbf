//! Gmsh files (`.msh`), versions 2.2 and 4.1, ASCII and binary:
//! `$MeshFormat`, `$PhysicalNames`, `$Entities`, `$Nodes`, `$Elements`;
//! other sections are stepped over. Node tags may be sparse: nodes are
//! numbered in file order (and written back as 1..n).
//!
//! A cell's zone is its physical group: in 2.2 the element's first tag, in
//! 4.1 the first physical tag of its entity (later physical tags of an
//! entity are not kept). Gmsh numbers physical groups per dimension: when
//! one tag names groups of two dimensions, the second gets a new tag (one
//! above every tag in the file), so each zone's tag is unique.
//!
//! Gmsh's prism is VTK's wedge inside out: its nodes (0, 1, 2, 3, 4, 5) are
//! the wedge's (0, 2, 1, 3, 5, 4), swapped on reading and writing.

mod read;
mod resolve;
#[cfg(test)]
pub(super) mod tests;
mod write;

pub(super) use read::read;
pub(super) use write::write;

/// Gmsh's prism to VTK's wedge and back (the swap is its own inverse).
const PRISM: [usize; 6] = [0, 2, 1, 3, 5, 4];
