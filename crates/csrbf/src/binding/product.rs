//! The product a new deformation costs: per cell, its candidates'
//! coefficients put in f32 lanes beside the coordinates the binding keeps;
//! per point, the evaluation's kernel sum over those lanes
//! ([`crate::lanes::Narrow`]) from the point's coordinates in the cell's
//! frame (computed from the centre the binding keeps), plus the polynomial
//! part in f64. The same cells, frames, candidates and arithmetic as
//! [`Deformation::displacements_f32`], so the same values, bit for bit;
//! a cell that is not narrow, or whose coefficients would cancel in f32,
//! is summed in f64 as the evaluation sums it.
//!
//! Each cell writes its points' displacements straight to their places in
//! the caller's buffer (the binding's `order`), so a refit allocates
//! nothing and makes one pass. Those places are scattered when the
//! caller's order is not the cells' (a point a cache line), so a cell sums
//! its points a chunk at a time and asks for the next chunk's places' lines
//! meanwhile.

use glam::{DVec3, Vec3};

use super::{Binding, Cell, Rest};
use crate::deformation::Deformation;
use crate::evaluate::{Candidates, PARALLEL_POINTS, Scatter, for_each_with_scratch};
use crate::lanes::{ChunkScratch, Coefficients, Narrow, Sums, View};
use crate::simd::Avx2Fma;

/// Per-thread scratch: a cell's coefficients in lanes, the candidates of a
/// cell summed in f64, and a chunk's arrays.
#[derive(Default)]
struct Scratch {
    alpha: [Vec<f32>; 3],
    candidates: Candidates,
    chunk: ChunkScratch,
}

/// Writes D of `d` at every bound point into `out` (point order; `out`
/// holds one vector per bound point).
pub(super) fn displacements(b: &Binding, d: &Deformation, out: &mut [Vec3]) {
    assert_eq!(out.len(), b.len(), "one displacement per bound point");
    // The evaluation's choice of kernel sum (so the same values).
    let sums = Sums::of(Avx2Fma::detect(), b.kernel);
    let coefficients = Coefficients::new(d.coefficients());
    let parallel = out.len() >= PARALLEL_POINTS;
    let out = Scatter::new(out);
    let work = |s: &mut Scratch, c: &Cell| cell(b, d, (sums, &coefficients), c, s, &out);
    for_each_with_scratch(&b.cells, parallel, work);
}

/// One cell's points.
fn cell(
    b: &Binding,
    d: &Deformation,
    (sums, coefficients): (Sums, &Coefficients),
    c: &Cell,
    s: &mut Scratch,
    out: &Scatter<'_, Vec3>,
) {
    let alpha = d.coefficients();
    let g = &b.groups[c.group];
    let points = c.point..c.point + c.points;
    // The cell's places in the caller's order (`None`: they are its own).
    let places = b.order.as_deref().map(|o| &o[points.clone()]);
    let mut narrow = c.narrow;
    if narrow {
        // The coefficients in lanes, and the sum of their sizes in the
        // evaluation's order.
        let ids = &g.ids[c.id..c.id + c.candidates];
        let reach = coefficients.fill(ids, &mut s.alpha);
        // Coefficients far larger than the moves cancel: f32 sums would
        // keep only their rounding.
        narrow = reach <= d.f32_reach();
    }
    if !narrow {
        let radius = b.radius;
        s.candidates
            .gather(d.octree(), points.clone().map(|k| b.rest.at(k)), radius);
        let linear = d.affine().map(|a| a.linear());
        for k in 0..c.points {
            let x = b.rest.at(c.point + k);
            let v = if x.is_finite() {
                let mut v = linear.map_or(DVec3::ZERO, |l| l.eval(x));
                let cand = &mut s.candidates;
                cand.for_each_weight(x, b.kernel, radius, |j, w| v += alpha[j as usize] * w);
                v.as_vec3()
            } else {
                Vec3::NAN
            };
            let place = places.map_or(c.point + k, |p| p[k] as usize);
            // SAFETY: each place belongs to this cell alone, and `order`
            // maps places to points one to one (a permutation, see
            // `Blocks`).
            #[allow(unsafe_code)]
            unsafe {
                out.write(place, v)
            };
        }
        return;
    }
    let lanes = c.id..c.id + c.candidates;
    let view = View {
        xyz: g.xyz.each_ref().map(|v| &v[lanes.clone()]),
        alpha: s.alpha.each_ref().map(Vec::as_slice),
    };
    let narrow = Narrow {
        view,
        sums,
        linear: d.affine().map(|a| a.linear()),
        centre: c.centre,
        inv_radius: 1.0 / b.radius,
        places,
        first: c.point,
    };
    // SAFETY: the cell's places are its own: `order` is a permutation and
    // the cells' ranges do not overlap (see `Blocks`).
    #[allow(unsafe_code)]
    unsafe {
        match &b.rest {
            Rest::F32(p) => narrow.write(&p[points], out, &mut s.chunk),
            Rest::F64(p) => narrow.write(&p[points], out, &mut s.chunk),
        }
    }
}
