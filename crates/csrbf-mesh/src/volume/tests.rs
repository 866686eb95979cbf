//! The volume readers and writers: round trips through every format and
//! flavour, hostile inputs; the files as meshio, Gmsh and ParaView write
//! them are in each format's tests.

use std::path::Path;

use glam::DVec3;

use super::msh::tests::{MSH22, MSH41};
use super::vtk::tests::{VTK42, VTK51};
use super::vtu::tests::{VTU_ASCII, VTU_ZLIB, appended_raw};
use super::{CellKind, VolumeFormat, VolumeMesh, Zone, msh, vtu};

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

/// Asserts `bytes` is refused with the file named and `needle` said.
#[track_caller]
pub(crate) fn refused(bytes: &[u8], f: VolumeFormat, needle: &str) {
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
