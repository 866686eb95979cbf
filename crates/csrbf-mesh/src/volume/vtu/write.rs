//! Writing: every array appended raw (or ASCII, or inline base64 in
//! tests), UInt64 headers, little-endian.

use crate::volume::VolumeMesh;
use crate::volume::scan::{self, ZONE_ARRAY};

/// Bytes per block of compressed data, as VTK writes them.
const BLOCK: usize = 32768;

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// How the arrays are written.
#[derive(Clone, Copy, Debug)]
pub(in crate::volume) enum Encoding {
    /// Numbers as text.
    Ascii,
    /// Base64 inside each `DataArray`.
    #[cfg_attr(not(test), allow(dead_code))]
    Inline { zlib: bool },
    /// Raw bytes in `<AppendedData>`.
    Appended { zlib: bool },
}

/// An array to write: its name, type, components, and little-endian bytes
/// or text.
struct Data {
    name: &'static str,
    ty: &'static str,
    comps: usize,
    bytes: Vec<u8>,
    text: String,
}

/// The header and data of one array in a binary file (UInt64 headers).
fn block(data: &[u8], zlib: bool) -> (Vec<u8>, Vec<u8>) {
    let mut head = Vec::new();
    if !zlib {
        head.extend_from_slice(&(data.len() as u64).to_le_bytes());
        return (head, data.to_vec());
    }
    let chunks: Vec<Vec<u8>> = data
        .chunks(BLOCK)
        .map(|c| miniz_oxide::deflate::compress_to_vec_zlib(c, 6))
        .collect();
    for v in [chunks.len(), BLOCK, data.len() % BLOCK] {
        head.extend_from_slice(&(v as u64).to_le_bytes());
    }
    for c in &chunks {
        head.extend_from_slice(&(c.len() as u64).to_le_bytes());
    }
    (head, chunks.concat())
}

pub(in crate::volume) fn write(mesh: &VolumeMesh, enc: Encoding) -> Vec<u8> {
    let ascii = matches!(enc, Encoding::Ascii);
    let c = &mesh.cells;
    let mut arrays = Vec::new();
    let mut add = |name, ty, comps, vals: &mut dyn Iterator<Item = (Vec<u8>, String)>| {
        let mut d = Data {
            name,
            ty,
            comps,
            bytes: Vec::new(),
            text: String::new(),
        };
        for (k, (b, t)) in vals.enumerate() {
            if ascii {
                d.text.push(if k % 9 == 0 { '\n' } else { ' ' });
                d.text.push_str(&t);
            } else {
                d.bytes.extend_from_slice(&b);
            }
        }
        arrays.push(d);
    };
    let f = |v: f64| {
        let mut s = String::new();
        scan::push_f64(&mut s, v);
        (
            v.to_le_bytes().to_vec(),
            if ascii { s } else { String::new() },
        )
    };
    let i = |v: i64| {
        (
            v.to_le_bytes().to_vec(),
            if ascii { v.to_string() } else { String::new() },
        )
    };
    add(
        "Points",
        "Float64",
        3,
        &mut mesh.points.iter().flat_map(|p| p.to_array()).map(f),
    );
    add(
        "connectivity",
        "Int64",
        1,
        &mut c.nodes.iter().map(|&v| i(v as i64)),
    );
    add(
        "offsets",
        "Int64",
        1,
        &mut c.offsets[1..].iter().map(|&v| i(v as i64)),
    );
    add(
        "types",
        "UInt8",
        1,
        &mut c
            .kinds
            .iter()
            .map(|k| (vec![k.vtk_type()], k.vtk_type().to_string())),
    );
    let zoned = !mesh.zones.is_empty() || !mesh.cell_zones.is_empty();
    if zoned {
        let tags = (0..c.len()).map(|k| mesh.cell_zones.get(k).copied().unwrap_or(0));
        add(
            ZONE_ARRAY,
            "Int32",
            1,
            &mut tags.map(|t| (t.to_le_bytes().to_vec(), t.to_string())),
        );
    }
    let mut out = String::new();
    let mut appended: Vec<u8> = Vec::new();
    out.push_str("<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\"");
    if matches!(
        enc,
        Encoding::Inline { zlib: true } | Encoding::Appended { zlib: true }
    ) {
        out.push_str(" compressor=\"vtkZLibDataCompressor\"");
    }
    out.push_str(">\n  <UnstructuredGrid>\n");
    if !mesh.zones.is_empty() {
        out.push_str("    <FieldData>\n");
        for z in &mesh.zones {
            out.push_str(&format!(
                "      <DataArray type=\"Int32\" Name=\"{}\" NumberOfTuples=\"2\" format=\"ascii\">{} {}</DataArray>\n",
                escape(&z.name),
                z.tag,
                z.dim
            ));
        }
        out.push_str("    </FieldData>\n");
    }
    out.push_str(&format!(
        "    <Piece NumberOfPoints=\"{}\" NumberOfCells=\"{}\">\n",
        mesh.points.len(),
        c.len()
    ));
    for (k, a) in arrays.iter().enumerate() {
        let open = match k {
            0 => "      <Points>\n",
            1 => "      <Cells>\n",
            4 => "      <CellData>\n",
            _ => "",
        };
        out.push_str(open);
        out.push_str(&format!(
            "        <DataArray type=\"{}\" Name=\"{}\" NumberOfComponents=\"{}\" format=\"{}\"",
            a.ty,
            a.name,
            a.comps,
            match enc {
                Encoding::Ascii => "ascii",
                Encoding::Inline { .. } => "binary",
                Encoding::Appended { .. } => "appended",
            }
        ));
        match enc {
            Encoding::Ascii => {
                out.push('>');
                out.push_str(&a.text);
                out.push_str("\n        </DataArray>\n");
            }
            Encoding::Inline { zlib } => {
                let (head, data) = block(&a.bytes, zlib);
                let mut text = Vec::new();
                if zlib {
                    crate::base64::encode_into(&head, &mut text);
                    crate::base64::encode_into(&data, &mut text);
                } else {
                    crate::base64::encode_into(&[head, data].concat(), &mut text);
                }
                out.push_str(">\n          ");
                out.push_str(&String::from_utf8_lossy(&text));
                out.push_str("\n        </DataArray>\n");
            }
            Encoding::Appended { zlib } => {
                out.push_str(&format!(" offset=\"{}\"/>\n", appended.len()));
                let (head, data) = block(&a.bytes, zlib);
                appended.extend_from_slice(&head);
                appended.extend_from_slice(&data);
            }
        }
        let close = match k {
            0 => "      </Points>\n",
            3 => "      </Cells>\n",
            4 => "      </CellData>\n",
            _ => "",
        };
        out.push_str(close);
    }
    out.push_str("    </Piece>\n  </UnstructuredGrid>\n");
    let mut bytes = out.into_bytes();
    if let Encoding::Appended { .. } = enc {
        bytes.extend_from_slice(b"  <AppendedData encoding=\"raw\">\n   _");
        bytes.extend_from_slice(&appended);
        bytes.extend_from_slice(b"\n  </AppendedData>\n");
    }
    bytes.extend_from_slice(b"</VTKFile>\n");
    bytes
}
