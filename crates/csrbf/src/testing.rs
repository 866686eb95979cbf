//! Helpers for the engine's own tests.

pub(crate) use crate::synthetic::Rng;

/// Asserts |a - b| <= tol * max(1, |b|), printing the difference.
#[track_caller]
pub(crate) fn assert_close(a: f64, b: f64, tol: f64, what: &str) {
    let diff = (a - b).abs();
    assert!(
        diff <= tol * b.abs().max(1.0),
        "{what}: {a} vs {b}, difference {diff:e} over tolerance {tol:e}"
    );
}

/// A grid of triangles in the plane z = 0, `n` x `n` cells over [0, 1]^2.
pub(crate) fn grid(n: usize) -> (Vec<glam::Vec3>, Vec<[u32; 3]>) {
    let at = |i: usize, j: usize| (j * (n + 1) + i) as u32;
    let v = (0..=n)
        .flat_map(|j| (0..=n).map(move |i| glam::Vec3::new(i as f32, j as f32, 0.0) / n as f32))
        .collect();
    let t = (0..n)
        .flat_map(|j| {
            (0..n).flat_map(move |i| {
                [
                    [at(i, j), at(i + 1, j), at(i + 1, j + 1)],
                    [at(i, j), at(i + 1, j + 1), at(i, j + 1)],
                ]
            })
        })
        .collect();
    (v, t)
}

/// An "arm beside a torso": a strip bent into a hairpin, its two legs
/// `gap` apart in x (the torso leg at x = 0, the arm leg at x = gap), each
/// `length` long down from y = 0, joined over the top by a half circle; it
/// extends over z in [0, 1]. Near in space across the gap, far along the
/// surface. Returns the points, triangles and, per point, whether it lies
/// on the torso leg (x < gap / 2 and y < 0).
pub(crate) fn hairpin(gap: f32, length: f32) -> (Vec<glam::Vec3>, Vec<[u32; 3]>, Vec<bool>) {
    let step = 0.05f32;
    let r = gap / 2.0;
    // The path in the xy-plane: down the torso leg reversed, over, down the arm.
    let mut path = Vec::new();
    let legs = (length / step).round() as usize;
    for k in (0..=legs).rev() {
        path.push(glam::Vec2::new(0.0, -(k as f32) * step));
    }
    let arc = ((std::f32::consts::PI * r / step).ceil() as usize).max(4);
    for k in 1..arc {
        let a = std::f32::consts::PI * (1.0 - k as f32 / arc as f32);
        path.push(glam::Vec2::new(r + r * a.cos(), r * a.sin()));
    }
    for k in 0..=legs {
        path.push(glam::Vec2::new(gap, -(k as f32) * step));
    }
    let rows = 10;
    let mut points = Vec::new();
    for p in &path {
        for j in 0..=rows {
            points.push(glam::Vec3::new(p.x, p.y, j as f32 / rows as f32));
        }
    }
    let at = |i: usize, j: usize| (i * (rows + 1) + j) as u32;
    let mut tris = Vec::new();
    for i in 0..path.len() - 1 {
        for j in 0..rows {
            tris.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            tris.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    let torso = points.iter().map(|p| p.x < r && p.y < 0.0).collect();
    (points, tris, torso)
}
