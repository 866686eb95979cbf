//! Volume meshes: nodes, cells of the linear kinds (tetrahedra, hexahedra,
//! wedges, pyramids, and the triangles, quads, lines and vertices that mark
//! boundaries), and named zones, as CFD and FEA tools store them; read and
//! written as VTK legacy (`.vtk`), VTK XML (`.vtu`) and Gmsh (`.msh`).
//!
//! Node order, cell order, cell kinds and zones are kept from the file, so a
//! morphed mesh can be handed back to the solver that made it. Nodes are
//! f64 (a solver's mesh must come back as precise as it went in). Cells
//! are stored in VTK's node order for every format (Gmsh's prism is VTK's
//! wedge turned inside out: its readers and writers swap it).
//!
//! ```
//! use csrbf_mesh::volume::{CellKind, VolumeMesh};
//! use glam::DVec3;
//!
//! let mut mesh = VolumeMesh::default();
//! mesh.points = vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z];
//! mesh.cells.push(CellKind::Tetra, &[0, 1, 2, 3]);
//! assert_eq!(mesh.cells.len(), 1);
//! assert!(mesh.check("tet.vtu".as_ref()).is_ok());
//! assert_eq!(mesh.boundary().len(), 4);
//! ```

pub mod quality;
pub mod shapes;

use std::collections::HashMap;
use std::path::Path;

use glam::DVec3;

use crate::{MeshError, Result};

/// The kind of a cell: the linear cells of VTK and Gmsh.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[non_exhaustive]
pub enum CellKind {
    /// One node.
    Vertex,
    /// Two nodes.
    Line,
    /// Three nodes, counter-clockwise seen from where its normal points.
    Triangle,
    /// Four nodes around.
    Quad,
    /// Four nodes; (0, 1, 2) turns counter-clockwise seen from node 3.
    Tetra,
    /// Five nodes: the base (0..4) counter-clockwise seen from the apex 4.
    Pyramid,
    /// Six nodes: triangles (0, 1, 2) and (3, 4, 5), the first's normal
    /// pointing away from the second (VTK's wedge).
    Wedge,
    /// Eight nodes: the bottom (0..4) counter-clockwise seen from the top
    /// (4..8), node 4 above node 0.
    Hexahedron,
}

impl CellKind {
    /// Every kind, by dimension.
    pub const ALL: [CellKind; 8] = [
        CellKind::Vertex,
        CellKind::Line,
        CellKind::Triangle,
        CellKind::Quad,
        CellKind::Tetra,
        CellKind::Pyramid,
        CellKind::Wedge,
        CellKind::Hexahedron,
    ];

    /// Its number of nodes.
    pub fn nodes(self) -> usize {
        match self {
            CellKind::Vertex => 1,
            CellKind::Line => 2,
            CellKind::Triangle => 3,
            CellKind::Quad | CellKind::Tetra => 4,
            CellKind::Pyramid => 5,
            CellKind::Wedge => 6,
            CellKind::Hexahedron => 8,
        }
    }

    /// Its dimension: 0 to 3.
    pub fn dim(self) -> u8 {
        match self {
            CellKind::Vertex => 0,
            CellKind::Line => 1,
            CellKind::Triangle | CellKind::Quad => 2,
            _ => 3,
        }
    }

    /// Its lower-case name, for messages and reports.
    pub fn name(self) -> &'static str {
        match self {
            CellKind::Vertex => "vertex",
            CellKind::Line => "line",
            CellKind::Triangle => "triangle",
            CellKind::Quad => "quad",
            CellKind::Tetra => "tetra",
            CellKind::Pyramid => "pyramid",
            CellKind::Wedge => "wedge",
            CellKind::Hexahedron => "hexahedron",
        }
    }

    /// VTK's cell type number.
    pub fn vtk_type(self) -> u8 {
        match self {
            CellKind::Vertex => 1,
            CellKind::Line => 3,
            CellKind::Triangle => 5,
            CellKind::Quad => 9,
            CellKind::Tetra => 10,
            CellKind::Hexahedron => 12,
            CellKind::Wedge => 13,
            CellKind::Pyramid => 14,
        }
    }

    /// The kind of a VTK cell type number, when csrbf reads it.
    pub fn from_vtk(t: i64) -> Option<CellKind> {
        CellKind::ALL.into_iter().find(|k| k.vtk_type() as i64 == t)
    }

    /// Gmsh's element type number.
    pub fn gmsh_type(self) -> u32 {
        match self {
            CellKind::Vertex => 15,
            CellKind::Line => 1,
            CellKind::Triangle => 2,
            CellKind::Quad => 3,
            CellKind::Tetra => 4,
            CellKind::Hexahedron => 5,
            CellKind::Wedge => 6,
            CellKind::Pyramid => 7,
        }
    }

    /// The kind of a Gmsh element type number, when csrbf reads it.
    pub fn from_gmsh(t: i64) -> Option<CellKind> {
        CellKind::ALL
            .into_iter()
            .find(|k| k.gmsh_type() as i64 == t)
    }

    /// The faces of a 3D cell, each as local node indices ordered so that
    /// its normal points out of the cell (triangles and quads); empty for
    /// the others.
    pub fn faces(self) -> &'static [&'static [usize]] {
        match self {
            CellKind::Tetra => &[&[0, 2, 1], &[0, 1, 3], &[1, 2, 3], &[0, 3, 2]],
            CellKind::Pyramid => &[
                &[0, 3, 2, 1],
                &[0, 1, 4],
                &[1, 2, 4],
                &[2, 3, 4],
                &[3, 0, 4],
            ],
            CellKind::Wedge => &[
                &[0, 1, 2],
                &[3, 5, 4],
                &[0, 3, 4, 1],
                &[1, 4, 5, 2],
                &[2, 5, 3, 0],
            ],
            CellKind::Hexahedron => &[
                &[0, 3, 2, 1],
                &[4, 5, 6, 7],
                &[0, 1, 5, 4],
                &[1, 2, 6, 5],
                &[2, 3, 7, 6],
                &[3, 0, 4, 7],
            ],
            _ => &[],
        }
    }
}

/// Cells in compressed form: cell `c` has kind `kinds[c]` and nodes
/// `nodes[offsets[c]..offsets[c + 1]]`.
#[derive(Clone, Debug, PartialEq)]
pub struct Cells {
    /// Each cell's kind.
    pub kinds: Vec<CellKind>,
    /// Start of each cell in `nodes`, plus the end.
    pub offsets: Vec<u32>,
    /// Node indices of every cell.
    pub nodes: Vec<u32>,
}

impl Default for Cells {
    fn default() -> Cells {
        Cells {
            kinds: Vec::new(),
            offsets: vec![0],
            nodes: Vec::new(),
        }
    }
}

impl Cells {
    /// Number of cells.
    pub fn len(&self) -> usize {
        self.kinds.len()
    }

    /// Whether there is no cell.
    pub fn is_empty(&self) -> bool {
        self.kinds.is_empty()
    }

    /// The nodes of cell `c`.
    pub fn cell(&self, c: usize) -> &[u32] {
        &self.nodes[self.offsets[c] as usize..self.offsets[c + 1] as usize]
    }

    /// Appends a cell (its node count is the kind's: checked by
    /// [`VolumeMesh::check`]).
    pub fn push(&mut self, kind: CellKind, nodes: &[u32]) {
        if self.offsets.is_empty() {
            self.offsets.push(0);
        }
        self.kinds.push(kind);
        self.nodes.extend_from_slice(nodes);
        self.offsets.push(self.nodes.len() as u32);
    }

    /// Every cell: its kind and nodes.
    pub fn iter(&self) -> impl Iterator<Item = (CellKind, &[u32])> + '_ {
        (0..self.len()).map(|c| (self.kinds[c], self.cell(c)))
    }

    /// How many cells of each kind, by kind, the kinds present only.
    pub fn counts(&self) -> Vec<(CellKind, usize)> {
        let mut n = [0usize; 8];
        for &k in &self.kinds {
            n[CellKind::ALL.iter().position(|&a| a == k).unwrap_or(0)] += 1;
        }
        CellKind::ALL
            .into_iter()
            .zip(n)
            .filter(|&(_, c)| c > 0)
            .collect()
    }
}

/// A named zone: Gmsh's physical group, a VTK file's zone array entry.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Zone {
    /// Its name (`zone <tag>` when the file names none).
    pub name: String,
    /// Its number in the file (Gmsh's physical tag), not 0.
    pub tag: i32,
    /// The dimension of its cells (2 for a boundary, 3 for a volume).
    pub dim: u8,
}

/// A volume mesh: nodes, cells, and the zone of each cell.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct VolumeMesh {
    /// The nodes, in the file's order.
    pub points: Vec<DVec3>,
    /// The cells, in the file's order.
    pub cells: Cells,
    /// The zone tag of each cell (0: none); empty when the file has no
    /// zones.
    pub cell_zones: Vec<i32>,
    /// The zones, each tag once.
    pub zones: Vec<Zone>,
}

impl VolumeMesh {
    /// Checks what every reader must guarantee: node counts matching the
    /// kinds, node indices in range, finite coordinates, a zone tag per cell
    /// (or none at all) and zones named once. The error names `path` and the
    /// cell or node.
    pub fn check(&self, path: &Path) -> Result<()> {
        let invalid = |message: String| MeshError::Invalid {
            path: path.to_owned(),
            message,
        };
        if let Some(i) = self.points.iter().position(|p| !p.is_finite()) {
            return Err(invalid(format!(
                "node {i} has a coordinate that is not a finite number"
            )));
        }
        let c = &self.cells;
        if c.offsets.len() != c.kinds.len() + 1
            || c.offsets.first() != Some(&0)
            || c.offsets.last().map(|&o| o as usize) != Some(c.nodes.len())
        {
            return Err(invalid(
                "the cells' offsets do not match their nodes".into(),
            ));
        }
        let n = self.points.len();
        for (i, (kind, nodes)) in c.iter().enumerate() {
            if nodes.len() != kind.nodes() {
                return Err(invalid(format!(
                    "cell {i} ({}) has {} nodes, not {}",
                    kind.name(),
                    nodes.len(),
                    kind.nodes()
                )));
            }
            if let Some(&v) = nodes.iter().find(|&&v| v as usize >= n) {
                return Err(invalid(format!(
                    "cell {i} ({}) names node {v}, but there are {n} nodes",
                    kind.name()
                )));
            }
        }
        if !self.cell_zones.is_empty() && self.cell_zones.len() != c.len() {
            return Err(invalid(format!(
                "{} cell zone tags for {} cells",
                self.cell_zones.len(),
                c.len()
            )));
        }
        let mut seen = HashMap::new();
        for z in &self.zones {
            if seen.insert(z.tag, &z.name).is_some() {
                return Err(invalid(format!("zone tag {} is given twice", z.tag)));
            }
        }
        if let Some((i, t)) = self
            .cell_zones
            .iter()
            .enumerate()
            .find(|&(_, t)| *t != 0 && !seen.contains_key(t))
        {
            return Err(invalid(format!(
                "cell {i} is in zone {t}, which is not declared"
            )));
        }
        Ok(())
    }

    /// The zone named `name`, or with that tag when `name` is a number.
    pub fn zone(&self, name: &str) -> Option<&Zone> {
        self.zones.iter().find(|z| z.name == name).or_else(|| {
            let tag: i32 = name.parse().ok()?;
            self.zones.iter().find(|z| z.tag == tag)
        })
    }

    /// The names of the zones, for messages.
    pub fn zone_names(&self) -> String {
        if self.zones.is_empty() {
            return "the mesh has no zones".into();
        }
        let names: Vec<String> = self
            .zones
            .iter()
            .map(|z| format!("{} ({}D)", z.name, z.dim))
            .collect();
        format!("its zones: {}", names.join(", "))
    }

    /// The cells of a zone, ascending.
    pub fn zone_cells(&self, tag: i32) -> Vec<u32> {
        (0..self.cell_zones.len() as u32)
            .filter(|&c| self.cell_zones[c as usize] == tag)
            .collect()
    }

    /// The nodes of a zone's cells, ascending, each once.
    pub fn zone_nodes(&self, tag: i32) -> Vec<u32> {
        let mut mark = vec![false; self.points.len()];
        for c in self.zone_cells(tag) {
            for &v in self.cells.cell(c as usize) {
                mark[v as usize] = true;
            }
        }
        (0..mark.len() as u32)
            .filter(|&v| mark[v as usize])
            .collect()
    }

    /// The outer surface: every face of a 3D cell that no other 3D cell
    /// shares, oriented out of the mesh, in cell order. Each face is
    /// returned with the cell it belongs to.
    pub fn boundary_faces(&self) -> Vec<(u32, Vec<u32>)> {
        let mut count: HashMap<Vec<u32>, u32> = HashMap::new();
        let key = |f: &[u32]| {
            let mut k = f.to_vec();
            k.sort_unstable();
            k
        };
        for (kind, nodes) in self.cells.iter() {
            for f in kind.faces() {
                let face: Vec<u32> = f.iter().map(|&l| nodes[l]).collect();
                *count.entry(key(&face)).or_insert(0) += 1;
            }
        }
        let mut out = Vec::new();
        for (c, (kind, nodes)) in self.cells.iter().enumerate() {
            for f in kind.faces() {
                let face: Vec<u32> = f.iter().map(|&l| nodes[l]).collect();
                if count.get(&key(&face)) == Some(&1) {
                    out.push((c as u32, face));
                }
            }
        }
        out
    }

    /// [`VolumeMesh::boundary_faces`] without the cells.
    pub fn boundary(&self) -> Vec<Vec<u32>> {
        self.boundary_faces().into_iter().map(|(_, f)| f).collect()
    }

    /// The surface to draw and to resolve control files on: every node as a
    /// vertex (so vertex i is node i), the outer boundary's faces, and one
    /// part per zone of 2D cells (a named boundary) with its faces added
    /// where the boundary lacks them.
    pub fn surface(&self) -> crate::Mesh {
        let mut mesh = crate::Mesh {
            positions: self.points.iter().map(|p| p.as_vec3()).collect(),
            ..Default::default()
        };
        let mut seen: HashMap<Vec<u32>, u32> = HashMap::new();
        let key = |f: &[u32]| {
            let mut k = f.to_vec();
            k.sort_unstable();
            k
        };
        for f in self.boundary() {
            seen.insert(key(&f), mesh.faces.len() as u32);
            mesh.faces.push(&f);
        }
        for z in self.zones.iter().filter(|z| z.dim == 2) {
            let mut faces = Vec::new();
            for c in self.zone_cells(z.tag) {
                let nodes = self.cells.cell(c as usize);
                if self.cells.kinds[c as usize].dim() != 2 {
                    continue;
                }
                let f = *seen.entry(key(nodes)).or_insert_with(|| {
                    mesh.faces.push(nodes);
                    mesh.faces.len() as u32 - 1
                });
                faces.push(f);
            }
            faces.sort_unstable();
            faces.dedup();
            mesh.parts.push(crate::Part {
                name: z.name.clone(),
                kind: crate::PartKind::Group,
                faces,
            });
        }
        mesh
    }
}

mod msh;
mod scan;
#[cfg(test)]
pub(crate) mod tests;
mod vtk;
mod vtu;

/// A volume mesh file format, with the flavour to write.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum VolumeFormat {
    /// VTK legacy, written BINARY (big-endian, version 4.2 cell layout).
    /// Reads ASCII and BINARY, the old and the 5.1 cell layouts.
    Vtk,
    /// VTK legacy, written ASCII.
    VtkAscii,
    /// VTK XML unstructured grid, written as raw appended binary
    /// (uncompressed). Reads ASCII, base64 and appended data, zlib or not.
    Vtu,
    /// VTK XML unstructured grid, written ASCII.
    VtuAscii,
    /// Gmsh, written as 4.1 binary. Reads 2.2 and 4.1, ASCII and binary.
    Msh,
    /// Gmsh, written as 2.2 ASCII (what older solvers' importers read).
    Msh22,
}

impl VolumeFormat {
    /// The extensions of the volume formats, for messages.
    pub const EXTENSIONS: &str = ".vtk, .vtu, .msh";

    /// The format of a path by its extension (case-insensitive): `Vtk`,
    /// `Vtu` or `Msh`.
    pub fn from_path(path: &Path) -> Result<VolumeFormat> {
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase())
            .unwrap_or_default();
        Ok(match ext.as_str() {
            "vtk" => VolumeFormat::Vtk,
            "vtu" => VolumeFormat::Vtu,
            "msh" => VolumeFormat::Msh,
            _ => {
                let why = if ext.is_empty() {
                    "has no extension to tell the volume mesh format by".to_string()
                } else {
                    format!("unknown volume mesh format {ext:?}")
                };
                return Err(MeshError::Invalid {
                    path: path.to_owned(),
                    message: format!("{why}; supported: {}", VolumeFormat::EXTENSIONS),
                });
            }
        })
    }

    /// Whether a path names a volume mesh by its extension.
    pub fn is_volume_path(path: &Path) -> bool {
        VolumeFormat::from_path(path).is_ok()
    }
}

impl VolumeMesh {
    /// Reads a volume mesh from a file's bytes; the reader tells ASCII,
    /// binary and version apart itself. The result is checked
    /// ([`VolumeMesh::check`]); errors name `path` and the line, byte, node
    /// or cell.
    pub fn from_bytes(bytes: &[u8], format: VolumeFormat, path: &Path) -> Result<VolumeMesh> {
        let mesh = match format {
            VolumeFormat::Vtk | VolumeFormat::VtkAscii => vtk::read(bytes, path)?,
            VolumeFormat::Vtu | VolumeFormat::VtuAscii => vtu::read(bytes, path)?,
            VolumeFormat::Msh | VolumeFormat::Msh22 => msh::read(bytes, path)?,
        };
        mesh.check(path)?;
        Ok(mesh)
    }

    /// The file's bytes in a format. The mesh is checked first (an error
    /// names it "the mesh to write").
    pub fn to_bytes(&self, format: VolumeFormat) -> Result<Vec<u8>> {
        self.to_bytes_for(format, Path::new("the mesh to write"))
    }

    fn to_bytes_for(&self, format: VolumeFormat, path: &Path) -> Result<Vec<u8>> {
        self.check(path)?;
        Ok(match format {
            VolumeFormat::Vtk => vtk::write(self, true),
            VolumeFormat::VtkAscii => vtk::write(self, false),
            VolumeFormat::Vtu => vtu::write(self, vtu::Encoding::Appended { zlib: false }),
            VolumeFormat::VtuAscii => vtu::write(self, vtu::Encoding::Ascii),
            VolumeFormat::Msh => msh::write(self, true, true),
            VolumeFormat::Msh22 => msh::write(self, false, false),
        })
    }
}

/// Reads a volume mesh; the format comes from the extension.
pub fn read(path: &Path) -> Result<VolumeMesh> {
    let format = VolumeFormat::from_path(path)?;
    let bytes = std::fs::read(path).map_err(|source| MeshError::Read {
        path: path.to_owned(),
        source,
    })?;
    VolumeMesh::from_bytes(&bytes, format, path)
}

/// Writes a volume mesh whole or not at all; the format (and its default
/// flavour: binary) comes from the extension.
pub fn write(path: &Path, mesh: &VolumeMesh) -> Result<()> {
    let bytes = mesh.to_bytes_for(VolumeFormat::from_path(path)?, path)?;
    crate::write_atomic(path, &bytes)
}
