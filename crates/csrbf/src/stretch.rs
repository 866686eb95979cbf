//! How much a deformation stretches each face of a mesh.
//!
//! A face's stretch is the largest singular value of the map that takes its
//! rest triangle onto its deformed one, in the triangle's plane: the
//! factor by which the longest line drawn on the face grew (2 when some
//! direction on it doubled). It is measured on the triangles as the mesh
//! shows them (rest and deformed corners, the piecewise-linear map), so it
//! is exact for what is drawn, needs no evaluation of the deformation, and
//! does not depend on the triangle's shape; it sees shear, which the ratios
//! of edge lengths miss (a square sheared into a long rhombus keeps two
//! edges' lengths). A face whose rest triangle has no area has no stretch.
//!
//! ```
//! use csrbf::face_stretches;
//! use glam::Vec3;
//!
//! let rest = [Vec3::ZERO, Vec3::X, Vec3::Y];
//! let moved = [Vec3::ZERO, Vec3::X * 3.0, Vec3::Y];
//! let s = face_stretches(&rest, &moved, &[[0, 1, 2]]);
//! assert!((s[0] - 3.0).abs() < 1e-12);
//! ```

use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// The default stretch above which a face is listed (4: some line on it
/// grew to four times its length).
pub const STRETCH_LIMIT: f64 = 4.0;

/// The stretch of every triangle (see the module docs): the largest
/// singular value of the rest-to-deformed map in its plane; NaN for a rest
/// triangle without area or a corner out of range or not finite.
pub fn face_stretches(rest: &[Vec3], moved: &[Vec3], triangles: &[[u32; 3]]) -> Vec<f64> {
    triangles
        .par_iter()
        .with_min_len(4096)
        .map(|t| {
            let get = |p: &[Vec3]| -> Option<[DVec3; 3]> {
                let c = [
                    p.get(t[0] as usize)?,
                    p.get(t[1] as usize)?,
                    p.get(t[2] as usize)?,
                ];
                Some(c.map(|v| v.as_dvec3()))
            };
            match (get(rest), get(moved)) {
                (Some(r), Some(m)) => singular_values(r, m).map_or(f64::NAN, |s| s.0),
                _ => f64::NAN,
            }
        })
        .collect()
}

/// The singular values (largest first) of the linear map taking the rest
/// triangle's edges onto the deformed one's, in the rest plane; None when
/// the rest triangle has no area or a value is not finite.
pub(crate) fn singular_values(rest: [DVec3; 3], moved: [DVec3; 3]) -> Option<(f64, f64)> {
    let (e1, e2) = (rest[1] - rest[0], rest[2] - rest[0]);
    let (f1, f2) = (moved[1] - moved[0], moved[2] - moved[0]);
    // An orthonormal basis (u, v) of the rest plane, u along e1.
    let l1 = e1.length();
    let n = e1.cross(e2);
    let area2 = n.length();
    if !(l1 > 0.0 && area2 > l1 * l1 * 1e-12 && f1.is_finite() && f2.is_finite()) {
        return None;
    }
    let u = e1 / l1;
    let v = n.cross(e1) / (area2 * l1);
    // Rest edges in (u, v): E = [[l1, e2.u], [0, e2.v]]; J = F E^-1.
    let (a, b, d) = (l1, e2.dot(u), e2.dot(v));
    let c1 = f1 / a;
    let c2 = (f2 - c1 * b) / d;
    // Singular values of J = [c1 c2] from J^T J = [[p, q], [q, r]].
    let (p, q, r) = (c1.dot(c1), c1.dot(c2), c2.dot(c2));
    let mean = 0.5 * (p + r);
    let spread = (0.25 * (p - r) * (p - r) + q * q).sqrt();
    let s1 = (mean + spread).sqrt();
    let s2 = (mean - spread).max(0.0).sqrt();
    s1.is_finite().then_some((s1, s2))
}

/// The faces' stretch in brief: the largest and where, and the faces over
/// a limit.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct StretchSummary {
    pub(crate) largest: f64,
    pub(crate) face: Option<u32>,
    pub(crate) over: Vec<u32>,
}

/// The largest stretch (1 when no face has one) and the faces over `limit`,
/// ascending; only faces with a moved corner are measured (the others are
/// 1).
pub(crate) fn summary(
    rest: &[Vec3],
    moved: &[Vec3],
    triangles: &[[u32; 3]],
    limit: f64,
) -> StretchSummary {
    let s = face_stretches(rest, moved, triangles);
    let mut largest = 1.0;
    let mut face = None;
    let mut over = Vec::new();
    for (f, &x) in s.iter().enumerate() {
        if x > largest {
            largest = x;
            face = Some(f as u32);
        }
        if x > limit {
            over.push(f as u32);
        }
    }
    StretchSummary {
        largest,
        face,
        over,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{Rng, assert_close};
    use glam::DMat3;

    /// The reference: singular values of the full 3x3 map that takes the
    /// rest triangle's edges and unit normal onto the deformed edges and a
    /// zero normal image, by the eigenvalues of J^T J (power iteration on a
    /// 3x3 is enough for the largest).
    fn largest_reference(r: [DVec3; 3], m: [DVec3; 3]) -> f64 {
        let (e1, e2) = (r[1] - r[0], r[2] - r[0]);
        let n = e1.cross(e2).normalize();
        let rest = DMat3::from_cols(e1, e2, n);
        let moved = DMat3::from_cols(m[1] - m[0], m[2] - m[0], DVec3::ZERO);
        let j = moved * rest.inverse();
        let jtj = j.transpose() * j;
        let mut x = DVec3::new(0.3, 0.7, 0.2);
        for _ in 0..500 {
            x = (jtj * x).normalize();
        }
        (jtj * x).length().sqrt()
    }

    #[test]
    fn matches_a_dense_reference_on_random_triangles() {
        let mut rng = Rng::new(5);
        for _ in 0..500 {
            let r = [rng.vec3(), rng.vec3(), rng.vec3()];
            let m = [rng.vec3() * 3.0, rng.vec3() * 3.0, rng.vec3() * 3.0];
            let Some((s1, s2)) = singular_values(r, m) else {
                continue;
            };
            assert!(s1 >= s2 && s2 >= 0.0);
            assert_close(s1, largest_reference(r, m), 1e-6, "largest singular value");
        }
    }

    #[test]
    fn rigid_motions_do_not_stretch_and_shear_does() {
        let rest = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0)];
        let tris = [[0, 1, 2], [1, 3, 2]];
        // A turn and a move.
        let q = glam::Quat::from_axis_angle(Vec3::new(1.0, 2.0, 3.0).normalize(), 1.1);
        let turned: Vec<Vec3> = rest.iter().map(|p| q * *p + Vec3::splat(5.0)).collect();
        for s in face_stretches(&rest, &turned, &tris) {
            assert_close(s, 1.0, 1e-6, "rigid");
        }
        // A shear x += 3 y keeps the bottom edge and the left edge's
        // direction of travel but stretches the face by the shear's norm.
        let sheared: Vec<Vec3> = rest.iter().map(|p| *p + Vec3::X * 3.0 * p.y).collect();
        let want = (0.5 * (11.0 + (11.0f64 * 11.0 - 4.0).sqrt())).sqrt();
        for s in face_stretches(&rest, &sheared, &tris) {
            assert_close(s, want, 1e-6, "shear");
        }
        // Degenerate and out-of-range triangles have none.
        let s = face_stretches(&rest, &rest, &[[0, 0, 1], [0, 1, 9]]);
        assert!(s.iter().all(|x| x.is_nan()));
        let sum = summary(&rest, &sheared, &tris, 2.0);
        assert_eq!(sum.over, vec![0, 1]);
        assert_close(sum.largest, want, 1e-6, "largest");
        let none = summary(&rest, &rest, &tris, STRETCH_LIMIT);
        assert_eq!((none.face, none.over.len()), (None, 0));
        assert_eq!(none.largest, 1.0);
    }

    /// The diagnostics list the faces over the limit, warn of them, and
    /// refuse a limit that is no limit.
    #[test]
    fn diagnostics_list_and_warn_of_stretched_faces() {
        use crate::{Combine, DiagnoseOptions, Error, FitOptions, FittedStage};
        let (rest, tris) = crate::testing::grid(20);
        // A long pull out of the plane with a small radius stretches the
        // faces around the start.
        let d = crate::Deformation::fit(
            &[DVec3::new(0.5, 0.5, 0.0)],
            &[DVec3::new(0.5, 0.5, 0.4)],
            FitOptions::new(0.15),
        )
        .expect("fit");
        let stages = [FittedStage::new(d)];
        let none = |_: &str| None;
        let run = |limit: f64| {
            crate::compose_diagnosed_with(
                &rest,
                &stages,
                Combine::Chain,
                &tris,
                &none,
                &DiagnoseOptions::default().with_stretch_limit(limit),
            )
        };
        let (moved, r) = run(2.0).expect("diagnose");
        let each = face_stretches(&rest, &moved, &tris);
        let want: Vec<u32> = (0..tris.len() as u32)
            .filter(|&f| each[f as usize] > 2.0)
            .collect();
        assert!(!want.is_empty());
        assert_eq!(r.stretched, want);
        assert_eq!(r.stretch_limit, 2.0);
        let top = each.iter().copied().fold(1.0, f64::max);
        assert_eq!(r.largest_stretch, top);
        assert_eq!(r.largest_stretch_face.map(|f| each[f as usize]), Some(top));
        assert!(r.warnings.iter().any(|w| w.kind() == "stretched"));
        // The default limit (4) lists fewer, or none.
        let (_, r4) = run(STRETCH_LIMIT).expect("diagnose");
        assert!(r4.stretched.len() < r.stretched.len());
        for bad in [0.5, f64::NAN, f64::INFINITY] {
            assert!(matches!(run(bad), Err(Error::BadStretchLimit(_))), "{bad}");
        }
    }
}
