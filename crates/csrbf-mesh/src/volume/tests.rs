//! The volume readers and writers: round trips through every format and
//! flavour, files as meshio, Gmsh and ParaView write them, hostile inputs.

use std::path::Path;

use glam::DVec3;

use super::quality::min_corner_det;
use super::{CellKind, VolumeFormat, VolumeMesh, Zone, msh, vtk, vtu};

/// Every cell kind, zones with names (one with a space, one without
/// cells), a cell in no zone, an unused node with extreme coordinates.
pub(crate) fn sample() -> VolumeMesh {
    let cube = [
        [0., 0., 0.],
        [1., 0., 0.],
        [1., 1., 0.],
        [0., 1., 0.],
        [0., 0., 1.],
        [1., 0., 1.],
        [1., 1., 1.],
        [0., 1., 1.],
        [0.5, 0.5, 2.],
        [2., 0., 0.],
        [2., 0., 1.],
        [0., 0., -1.],
    ];
    let mut m = VolumeMesh {
        points: cube
            .iter()
            .map(|&p| DVec3::from_array(p) * (1.0 / 3.0) + DVec3::new(0.1, 0.2, 0.7))
            .collect(),
        ..Default::default()
    };
    m.points.push(DVec3::new(-1e-7, 12345.678901234567, 1e300));
    let cells: [(CellKind, &[u32], i32); 9] = [
        (CellKind::Tetra, &[0, 3, 1, 11], 1),
        (CellKind::Triangle, &[1, 9, 10], 2),
        (CellKind::Hexahedron, &[0, 1, 2, 3, 4, 5, 6, 7], 1),
        (CellKind::Wedge, &[1, 2, 9, 5, 6, 10], 1),
        (CellKind::Quad, &[3, 2, 6, 7], 2),
        (CellKind::Pyramid, &[4, 5, 6, 7, 8], 1),
        (CellKind::Line, &[0, 1], 5),
        (CellKind::Line, &[1, 2], 0),
        (CellKind::Vertex, &[8], 7),
    ];
    for (kind, nodes, zone) in cells {
        m.cells.push(kind, nodes);
        m.cell_zones.push(zone);
    }
    for (name, tag, dim) in [
        ("fluid", 1, 3),
        ("wall", 2, 2),
        ("edge line", 5, 1),
        ("tip", 7, 0),
        ("spare", 9, 2),
    ] {
        m.zones.push(Zone {
            name: name.into(),
            tag,
            dim,
        });
    }
    m.check(Path::new("sample")).expect("the sample is valid");
    m
}

/// Every format and flavour the writers make, by name.
fn flavours(m: &VolumeMesh) -> Vec<(&'static str, VolumeFormat, Vec<u8>)> {
    let mut out: Vec<(&str, VolumeFormat, Vec<u8>)> = [
        VolumeFormat::Vtk,
        VolumeFormat::VtkAscii,
        VolumeFormat::Vtu,
        VolumeFormat::VtuAscii,
        VolumeFormat::Msh,
        VolumeFormat::Msh22,
    ]
    .into_iter()
    .map(|f| ("public", f, m.to_bytes(f).expect("write")))
    .collect();
    use vtu::Encoding;
    for (name, enc) in [
        ("vtu inline", Encoding::Inline { zlib: false }),
        ("vtu inline zlib", Encoding::Inline { zlib: true }),
        ("vtu appended zlib", Encoding::Appended { zlib: true }),
    ] {
        out.push((name, VolumeFormat::Vtu, vtu::write(m, enc)));
    }
    out.push((
        "msh 4.1 ascii",
        VolumeFormat::Msh,
        msh::write(m, true, false),
    ));
    out.push((
        "msh 2.2 binary",
        VolumeFormat::Msh,
        msh::write(m, false, true),
    ));
    out
}

/// The sample in every flavour and the hand-written files, for the fuzz
/// test.
pub(crate) fn fuzz_seeds() -> Vec<(VolumeFormat, Vec<u8>)> {
    let mut seeds: Vec<(VolumeFormat, Vec<u8>)> = flavours(&sample())
        .into_iter()
        .map(|(_, f, b)| (f, b))
        .collect();
    for (text, f) in [
        (MSH22, VolumeFormat::Msh),
        (MSH41, VolumeFormat::Msh),
        (VTK51, VolumeFormat::Vtk),
        (VTK42, VolumeFormat::Vtk),
        (VTU_ASCII, VolumeFormat::Vtu),
        (VTU_ZLIB, VolumeFormat::Vtu),
    ] {
        seeds.push((f, text.as_bytes().to_vec()));
    }
    seeds.push((VolumeFormat::Vtu, appended_raw(true)));
    seeds
}

#[test]
fn every_flavour_round_trips_exactly() {
    let m = sample();
    for (name, f, bytes) in flavours(&m) {
        let back = VolumeMesh::from_bytes(&bytes, f, Path::new("rt"))
            .unwrap_or_else(|e| panic!("{name} {f:?}: {e}"));
        assert_eq!(back, m, "{name} {f:?}");
    }
}

#[test]
fn an_empty_mesh_round_trips() {
    let m = VolumeMesh::default();
    for (name, f, bytes) in flavours(&m) {
        let back = VolumeMesh::from_bytes(&bytes, f, Path::new("rt"))
            .unwrap_or_else(|e| panic!("{name} {f:?}: {e}"));
        assert_eq!(back, m, "{name} {f:?}");
    }
}

#[test]
fn files_are_written_whole_and_read_by_extension() {
    let dir = std::env::temp_dir().join(format!("csrbf-volume-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let m = sample();
    for ext in ["vtk", "VTU", "msh"] {
        let p = dir.join(format!("m.{ext}"));
        super::write(&p, &m).unwrap();
        assert_eq!(super::read(&p).unwrap(), m, "{ext}");
    }
    let e = super::read(&dir.join("m.stl")).unwrap_err().to_string();
    assert!(e.contains("m.stl") && e.contains(".vtk, .vtu, .msh"), "{e}");
    assert!(!VolumeFormat::is_volume_path(Path::new("a.obj")));
    assert!(VolumeFormat::is_volume_path(Path::new("a.Msh")));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_wedge_through_gmsh_stays_in_vtk_order_and_positive() {
    let m = sample();
    let wedge = m.cells.cell(3).to_vec();
    let p: Vec<DVec3> = wedge.iter().map(|&v| m.points[v as usize]).collect();
    assert!(min_corner_det(CellKind::Wedge, &p) > 0.0);
    for f in [VolumeFormat::Msh, VolumeFormat::Msh22] {
        let bytes = m.to_bytes(f).unwrap();
        let back = VolumeMesh::from_bytes(&bytes, f, Path::new("w.msh")).unwrap();
        assert_eq!(back.cells.cell(3), wedge);
    }
    // The 2.2 file holds Gmsh's order: 1 9 2 then 5 10 6 (1-based: +1).
    let text = String::from_utf8(m.to_bytes(VolumeFormat::Msh22).unwrap()).unwrap();
    assert!(text.contains("\n4 6 2 1 1 2 10 3 6 11 7\n"), "{text}");
    // A prism as Gmsh makes it: bottom (0, 1, 2) turning toward the top.
    let gmsh = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n6\n1 0 0 0\n2 1 0 0\n3 0 1 0\n\
                4 0 0 1\n5 1 0 1\n6 0 1 1\n$EndNodes\n$Elements\n1\n1 6 2 0 1 1 2 3 4 5 6\n$EndElements\n";
    let m = VolumeMesh::from_bytes(gmsh.as_bytes(), VolumeFormat::Msh, Path::new("p.msh")).unwrap();
    assert_eq!(m.cells.cell(0), [0, 2, 1, 3, 5, 4]);
    let p: Vec<DVec3> = m
        .cells
        .cell(0)
        .iter()
        .map(|&v| m.points[v as usize])
        .collect();
    assert!(min_corner_det(CellKind::Wedge, &p) > 0.0);
}

const MSH22: &str = "$MeshFormat
2.2 0 8
$EndMeshFormat
$PhysicalNames
2
2 1 \"inlet\"
3 2 \"fluid region\"
$EndPhysicalNames
$Comments
anything, even $Nodes
$EndComments
$Nodes
5
10 0 0 0
20 1 0 0
30 0 1 0
40 0 0 1
7 1 1 1
$EndNodes
$Elements
3
1 2 2 1 5 10 30 20
2 4 2 2 1 10 20 30 40
3 15 2 0 3 7
$EndElements
$NodeData
1
\"temperature\"
1
0.0
3
0
1
5
10 1
20 1
30 1
40 1
7 1
$EndNodeData
";

const MSH41: &str = "$MeshFormat
4.1 0 8
$EndMeshFormat
$PhysicalNames
2
2 5 \"wall\"
3 6 \"air\"
$EndPhysicalNames
$Entities
0 0 1 1
3 0 0 0 1 1 0 1 5 3 1 2 3
1 0 0 -1 1 1 1 2 6 8 1 -3
$EndEntities
$Nodes
2 5 2 100
2 3 0 3
2
100
50
0 0 0
1 0 0
0 1 0
3 1 0 2
7
9
0 0 1
0 0 -1
$EndNodes
$Elements
2 3 1 3
2 3 2 1
1 2 100 50
3 1 4 2
2 2 50 100 7
3 2 50 100 9
$EndElements
$Periodic
0
$EndPeriodic
";

#[test]
fn gmsh_files_read_right() {
    let m =
        VolumeMesh::from_bytes(MSH22.as_bytes(), VolumeFormat::Msh, Path::new("a.msh")).unwrap();
    assert_eq!(m.points.len(), 5);
    assert_eq!(m.points[4], DVec3::ONE);
    assert_eq!(
        m.cells.kinds,
        [CellKind::Triangle, CellKind::Tetra, CellKind::Vertex]
    );
    assert_eq!(m.cells.cell(0), [0, 2, 1]);
    assert_eq!(m.cells.cell(1), [0, 1, 2, 3]);
    assert_eq!(m.cells.cell(2), [4]);
    assert_eq!(m.cell_zones, [1, 2, 0]);
    assert_eq!(
        m.zones,
        [
            Zone {
                name: "inlet".into(),
                tag: 1,
                dim: 2
            },
            Zone {
                name: "fluid region".into(),
                tag: 2,
                dim: 3
            },
        ]
    );

    let m =
        VolumeMesh::from_bytes(MSH41.as_bytes(), VolumeFormat::Msh, Path::new("b.msh")).unwrap();
    assert_eq!(m.points[1], DVec3::X);
    assert_eq!(m.points[4], -DVec3::Z);
    assert_eq!(m.cells.cell(0), [0, 1, 2]);
    assert_eq!(m.cells.cell(1), [0, 2, 1, 3]);
    assert_eq!(m.cells.cell(2), [0, 2, 1, 4]);
    assert_eq!(m.cell_zones, [5, 6, 6]);
    assert_eq!(m.zone("air").map(|z| z.dim), Some(3));
    assert_eq!(m.zone("wall").map(|z| z.tag), Some(5));
}

#[test]
fn gmsh_physical_tags_shared_by_two_dimensions_get_their_own_zones() {
    let text = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$PhysicalNames\n2\n2 1 \"inlet\"\n3 1 \"fluid\"\n\
                $EndPhysicalNames\n$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n$EndNodes\n\
                $Elements\n2\n1 2 2 1 1 1 3 2\n2 4 2 1 1 1 2 3 4\n$EndElements\n";
    let m = VolumeMesh::from_bytes(text.as_bytes(), VolumeFormat::Msh, Path::new("c.msh")).unwrap();
    assert_eq!(m.zone("inlet").map(|z| (z.tag, z.dim)), Some((1, 2)));
    assert_eq!(m.zone("fluid").map(|z| (z.tag, z.dim)), Some((2, 3)));
    assert_eq!(m.cell_zones, [1, 2]);
}

#[test]
fn the_bundled_gmsh_file_reads() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/volume/sphere_in_box.msh");
    // Bundled (made by scripts/make_volume_sample.py): its absence fails.
    let bytes = std::fs::read(&path).expect("assets/volume/sphere_in_box.msh is bundled");
    let m = VolumeMesh::from_bytes(&bytes, VolumeFormat::Msh, &path).unwrap();
    let names: Vec<&str> = m.zones.iter().map(|z| z.name.as_str()).collect();
    for z in ["outer", "inner", "fluid"] {
        assert!(names.contains(&z), "{names:?}");
    }
    let fluid = m.zone("fluid").unwrap().tag;
    let tets = m.zone_cells(fluid);
    assert!(!tets.is_empty());
    for c in tets {
        let p: Vec<DVec3> = m
            .cells
            .cell(c as usize)
            .iter()
            .map(|&v| m.points[v as usize])
            .collect();
        assert!(
            min_corner_det(m.cells.kinds[c as usize], &p) > 0.0,
            "cell {c}"
        );
    }
    for f in [VolumeFormat::Msh, VolumeFormat::Vtk, VolumeFormat::Vtu] {
        let back = VolumeMesh::from_bytes(&m.to_bytes(f).unwrap(), f, Path::new("x")).unwrap();
        assert_eq!(back, m, "{f:?}");
    }
}

/// As meshio 5 writes a Gmsh mesh to VTK (5.1 layout).
const VTK51: &str = "# vtk DataFile Version 5.1
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
const VTK42: &str = "# vtk DataFile Version 4.2
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

/// As ParaView writes ASCII VTU (information keys inside an array).
const VTU_ASCII: &str = r#"<?xml version="1.0"?>
<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" header_type="UInt64">
  <UnstructuredGrid>
    <Piece NumberOfPoints="4" NumberOfCells="1">
      <PointData>
        <DataArray type="Float64" Name="T" format="ascii" RangeMin="0" RangeMax="3">
          0 1 2 3
        </DataArray>
      </PointData>
      <CellData>
        <DataArray type="Int32" Name="zone" format="ascii" RangeMin="3" RangeMax="3">
          3
        </DataArray>
      </CellData>
      <Points>
        <DataArray type="Float32" Name="Points" NumberOfComponents="3" format="ascii" RangeMin="0" RangeMax="1">
          <InformationKey name="L2_NORM_RANGE" location="vtkDataArray" length="2">
            <Value index="0">
              0
            </Value>
            <Value index="1">
              1
            </Value>
          </InformationKey>
          0 0 0 1 0 0
          0 1 0 0 0 1
        </DataArray>
      </Points>
      <Cells>
        <DataArray type="Int64" Name="connectivity" format="ascii" RangeMin="0" RangeMax="3">
          0 1 2 3
        </DataArray>
        <DataArray type="Int64" Name="offsets" format="ascii" RangeMin="4" RangeMax="4">
          4
        </DataArray>
        <DataArray type="UInt8" Name="types" format="ascii" RangeMin="10" RangeMax="10">
          10
        </DataArray>
      </Cells>
    </Piece>
  </UnstructuredGrid>
</VTKFile>
"#;

/// Inline base64 with zlib blocks of 16 bytes and UInt32 headers, the
/// header and the blocks encoded apart (as VTK does); made with Python's
/// zlib and base64.
const VTU_ZLIB: &str = r#"<?xml version="1.0"?>
<VTKFile type="UnstructuredGrid" version="0.1" byte_order="LittleEndian" compressor="vtkZLibDataCompressor">
  <UnstructuredGrid>
    <FieldData>
      <DataArray type="Int32" Name="wall" NumberOfTuples="2" format="ascii">1 2</DataArray>
    </FieldData>
    <Piece NumberOfPoints="5" NumberOfCells="2">
      <Points>
        <DataArray type="Float32" Name="Points" NumberOfComponents="3" format="binary">
          BAAAABAAAAAMAAAADQAAAA0AAAANAAAADgAAAA==eJxjYEAGDfYAAU8AwHicY2BABg32AAFPAMB4nGNgQAYN9gABTwDAeJxjYGCwZ4BiAAO9AL4=
        </DataArray>
      </Points>
      <Cells>
        <DataArray type="Int32" Name="connectivity" format="binary">
          AgAAABAAAAAMAAAAEwAAABEAAAA=eJxjYGBgYARiJiBmBmIAADgAB3icY2BgYGACYkYgBgAAIAAE
        </DataArray>
        <DataArray type="Int32" Name="offsets" format="binary">
          AQAAABAAAAAIAAAADgAAAA==eJxjYWBgYAdiAABEAAw=
        </DataArray>
        <DataArray type="UInt8" Name="types" format="binary">
          AQAAABAAAAACAAAACgAAAA==eJzjYgUAABsAEA==
        </DataArray>
      </Cells>
      <CellData Scalars="gmsh:physical">
        <DataArray type="Int32" Name="gmsh:physical" format="binary">
          AQAAABAAAAAIAAAADgAAAA==eJxjZmBgYARiAAAkAAU=
        </DataArray>
      </CellData>
    </Piece>
  </UnstructuredGrid>
</VTKFile>
"#;

/// Appended raw data with UInt32 headers (no header_type: version 0.1),
/// Float32 points and Int32 indices, in either byte order.
fn appended_raw(big: bool) -> Vec<u8> {
    let order = if big { "BigEndian" } else { "LittleEndian" };
    let mut data = Vec::new();
    let mut offsets = Vec::new();
    let mut array = |bytes: Vec<u8>| {
        offsets.push(data.len());
        let n = bytes.len() as u32;
        data.extend_from_slice(&if big {
            n.to_be_bytes()
        } else {
            n.to_le_bytes()
        });
        data.extend_from_slice(&bytes);
    };
    let f32s = |v: &[f32]| -> Vec<u8> {
        v.iter()
            .flat_map(|x| {
                if big {
                    x.to_be_bytes()
                } else {
                    x.to_le_bytes()
                }
            })
            .collect()
    };
    let i32s = |v: &[i32]| -> Vec<u8> {
        v.iter()
            .flat_map(|x| {
                if big {
                    x.to_be_bytes()
                } else {
                    x.to_le_bytes()
                }
            })
            .collect()
    };
    array(f32s(&[
        0., 0., 0., 1., 0., 0., 0., 1., 0., 0., 0., 1., 0.25, 0.5, 2.,
    ]));
    array(i32s(&[0, 1, 2, 3, 4, 1, 0]));
    array(i32s(&[4, 7]));
    array(vec![10, 5]);
    array(i32s(&[11, 12]));
    let head = format!(
        r#"<?xml version="1.0"?>
<VTKFile type="UnstructuredGrid" version="0.1" byte_order="{order}">
  <UnstructuredGrid>
    <Piece NumberOfPoints="5" NumberOfCells="2">
      <Points>
        <DataArray type="Float32" Name="Points" NumberOfComponents="3" format="appended" offset="{}"/>
      </Points>
      <Cells>
        <DataArray type="Int32" Name="connectivity" format="appended" offset="{}"/>
        <DataArray type="Int32" Name="offsets" format="appended" offset="{}"/>
        <DataArray type="UInt8" Name="types" format="appended" offset="{}"/>
      </Cells>
      <CellData>
        <DataArray type="Int32" Name="CellEntityIds" format="appended" offset="{}"/>
      </CellData>
    </Piece>
  </UnstructuredGrid>
  <AppendedData encoding="raw">
   _"#,
        offsets[0], offsets[1], offsets[2], offsets[3], offsets[4]
    );
    let mut out = head.into_bytes();
    out.extend_from_slice(&data);
    out.extend_from_slice(b"\n  </AppendedData>\n</VTKFile>\n");
    out
}

#[test]
fn vtu_files_read_right() {
    let m = VolumeMesh::from_bytes(VTU_ASCII.as_bytes(), VolumeFormat::Vtu, Path::new("a.vtu"))
        .unwrap();
    assert_eq!(m.points, [DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z]);
    assert_eq!(m.cells.kinds, [CellKind::Tetra]);
    assert_eq!(m.cell_zones, [3]);
    assert_eq!(
        m.zones,
        [Zone {
            name: "zone 3".into(),
            tag: 3,
            dim: 3
        }]
    );

    let m =
        VolumeMesh::from_bytes(VTU_ZLIB.as_bytes(), VolumeFormat::Vtu, Path::new("b.vtu")).unwrap();
    assert_eq!(m.points[4], DVec3::splat(0.5));
    assert_eq!(m.cells.kinds, [CellKind::Tetra, CellKind::Triangle]);
    assert_eq!(m.cells.cell(1), [0, 2, 1]);
    assert_eq!(m.cell_zones, [3, 1]);
    assert_eq!(
        m.zones,
        [
            Zone {
                name: "wall".into(),
                tag: 1,
                dim: 2
            },
            Zone {
                name: "zone 3".into(),
                tag: 3,
                dim: 3
            },
        ]
    );

    for big in [false, true] {
        let m = VolumeMesh::from_bytes(&appended_raw(big), VolumeFormat::Vtu, Path::new("c.vtu"))
            .unwrap_or_else(|e| panic!("big {big}: {e}"));
        assert_eq!(m.points[4], DVec3::new(0.25, 0.5, 2.0));
        assert_eq!(m.cells.cell(0), [0, 1, 2, 3]);
        assert_eq!(m.cells.cell(1), [4, 1, 0]);
        assert_eq!(m.cell_zones, [11, 12]);
    }
}

#[test]
fn vtu_appended_base64_reads() {
    // The raw sample's data re-encoded as base64, each array apart.
    let raw = appended_raw(false);
    let text = String::from_utf8_lossy(&raw);
    let start = text.find("   _").unwrap() + 4;
    let data = &raw[start..raw.len() - "\n  </AppendedData>\n</VTKFile>\n".len()];
    let mut offsets = Vec::new();
    let mut encoded = Vec::new();
    let mut at = 0;
    while at < data.len() {
        let n = u32::from_le_bytes(data[at..at + 4].try_into().unwrap()) as usize;
        offsets.push(encoded.len());
        crate::base64::encode_into(&data[at..at + 4 + n], &mut encoded);
        at += 4 + n;
    }
    let mut head = text[..start].replace("encoding=\"raw\"", "encoding=\"base64\"");
    for (k, o) in offsets.iter().enumerate().rev() {
        let needle = format!("offset=\"{}\"", appended_offsets(&raw)[k]);
        head = head.replacen(&needle, &format!("offset=\"{o}\""), 1);
    }
    let mut file = head.into_bytes();
    file.extend_from_slice(&encoded);
    file.extend_from_slice(b"\n  </AppendedData>\n</VTKFile>\n");
    let m = VolumeMesh::from_bytes(&file, VolumeFormat::Vtu, Path::new("d.vtu")).unwrap();
    assert_eq!(m.cells.cell(1), [4, 1, 0]);
    assert_eq!(m.cell_zones, [11, 12]);
}

/// The offsets of a raw appended file's arrays, in order.
fn appended_offsets(raw: &[u8]) -> Vec<usize> {
    let text = String::from_utf8_lossy(raw);
    text.split("offset=\"")
        .skip(1)
        .map(|s| s[..s.find('"').unwrap()].parse().unwrap())
        .collect()
}

/// Asserts `bytes` is refused with the file named and `needle` said.
#[track_caller]
fn refused(bytes: &[u8], f: VolumeFormat, needle: &str) {
    let name = "bad.file";
    match VolumeMesh::from_bytes(bytes, f, Path::new(name)) {
        Ok(_) => panic!("read, but should be refused for {needle:?}"),
        Err(e) => {
            let e = e.to_string();
            assert!(
                e.starts_with(name) && e.contains(needle),
                "{needle:?} not in {e}"
            );
        }
    }
}

#[test]
fn truncated_files_are_refused() {
    let m = sample();
    for (name, f, bytes) in flavours(&m) {
        for cut in [bytes.len() / 3, bytes.len() / 2, bytes.len() * 9 / 10] {
            let r = VolumeMesh::from_bytes(&bytes[..cut], f, Path::new("cut.file"));
            let e = r
                .err()
                .unwrap_or_else(|| panic!("{name} {f:?} cut at {cut} read"));
            assert!(e.to_string().starts_with("cut.file"), "{e}");
        }
    }
}

#[test]
fn wrong_counts_are_refused() {
    refused(
        VTK51
            .replace("POINTS 5 double", "POINTS 6 double")
            .as_bytes(),
        VolumeFormat::Vtk,
        "",
    );
    refused(
        VTK42.replace("CELLS 2 11", "CELLS 2 12").as_bytes(),
        VolumeFormat::Vtk,
        "bad.file:",
    );
    refused(
        VTK42
            .replace("CELL_TYPES 2\n13\n5", "CELL_TYPES 1\n13\n")
            .as_bytes(),
        VolumeFormat::Vtk,
        "1 cell types for 2 cells",
    );
    refused(
        MSH41.replace("2 5 2 100", "2 6 2 100").as_bytes(),
        VolumeFormat::Msh,
        "$Nodes says 6 nodes, its blocks hold 5",
    );
    refused(
        VTU_ASCII
            .replace("NumberOfCells=\"1\"", "NumberOfCells=\"2\"")
            .as_bytes(),
        VolumeFormat::Vtu,
        "1 offsets and 1 types for 2 cells",
    );
    refused(
        MSH22.replace("$Elements\n3\n", "$Elements\n4\n").as_bytes(),
        VolumeFormat::Msh,
        "bad.file:",
    );
}

#[test]
fn node_indices_out_of_range_are_refused() {
    refused(
        VTK42.replace("3 3 4 5", "3 3 4 6").as_bytes(),
        VolumeFormat::Vtk,
        "a node of cell 1 is 6, but there are 6 nodes",
    );
    refused(
        VTK51
            .replace(
                "CONNECTIVITY vtktypeint64\n0",
                "CONNECTIVITY vtktypeint64\n-1",
            )
            .as_bytes(),
        VolumeFormat::Vtk,
        "a node of cell 0 is -1",
    );
    refused(
        MSH22
            .replace("1 2 2 1 5 10 30 20", "1 2 2 1 5 10 30 21")
            .as_bytes(),
        VolumeFormat::Msh,
        "element 1 names node 21, which $Nodes does not define",
    );
    refused(
        VTU_ASCII
            .replace(
                "0 1 2 3\n        </DataArray>\n        <DataArray type=\"Int64\" Name=\"offsets\"",
                "0 1 2 4\n        </DataArray>\n        <DataArray type=\"Int64\" Name=\"offsets\"",
            )
            .as_bytes(),
        VolumeFormat::Vtu,
        "is 4, but there are 4 nodes",
    );
}

#[test]
fn unknown_cell_types_are_refused_by_number_and_cell() {
    refused(
        VTK42.replace("13\n5\n", "13\n42\n").as_bytes(),
        VolumeFormat::Vtk,
        "cell 1 has VTK cell type 42 (polyhedron)",
    );
    refused(
        VTU_ASCII
            .replace(">\n          10\n", ">\n          24\n")
            .as_bytes(),
        VolumeFormat::Vtu,
        "cell 0 has VTK cell type 24",
    );
    refused(
        MSH22.replace("3 15 2 0 3 7", "3 200 2 0 3 7").as_bytes(),
        VolumeFormat::Msh,
        "element 3 has Gmsh element type 200",
    );
}

#[test]
fn second_order_cells_are_refused_by_name() {
    refused(
        MSH22
            .replace(
                "2 4 2 2 1 10 20 30 40",
                "2 11 2 2 1 10 20 30 40 1 2 3 4 5 6",
            )
            .as_bytes(),
        VolumeFormat::Msh,
        "second-order cells (Gmsh type 11, 10-node tetrahedron) at element 2: csrbf morphs linear cells only",
    );
    refused(
        MSH41.replace("3 1 4 2\n", "3 1 11 2\n").as_bytes(),
        VolumeFormat::Msh,
        "second-order cells (Gmsh type 11, 10-node tetrahedron) at element 2",
    );
}

#[test]
fn nan_coordinates_are_refused() {
    refused(
        VTK51.replace("0.1 0.2 0.3", "0.1 nan 0.3").as_bytes(),
        VolumeFormat::Vtk,
        "node 4 has a coordinate that is not a finite number",
    );
    refused(
        MSH22.replace("7 1 1 1", "7 1 NaN 1").as_bytes(),
        VolumeFormat::Msh,
        "node 4 has a coordinate",
    );
    let mut m = sample();
    m.points[2].y = f64::NAN;
    assert!(m.to_bytes(VolumeFormat::Vtu).is_err());
}

#[test]
fn huge_counts_are_refused_without_allocating() {
    let huge = "1152921504606846976"; // 2^60
    refused(
        VTK51
            .replace("POINTS 5", &format!("POINTS {huge}"))
            .as_bytes(),
        VolumeFormat::Vtk,
        "more than the file holds",
    );
    refused(
        VTK42
            .replace("CELLS 2 11", &format!("CELLS {huge} 11"))
            .as_bytes(),
        VolumeFormat::Vtk,
        "more than the file holds",
    );
    refused(
        MSH41
            .replace("2 5 2 100", &format!("2 {huge} 2 100"))
            .as_bytes(),
        VolumeFormat::Msh,
        "more than the file holds",
    );
    refused(
        MSH22
            .replace("$Nodes\n5", &format!("$Nodes\n{huge}"))
            .as_bytes(),
        VolumeFormat::Msh,
        "more than the file holds",
    );
    let m = sample();
    let mut bin = m.to_bytes(VolumeFormat::Vtk).unwrap();
    let at = bin.windows(7).position(|w| w == b"POINTS ").unwrap() + 7;
    let end = at + bin[at..].iter().position(|&b| b == b' ').unwrap();
    bin.splice(at..end, huge.bytes());
    refused(&bin, VolumeFormat::Vtk, "more than the file holds");
    // A raw appended header asking for 2^60 bytes.
    let mut raw = appended_raw(false);
    let o = raw.windows(4).position(|w| w == b"   _").unwrap() + 4;
    raw[o..o + 4].copy_from_slice(&0xF000_0000u32.to_le_bytes());
    refused(&raw, VolumeFormat::Vtu, "its header says 4026531840 bytes");
    let mut vtu = m.to_bytes(VolumeFormat::Vtu).unwrap();
    let o = vtu.windows(4).position(|w| w == b"   _").unwrap() + 4;
    vtu[o..o + 8].copy_from_slice(&(1u64 << 60).to_le_bytes());
    refused(
        &vtu,
        VolumeFormat::Vtu,
        "its header says 1152921504606846976 bytes",
    );
}

#[test]
fn other_files_are_refused_by_what_they_are() {
    refused(
        b"<?xml version=\"1.0\"?>\n<VTKFile",
        VolumeFormat::Vtk,
        "name it .vtu",
    );
    refused(
        b"$NOD\n1\n1 0 0 0\n$ENDNOD\n",
        VolumeFormat::Msh,
        "a Gmsh 1 file",
    );
    refused(
        b"$MeshFormat\n4.0 0 8\n$EndMeshFormat\n",
        VolumeFormat::Msh,
        "Gmsh format 4.0",
    );
    refused(
        b"<VTKFile type=\"PolyData\"><PolyData/></VTKFile>",
        VolumeFormat::Vtu,
        "PolyData",
    );
    refused(b"", VolumeFormat::Msh, "empty");
    refused(b"", VolumeFormat::Vtk, "bad.file");
    refused(b"", VolumeFormat::Vtu, "bad.file");
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

#[test]
fn vtu_pieces_are_joined() {
    let piece = |z: &str| {
        format!(
            r#"<Piece NumberOfPoints="3" NumberOfCells="1"><Points><DataArray type="Float64" NumberOfComponents="3">0 0 0 1 0 0 0 1 0</DataArray></Points>
<Cells><DataArray type="Int32" Name="connectivity">0 1 2</DataArray><DataArray type="Int32" Name="offsets">3</DataArray>
<DataArray type="UInt8" Name="types">5</DataArray></Cells>{z}</Piece>"#
        )
    };
    let text = format!(
        r#"<VTKFile type="UnstructuredGrid"><UnstructuredGrid>{}{}</UnstructuredGrid></VTKFile>"#,
        piece(""),
        piece(r#"<CellData><DataArray type="Int32" Name="cell_zone">4</DataArray></CellData>"#)
    );
    let m = VolumeMesh::from_bytes(text.as_bytes(), VolumeFormat::Vtu, Path::new("p.vtu")).unwrap();
    assert_eq!(m.points.len(), 6);
    assert_eq!(m.cells.cell(1), [3, 4, 5]);
    assert_eq!(m.cell_zones, [0, 4]);
    assert_eq!(
        m.zones,
        [Zone {
            name: "zone 4".into(),
            tag: 4,
            dim: 2
        }]
    );
}
