//! Volume meshes made, not read: the box around a cavity that the volume
//! examples, tests and benchmarks morph.

use glam::DVec3;

use super::{CellKind, VolumeMesh, Zone};

/// The zone tags of [`box_with_cavity`].
pub const OUTER: i32 = 1;
/// The cavity's surface (the object's boundary).
pub const INNER: i32 = 2;
/// The cells.
pub const FLUID: i32 = 3;

/// A cube [-1, 1]^3 of `n`^3 small cubes, each split into six tetrahedra
/// (Kuhn's split: every face cut by the same diagonal, so neighbours
/// agree), without the cubes whose centre is within `hole` of the middle
/// (max norm): a box around a cubic object. Zones: `outer` (the box's
/// triangles), `inner` (the cavity's: the object's surface), `fluid` (the
/// tetrahedra). `n` tets per side 6 n^3 less the hole's; n = 56 gives
/// about a million.
pub fn box_with_cavity(n: usize, hole: f64) -> VolumeMesh {
    let n = n.max(1);
    let h = 2.0 / n as f64;
    box_without(n, &|i, j, k| {
        let centre = DVec3::new(
            -1.0 + h * (i as f64 + 0.5),
            -1.0 + h * (j as f64 + 0.5),
            -1.0 + h * (k as f64 + 0.5),
        );
        centre.abs().max_element() < hole
    })
}

/// [`box_with_cavity`] with `k`^3 cubic cavities of `s`^3 small cubes each,
/// spread evenly (a porous block: many boundary nodes for its cells), all
/// one `inner` zone. `box_with_cavities(56, 6, 4)` has about 970k
/// tetrahedra and 52k boundary nodes.
pub fn box_with_cavities(n: usize, k: usize, s: usize) -> VolumeMesh {
    let n = n.max(1);
    let (k, s) = (k.min(n), s.min(n / k.max(1)));
    let starts: Vec<usize> = (0..k)
        .map(|c| ((2 * c + 1) * n / (2 * k)).saturating_sub(s / 2))
        .collect();
    let inside = |x: usize| starts.iter().any(|&a| x >= a && x < a + s);
    box_without(n, &|i, j, l| s > 0 && inside(i) && inside(j) && inside(l))
}

/// The grid of `n`^3 cubes over [-1, 1]^3 less those `removed` says (by
/// their integer corner), as tetrahedra with zones.
fn box_without(n: usize, removed: &dyn Fn(usize, usize, usize) -> bool) -> VolumeMesh {
    let side = n + 1;
    let id = |i: usize, j: usize, k: usize| (i + side * (j + side * k)) as u32;
    let h = 2.0 / n as f64;
    let mut mesh = VolumeMesh::default();
    for k in 0..side {
        for j in 0..side {
            for i in 0..side {
                mesh.points.push(DVec3::new(
                    -1.0 + h * i as f64,
                    -1.0 + h * j as f64,
                    -1.0 + h * k as f64,
                ));
            }
        }
    }
    const PATHS: [[usize; 3]; 6] = [
        [0, 1, 2],
        [0, 2, 1],
        [1, 0, 2],
        [1, 2, 0],
        [2, 0, 1],
        [2, 1, 0],
    ];
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                if removed(i, j, k) {
                    continue;
                }
                for path in PATHS {
                    let mut at = [i, j, k];
                    let mut tet = [id(i, j, k); 4];
                    for (step, &axis) in path.iter().enumerate() {
                        at[axis] += 1;
                        tet[step + 1] = id(at[0], at[1], at[2]);
                    }
                    let p = tet.map(|v| mesh.points[v as usize]);
                    if (p[1] - p[0]).dot((p[2] - p[0]).cross(p[3] - p[0])) < 0.0 {
                        tet.swap(1, 2);
                    }
                    mesh.cells.push(CellKind::Tetra, &tet);
                }
            }
        }
    }
    let tets = mesh.cells.len();
    mesh.cell_zones = vec![FLUID; tets];
    for (_, face) in mesh.boundary_faces() {
        let outer = face
            .iter()
            .all(|&v| mesh.points[v as usize].abs().max_element() > 1.0 - 1e-9);
        mesh.cells.push(CellKind::Triangle, &face);
        mesh.cell_zones.push(if outer { OUTER } else { INNER });
    }
    // Unused nodes (inside the hole) stay: node numbers are the grid's.
    mesh.zones = vec![
        Zone {
            name: "outer".into(),
            tag: OUTER,
            dim: 2,
        },
        Zone {
            name: "inner".into(),
            tag: INNER,
            dim: 2,
        },
        Zone {
            name: "fluid".into(),
            tag: FLUID,
            dim: 3,
        },
    ];
    mesh
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::quality::min_corner_det;

    #[test]
    fn cavities_are_spread_and_counted() {
        let m = box_with_cavities(12, 2, 3);
        m.check("porous".as_ref()).expect("valid");
        assert_eq!(m.zone_cells(FLUID).len(), 6 * (12 * 12 * 12 - 8 * 27));
        // Each cavity: 6 sides of 9 squares of 2 triangles.
        assert_eq!(m.zone_cells(INNER).len(), 8 * 6 * 9 * 2);
        assert_eq!(box_with_cavities(5, 0, 0).zone_cells(FLUID).len(), 6 * 125);
    }

    #[test]
    fn the_box_is_valid_closed_and_zoned() {
        let m = box_with_cavity(6, 0.34);
        m.check("box".as_ref()).expect("valid");
        // 216 cubes less the 8 in the middle (centres within 0.34).
        assert_eq!(m.zone_cells(FLUID).len(), 6 * (216 - 8));
        for (kind, nodes) in m.cells.iter() {
            if kind == CellKind::Tetra {
                let p: Vec<DVec3> = nodes.iter().map(|&v| m.points[v as usize]).collect();
                assert!(min_corner_det(kind, &p) > 0.0);
            }
        }
        // Outer: 6 sides of 36 squares of 2 triangles; inner: 6 sides of 4.
        assert_eq!(m.zone_cells(OUTER).len(), 6 * 36 * 2);
        assert_eq!(m.zone_cells(INNER).len(), 6 * 4 * 2);
        // Every boundary triangle is a face of exactly one tetrahedron.
        assert_eq!(m.boundary().len(), 6 * 36 * 2 + 6 * 4 * 2);
    }
}
