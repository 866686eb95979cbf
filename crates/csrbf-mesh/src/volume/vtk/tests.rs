//! Legacy VTK files as meshio and ParaView write them, names, pixels and
//! voxels.

use std::path::Path;

use glam::DVec3;

use super::cells::vtk_cell;
use super::read::decode_name;
use super::write::encode_name;
use crate::volume::CellKind;
use crate::volume::tests::sample;
use crate::volume::{VolumeFormat, VolumeMesh, Zone, vtk};

#[test]
fn names_round_trip_through_percent_codes() {
    for name in ["inlet", "far field", "100%", "é x", ""] {
        let e = encode_name(name);
        assert!(!e.contains(' ') && !e.is_empty(), "{e}");
        if !name.is_empty() {
            assert_eq!(decode_name(&e), name);
        }
    }
}

#[test]
fn pixels_and_voxels_become_quads_and_hexahedra() {
    let mut q = vec![0, 1, 2, 3];
    assert_eq!(vtk_cell(8, &mut q), Ok(CellKind::Quad));
    assert_eq!(q, [0, 1, 3, 2]);
    let e = vtk_cell(24, &mut [0; 10]).unwrap_err();
    assert!(e.contains("24 (a quadratic"), "{e}");
}

/// As meshio 5 writes a Gmsh mesh to VTK (5.1 layout).
pub(crate) const VTK51: &str = "# vtk DataFile Version 5.1
written by meshio v5.3.5
ASCII
DATASET UNSTRUCTURED_GRID
FIELD FieldData 2
inlet 1 2 int
1 2
fluid 1 2 int
2 3
POINTS 5 double
0.0 0.0 0.0 1.0 0.0 0.0 0.0 1.0 0.0 0.0 0.0 1.0 0.1 0.2 0.3
CELLS 3 7
OFFSETS vtktypeint64
0
3
7
CONNECTIVITY vtktypeint64
0
2
1
0
1
2
3
CELL_TYPES 2
5
10

CELL_DATA 2
FIELD FieldData 2
gmsh:physical 1 2 int
1
2
gmsh:geometrical 1 2 int
1
1
";

/// As ParaView writes legacy VTK (4.2 layout, metadata, point data).
pub(crate) const VTK42: &str = "# vtk DataFile Version 4.2
vtk output
ASCII
DATASET UNSTRUCTURED_GRID
POINTS 6 float
0 0 0 1 0 0 0 1 0
0 0 1 1 0 1 0 1 1
METADATA
INFORMATION 2
NAME L2_NORM_RANGE LOCATION vtkDataArray
DATA 2 0 1.41421
NAME L2_NORM_FINITE_RANGE LOCATION vtkDataArray
DATA 2 0 1.41421

CELLS 2 11
6 0 1 2 3 4 5
3 3 4 5
CELL_TYPES 2
13
5

CELL_DATA 2
SCALARS CellEntityIds int 1
LOOKUP_TABLE default
4 7
POINT_DATA 6
VECTORS displacement float
0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0
SCALARS pressure double
LOOKUP_TABLE default
1 2 3 4 5 6
FIELD FieldData 1
temperature 1 6 double
1 1 1 1 1 1
";

#[test]
fn legacy_vtk_files_read_right() {
    let m =
        VolumeMesh::from_bytes(VTK51.as_bytes(), VolumeFormat::Vtk, Path::new("a.vtk")).unwrap();
    assert_eq!(m.points[4], DVec3::new(0.1, 0.2, 0.3));
    assert_eq!(m.cells.kinds, [CellKind::Triangle, CellKind::Tetra]);
    assert_eq!(m.cells.cell(0), [0, 2, 1]);
    assert_eq!(m.cells.cell(1), [0, 1, 2, 3]);
    assert_eq!(m.cell_zones, [1, 2]);
    assert_eq!(
        m.zones,
        [
            Zone {
                name: "inlet".into(),
                tag: 1,
                dim: 2
            },
            Zone {
                name: "fluid".into(),
                tag: 2,
                dim: 3
            },
        ]
    );

    let m =
        VolumeMesh::from_bytes(VTK42.as_bytes(), VolumeFormat::Vtk, Path::new("b.vtk")).unwrap();
    assert_eq!(m.points.len(), 6);
    assert_eq!(m.cells.kinds, [CellKind::Wedge, CellKind::Triangle]);
    assert_eq!(m.cells.cell(1), [3, 4, 5]);
    assert_eq!(m.cell_zones, [4, 7]);
    assert_eq!(
        m.zones,
        [
            Zone {
                name: "zone 4".into(),
                tag: 4,
                dim: 3
            },
            Zone {
                name: "zone 7".into(),
                tag: 7,
                dim: 2
            },
        ]
    );
}

#[test]
fn legacy_vtk_polydata_is_refused_with_a_hint() {
    let text = "# vtk DataFile Version 3.0\nx\nASCII\nDATASET POLYDATA\nPOINTS 0 float\n";
    let e = VolumeMesh::from_bytes(text.as_bytes(), VolumeFormat::Vtk, Path::new("s.vtk"))
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("s.vtk:4: ") && e.contains("POLYDATA") && e.contains(".ply"),
        "{e}"
    );
}

#[test]
fn legacy_vtk_writes_what_meshio_reads() {
    let m = sample();
    let text = String::from_utf8(m.to_bytes(VolumeFormat::VtkAscii).unwrap()).unwrap();
    assert!(
        text.contains("FIELD FieldData 5\nfluid 1 2 int\n1 3\n"),
        "{text}"
    );
    assert!(text.contains("edge%20line 1 2 int\n5 1\n"), "{text}");
    assert!(
        text.contains("SCALARS gmsh:physical int 1\nLOOKUP_TABLE default\n"),
        "{text}"
    );
    let _ = vtk::write(&m, true);
}
