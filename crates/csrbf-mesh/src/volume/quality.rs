//! The shape of cells: signed corner Jacobians, the scaled Jacobian, and
//! whether a cell is inside out.
//!
//! A 3D cell is judged at its corners: at each, the determinant of the
//! three edges leaving it (in the order that makes it positive for a valid
//! cell). A tetrahedron has one such value up to a factor (its signed
//! volume times 6); a hexahedron, wedge or pyramid is valid, with a
//! positive Jacobian everywhere inside, only when all its corner values are
//! positive (the criterion of Verdict and of the solvers' mesh checks: a
//! necessary condition for a hexahedron, whose Jacobian is not linear). A
//! pyramid's apex joins four edges; its base corners' determinants are the
//! tetrahedra of its two diagonal splits, which judge the apex too.
//!
//! The scaled Jacobian is the least corner determinant over the product of
//! its edges' lengths, scaled so that the ideal shape (regular
//! tetrahedron, equilateral wedge, cube) gives 1: 0 is flat, below 0 inside
//! out.

use glam::DVec3;

use super::CellKind;

/// The corners of a kind: per corner, its node and the three nodes its
/// edges run to, ordered so that the determinant is positive for a valid
/// cell. Empty for 0D-2D cells.
pub fn corners(kind: CellKind) -> &'static [[usize; 4]] {
    match kind {
        CellKind::Tetra => &[[0, 1, 2, 3]],
        CellKind::Hexahedron => &[
            [0, 1, 3, 4],
            [1, 2, 0, 5],
            [2, 3, 1, 6],
            [3, 0, 2, 7],
            [4, 7, 5, 0],
            [5, 4, 6, 1],
            [6, 5, 7, 2],
            [7, 6, 4, 3],
        ],
        CellKind::Wedge => &[
            [0, 2, 1, 3],
            [1, 0, 2, 4],
            [2, 1, 0, 5],
            [3, 4, 5, 0],
            [4, 5, 3, 1],
            [5, 3, 4, 2],
        ],
        // Each base corner's determinant is a tetrahedron with the apex;
        // the four are the two diagonal splits' tetrahedra, so the apex is
        // judged by them too.
        CellKind::Pyramid => &[[0, 1, 3, 4], [1, 2, 0, 4], [2, 3, 1, 4], [3, 0, 2, 4]],
        _ => &[],
    }
}

/// The factor that makes a corner of the ideal shape score 1.
fn ideal_scale(kind: CellKind) -> f64 {
    match kind {
        CellKind::Tetra => std::f64::consts::SQRT_2,
        CellKind::Wedge => 2.0 / 3f64.sqrt(),
        // The ideal pyramid (every edge equal): its base corners score
        // 1/sqrt2 unscaled.
        CellKind::Pyramid => std::f64::consts::SQRT_2,
        _ => 1.0,
    }
}

/// det[a, b, c] = a . (b x c).
#[inline]
pub fn det3(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    a.dot(b.cross(c))
}

/// The corner determinants of a cell whose nodes are at `p` (indexed by
/// the cell's local node numbers), in [`corners`]' order.
pub fn corner_dets(kind: CellKind, p: &[DVec3]) -> impl Iterator<Item = f64> + '_ {
    corners(kind)
        .iter()
        .map(move |&[o, a, b, c]| det3(p[a] - p[o], p[b] - p[o], p[c] - p[o]))
}

/// The least corner determinant of a cell (+inf for 0D-2D cells): not
/// positive when the cell is flat or inside out.
pub fn min_corner_det(kind: CellKind, p: &[DVec3]) -> f64 {
    // NaN wins (a corner that is not a number is not positive).
    corner_dets(kind, p).fold(
        f64::INFINITY,
        |a, b| if b < a || b.is_nan() { b } else { a },
    )
}

/// The scaled Jacobian of a cell: 1 for the ideal shape, 0 flat, negative
/// inside out; +inf for 0D-2D cells (none to judge). A corner with an edge
/// of zero length scores 0.
pub fn scaled_jacobian(kind: CellKind, p: &[DVec3]) -> f64 {
    let mut least = f64::INFINITY;
    for &[o, a, b, c] in corners(kind) {
        let (ea, eb, ec) = (p[a] - p[o], p[b] - p[o], p[c] - p[o]);
        let lengths = ea.length() * eb.length() * ec.length();
        let s = if lengths > 0.0 {
            det3(ea, eb, ec) / lengths * ideal_scale(kind)
        } else {
            0.0
        };
        least = least.min(s);
    }
    least
        .min(1.0)
        .max(if least.is_finite() { -1.0 } else { least })
}

/// The cubic det[e_a + s f_a, e_b + s f_b, e_c + s f_c] as its
/// coefficients [c0, c1, c2, c3] (c0 + c1 s + c2 s^2 + c3 s^3): a corner's
/// determinant while each node moves along a straight line (`e` the rest
/// edges, `f` how much each edge changes by s = 1).
pub fn det_cubic(e: [DVec3; 3], f: [DVec3; 3]) -> [f64; 4] {
    let [ea, eb, ec] = e;
    let [fa, fb, fc] = f;
    [
        det3(ea, eb, ec),
        det3(fa, eb, ec) + det3(ea, fb, ec) + det3(ea, eb, fc),
        det3(fa, fb, ec) + det3(fa, eb, fc) + det3(ea, fb, fc),
        det3(fa, fb, fc),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ideal(kind: CellKind) -> Vec<DVec3> {
        let h = 3f64.sqrt() / 2.0;
        match kind {
            CellKind::Tetra => vec![
                DVec3::new(0.0, 0.0, 0.0),
                DVec3::new(1.0, 0.0, 0.0),
                DVec3::new(0.5, h, 0.0),
                DVec3::new(0.5, h / 3.0, (2.0f64 / 3.0).sqrt()),
            ],
            CellKind::Hexahedron => (0..8)
                .map(|i| {
                    let b = [(0, 0), (1, 0), (1, 1), (0, 1)][i % 4];
                    DVec3::new(b.0 as f64, b.1 as f64, (i / 4) as f64)
                })
                .collect(),
            // VTK's wedge: (0, 1, 2) turns clockwise seen from (3, 4, 5).
            CellKind::Wedge => {
                let t = [DVec3::ZERO, DVec3::new(0.5, h, 0.0), DVec3::X];
                t.iter()
                    .chain(t.iter())
                    .enumerate()
                    .map(|(i, &p)| p + DVec3::Z * (i / 3) as f64)
                    .collect()
            }
            CellKind::Pyramid => vec![
                DVec3::new(0.0, 0.0, 0.0),
                DVec3::new(1.0, 0.0, 0.0),
                DVec3::new(1.0, 1.0, 0.0),
                DVec3::new(0.0, 1.0, 0.0),
                DVec3::new(0.5, 0.5, std::f64::consts::FRAC_1_SQRT_2),
            ],
            _ => vec![],
        }
    }

    #[test]
    fn ideal_cells_score_one_or_near_and_mirrored_ones_negative() {
        for kind in [
            CellKind::Tetra,
            CellKind::Hexahedron,
            CellKind::Wedge,
            CellKind::Pyramid,
        ] {
            let p = ideal(kind);
            let s = scaled_jacobian(kind, &p);
            assert!((s - 1.0).abs() < 1e-12, "{kind:?}: {s}");
            assert!(min_corner_det(kind, &p) > 0.0);
            let mirrored: Vec<DVec3> = p.iter().map(|q| DVec3::new(-q.x, q.y, q.z)).collect();
            assert!(scaled_jacobian(kind, &mirrored) < 0.0, "{kind:?}");
            assert!(min_corner_det(kind, &mirrored) < 0.0, "{kind:?}");
        }
    }

    #[test]
    fn the_faces_point_out_of_the_ideal_cells() {
        for kind in [
            CellKind::Tetra,
            CellKind::Hexahedron,
            CellKind::Wedge,
            CellKind::Pyramid,
        ] {
            let p = ideal(kind);
            let centre = p.iter().sum::<DVec3>() / p.len() as f64;
            for f in kind.faces() {
                let c = f.iter().map(|&i| p[i]).sum::<DVec3>() / f.len() as f64;
                let n = (p[f[1]] - p[f[0]]).cross(p[f[2]] - p[f[0]]);
                assert!(n.dot(c - centre) > 0.0, "{kind:?} face {f:?}");
            }
        }
    }

    #[test]
    fn the_cubic_is_the_determinant_along_the_path() {
        let e = [
            DVec3::new(1.0, 0.2, 0.0),
            DVec3::new(0.1, 1.0, 0.3),
            DVec3::new(0.0, -0.2, 1.0),
        ];
        let f = [
            DVec3::new(-0.5, 0.3, 0.1),
            DVec3::new(0.2, -1.9, 0.0),
            DVec3::new(0.4, 0.1, -0.7),
        ];
        let c = det_cubic(e, f);
        for s in [0.0, 0.3, 0.77, 1.0] {
            let d = det3(e[0] + f[0] * s, e[1] + f[1] * s, e[2] + f[2] * s);
            let v = c[0] + s * (c[1] + s * (c[2] + s * c[3]));
            assert!((d - v).abs() < 1e-12, "{s}: {d} {v}");
        }
    }
}
