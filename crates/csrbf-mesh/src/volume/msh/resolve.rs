//! Node tags to indices, physical groups to zones.

use std::collections::HashMap;
use std::path::Path;

use crate::volume::scan;
use crate::volume::{CellKind, VolumeMesh, Zone};
use crate::{MeshError, Result};

/// What the sections give before the zones and node tags are resolved.
#[derive(Default)]
pub(super) struct Raw {
    pub(super) names: Vec<(u8, i32, String)>,
    /// (dim, entity tag) to its first physical tag.
    pub(super) entities: HashMap<(u8, i64), i32>,
    pub(super) node_tags: Vec<u64>,
    pub(super) points: Vec<glam::DVec3>,
    pub(super) kinds: Vec<CellKind>,
    /// Node tags of each cell, in VTK order.
    pub(super) nodes: Vec<u64>,
    /// Each cell's (dim, physical tag) (2.2) or (dim, entity tag) (4.1).
    pub(super) keys: Vec<(u8, i64)>,
    /// Each cell's tag in the file, for messages.
    pub(super) tags: Vec<u64>,
    /// Whether the keys are entities (4.1).
    pub(super) v4: bool,
}

/// Node tags to indices, physical groups to zones.
pub(super) fn resolve(raw: Raw, path: &Path) -> Result<VolumeMesh> {
    let invalid = |message: String| MeshError::Invalid {
        path: path.to_owned(),
        message,
    };
    let n = raw.node_tags.len();
    let max = raw.node_tags.iter().copied().max().unwrap_or(0);
    let mut dense: Vec<u32> = Vec::new();
    let mut sparse: HashMap<u64, u32> = HashMap::new();
    let small = max <= 4 * n as u64 + 1024;
    if small {
        dense = vec![u32::MAX; max as usize + 1];
    }
    if n >= u32::MAX as usize {
        return Err(invalid(format!("{n} nodes: csrbf reads up to 2^32 - 1")));
    }
    for (i, &t) in raw.node_tags.iter().enumerate() {
        let fresh = if small {
            std::mem::replace(&mut dense[t as usize], i as u32) == u32::MAX
        } else {
            sparse.insert(t, i as u32).is_none()
        };
        if !fresh {
            return Err(invalid(format!("node tag {t} is given twice")));
        }
    }
    let index = |t: u64| {
        if small {
            dense.get(t as usize).copied().filter(|&i| i != u32::MAX)
        } else {
            sparse.get(&t).copied()
        }
    };
    let mut mesh = VolumeMesh {
        points: raw.points,
        ..Default::default()
    };
    if raw.nodes.len() > u32::MAX as usize {
        return Err(invalid("more than 2^32 cell nodes".into()));
    }
    let mut at = 0;
    let mut nodes = Vec::with_capacity(8);
    for (c, &kind) in raw.kinds.iter().enumerate() {
        nodes.clear();
        for &t in &raw.nodes[at..at + kind.nodes()] {
            nodes.push(index(t).ok_or_else(|| {
                invalid(format!(
                    "element {} names node {t}, which $Nodes does not define",
                    raw.tags[c]
                ))
            })?);
        }
        at += kind.nodes();
        mesh.cells.push(kind, &nodes);
    }
    // Each cell's (dim, physical tag).
    let phys: Vec<(u8, i32)> = raw
        .keys
        .iter()
        .map(|&(dim, k)| {
            if raw.v4 {
                return Ok((dim, raw.entities.get(&(dim, k)).copied().unwrap_or(0)));
            }
            i32::try_from(k)
                .map(|t| (dim, t))
                .map_err(|_| invalid(format!("physical tag {k} is beyond 32 bits")))
        })
        .collect::<Result<_>>()?;
    let any = phys.iter().any(|&(_, t)| t != 0);
    if !any && raw.names.is_empty() {
        return Ok(mesh);
    }
    let mut top = raw
        .names
        .iter()
        .map(|n| n.1)
        .chain(phys.iter().map(|p| p.1))
        .max()
        .unwrap_or(0);
    let mut tag_of: HashMap<(u8, i32), i32> = HashMap::new();
    let mut taken: HashMap<i32, u8> = HashMap::new();
    let mut assign = |dim: u8, t: i32| -> i32 {
        *tag_of.entry((dim, t)).or_insert_with(|| {
            let tag = match taken.get(&t) {
                Some(&d) if d != dim => {
                    top += 1;
                    top
                }
                _ => t,
            };
            taken.insert(tag, dim);
            tag
        })
    };
    let mut zones = Vec::new();
    for (dim, t, name) in &raw.names {
        let tag = assign(*dim, *t);
        if !zones.iter().any(|z: &Zone| z.tag == tag) {
            zones.push(Zone {
                name: name.clone(),
                tag,
                dim: *dim,
            });
        }
    }
    mesh.cell_zones = phys
        .iter()
        .map(|&(dim, t)| if t == 0 { 0 } else { assign(dim, t) })
        .collect();
    mesh.zones = scan::zones(zones, &mesh.cell_zones, &mesh.cells.kinds);
    Ok(mesh)
}
