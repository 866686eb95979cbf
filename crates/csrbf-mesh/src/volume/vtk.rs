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

use std::path::Path;

use super::scan::{self, Binary, Cursor, Scalar, ZONE_ARRAY, ZONE_ARRAYS};
use super::{CellKind, Cells, VolumeMesh, Zone};
use crate::Result;

/// A legacy type name's scalar type; `None` for `bit` and strings.
fn scalar(name: &str) -> Option<Scalar> {
    Some(match name.to_ascii_lowercase().as_str() {
        // VTK 5.1 also names them by size (meshio writes `vtktypeint32`).
        "char" | "signed_char" | "vtktypeint8" => Scalar::I8,
        "unsigned_char" | "vtktypeuint8" => Scalar::U8,
        "short" | "vtktypeint16" => Scalar::I16,
        "unsigned_short" | "vtktypeuint16" => Scalar::U16,
        "int" | "vtkidtype" | "vtktypeint32" => Scalar::I32,
        "unsigned_int" | "vtktypeuint32" => Scalar::U32,
        "long" | "vtktypeint64" => Scalar::I64,
        "unsigned_long" | "vtktypeuint64" => Scalar::U64,
        "float" | "vtktypefloat32" => Scalar::F32,
        "double" | "vtktypefloat64" => Scalar::F64,
        _ => return None,
    })
}

/// Reads the values of arrays in an ASCII or a BINARY file.
struct Reader<'a> {
    c: Cursor<'a>,
    binary: bool,
}

/// An array's values, as read.
enum Values<'a> {
    Text(Vec<&'a [u8]>),
    Binary(Binary<'a>),
}

impl<'a> Reader<'a> {
    fn keyword(&mut self, what: &str) -> Result<String> {
        Ok(self.c.text(what)?.to_ascii_lowercase())
    }

    /// `n` values of the type named `ty` (after its header line).
    fn values(&mut self, n: usize, ty: &str, what: &str) -> Result<Values<'a>> {
        let lower = ty.to_ascii_lowercase();
        if self.binary {
            self.c.end_line();
            if lower == "bit" {
                self.c.take(n.div_ceil(8), what)?;
                return Ok(Values::Text(Vec::new()));
            }
            let s = scalar(&lower).ok_or_else(|| {
                self.c
                    .error(format!("{what}: type {ty:?} is not one csrbf reads"))
            })?;
            return Ok(Values::Binary(self.c.binary(n, s, true, what)?));
        }
        if scalar(&lower).is_none() && lower != "bit" {
            return Err(self
                .c
                .error(format!("{what}: type {ty:?} is not one csrbf reads")));
        }
        let n = self.c.fits(n as u64, 2, what)?;
        let mut words = Vec::with_capacity(n.min(self.c.left() / 2 + 1));
        for _ in 0..n {
            match self.c.word() {
                Some(w) => words.push(w),
                None => {
                    return Err(self
                        .c
                        .error(format!("the file ends inside {what}: {n} values expected")));
                }
            }
        }
        Ok(Values::Text(words))
    }

    fn floats(&mut self, n: usize, ty: &str, what: &str) -> Result<Vec<f64>> {
        let start = self.c.pos;
        match self.values(n, ty, what)? {
            Values::Binary(b) => Ok(b.f64s().collect()),
            Values::Text(words) => words
                .iter()
                .map(|w| {
                    std::str::from_utf8(w)
                        .ok()
                        .and_then(|s| s.parse::<f64>().ok())
                        .ok_or_else(|| self.bad_word(start, w, what))
                })
                .collect(),
        }
    }

    fn ints(&mut self, n: usize, ty: &str, what: &str) -> Result<Vec<i64>> {
        let start = self.c.pos;
        if scalar(ty).is_none_or(|s| s.is_float()) {
            return Err(self.c.error(format!("{what} must be integers, not {ty:?}")));
        }
        match self.values(n, ty, what)? {
            Values::Binary(b) => b.i64s(self.c.path, what),
            Values::Text(words) => words
                .iter()
                .map(|w| {
                    std::str::from_utf8(w)
                        .ok()
                        .and_then(|s| s.parse::<i64>().ok())
                        .ok_or_else(|| self.bad_word(start, w, what))
                })
                .collect(),
        }
    }

    /// The error for a word that is not a number, at its line.
    fn bad_word(&self, from: usize, w: &[u8], what: &str) -> crate::MeshError {
        let at = w.as_ptr() as usize - self.c.bytes.as_ptr() as usize;
        let line = self.c.line_at(at.max(from));
        crate::MeshError::parse(
            self.c.path,
            Some(line),
            format!(
                "{what}: {:?} is not a valid number",
                String::from_utf8_lossy(w)
            ),
        )
    }

    /// Skips VTK 8's `METADATA` block after an array (ended by a blank
    /// line), if there is one.
    fn skip_metadata(&mut self) {
        let at = self.c.pos;
        if self
            .c
            .word()
            .is_some_and(|w| w.eq_ignore_ascii_case(b"METADATA"))
        {
            self.c.end_line();
            while self.c.left() > 0 && !self.c.rest_of_line().is_empty() {}
        } else {
            self.c.pos = at;
        }
    }

    /// A `FIELD name k` block: each array `name ncomp ntuples type` and its
    /// values; calls `keep` with each integer array's name, components and
    /// values.
    fn field(&mut self, mut keep: impl FnMut(String, usize, Vec<i64>)) -> Result<()> {
        self.c.text("the field data's name")?;
        let k = self.c.count("the number of field arrays", 4)?;
        for _ in 0..k {
            let name = self.c.text("a field array's name")?;
            if name == "NULL_ARRAY" {
                continue;
            }
            let name = decode_name(name);
            let comps = self.c.count("the number of components", 1)?;
            let tuples = self.c.count("the number of tuples", 1)?;
            let ty = self.c.text("the field array's type")?;
            let n = comps.checked_mul(tuples).ok_or_else(|| {
                self.c.error(format!(
                    "field array {name:?} is too large: {comps} × {tuples}"
                ))
            })?;
            let what = format!("field array {name:?}");
            if scalar(ty).is_some_and(|s| !s.is_float()) {
                let values = self.ints(n, ty, &what)?;
                keep(name, comps, values);
            } else {
                self.values(n, ty, &what)?;
            }
            self.skip_metadata();
        }
        Ok(())
    }
}

/// A legacy array name: `%XX` stands for the byte XX (how VTK writes
/// spaces and other special characters).
fn decode_name(name: &str) -> String {
    let b = name.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let hex = b
            .get(i + 1..i + 3)
            .and_then(|h| std::str::from_utf8(h).ok())
            .and_then(|h| u8::from_str_radix(h, 16).ok());
        match (b[i], hex) {
            (b'%', Some(v)) => {
                out.push(v);
                i += 3;
            }
            (c, _) => {
                out.push(c);
                i += 1;
            }
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// A name as a legacy file can hold it: one word, `%XX` for what is not a
/// printable character other than `%`.
fn encode_name(name: &str) -> String {
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
pub(super) fn build_cells(
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

pub(super) fn read(bytes: &[u8], path: &Path) -> Result<VolumeMesh> {
    let mut r = Reader {
        c: Cursor::new(bytes, path),
        binary: false,
    };
    let head = r.c.rest_of_line();
    if !head.starts_with(b"# vtk DataFile") {
        let xml = bytes.trim_ascii_start().starts_with(b"<");
        return Err(r.c.error(if xml {
            "this is a VTK XML file, not a legacy one: name it .vtu".to_string()
        } else {
            "not a VTK legacy file: it does not start with \"# vtk DataFile Version\"".into()
        }));
    }
    r.c.end_line(); // the title
    let mode = r.keyword("ASCII or BINARY")?;
    r.binary = match mode.as_str() {
        "ascii" => false,
        "binary" => true,
        _ => return Err(r.c.error(format!("expected ASCII or BINARY, not {mode:?}"))),
    };
    if r.keyword("DATASET")? != "dataset" {
        return Err(r.c.error("expected DATASET UNSTRUCTURED_GRID"));
    }
    let dataset = r.c.text("the dataset's type")?.to_ascii_uppercase();
    match dataset.as_str() {
        "UNSTRUCTURED_GRID" => {}
        "POLYDATA" => {
            return Err(r.c.error(
                "csrbf reads unstructured grids from .vtk; this file holds POLYDATA: \
                 read it as a surface mesh (convert it to .ply or .obj)",
            ));
        }
        other => {
            return Err(r.c.error(format!(
                "csrbf reads unstructured grids from .vtk; this file holds {other}: \
                 convert it to an unstructured grid (ParaView, meshio)"
            )));
        }
    }
    let mut mesh = VolumeMesh::default();
    let mut named: Vec<Zone> = Vec::new();
    let mut zone_array: Option<(usize, Vec<i64>, usize)> = None; // rank, values, line
    let mut cells: Option<(Vec<i64>, Vec<i64>, usize)> = None; // offsets, conn, line
    let mut types: Option<Vec<i64>> = None;
    let mut section = ""; // "", "cell" or "point" data
    let mut count = 0usize; // values per array in that section
    while let Some(word) = r.c.peek_word() {
        let key = r.keyword("a keyword")?;
        let line = r.c.line_at(r.c.pos);
        match key.as_str() {
            "field" if section.is_empty() => r.field(|name, _, v| {
                if let [tag, dim] = v[..]
                    && let (Ok(tag), Ok(dim)) = (i32::try_from(tag), u8::try_from(dim))
                    && tag != 0
                    && dim <= 3
                {
                    named.push(Zone { name, tag, dim });
                }
            })?,
            "points" => {
                let n = r.c.count("the number of points", 3)?;
                let ty = r.c.text("the points' type")?;
                let v = r.floats(n.saturating_mul(3), ty, "the points")?;
                mesh.points = v
                    .chunks_exact(3)
                    .map(|p| glam::DVec3::new(p[0], p[1], p[2]))
                    .collect();
                r.skip_metadata();
            }
            "cells" => {
                let (offsets, conn) = read_cells(&mut r)?;
                cells = Some((offsets, conn, line));
            }
            "cell_types" => {
                let n = r.c.count("the number of cell types", 1)?;
                types = Some(r.ints(n, "int", "the cell types")?);
            }
            "cell_data" | "point_data" => {
                count = r.c.count("the number of values", 1)?;
                section = if key == "cell_data" { "cell" } else { "point" };
            }
            "metadata" => {
                r.c.end_line();
                while r.c.left() > 0 && !r.c.rest_of_line().is_empty() {}
            }
            _ if section.is_empty() => {
                return Err(r.c.error(format!(
                    "unexpected {:?} in an unstructured grid",
                    String::from_utf8_lossy(word)
                )));
            }
            _ => {
                let mut found = |name: String, comps: usize, v: Vec<i64>, line: usize| {
                    let rank = ZONE_ARRAYS.iter().position(|&z| z == name);
                    if let Some(rank) = rank
                        && section == "cell"
                        && comps == 1
                        && zone_array.as_ref().is_none_or(|z| rank < z.0)
                    {
                        zone_array = Some((rank, v, line));
                    }
                };
                attribute(&mut r, &key, count, line, &mut found)?;
            }
        }
    }
    let Some((offsets, conn, line)) = cells else {
        return Err(r.c.error("the file has no CELLS"));
    };
    let types = types.ok_or_else(|| r.c.error("the file has no CELL_TYPES"))?;
    mesh.cells = build_cells(&offsets, &conn, &types, mesh.points.len())
        .map_err(|m| crate::MeshError::parse(path, Some(line), m))?;
    if let Some((_, v, line)) = zone_array {
        if v.len() != mesh.cells.len() {
            return Err(crate::MeshError::parse(
                path,
                Some(line),
                format!("{} zone values for {} cells", v.len(), mesh.cells.len()),
            ));
        }
        mesh.cell_zones = v
            .iter()
            .map(|&t| i32::try_from(t))
            .collect::<Result<_, _>>()
            .map_err(|_| crate::MeshError::parse(path, Some(line), "a zone tag beyond 32 bits"))?;
        mesh.zones = scan::zones(named, &mesh.cell_zones, &mesh.cells.kinds);
    }
    Ok(mesh)
}

/// `CELLS a b` and what follows, in either layout: the offsets (start of
/// each cell, plus the end) and the node indices.
fn read_cells(r: &mut Reader) -> Result<(Vec<i64>, Vec<i64>)> {
    let a = r.c.count("the number of cells", 1)?;
    let b = r.c.count("the size of the cell list", 1)?;
    if r.c
        .peek_word()
        .is_some_and(|w| w.eq_ignore_ascii_case(b"OFFSETS"))
    {
        r.c.word();
        let ty = r.c.text("the offsets' type")?;
        let offsets = r.ints(a, ty, "the cell offsets")?;
        r.skip_metadata();
        if r.keyword("CONNECTIVITY")? != "connectivity" {
            return Err(r.c.error("expected CONNECTIVITY after the OFFSETS"));
        }
        let ty = r.c.text("the connectivity's type")?;
        let conn = r.ints(b, ty, "the cell connectivity")?;
        r.skip_metadata();
        if offsets.first().is_some_and(|&o| o != 0)
            || offsets.last().is_some_and(|&o| o != b as i64)
        {
            return Err(r.c.error(format!(
                "the cell offsets must run from 0 to {b}, the connectivity's size"
            )));
        }
        if offsets.is_empty() {
            return Ok((vec![0], conn));
        }
        return Ok((offsets, conn));
    }
    let line = r.c.line_at(r.c.pos);
    let list = r.ints(b, "int", "the cell list")?;
    r.skip_metadata();
    let mut offsets = Vec::with_capacity(a.min(list.len()) + 1);
    let mut conn = Vec::with_capacity(list.len().saturating_sub(a));
    offsets.push(0);
    let mut i = 0;
    for c in 0..a {
        let n = list.get(i).copied().ok_or_else(|| {
            crate::MeshError::parse(
                r.c.path,
                Some(line),
                format!("the cell list of size {b} ends before cell {c} of {a}"),
            )
        })?;
        let end = usize::try_from(n)
            .ok()
            .and_then(|n| (i + 1).checked_add(n))
            .filter(|&e| e <= list.len())
            .ok_or_else(|| {
                crate::MeshError::parse(
                    r.c.path,
                    Some(line),
                    format!("cell {c} has {n} nodes, more than the cell list of size {b} holds"),
                )
            })?;
        conn.extend_from_slice(&list[i + 1..end]);
        offsets.push(conn.len() as i64);
        i = end;
    }
    if i != list.len() {
        return Err(crate::MeshError::parse(
            r.c.path,
            Some(line),
            format!("the cell list has size {b}, but its {a} cells use {i}"),
        ));
    }
    Ok((offsets, conn))
}

/// One point or cell data attribute (`SCALARS`, `VECTORS`, `FIELD`, ...):
/// integer scalars and field arrays go to `found` (name, components,
/// values, line); the rest is skipped.
fn attribute(
    r: &mut Reader,
    key: &str,
    n: usize,
    line: usize,
    found: &mut impl FnMut(String, usize, Vec<i64>, usize),
) -> Result<()> {
    match key {
        "scalars" => {
            let name = decode_name(r.c.text("the scalars' name")?);
            let ty = r.c.text("the scalars' type")?.to_string();
            let mut comps = 1;
            if r.c
                .peek_word()
                .is_some_and(|w| w.iter().all(u8::is_ascii_digit))
            {
                comps = r.c.count("the number of components", 1)?;
            }
            if r.c
                .peek_word()
                .is_some_and(|w| w.eq_ignore_ascii_case(b"LOOKUP_TABLE"))
            {
                r.c.word();
                r.c.text("the lookup table's name")?;
            }
            let total = n.saturating_mul(comps);
            let what = format!("scalars {name:?}");
            if scalar(&ty).is_some_and(|s| !s.is_float()) {
                let v = r.ints(total, &ty, &what)?;
                found(name, comps, v, line);
            } else {
                r.values(total, &ty, &what)?;
            }
        }
        "vectors" | "normals" | "tensors" | "texture_coordinates" => {
            r.c.text("the array's name")?;
            let mut per = if key == "tensors" { 9 } else { 3 };
            if key == "texture_coordinates" {
                per = r.c.count("the texture coordinates' dimension", 1)?;
            }
            let ty = r.c.text("the array's type")?;
            r.values(n.saturating_mul(per), ty, key)?;
        }
        "color_scalars" => {
            r.c.text("the colour scalars' name")?;
            let m = r.c.count("the number of colour components", 1)?;
            let ty = if r.binary { "unsigned_char" } else { "float" };
            r.values(n.saturating_mul(m), ty, "the colour scalars")?;
        }
        "lookup_table" => {
            r.c.text("the lookup table's name")?;
            let m = r.c.count("the lookup table's size", 4)?;
            let ty = if r.binary { "unsigned_char" } else { "float" };
            r.values(m.saturating_mul(4), ty, "the lookup table")?;
        }
        "global_ids" | "pedigree_ids" => {
            r.c.text("the ids' name")?;
            let ty = r.c.text("the ids' type")?;
            r.values(n, ty, key)?;
        }
        "field" => r.field(|name, comps, v| found(name, comps, v, line))?,
        _ => {
            return Err(r.c.error(format!(
                "unexpected {:?} in the point or cell data",
                key.to_ascii_uppercase()
            )));
        }
    }
    r.skip_metadata();
    Ok(())
}

/// Writes a legacy file: ASCII, or BINARY (big-endian).
pub(super) fn write(mesh: &VolumeMesh, binary: bool) -> Vec<u8> {
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
