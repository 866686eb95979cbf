//! VTK's cell types and cell lists, shared with the XML reader.

use crate::Result;
use crate::volume::scan;
use crate::volume::{CellKind, Cells};

/// Converts VTK's cell type number and nodes to csrbf's kind, turning
/// pixels and voxels (VTK types 8 and 11) into quads and hexahedra.
pub(super) fn vtk_cell(t: i64, nodes: &mut [u32]) -> Result<CellKind, String> {
    let kind = match t {
        8 => CellKind::Quad,
        11 => CellKind::Hexahedron,
        _ => CellKind::from_vtk(t).ok_or_else(|| {
            let name = match t {
                2 => " (poly-vertex)",
                4 => " (poly-line)",
                6 => " (triangle strip)",
                7 => " (polygon)",
                21..=37 => " (a quadratic or higher-order cell)",
                42 => " (polyhedron)",
                60.. => " (a higher-order cell)",
                _ => "",
            };
            format!(
                "VTK cell type {t}{name}, which csrbf does not read: it reads the linear cells \
                 (VTK types 1, 3, 5, 8, 9, 10, 11, 12, 13, 14)"
            )
        })?,
    };
    if nodes.len() != kind.nodes() {
        return Err(format!(
            "VTK cell type {t} ({}) with {} nodes, not {}",
            kind.name(),
            nodes.len(),
            kind.nodes()
        ));
    }
    if t == 8 || t == 11 {
        for q in nodes.chunks_exact_mut(4) {
            q.swap(2, 3);
        }
    }
    Ok(kind)
}

/// Builds the cells from offsets (start of each cell, plus the end),
/// connectivity and types, checking each index; errors name the cell.
pub(in crate::volume) fn build_cells(
    offsets: &[i64],
    conn: &[i64],
    types: &[i64],
    npoints: usize,
) -> Result<Cells, String> {
    if offsets.len() != types.len() + 1 {
        return Err(format!(
            "{} cell types for {} cells",
            types.len(),
            offsets.len().saturating_sub(1)
        ));
    }
    if conn.len() > u32::MAX as usize {
        return Err("too many cell nodes (more than 2^32)".into());
    }
    let mut cells = Cells::default();
    cells.kinds.reserve(types.len());
    cells.nodes.reserve(conn.len());
    let mut nodes = Vec::new();
    for (c, &t) in types.iter().enumerate() {
        let (a, b) = (offsets[c], offsets[c + 1]);
        if a < 0 || b < a || b as u64 > conn.len() as u64 {
            return Err(format!(
                "cell {c}'s offsets ({a} to {b}) are not within its {} node indices",
                conn.len()
            ));
        }
        nodes.clear();
        for &v in &conn[a as usize..b as usize] {
            nodes.push(scan::index(v, npoints, || format!("a node of cell {c}"))?);
        }
        let kind = vtk_cell(t, &mut nodes).map_err(|e| format!("cell {c} has {e}"))?;
        cells.push(kind, &nodes);
    }
    Ok(cells)
}
