//! VTK legacy files (`.vtk`): `DATASET UNSTRUCTURED_GRID`, ASCII or BINARY
//! (big-endian), cells in the old layout (`n i0 i1 ...` per cell) or VTK
//! 5.1's (`OFFSETS` and `CONNECTIVITY`), zones as an integer cell array
//! and their names as dataset field data (`name` = [tag, dim], as meshio
//! keeps Gmsh's physical groups).
//!
//! Zone names are read only with a zone array (an integer field data pair
//! alone could be anything).
//!
//! Written as version 4.2 (the old cell layout, which every VTK reads),
//! zones as the cell array `gmsh:physical` and field data as above.

mod cells;
mod read;
#[cfg(test)]
pub(super) mod tests;
mod write;

pub(super) use cells::build_cells;
pub(super) use read::read;
pub(super) use write::write;
