//! Reading: the header, then keyword by keyword, each array's values in
//! ASCII or BINARY.

use std::path::Path;

use super::cells::build_cells;
use crate::Result;
use crate::volume::scan::{self, Binary, Cursor, Scalar, ZONE_ARRAYS};
use crate::volume::{VolumeMesh, Zone};

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
pub(super) fn decode_name(name: &str) -> String {
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

pub(in crate::volume) fn read(bytes: &[u8], path: &Path) -> Result<VolumeMesh> {
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
                if let Some(z) = scan::named_zone(&name, &v) {
                    named.push(z);
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
