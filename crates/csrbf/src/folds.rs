//! Where deformations acting on a mesh turn it inside out, and from which
//! phase: det J <= 0 at a triangle's centroid.
//!
//! The centroid is sampled because it is the one point every triangle of a
//! polygon's fan has inside it, away from the vertices a control vector's
//! start usually sits on; a fold smaller than a triangle can slip between
//! centroids, and a fold over a large triangle is judged at its middle.
//!
//! A stage on a region moves a point by phase * w * D, where w is the
//! region's weight (1 inside, 0 outside, blended in a falloff). w lives on
//! the vertices; on a triangle it is their linear interpolant, so the
//! stage's Jacobian there is I + phase (w G + D grad(w)^T). Stages added
//! ([`Combine::Add`], or a single stage) make the whole Jacobian
//! I + s sum_k phase_k (...), linear in the scale s of every phase: its
//! determinant is a cubic and [`fold_phase`] its first root. Chained stages
//! multiply their Jacobians, each at the point the ones before it moved
//! there; the fold phase is then found by scanning s and bisecting.

use glam::{DMat3, DVec3, Vec3};
use rayon::prelude::*;

use crate::error::Result;
use crate::jacobian::fold_phase;
use crate::region::Region;
use crate::stage::{Combine, FittedStage};

/// What [`folds`] found.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Folds {
    /// Triangles whose centroid the deformed map turns inside out
    /// (det J <= 0), ascending.
    pub triangles: Vec<u32>,
    /// The first scale s in (0, 1] of every stage's phase at which some
    /// centroid folds; None when none does up to the phases given.
    pub fold_phase: Option<f64>,
}

/// Steps of the scan of s for chained stages (then 30 bisections).
const CHAIN_SCAN: usize = 32;

/// One stage's weights on the triangles: per triangle the weight at the
/// centroid and its gradient in rest coordinates; None when the stage acts
/// on every point with weight 1.
type FaceWeights = Option<Vec<(f64, DVec3)>>;

/// Inside-out triangles of `rest` (deformed by `stages` combined as
/// `combine`, each at its phase) and the first phase at which any folds.
pub fn folds(
    rest: &[Vec3],
    triangles: &[[u32; 3]],
    stages: &[FittedStage],
    combine: Combine,
    groups: &dyn Fn(&str) -> Option<Vec<u32>>,
) -> Result<Folds> {
    if triangles.is_empty() || stages.is_empty() {
        return Ok(Folds::default());
    }
    if stages.iter().any(|s| s.rigid_part) {
        return folds_with_rigid_parts(rest, triangles, stages, combine, groups);
    }
    let centroids: Vec<DVec3> = triangles
        .iter()
        .map(|t| {
            t.iter()
                .map(|&v| rest[v as usize].as_dvec3())
                .sum::<DVec3>()
                / 3.0
        })
        .collect();
    let weights = stages
        .iter()
        .map(|s| face_weights(rest, triangles, &s.region, groups))
        .collect::<Result<Vec<FaceWeights>>>()?;
    // A sweep's steps move by phases that are not linear in the scale: only
    // the chained scan follows them.
    let swept = stages.iter().any(|s| s.sweep.is_some());
    if (combine == Combine::Add || stages.len() == 1) && !swept {
        return Ok(added(&centroids, stages, &weights));
    }
    Ok(chained(&centroids, stages, &weights))
}

/// [`folds`] of stages with handles' rigid parts. A rigid part moves its
/// points as one (an affine map of positive determinant), so no face all of
/// whose corners it moves can fold: those faces are left out. Its
/// deformation's blend, the stages after it, stands for the rest: its map
/// meets the rigid part at the handle's samples, so it is judged over the
/// handle's points as well as its own region (a face with corners on both
/// sides is where they meet).
fn folds_with_rigid_parts(
    rest: &[Vec3],
    triangles: &[[u32; 3]],
    stages: &[FittedStage],
    combine: Combine,
    groups: &dyn Fn(&str) -> Option<Vec<u32>>,
) -> Result<Folds> {
    let mut rigid = vec![false; rest.len()];
    let mut kept: Vec<FittedStage> = Vec::with_capacity(stages.len());
    let mut k = 0;
    while k < stages.len() {
        if !stages[k].rigid_part {
            kept.push(stages[k].clone());
            k += 1;
            continue;
        }
        let mut moved = Vec::new();
        while k < stages.len() && stages[k].rigid_part {
            moved = stages[k].region.select(rest, groups)?;
            k += 1;
        }
        for &i in &moved {
            if let Some(r) = rigid.get_mut(i as usize) {
                *r = true;
            }
        }
        // The blend: the next deformation's stages (a sweep's every step).
        let blend = match stages.get(k).and_then(|s| s.sweep) {
            Some(step) => (step.count - step.index) as usize,
            None => 1,
        };
        for s in stages.iter().skip(k).take(blend) {
            let (mut idx, mut w) = s.region.weights(rest, groups)?;
            idx.extend(moved.iter().copied());
            w.extend(std::iter::repeat_n(1.0, moved.len()));
            let mut both: Vec<(u32, f32)> = idx.into_iter().zip(w).collect();
            both.sort_unstable_by_key(|x| x.0);
            both.dedup_by_key(|x| x.0);
            let (vertices, weights) = both.into_iter().unzip();
            kept.push(s.clone().with_region(Region::Weights { vertices, weights }));
        }
        k += blend;
    }
    let faces: Vec<usize> = (0..triangles.len())
        .filter(|&f| {
            !triangles[f]
                .iter()
                .all(|&v| rigid.get(v as usize).copied().unwrap_or(false))
        })
        .collect();
    let subset: Vec<[u32; 3]> = faces.iter().map(|&f| triangles[f]).collect();
    if subset.is_empty() || kept.is_empty() {
        return Ok(Folds::default());
    }
    let found = folds(rest, &subset, &kept, combine, groups)?;
    Ok(Folds {
        triangles: found
            .triangles
            .iter()
            .map(|&t| faces[t as usize] as u32)
            .collect(),
        fold_phase: found.fold_phase,
    })
}

fn face_weights(
    rest: &[Vec3],
    triangles: &[[u32; 3]],
    region: &Region,
    groups: &dyn Fn(&str) -> Option<Vec<u32>>,
) -> Result<FaceWeights> {
    if *region == Region::All {
        return Ok(None);
    }
    let (idx, w) = region.weights(rest, groups)?;
    let mut wv = vec![0.0f64; rest.len()];
    for (&i, &w) in idx.iter().zip(&w) {
        wv[i as usize] = w as f64;
    }
    Ok(Some(
        triangles
            .iter()
            .map(|t| {
                let p = t.map(|v| rest[v as usize].as_dvec3());
                let w = t.map(|v| wv[v as usize]);
                ((w[0] + w[1] + w[2]) / 3.0, plane_gradient(p, w))
            })
            .collect(),
    ))
}

/// The gradient of the linear function with values `w` at the corners `p`,
/// in the triangle's plane (zero across it, and for a degenerate triangle).
fn plane_gradient(p: [DVec3; 3], w: [f64; 3]) -> DVec3 {
    let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
    let n = e1.cross(e2);
    let n2 = n.length_squared();
    if !(n2 > 0.0) || (w[0] == w[1] && w[1] == w[2]) {
        return DVec3::ZERO;
    }
    ((w[1] - w[0]) * e2.cross(n) + (w[2] - w[0]) * n.cross(e1)) / n2
}

/// The weight and gradient of stage `k` at triangle `f`.
fn weight_at(weights: &FaceWeights, f: usize) -> (f64, DVec3) {
    weights.as_ref().map_or((1.0, DVec3::ZERO), |w| w[f])
}

/// A stage's displacement gradient on a triangle, its region included:
/// w G + D grad(w)^T.
fn stage_gradient(w: f64, grad_w: DVec3, d: DVec3, g: DMat3) -> DMat3 {
    g * w + DMat3::from_cols(d * grad_w.x, d * grad_w.y, d * grad_w.z)
}

/// Triangles (by index) a stage moves: any corner with a weight.
fn acts_on(weights: &FaceWeights, f: usize) -> bool {
    weights
        .as_ref()
        .is_none_or(|w| w[f].0 > 0.0 || w[f].1 != DVec3::ZERO)
}

fn added(centroids: &[DVec3], stages: &[FittedStage], weights: &[FaceWeights]) -> Folds {
    // One deformation over every point: cells whose gradient bound keeps
    // |phase G| < 1 cannot fold and are not evaluated (most of a local edit).
    let limit = match (stages, weights) {
        ([one], [None]) if one.phase > 0.0 => 1.0 / one.phase,
        _ => 0.0,
    };
    // The summed gradient of every face some stage evaluated, sparse.
    let mut total: Vec<(u32, DMat3)> = Vec::new();
    let mut slot: Vec<u32> = if stages.len() > 1 {
        vec![u32::MAX; centroids.len()]
    } else {
        Vec::new()
    };
    for (k, stage) in stages.iter().enumerate() {
        let faces: Vec<u32> = match &weights[k] {
            None => (0..centroids.len() as u32).collect(),
            Some(_) => (0..centroids.len() as u32)
                .filter(|&f| acts_on(&weights[k], f as usize))
                .collect(),
        };
        let pts: Vec<DVec3> = faces.iter().map(|&f| centroids[f as usize]).collect();
        for (i, d, g) in stage
            .deformation
            .displacements_and_gradients_above(&pts, limit)
        {
            let f = faces[i as usize];
            let (w, gw) = weight_at(&weights[k], f as usize);
            let add = stage_gradient(w, gw, d, g) * stage.phase;
            if slot.is_empty() {
                total.push((f, add));
            } else if slot[f as usize] == u32::MAX {
                slot[f as usize] = total.len() as u32;
                total.push((f, add));
            } else {
                total[slot[f as usize] as usize].1 += add;
            }
        }
    }
    let found: Vec<(u32, bool, Option<f64>)> = total
        .par_iter()
        .map(|(f, g)| {
            // Folded at s = 1 (the phases given), and from which s on.
            let folded = !((DMat3::IDENTITY + *g).determinant() > 0.0);
            (*f, folded, fold_phase(*g))
        })
        .collect();
    let mut triangles: Vec<u32> = found.iter().filter(|x| x.1).map(|x| x.0).collect();
    triangles.sort_unstable();
    Folds {
        triangles,
        fold_phase: found.iter().filter_map(|x| x.2).min_by(f64::total_cmp),
    }
}

/// A chained stage's weight at triangle `f` and the gradient of its
/// weighted displacement there: w lives on the rest surface, so its
/// gradient where the stage acts is the rest one carried by `jac`, the
/// stages before it.
fn chained_gradient(
    weights: &FaceWeights,
    f: usize,
    jac: &DMat3,
    d: DVec3,
    g: DMat3,
) -> (f64, DMat3) {
    let (w, gw_rest) = weight_at(weights, f);
    let gw = if gw_rest == DVec3::ZERO {
        gw_rest
    } else {
        jac.inverse().transpose() * gw_rest
    };
    (w, stage_gradient(w, gw, d, g))
}

/// Moves a centroid `x` (and its Jacobian `jac`) by a stage of weight `w`,
/// gradient `m` and displacement `d` at phase `t`.
fn advance(x: &mut DVec3, jac: &mut DMat3, (w, m, d): (f64, DMat3, DVec3), t: f64) {
    *jac = (DMat3::IDENTITY + m * t) * *jac;
    *x += d * (w * t);
}

/// det J of the chain at every centroid in `faces`, every phase scaled by `s`.
fn chain_dets(
    centroids: &[DVec3],
    faces: &[usize],
    stages: &[FittedStage],
    weights: &[FaceWeights],
    s: f64,
) -> Vec<f64> {
    let mut x: Vec<DVec3> = faces.iter().map(|&f| centroids[f]).collect();
    let mut jac = vec![DMat3::IDENTITY; faces.len()];
    for (k, stage) in stages.iter().enumerate() {
        let t = stage.phase_at(s);
        let dg = stage.deformation.displacements_and_gradients(&x);
        for (i, (d, g)) in dg.into_iter().enumerate() {
            let (w, m) = chained_gradient(&weights[k], faces[i], &jac[i], d, g);
            advance(&mut x[i], &mut jac[i], (w, m, d), t);
        }
    }
    jac.iter().map(|j| j.determinant()).collect()
}

fn chained(centroids: &[DVec3], stages: &[FittedStage], weights: &[FaceWeights]) -> Folds {
    // Every stage certified (|phase G| < 1 everywhere in space, as a sweep's
    // steps are) and none blended by a region: each stage's map is
    // one-to-one at every phase, and so is their chain. Nothing can fold,
    // and the check (k evaluations with gradients at every centroid) is not
    // run: `crates/csrbf-py/bench/fold_truth.py` measures it against a dense
    // reference instead.
    let certified = weights.iter().all(Option::is_none)
        && stages.iter().all(|s| {
            // A sweep's step can run in full whatever the sweep's phase.
            let most = if s.sweep.is_some() {
                1.0
            } else {
                s.phase.clamp(0.0, 1.0)
            };
            s.deformation.gradient_bound() * most < 1.0
        });
    if certified {
        return Folds::default();
    }
    if let Some(f) = swept(centroids, stages, weights) {
        return f;
    }
    scanned(centroids, stages, weights)
}

/// A sweep's chain (every stage a step of one sweep, in order: each runs
/// while the others stand, full or not begun), walked once: at step k the
/// steps before it are whole, so det J(s) = det(I + t M_k) det(J before),
/// and the first fold in the step's phase interval is the cubic's first
/// root ([`crate::fold_phase`]), exact, at one gradient per centroid and
/// step. The general scan ([`scanned`]) took 33 walks of the whole chain and
/// 30 more to bisect (a 246-step sweep in a connected region: 46 s on a
/// 2,775-vertex elephant) and could miss a fold between its 32 phases.
/// None when the stages are not one sweep's steps.
fn swept(centroids: &[DVec3], stages: &[FittedStage], weights: &[FaceWeights]) -> Option<Folds> {
    let first = stages.first()?;
    let count = first.sweep?.count as usize;
    let one_sweep = stages.len() == count
        && stages.iter().enumerate().all(|(k, s)| {
            s.phase == first.phase
                && s.sweep.map(|w| (w.index as usize, w.count as usize)) == Some((k, count))
        });
    if !one_sweep || !(first.phase > 0.0) {
        return None;
    }
    // Step k runs over track phases s in [k, k + 1] / (phase count).
    let scale = first.phase * count as f64;
    let mut x = centroids.to_vec();
    let mut jac = vec![DMat3::IDENTITY; centroids.len()];
    let mut fold_phase: Option<f64> = None;
    for (k, stage) in stages.iter().enumerate() {
        let t_end = stage.phase_at(1.0);
        if !(t_end > 0.0) {
            break;
        }
        let dg = stage.deformation.displacements_and_gradients(&x);
        let mut first_here: Option<f64> = None;
        for (i, (d, g)) in dg.into_iter().enumerate() {
            let (w, m) = chained_gradient(&weights[k], i, &jac[i], d, g);
            if fold_phase.is_none()
                && let Some(t) = crate::fold_phase(m)
                && t <= t_end
            {
                first_here = Some(first_here.map_or(t, |f: f64| f.min(t)));
            }
            advance(&mut x[i], &mut jac[i], (w, m, d), t_end);
        }
        if let Some(t) = first_here {
            fold_phase = Some((k as f64 + t) / scale);
        }
    }
    let triangles = (0..jac.len() as u32)
        .filter(|&f| !(jac[f as usize].determinant() > 0.0))
        .collect();
    Some(Folds {
        triangles,
        fold_phase,
    })
}

/// Any chain: the determinants at every centroid at [`CHAIN_SCAN`] phases,
/// then bisection in the first bracket where one folds.
fn scanned(centroids: &[DVec3], stages: &[FittedStage], weights: &[FaceWeights]) -> Folds {
    let all: Vec<usize> = (0..centroids.len()).collect();
    let at_one = chain_dets(centroids, &all, stages, weights, 1.0);
    let triangles: Vec<u32> = (0..at_one.len() as u32)
        .filter(|&f| !(at_one[f as usize] > 0.0))
        .collect();
    // Scan s, then bisect the first bracket where some centroid folds.
    let mut lo = 0.0;
    let mut folded: Option<(f64, Vec<usize>)> = None;
    for step in 1..=CHAIN_SCAN {
        let s = step as f64 / CHAIN_SCAN as f64;
        let dets = if step == CHAIN_SCAN {
            at_one.clone()
        } else {
            chain_dets(centroids, &all, stages, weights, s)
        };
        let bad: Vec<usize> = (0..dets.len()).filter(|&f| !(dets[f] > 0.0)).collect();
        if !bad.is_empty() {
            folded = Some((s, bad));
            break;
        }
        lo = s;
    }
    let fold_phase = folded.map(|(mut hi, bad)| {
        for _ in 0..30 {
            let mid = 0.5 * (lo + hi);
            if chain_dets(centroids, &bad, stages, weights, mid)
                .iter()
                .any(|d| !(*d > 0.0))
            {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        hi
    });
    Folds {
        triangles,
        fold_phase,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Deformation, FitOptions, Kernel};
    use glam::Vec3;

    use crate::testing::grid;

    /// The region within `distance` along the grid of its one start at its
    /// middle, blended over `falloff`, resolved into weights.
    fn connected(rest: &[Vec3], tris: &[[u32; 3]], distance: f64, falloff: f64) -> Region {
        let surface = crate::Surface::new(rest, tris).expect("surface");
        let seeds = surface.seeds_at(&[DVec3::new(0.5, 0.5, 0.0)]);
        Region::Falloff {
            inner: Box::new(Region::Connected {
                distance,
                from: crate::Origin::Starts,
            }),
            width: falloff,
        }
        .on_surface(&surface, &seeds)
        .expect("region")
    }

    /// A dense reference: det J of the composed map at each centroid by
    /// central differences of the composition itself.
    fn reference(
        rest: &[Vec3],
        tris: &[[u32; 3]],
        stages: &[FittedStage],
        combine: Combine,
        s: f64,
    ) -> Vec<u32> {
        let map = |x: DVec3| -> DVec3 {
            let mut p = x;
            for st in stages {
                let at = if combine == Combine::Chain { p } else { x };
                p += st.deformation.displacement_at(at) * (st.phase * s);
            }
            p
        };
        let h = 1e-6;
        (0..tris.len() as u32)
            .filter(|&f| {
                let c = tris[f as usize]
                    .iter()
                    .map(|&v| rest[v as usize].as_dvec3())
                    .sum::<DVec3>()
                    / 3.0;
                let col = |k: usize| {
                    (map(c + DVec3::AXES[k] * h) - map(c - DVec3::AXES[k] * h)) / (2.0 * h)
                };
                DMat3::from_cols(col(0), col(1), col(2)).determinant() <= 0.0
            })
            .collect()
    }

    #[test]
    fn inside_out_triangles_match_a_dense_reference() {
        let (rest, tris) = grid(40);
        // A long pull across the middle: past the fold-free bound.
        let d1 = Deformation::fit(
            &[DVec3::new(0.5, 0.5, 0.0)],
            &[DVec3::new(0.8, 0.5, 0.0)],
            FitOptions::new(0.3).with_kernel(Kernel::C2),
        )
        .expect("fit");
        let d2 = Deformation::fit(
            &[DVec3::new(0.3, 0.3, 0.0), DVec3::new(0.7, 0.7, 0.0)],
            &[DVec3::new(0.3, 0.45, 0.0), DVec3::new(0.55, 0.7, 0.0)],
            FitOptions::new(0.25).with_kernel(Kernel::C4),
        )
        .expect("fit");
        let none = |_: &str| None;
        for (stages, combine) in [
            (vec![FittedStage::new(d1.clone())], Combine::Chain),
            (
                vec![
                    FittedStage::new(d1.clone()),
                    FittedStage::new(d2.clone()).with_phase(0.8),
                ],
                Combine::Add,
            ),
            (
                vec![FittedStage::new(d1.clone()), FittedStage::new(d2.clone())],
                Combine::Chain,
            ),
        ] {
            let got = folds(&rest, &tris, &stages, combine, &none).expect("folds");
            let want = reference(&rest, &tris, &stages, combine, 1.0);
            assert!(!want.is_empty(), "the edit must fold");
            let diff = got.triangles.iter().filter(|t| !want.contains(t)).count()
                + want.iter().filter(|t| !got.triangles.contains(t)).count();
            assert!(
                diff <= 2,
                "{combine:?}: {} vs {} ({diff} differ)",
                got.triangles.len(),
                want.len()
            );
            // The fold phase: nothing folds just before it, something just after.
            let p = got.fold_phase.expect("folds");
            assert!(
                reference(&rest, &tris, &stages, combine, p - 0.01).is_empty(),
                "{combine:?} {p}"
            );
            assert!(
                !reference(&rest, &tris, &stages, combine, (p + 0.01).min(1.0)).is_empty(),
                "{combine:?} {p}"
            );
        }
        // A short move folds nothing.
        let small = Deformation::fit(
            &[DVec3::new(0.5, 0.5, 0.0)],
            &[DVec3::new(0.55, 0.5, 0.0)],
            FitOptions::new(0.3),
        )
        .expect("fit");
        let f = folds(
            &rest,
            &tris,
            &[FittedStage::new(small)],
            Combine::Chain,
            &none,
        )
        .expect("folds");
        assert_eq!(f, Folds::default());
    }

    /// A region's hard edge shears the triangles across it: their Jacobian
    /// includes D grad(w)^T.
    #[test]
    fn a_region_edge_is_part_of_the_jacobian() {
        let (rest, tris) = grid(20);
        let d = Deformation::fit(
            &[DVec3::new(0.5, 0.5, 0.0)],
            &[DVec3::new(0.5, 0.5, 0.0) + DVec3::new(-0.2, 0.0, 0.0)],
            FitOptions::new(0.6),
        )
        .expect("fit");
        // The right half moves left, into the left half, which stays.
        let region = Region::Box {
            min: DVec3::new(0.5, -1.0, -1.0),
            max: DVec3::new(2.0, 2.0, 2.0),
        };
        let none = |_: &str| None;
        let f = folds(
            &rest,
            &tris,
            &[FittedStage::new(d.clone()).with_region(region)],
            Combine::Chain,
            &none,
        )
        .expect("folds");
        assert!(!f.triangles.is_empty());
        let cx = |t: u32| {
            tris[t as usize]
                .iter()
                .map(|&v| rest[v as usize].x)
                .sum::<f32>()
                / 3.0
        };
        assert!(
            f.triangles.iter().all(|&t| (cx(t) - 0.5).abs() < 0.06),
            "only the seam folds"
        );
        // Without the region nothing folds.
        let whole =
            folds(&rest, &tris, &[FittedStage::new(d)], Combine::Chain, &none).expect("folds");
        assert!(whole.triangles.is_empty());
    }

    /// A sweep's chain walked step by step finds what the general scan
    /// finds: the same inside-out triangles (the same arithmetic at the
    /// full phase) and the first fold phase, exactly where the scan bisects
    /// to it (a sweep blended by a region is not certified, so it is
    /// checked).
    #[test]
    fn a_sweeps_folds_walked_step_by_step_match_the_scan() {
        let (rest, tris) = grid(40);
        let region = connected(&rest, &tris, 0.08, 0.05);
        let sweep = crate::Sweep::fit(
            &[DVec3::new(0.5, 0.5, 0.0)],
            &[DVec3::new(0.8, 0.5, 0.0)],
            &crate::Paths::default(),
            FitOptions::new(0.3).with_kernel(Kernel::C2),
            crate::SweepOptions { steps: Some(12) },
        )
        .expect("sweep");
        let stages = FittedStage::sweep(sweep, region, 1.0);
        assert_eq!(stages.len(), 12);
        let rest64: Vec<DVec3> = rest.iter().map(|p| p.as_dvec3()).collect();
        let centroids: Vec<DVec3> = tris
            .iter()
            .map(|t| (rest64[t[0] as usize] + rest64[t[1] as usize] + rest64[t[2] as usize]) / 3.0)
            .collect();
        let none = |_: &str| None;
        let weights: Vec<FaceWeights> = stages
            .iter()
            .map(|s| face_weights(&rest, &tris, &s.region, &none).expect("weights"))
            .collect();
        let walked = swept(&centroids, &stages, &weights).expect("one sweep");
        let scan = scanned(&centroids, &stages, &weights);
        assert!(!scan.triangles.is_empty(), "the blend must fold");
        assert_eq!(walked.triangles, scan.triangles);
        let (a, b) = (
            walked.fold_phase.expect("walked"),
            scan.fold_phase.expect("scanned"),
        );
        assert!((a - b).abs() < 1e-9, "walked {a}, scanned {b}");
        // And through the public entry point.
        let f = folds(&rest, &tris, &stages, Combine::Chain, &none).expect("folds");
        assert_eq!(f.triangles, walked.triangles);
    }

    /// A connected region's weights go through the same path as any
    /// region's: its inside-out triangles match central differences of the
    /// weighted map x + t w(x) D(x), w the linear interpolant of the vertex
    /// weights over the triangle's plane (issue 23).
    #[test]
    fn a_connected_region_folds_as_its_weighted_map() {
        let (rest, tris) = grid(40);
        let region = connected(&rest, &tris, 0.1, 0.12);
        let Region::Weights { vertices, weights } = &region else {
            panic!("not resolved");
        };
        let mut wv = vec![0.0f64; rest.len()];
        for (&v, &w) in vertices.iter().zip(weights) {
            wv[v as usize] = w as f64;
        }
        let d = Deformation::fit(
            &[DVec3::new(0.5, 0.5, 0.0)],
            &[DVec3::new(0.75, 0.5, 0.0)],
            FitOptions::new(0.3).with_kernel(Kernel::C2),
        )
        .expect("fit");
        let stages = [FittedStage::new(d).with_region(region.clone())];
        let none = |_: &str| None;
        let got = folds(&rest, &tris, &stages, Combine::Chain, &none).expect("folds");
        let d = &stages[0].deformation;
        let want: Vec<u32> = (0..tris.len() as u32)
            .filter(|&f| {
                let p = tris[f as usize].map(|v| rest[v as usize].as_dvec3());
                let w = tris[f as usize].map(|v| wv[v as usize]);
                let n = (p[1] - p[0]).cross(p[2] - p[0]);
                let weight = |x: DVec3| {
                    // Barycentric coordinates of x's projection on the plane.
                    let a = (p[1] - x).cross(p[2] - x).dot(n) / n.length_squared();
                    let b = (p[2] - x).cross(p[0] - x).dot(n) / n.length_squared();
                    a * w[0] + b * w[1] + (1.0 - a - b) * w[2]
                };
                let map = |x: DVec3| x + d.displacement_at(x) * weight(x);
                let c = (p[0] + p[1] + p[2]) / 3.0;
                let h = 1e-6;
                let col = |k: usize| {
                    (map(c + DVec3::AXES[k] * h) - map(c - DVec3::AXES[k] * h)) / (2.0 * h)
                };
                DMat3::from_cols(col(0), col(1), col(2)).determinant() <= 0.0
            })
            .collect();
        assert!(!want.is_empty(), "the edit must fold in the blend");
        let diff = got.triangles.iter().filter(|t| !want.contains(t)).count()
            + want.iter().filter(|t| !got.triangles.contains(t)).count();
        assert!(
            diff <= 2,
            "{} vs {} ({diff} differ)",
            got.triangles.len(),
            want.len()
        );
        // Without the region the same pull folds elsewhere or not at all:
        // the region's own gradient is what folds here.
        let whole = folds(
            &rest,
            &tris,
            &[FittedStage::new(d.clone())],
            Combine::Chain,
            &none,
        )
        .expect("folds");
        assert_ne!(whole.triangles, got.triangles);
    }
}
