//! VTK XML files as ParaView and VTK write them: ASCII, inline zlib,
//! appended raw and base64, either byte order, several pieces.

use std::path::Path;

use glam::DVec3;

use crate::volume::{CellKind, VolumeFormat, VolumeMesh, Zone};

/// As ParaView writes ASCII VTU (information keys inside an array).
pub(crate) const VTU_ASCII: &str = r#"<?xml version="1.0"?>
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
pub(crate) const VTU_ZLIB: &str = r#"<?xml version="1.0"?>
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
pub(crate) fn appended_raw(big: bool) -> Vec<u8> {
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
