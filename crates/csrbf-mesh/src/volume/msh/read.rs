//! Reading: the sections, in ASCII or binary, into what they give.

use std::path::Path;

use super::PRISM;
use super::resolve::{Raw, resolve};
use crate::volume::scan::{Cursor, Scalar};
use crate::volume::{CellKind, VolumeMesh};
use crate::{MeshError, Result};

/// Gmsh element types csrbf does not read, by name.
fn unsupported(t: i64, element: &str) -> String {
    let second = match t {
        8 => Some("3-node line"),
        9 => Some("6-node triangle"),
        10 => Some("9-node quadrangle"),
        11 => Some("10-node tetrahedron"),
        12 => Some("27-node hexahedron"),
        13 => Some("18-node prism"),
        14 => Some("14-node pyramid"),
        16 => Some("8-node quadrangle"),
        17 => Some("20-node hexahedron"),
        18 => Some("15-node prism"),
        19 => Some("13-node pyramid"),
        _ => None,
    };
    match second {
        Some(name) => format!(
            "second-order cells (Gmsh type {t}, {name}) at {element}: csrbf morphs linear cells only"
        ),
        None if (20..=140).contains(&t) => format!(
            "higher-order cells (Gmsh type {t}) at {element}: csrbf morphs linear cells only"
        ),
        None => format!(
            "{element} has Gmsh element type {t}, which csrbf does not read \
             (it reads types 1 to 7 and 15, the linear cells)"
        ),
    }
}

/// Reads numbers as the file stores them: words, or binary (`int` 4 bytes,
/// `size_t` 4 or 8, `double` 8).
struct Reader<'a> {
    c: Cursor<'a>,
    binary: bool,
    big: bool,
    size_t: usize,
    v4: bool,
}

impl Reader<'_> {
    fn bin(&mut self, ty: Scalar, what: &str) -> Result<&[u8]> {
        let at = self.c.pos;
        self.c.take(ty.size(), what).map_err(|_| {
            self.c
                .error_at_byte(at, format!("the file ends inside {what}"))
        })
    }

    fn int(&mut self, what: &str) -> Result<i64> {
        if !self.binary {
            return self.c.number(what);
        }
        let big = self.big;
        let b = self.bin(Scalar::I32, what)?;
        Ok(Scalar::I32.i64(b, big).unwrap_or(0))
    }

    fn size(&mut self, what: &str) -> Result<u64> {
        if !self.binary {
            return self.c.number(what);
        }
        let (big, ty) = (
            self.big,
            if self.size_t == 8 {
                Scalar::U64
            } else {
                Scalar::U32
            },
        );
        let at = self.c.pos;
        let b = self.bin(ty, what)?;
        ty.i64(b, big)
            .map(|v| v as u64)
            .ok_or_else(|| self.c.error_at_byte(at, format!("{what} is beyond 2^63")))
    }

    fn real(&mut self, what: &str) -> Result<f64> {
        if !self.binary {
            return self.c.number(what);
        }
        let big = self.big;
        Ok(Scalar::F64.f64(self.bin(Scalar::F64, what)?, big))
    }

    /// A count of things of at least `bytes_each` bytes (binary) or one
    /// word each, refused when the file cannot hold it.
    fn count(&mut self, what: &str, bytes_each: usize) -> Result<usize> {
        let n = self.size(what)?;
        self.c
            .fits(n, if self.binary { bytes_each } else { 2 }, what)
    }

    /// Where an error is: the line (text) or the byte.
    fn here(&self, message: String) -> MeshError {
        if self.binary {
            self.c.error_at_byte(self.c.pos, message)
        } else {
            self.c.error(message)
        }
    }

    fn end(&mut self, section: &str) -> Result<()> {
        let want = format!("$End{section}");
        match self.c.word() {
            Some(w) if w == want.as_bytes() => Ok(()),
            w => Err(self.c.error(format!(
                "expected {want}, found {:?}",
                String::from_utf8_lossy(w.unwrap_or(b"the end of the file"))
            ))),
        }
    }
}
pub(in crate::volume) fn read(bytes: &[u8], path: &Path) -> Result<VolumeMesh> {
    let mut r = Reader {
        c: Cursor::new(bytes, path),
        binary: false,
        big: false,
        size_t: 8,
        v4: false,
    };
    let mut raw = Raw::default();
    let mut first = true;
    while let Some(w) = r.c.word() {
        let section = String::from_utf8_lossy(w).into_owned();
        let Some(name) = section.strip_prefix('$') else {
            return Err(r
                .c
                .error(format!("expected a section ($Name), found {section:?}")));
        };
        if first && name != "MeshFormat" {
            return Err(r.c.error(if name == "NOD" || name == "NOE" {
                "a Gmsh 1 file: csrbf reads Gmsh 2.2 and 4.1 (save it in one of those)".into()
            } else {
                format!("not a Gmsh file: it starts with {section:?}, not $MeshFormat")
            }));
        }
        first = false;
        match name {
            "MeshFormat" => mesh_format(&mut r)?,
            "PhysicalNames" => physical_names(&mut r, &mut raw)?,
            "Entities" if r.v4 => entities(&mut r, &mut raw)?,
            "Nodes" if r.v4 => nodes4(&mut r, &mut raw)?,
            "Nodes" => nodes2(&mut r, &mut raw)?,
            "Elements" if r.v4 => elements4(&mut r, &mut raw)?,
            "Elements" => elements2(&mut r, &mut raw)?,
            _ => {
                let end = format!("$End{name}");
                let at = r.c.pos;
                let found = r.c.bytes[at..]
                    .windows(end.len())
                    .position(|s| s == end.as_bytes())
                    .ok_or_else(|| r.c.error(format!("section {section} has no {end}")))?;
                r.c.pos = at + found + end.len();
                continue;
            }
        }
        r.end(name)?;
    }
    if first {
        return Err(r.c.error("the file is empty"));
    }
    raw.v4 = r.v4;
    resolve(raw, path)
}

fn mesh_format(r: &mut Reader) -> Result<()> {
    let version = r.c.text("the version")?.to_string();
    let kind: u8 = r.c.number("the file type")?;
    let data_size: usize = r.c.number("the data size")?;
    match version.as_str() {
        "2" | "2.0" | "2.1" | "2.2" => r.v4 = false,
        "4.1" => r.v4 = true,
        v => {
            return Err(r.c.error(format!(
                "Gmsh format {v}: csrbf reads 2.2 and 4.1 (save the mesh in one of those)"
            )));
        }
    }
    r.binary = match kind {
        0 => false,
        1 => true,
        k => {
            return Err(r
                .c
                .error(format!("file type {k}: neither 0 (ASCII) nor 1 (binary)")));
        }
    };
    if r.binary {
        if !(data_size == 8 || r.v4 && data_size == 4) {
            return Err(r.c.error(format!(
                "data size {data_size}: csrbf reads 8 (and 4 in 4.1)"
            )));
        }
        r.size_t = data_size;
        r.c.end_line();
        let at = r.c.pos;
        let one = r.c.take(4, "the byte order mark")?;
        r.big = match one {
            [1, 0, 0, 0] => false,
            [0, 0, 0, 1] => true,
            _ => {
                return Err(r
                    .c
                    .error_at_byte(at, "the byte order mark is not the integer 1"));
            }
        };
    }
    Ok(())
}

fn physical_names(r: &mut Reader, raw: &mut Raw) -> Result<()> {
    let n = r.c.count("the number of physical names", 6)?;
    for _ in 0..n {
        let dim: u8 = r.c.number("a physical group's dimension")?;
        let tag: i32 = r.c.number("a physical group's tag")?;
        let line = r.c.rest_of_line();
        let name = line
            .strip_prefix(b"\"")
            .and_then(|l| l.strip_suffix(b"\""))
            .ok_or_else(|| {
                r.c.error("a physical group's name must be in double quotes")
            })?;
        if dim > 3 || tag == 0 {
            return Err(r
                .c
                .error(format!("physical group {tag} of dimension {dim}")));
        }
        raw.names
            .push((dim, tag, String::from_utf8_lossy(name).into_owned()));
    }
    Ok(())
}

fn entities(r: &mut Reader, raw: &mut Raw) -> Result<()> {
    if r.binary {
        r.c.end_line();
    }
    let mut counts = [0usize; 4];
    for (d, n) in counts.iter_mut().enumerate() {
        *n = r.count(&format!("the number of {d}D entities"), 28 + r.size_t)?;
    }
    for (dim, &n) in counts.iter().enumerate() {
        for _ in 0..n {
            let tag = r.int("an entity's tag")?;
            for _ in 0..if dim == 0 { 3 } else { 6 } {
                r.real("an entity's bounds")?;
            }
            let phys = r.count("the number of physical tags", 4)?;
            let mut first = 0;
            for k in 0..phys {
                let p = r.int("a physical tag")?;
                if k == 0 {
                    // Gmsh writes a physical group of an entity with the
                    // opposite orientation as a negative tag.
                    first = i32::try_from(p.unsigned_abs())
                        .map_err(|_| r.here(format!("physical tag {p} is beyond 32 bits")))?;
                }
            }
            raw.entities.entry((dim as u8, tag)).or_insert(first);
            if dim > 0 {
                let bounding = r.count("the number of bounding entities", 4)?;
                for _ in 0..bounding {
                    r.int("a bounding entity")?;
                }
            }
        }
    }
    Ok(())
}

fn nodes4(r: &mut Reader, raw: &mut Raw) -> Result<()> {
    if r.binary {
        r.c.end_line();
    }
    let size_t = r.size_t;
    let blocks = r.count("the number of node blocks", 12 + size_t)?;
    let total = r.count("the number of nodes", 24 + size_t)?;
    r.size("the least node tag")?;
    r.size("the greatest node tag")?;
    for _ in 0..blocks {
        let dim = r.int("a node block's dimension")?;
        r.int("a node block's entity")?;
        let parametric = r.int("a node block's parametric flag")?;
        let n = r.count("the number of nodes in a block", 24 + size_t)?;
        let params = if parametric != 0 {
            dim.clamp(0, 3) as usize
        } else {
            0
        };
        for _ in 0..n {
            raw.node_tags.push(r.size("a node tag")?);
        }
        for _ in 0..n {
            let x = r.real("a node's x")?;
            let y = r.real("a node's y")?;
            let z = r.real("a node's z")?;
            raw.points.push(glam::DVec3::new(x, y, z));
            for _ in 0..params {
                r.real("a node's parametric coordinate")?;
            }
        }
    }
    if raw.points.len() != total {
        return Err(r.here(format!(
            "$Nodes says {total} nodes, its blocks hold {}",
            raw.points.len()
        )));
    }
    Ok(())
}

fn nodes2(r: &mut Reader, raw: &mut Raw) -> Result<()> {
    let n: u64 = r.c.number("the number of nodes")?;
    let n =
        r.c.fits(n, if r.binary { 28 } else { 8 }, "the number of nodes")?;
    if r.binary {
        r.c.end_line();
    }
    for _ in 0..n {
        let tag = r.int("a node tag")?;
        let tag = u64::try_from(tag).map_err(|_| r.here(format!("node tag {tag} is negative")))?;
        raw.node_tags.push(tag);
        let x = r.real("a node's x")?;
        let y = r.real("a node's y")?;
        let z = r.real("a node's z")?;
        raw.points.push(glam::DVec3::new(x, y, z));
    }
    Ok(())
}

/// One element: its kind from the type, its nodes (reordered to VTK's),
/// its key for the zone.
fn element(r: &mut Reader, raw: &mut Raw, kind: CellKind, tag: u64, key: (u8, i64)) -> Result<()> {
    let start = raw.nodes.len();
    for _ in 0..kind.nodes() {
        let v = if r.v4 {
            r.size("an element's node")?
        } else {
            let v = r.int("an element's node")?;
            u64::try_from(v).map_err(|_| r.here(format!("element {tag} names node {v}")))?
        };
        raw.nodes.push(v);
    }
    if kind == CellKind::Wedge {
        let g: Vec<u64> = raw.nodes[start..].to_vec();
        for (k, &p) in PRISM.iter().enumerate() {
            raw.nodes[start + k] = g[p];
        }
    }
    raw.kinds.push(kind);
    raw.keys.push(key);
    raw.tags.push(tag);
    Ok(())
}

fn kind_of(r: &Reader, t: i64, tag: u64) -> Result<CellKind> {
    CellKind::from_gmsh(t).ok_or_else(|| r.here(unsupported(t, &format!("element {tag}"))))
}

fn elements4(r: &mut Reader, raw: &mut Raw) -> Result<()> {
    if r.binary {
        r.c.end_line();
    }
    let size_t = r.size_t;
    let blocks = r.count("the number of element blocks", 12 + size_t)?;
    let total = r.count("the number of elements", 2 * size_t)?;
    r.size("the least element tag")?;
    r.size("the greatest element tag")?;
    let before = raw.kinds.len();
    for _ in 0..blocks {
        let dim = r.int("an element block's dimension")?;
        let entity = r.int("an element block's entity")?;
        let t = r.int("an element block's type")?;
        let n = r.count("the number of elements in a block", 2 * size_t)?;
        if n == 0 {
            continue;
        }
        let kind = CellKind::from_gmsh(t).ok_or_else(|| {
            let at = format!("element {} (entity {entity})", raw.kinds.len() + 1);
            r.here(unsupported(t, &at))
        })?;
        let dim = u8::try_from(dim)
            .ok()
            .filter(|&d| d <= 3)
            .ok_or_else(|| r.here(format!("element block dimension {dim}")))?;
        for _ in 0..n {
            let tag = r.size("an element tag")?;
            element(r, raw, kind, tag, (dim, entity))?;
        }
    }
    if raw.kinds.len() - before != total {
        return Err(r.here(format!(
            "$Elements says {total} elements, its blocks hold {}",
            raw.kinds.len() - before
        )));
    }
    Ok(())
}

fn elements2(r: &mut Reader, raw: &mut Raw) -> Result<()> {
    let n: u64 = r.c.number("the number of elements")?;
    let n = r.c.fits(n, 8, "the number of elements")?;
    let mut read = 0;
    if !r.binary {
        for _ in 0..n {
            let tag = r.int("an element tag")?;
            let t = r.int("an element type")?;
            let ntags = r.c.count("the number of tags", 2)?;
            let mut phys = 0;
            for k in 0..ntags {
                let v = r.int("an element tag")?;
                if k == 0 {
                    phys = v;
                }
            }
            let tag = tag as u64;
            let kind = kind_of(r, t, tag)?;
            element(r, raw, kind, tag, (kind.dim(), phys))?;
        }
        return Ok(());
    }
    r.c.end_line();
    while read < n {
        let t = r.int("an element type")?;
        let count = r.int("the number of elements")?;
        let ntags = r.int("the number of tags")?;
        let kind = kind_of(r, t, read as u64 + 1)?;
        let (Ok(count), Ok(ntags)) = (usize::try_from(count), usize::try_from(ntags)) else {
            return Err(r.here(format!("{count} elements of {ntags} tags")));
        };
        if count == 0 || count > n - read {
            return Err(r.here(format!(
                "a group of {count} elements where {} are left to read",
                n - read
            )));
        }
        for _ in 0..count {
            let tag = r.int("an element tag")?;
            let mut phys = 0;
            for k in 0..ntags {
                let v = r.int("an element tag")?;
                if k == 0 {
                    phys = v;
                }
            }
            element(r, raw, kind, tag as u64, (kind.dim(), phys))?;
        }
        read += count;
    }
    Ok(())
}
