//! Writing: version 4.2, ASCII or BINARY (big-endian).

use crate::volume::VolumeMesh;
use crate::volume::scan::{self, ZONE_ARRAY};

/// A name as a legacy file can hold it: one word, `%XX` for what is not a
/// printable character other than `%`.
pub(super) fn encode_name(name: &str) -> String {
    let mut out = String::new();
    for &b in name.as_bytes() {
        if b.is_ascii_graphic() && b != b'%' {
            out.push(b as char);
        } else {
            out.push_str(&format!("%{b:02X}"));
        }
    }
    if out.is_empty() { "%00".into() } else { out }
}

/// Writes a legacy file: ASCII, or BINARY (big-endian).
pub(in crate::volume) fn write(mesh: &VolumeMesh, binary: bool) -> Vec<u8> {
    let mut out = Out {
        buf: Vec::new(),
        binary,
        text: String::new(),
    };
    out.head(&format!(
        "# vtk DataFile Version 4.2\ncsrbf volume mesh\n{}\nDATASET UNSTRUCTURED_GRID\n",
        if binary { "BINARY" } else { "ASCII" }
    ));
    if !mesh.zones.is_empty() {
        out.head(&format!("FIELD FieldData {}\n", mesh.zones.len()));
        for z in &mesh.zones {
            out.head(&format!("{} 1 2 int\n", encode_name(&z.name)));
            out.ints(&[z.tag as i64, z.dim as i64]);
        }
    }
    out.head(&format!("POINTS {} double\n", mesh.points.len()));
    if binary {
        for p in &mesh.points {
            for v in p.to_array() {
                out.buf.extend_from_slice(&v.to_be_bytes());
            }
        }
        out.buf.push(b'\n');
    } else {
        for p in &mesh.points {
            for (i, v) in p.to_array().into_iter().enumerate() {
                scan::push_f64(&mut out.text, v);
                out.text.push(if i == 2 { '\n' } else { ' ' });
            }
        }
        out.flush();
    }
    let c = &mesh.cells;
    out.head(&format!("CELLS {} {}\n", c.len(), c.len() + c.nodes.len()));
    let mut list = Vec::with_capacity(c.len() + c.nodes.len());
    for (_, nodes) in c.iter() {
        list.push(nodes.len() as i64);
        list.extend(nodes.iter().map(|&v| v as i64));
    }
    out.rows(&list, c.iter().map(|(_, n)| n.len() + 1));
    out.head(&format!("CELL_TYPES {}\n", c.len()));
    let types: Vec<i64> = c.kinds.iter().map(|k| k.vtk_type() as i64).collect();
    out.ints(&types);
    if !mesh.zones.is_empty() || !mesh.cell_zones.is_empty() {
        out.head(&format!(
            "CELL_DATA {}\nSCALARS {ZONE_ARRAY} int 1\nLOOKUP_TABLE default\n",
            c.len()
        ));
        let tags: Vec<i64> = if mesh.cell_zones.is_empty() {
            vec![0; c.len()]
        } else {
            mesh.cell_zones.iter().map(|&t| t as i64).collect()
        };
        out.ints(&tags);
    }
    out.buf
}

/// A legacy file being written.
struct Out {
    buf: Vec<u8>,
    binary: bool,
    text: String,
}

impl Out {
    fn head(&mut self, s: &str) {
        self.buf.extend_from_slice(s.as_bytes());
    }

    fn flush(&mut self) {
        self.buf.extend_from_slice(self.text.as_bytes());
        self.text.clear();
    }

    /// Integers as 32-bit (binary) or one line of at most 9 each (ASCII).
    fn ints(&mut self, v: &[i64]) {
        let rows = std::iter::repeat_n(9, v.len().div_ceil(9));
        self.rows(v, rows);
    }

    /// Integers; in ASCII, `rows` gives how many go on each line.
    fn rows(&mut self, v: &[i64], rows: impl Iterator<Item = usize>) {
        if self.binary {
            for &x in v {
                self.buf.extend_from_slice(&(x as i32).to_be_bytes());
            }
            self.buf.push(b'\n');
            return;
        }
        let mut i = 0;
        for n in rows {
            let end = (i + n).min(v.len());
            for (k, x) in v[i..end].iter().enumerate() {
                if k > 0 {
                    self.text.push(' ');
                }
                self.text.push_str(&x.to_string());
            }
            self.text.push('\n');
            i = end;
        }
        self.flush();
    }
}
