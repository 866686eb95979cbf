//! Writing: 4.1 or 2.2, binary or ASCII.

use std::collections::HashMap;

use super::PRISM;
use crate::volume::scan;
use crate::volume::{CellKind, VolumeMesh};

/// A Gmsh file being written: numbers as words or as binary.
struct Out {
    buf: Vec<u8>,
    binary: bool,
}

impl Out {
    fn text(&mut self, s: &str) {
        self.buf.extend_from_slice(s.as_bytes());
    }

    fn word(&mut self, s: &str) {
        self.text(s);
        self.buf.push(b' ');
    }

    fn int(&mut self, v: i64) {
        if self.binary {
            self.buf.extend_from_slice(&(v as i32).to_le_bytes());
        } else {
            self.word(&v.to_string());
        }
    }

    fn size(&mut self, v: u64) {
        if self.binary {
            self.buf.extend_from_slice(&v.to_le_bytes());
        } else {
            self.word(&v.to_string());
        }
    }

    fn real(&mut self, v: f64) {
        if self.binary {
            self.buf.extend_from_slice(&v.to_le_bytes());
        } else {
            let mut s = String::new();
            scan::push_f64(&mut s, v);
            self.word(&s);
        }
    }

    /// Ends a record: the line in text.
    fn end(&mut self) {
        if !self.binary {
            if self.buf.last() == Some(&b' ') {
                self.buf.pop();
            }
            self.buf.push(b'\n');
        }
    }

    /// Starts a section's body (binary data starts after its line).
    fn section(&mut self, name: &str) {
        self.text(&format!("${name}\n"));
    }

    fn end_section(&mut self, name: &str) {
        if self.binary {
            self.buf.push(b'\n');
        }
        self.text(&format!("$End{name}\n"));
    }
}

/// Writes a Gmsh file: 4.1 or 2.2, binary or ASCII.
pub(in crate::volume) fn write(mesh: &VolumeMesh, v4: bool, binary: bool) -> Vec<u8> {
    let mut o = Out {
        buf: Vec::new(),
        binary: false,
    };
    let zone = |c: usize| mesh.cell_zones.get(c).copied().unwrap_or(0);
    // One entity per (dimension, zone), numbered per dimension.
    let mut entity: HashMap<(u8, i32), i64> = HashMap::new();
    let mut per_dim = [Vec::new(), Vec::new(), Vec::new(), Vec::new()];
    for (c, k) in mesh.cells.kinds.iter().enumerate() {
        let key = (k.dim(), zone(c));
        entity.entry(key).or_insert_with(|| {
            let list: &mut Vec<i32> = &mut per_dim[k.dim() as usize];
            list.push(key.1);
            list.len() as i64
        });
    }
    o.section("MeshFormat");
    o.text(if v4 { "4.1" } else { "2.2" });
    o.text(if binary { " 1 8\n" } else { " 0 8\n" });
    if binary {
        o.buf.extend_from_slice(&1i32.to_le_bytes());
        o.buf.push(b'\n');
    }
    o.text("$EndMeshFormat\n");
    if !mesh.zones.is_empty() {
        o.section("PhysicalNames");
        o.text(&format!("{}\n", mesh.zones.len()));
        for z in &mesh.zones {
            // A name cannot hold a double quote in Gmsh's files.
            o.text(&format!(
                "{} {} \"{}\"\n",
                z.dim,
                z.tag,
                z.name.replace('"', "'")
            ));
        }
        o.text("$EndPhysicalNames\n");
    }
    o.binary = binary;
    let (lo, hi) = mesh.points.iter().fold(
        (
            glam::DVec3::splat(f64::INFINITY),
            glam::DVec3::splat(f64::NEG_INFINITY),
        ),
        |(lo, hi), &p| (lo.min(p), hi.max(p)),
    );
    let (lo, hi) = if mesh.points.is_empty() {
        (glam::DVec3::ZERO, glam::DVec3::ZERO)
    } else {
        (lo, hi)
    };
    if v4 {
        o.section("Entities");
        for list in &per_dim {
            o.size(list.len() as u64);
        }
        o.end();
        for (dim, list) in per_dim.iter().enumerate() {
            for (k, &z) in list.iter().enumerate() {
                o.int(k as i64 + 1);
                for v in lo.to_array() {
                    o.real(v);
                }
                if dim > 0 {
                    for v in hi.to_array() {
                        o.real(v);
                    }
                }
                o.size(u64::from(z != 0));
                if z != 0 {
                    o.int(z as i64);
                }
                if dim > 0 {
                    o.size(0);
                }
                o.end();
            }
        }
        o.end_section("Entities");
        // Every node in one block, on the first entity of the highest
        // dimension.
        o.section("Nodes");
        let n = mesh.points.len() as u64;
        let blocks = u64::from(n > 0);
        for v in [blocks, n, n.min(1), n] {
            o.size(v);
        }
        o.end();
        if n > 0 {
            let dim = (0..4).rev().find(|&d| !per_dim[d].is_empty()).unwrap_or(3);
            for v in [dim as i64, 1, 0] {
                o.int(v);
            }
            o.size(n);
            o.end();
            for t in 1..=n {
                o.size(t);
                o.end();
            }
            for p in &mesh.points {
                for v in p.to_array() {
                    o.real(v);
                }
                o.end();
            }
        }
        o.end_section("Nodes");
        // Element blocks: runs of cells of one kind and entity.
        o.section("Elements");
        let c = &mesh.cells;
        let mut runs: Vec<(usize, usize)> = Vec::new();
        for k in 0..c.len() {
            let same = |a: usize| c.kinds[a] == c.kinds[k] && zone(a) == zone(k);
            match runs.last_mut() {
                Some((s, e)) if *e == k && same(*s) => *e += 1,
                _ => runs.push((k, k + 1)),
            }
        }
        let m = c.len() as u64;
        for v in [runs.len() as u64, m, m.min(1), m] {
            o.size(v);
        }
        o.end();
        for &(s, e) in &runs {
            let kind = c.kinds[s];
            o.int(kind.dim() as i64);
            o.int(entity.get(&(kind.dim(), zone(s))).copied().unwrap_or(1));
            o.int(kind.gmsh_type() as i64);
            o.size((e - s) as u64);
            o.end();
            for k in s..e {
                o.size(k as u64 + 1);
                for v in gmsh_nodes(kind, c.cell(k)) {
                    o.size(v as u64 + 1);
                }
                o.end();
            }
        }
        o.end_section("Elements");
        return o.buf;
    }
    o.binary = false;
    o.text(&format!("$Nodes\n{}\n", mesh.points.len()));
    o.binary = binary;
    for (i, p) in mesh.points.iter().enumerate() {
        o.int(i as i64 + 1);
        for v in p.to_array() {
            o.real(v);
        }
        o.end();
    }
    o.end_section("Nodes");
    o.binary = false;
    o.text(&format!("$Elements\n{}\n", mesh.cells.len()));
    o.binary = binary;
    let c = &mesh.cells;
    let mut k = 0;
    while k < c.len() {
        let kind = c.kinds[k];
        let run = if binary {
            (k..c.len()).take_while(|&j| c.kinds[j] == kind).count()
        } else {
            1
        };
        if binary {
            for v in [kind.gmsh_type() as i64, run as i64, 2] {
                o.int(v);
            }
        }
        for j in k..k + run {
            o.int(j as i64 + 1);
            if !binary {
                o.int(kind.gmsh_type() as i64);
                o.int(2);
            }
            o.int(zone(j) as i64);
            o.int(entity.get(&(kind.dim(), zone(j))).copied().unwrap_or(1));
            for v in gmsh_nodes(kind, c.cell(j)) {
                o.int(v as i64 + 1);
            }
            o.end();
        }
        k += run;
    }
    o.end_section("Elements");
    o.buf
}

/// A cell's nodes in Gmsh's order.
fn gmsh_nodes(kind: CellKind, nodes: &[u32]) -> Vec<u32> {
    if kind == CellKind::Wedge {
        PRISM.iter().map(|&p| nodes[p]).collect()
    } else {
        nodes.to_vec()
    }
}
