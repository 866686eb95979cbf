//! A time to positions: deformations blended by their phase tracks (chains
//! evaluated), contact, the rigid motion, normals.
//!
//! An object with no chain of several stages and no contact takes the short
//! way: its points are built as x y z w straight into the normals' lanes
//! from its [`RestLanes`] (rest points, then each stage's displacement times
//! its phase, stage after stage as the `Vec3` code adds them), so a frame
//! makes no pass to copy `Vec3`s and allocates nothing. The others add
//! their displacements to `Vec3`s, as they did, and the normals copy them.

use glam::Vec3;

use super::{Animated, BoundStage, ChainScratch, Frame, FrameObject, Object, RestLanes, Scene};
use csrbf::Combine;
use csrbf_mesh::POINT_FLOATS;

/// Below this share of the vertices (one in eight) a stage's displacement
/// is scattered to its vertices; at or above it a pass over every lane,
/// eight at a time, costs less.
const DENSE_SHARE: usize = 8;

/// Most wide stages a frame adds in the pass that moves its points out.
const FUSED: usize = 4;

/// Most vertices of a mesh whose narrow stages before a wide one are kept
/// dense (16 bytes a vertex each) so that all its stages are added in that
/// pass: the fish's tail (198 of 2108 vertices, between the beak and the
/// wings) made the beak a pass of its own (frame 15.7 -> 15.3 us).
const FUSE_ALL_VERTICES: usize = 1 << 16;

/// What [`Scene::lanes_frame`] leaves to the way out: the base of the
/// fused stages (None: the lanes), their displacements and phases, and how
/// many of them there are.
type Fused<'a> = (Option<&'a [f32]>, [(&'a [f32], f32); FUSED], usize);

impl RestLanes {
    /// The rest points of `positions` as x y z 0 and, for each stage of
    /// `deformations` in order that moves one vertex in eight or more (on a
    /// small mesh of few stages, also each stage before such a one), its
    /// displacement over every vertex as x y z -0 (-0 where it moves none).
    pub fn new(positions: &[Vec3], deformations: &[Animated]) -> RestLanes {
        RestLanes::with_share(positions, deformations, DENSE_SHARE)
    }

    /// [`RestLanes::new`] keeping dense every stage that moves one vertex
    /// in `share` or more and, on a small mesh of at most [`FUSED`] stages,
    /// every stage before a dense one.
    fn with_share(positions: &[Vec3], deformations: &[Animated], share: usize) -> RestLanes {
        let n = positions.len();
        let rest = positions
            .iter()
            .flat_map(|p| [p.x, p.y, p.z, 0.0])
            .collect::<Vec<f32>>()
            .into();
        let stages: Vec<&BoundStage> = deformations.iter().flat_map(|a| &a.stages).collect();
        // Which stages can be dense: each vertex once, a displacement each.
        let able: Vec<bool> = stages
            .iter()
            .map(|st| {
                let mut seen = vec![false; n];
                st.vertices.len() == st.displacement.len()
                    && st.vertices.iter().all(|&v| {
                        (v as usize) < n && !std::mem::replace(&mut seen[v as usize], true)
                    })
            })
            .collect();
        let mut keep: Vec<bool> = stages
            .iter()
            .zip(&able)
            .map(|(st, &able)| able && st.vertices.len().saturating_mul(share) >= n)
            .collect();
        // A narrow stage before a dense one would split the pass that adds
        // the dense ones as the points are moved out in two (the stages
        // before it added lane by lane): on a small mesh it is kept dense
        // too, one more array read in that pass.
        if stages.len() <= FUSED
            && n <= FUSE_ALL_VERTICES
            && let Some(last) = keep.iter().rposition(|&k| k)
        {
            for (k, &able) in keep[..last].iter_mut().zip(&able) {
                *k |= able;
            }
        }
        let dense = stages
            .iter()
            .zip(keep)
            .map(|(st, keep)| {
                keep.then(|| {
                    // -0: x + -0 * t is x for every x when t is not
                    // negative (+0 would turn a -0 into +0).
                    let mut d = csrbf_mesh::CacheAligned::filled(POINT_FLOATS * n, -0.0);
                    for (&v, dv) in st.vertices.iter().zip(&st.displacement) {
                        let at = POINT_FLOATS * v as usize;
                        d[at..at + 3].copy_from_slice(&dv.to_array());
                    }
                    d
                })
            })
            .collect();
        RestLanes { rest, dense }
    }

    /// Whether `obj`'s frames can be built in the lanes: prepared for its
    /// mesh and stages, no chain of several stages, no contact (both need
    /// the points as `Vec3`s mid-frame).
    fn fits(&self, obj: &Object) -> bool {
        let n = obj.mesh.positions.len();
        obj.contact.is_none()
            && self.rest.len() == POINT_FLOATS * n
            && obj.normals.vertices() == n
            && self.dense.len()
                == obj
                    .deformations
                    .iter()
                    .map(|a| a.stages.len())
                    .sum::<usize>()
            && obj
                .deformations
                .iter()
                .all(|a| a.combine != Combine::Chain || a.stages.len() <= 1)
    }
}

impl Scene {
    /// Every object's world vertices, normals and control vectors at `time`.
    pub fn frame(&self, time: f64) -> Frame {
        let mut f = Frame::default();
        self.frame_into(time, &mut f);
        f
    }

    /// [`Scene::frame`] into an existing frame, reusing its buffers: for
    /// playback, where a frame a tick should allocate nothing.
    pub fn frame_into(&self, time: f64, frame: &mut Frame) {
        frame.time = time;
        frame
            .objects
            .resize_with(self.objects.len(), FrameObject::default);
        for (oi, (obj, out)) in self
            .objects
            .iter()
            .zip(frame.objects.iter_mut())
            .enumerate()
        {
            // Each track's phase once (the controls, then the points).
            let phases = &mut out.phases;
            phases.clear();
            phases.extend(obj.deformations.iter().map(|a| a.track.phase(time) as f32));
            let controls = &mut out.controls;
            controls.clear();
            for (anim, &t) in obj.deformations.iter().zip(&out.phases) {
                for st in &anim.stages {
                    for (s, g) in st.deformation.starts().iter().zip(&st.targets) {
                        let (s, g) = (s.as_vec3(), g.as_vec3());
                        controls.push((s, s + (g - s) * t, g, st.deformation.radius() as f32));
                    }
                }
            }
            let (rot, shift) = obj.transform(time);
            let (rot32, shift32) = (glam::Mat3::from_quat(rot.as_quat()), shift.as_vec3());
            if obj.lanes.fits(obj) {
                let (base, stages, fused) = Self::lanes_frame(obj, &out.phases, &mut out.scratch);
                obj.normals.moved_from_lanes_adding(
                    base,
                    &stages[..fused],
                    rot32,
                    shift32,
                    &mut out.scratch,
                    &mut out.positions,
                    &mut out.normals,
                );
            } else {
                let local = &mut out.positions;
                local.clear();
                local.extend_from_slice(&obj.mesh.positions);
                for (anim, &t) in obj.deformations.iter().zip(&out.phases) {
                    if anim.combine == Combine::Chain && anim.stages.len() > 1 {
                        Self::chain_frame(&obj.mesh.positions, anim, t, &mut out.chain, local);
                    } else {
                        for st in &anim.stages {
                            for (&v, d) in st.vertices.iter().zip(&st.displacement) {
                                local[v as usize] += *d * t;
                            }
                        }
                    }
                }
                if let Some(c) = &obj.contact {
                    self.contact(oi, c, time, local, &mut out.controls);
                }
                obj.normals
                    .moved_into(local, rot32, shift32, &mut out.scratch, &mut out.normals);
            }
            for (s, p, g, _) in out.controls.iter_mut() {
                *s = rot32 * *s + shift32;
                *p = rot32 * *p + shift32;
                *g = rot32 * *g + shift32;
            }
        }
    }

    /// The object's local points built in the normals' lanes: rest, then
    /// each stage's displacement times its track's phase (`phases`, one a
    /// deformation), in the order and with the arithmetic of the `Vec3`
    /// path (`p += d * t`). The last wide stages in a row (up to
    /// [`FUSED`]) are left to the caller, who adds them as the points are
    /// moved out: their base (the rest points when no stage came before,
    /// else None: the lanes), their displacements and phases, and how many.
    fn lanes_frame<'a>(
        obj: &'a Object,
        phases: &[f32],
        scratch: &mut csrbf_mesh::NormalsScratch,
    ) -> Fused<'a> {
        let p = scratch.points_mut(&obj.normals);
        let rest = &obj.lanes.rest[..];
        let stages = || {
            obj.deformations
                .iter()
                .zip(phases)
                .flat_map(|(a, &t)| a.stages.iter().map(move |st| (st, t)))
                .zip(&obj.lanes.dense)
        };
        // -0 * t is -0 only for t not negative (and finite).
        let wide = |d: &'a Option<csrbf_mesh::CacheAligned>, t: f32| {
            d.as_deref()
                .filter(|_| t.is_finite() && t.is_sign_positive())
        };
        let mut run = 0;
        for ((_, t), d) in stages() {
            run = if wide(d, t).is_some() { run + 1 } else { 0 };
        }
        let first_fused = obj.lanes.dense.len() - run.min(FUSED);
        // The lanes hold the rest points from the first stage on: the first
        // wide stage adds to them as it copies them.
        let mut started = false;
        for ((st, t), d) in stages().take(first_fused) {
            match wide(d, t) {
                Some(d) if started => csrbf_mesh::add_scaled(p, d, t),
                Some(d) => csrbf_mesh::scaled_sum_into(p, rest, d, t),
                None => {
                    if !started {
                        p.copy_from_slice(rest);
                    }
                    for (&v, d) in st.vertices.iter().zip(&st.displacement) {
                        let (at, d) = (POINT_FLOATS * v as usize, *d * t);
                        // A stage's vertices are the mesh's: `get_mut`
                        // only keeps a bad one from panicking.
                        if let Some(q) = p.get_mut(at..at + 3) {
                            q[0] += d.x;
                            q[1] += d.y;
                            q[2] += d.z;
                        }
                    }
                }
            }
            started = true;
        }
        let mut fused: [(&[f32], f32); FUSED] = [(&[], 0.0); FUSED];
        let mut count = 0;
        for (slot, ((_, t), d)) in fused.iter_mut().zip(stages().skip(first_fused)) {
            if let Some(d) = wide(d, t) {
                *slot = (d, t);
                count += 1;
            }
        }
        ((!started).then_some(rest), fused, count)
    }

    /// Adds what a chained control file does at track phase `t`: each stage after
    /// the first is evaluated at the points this file's stages before it moved
    /// (other files of the part add, as blend shapes do).
    fn chain_frame(
        rest: &[Vec3],
        anim: &Animated,
        t: f32,
        scratch: &mut ChainScratch,
        local: &mut [Vec3],
    ) {
        Self::chain_at(rest, anim, t, scratch);
        for (l, d) in local.iter_mut().zip(&scratch.x) {
            *l += *d;
        }
    }

    /// The displacement of every vertex by a chained control file at full
    /// track phase (each stage at its own phase in the file).
    pub fn chained_displacement(rest: &[Vec3], anim: &Animated) -> Vec<Vec3> {
        let mut scratch = ChainScratch::default();
        Self::chain_at(rest, anim, 1.0, &mut scratch);
        scratch.x
    }

    /// The chain's displacement at track phase `t` into `scratch.x`, in
    /// buffers kept between frames.
    fn chain_at(rest: &[Vec3], anim: &Animated, t: f32, scratch: &mut ChainScratch) {
        let ChainScratch { x, pts, d } = scratch;
        x.clear();
        x.extend_from_slice(rest);
        for (si, st) in anim.stages.iter().enumerate() {
            if si == 0 {
                let f = st.displacement_factor(t);
                for (&v, d) in st.vertices.iter().zip(&st.displacement) {
                    x[v as usize] += *d * f;
                }
            } else {
                let f = st.phase_at(t);
                if f == 0.0 {
                    continue; // a sweep's step not begun yet
                }
                pts.clear();
                pts.extend(st.region.iter().map(|&v| x[v as usize]));
                d.clear();
                d.resize(pts.len(), Vec3::ZERO);
                if st.deformation.displacements_f32_into(pts, d).is_err() {
                    continue; // cannot fail: the lengths were just made equal
                }
                for ((&v, d), w) in st.region.iter().zip(d.iter()).zip(&st.weights) {
                    x[v as usize] += *d * (f * w);
                }
            }
        }
        for (x, r) in x.iter_mut().zip(rest) {
            *x -= *r;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use csrbf_edit::controls::ControlFile;

    /// The frame as it was computed before the lanes: rest `Vec3`s, each
    /// stage scattered (a chain evaluated in fresh buffers), contact, then
    /// the plain normals function and the rigid motion, one vertex at a time.
    fn reference(scene: &Scene, time: f64) -> Vec<(Vec<Vec3>, Vec<Vec3>)> {
        let mut out = Vec::new();
        for (oi, obj) in scene.objects.iter().enumerate() {
            let rest = &obj.mesh.positions;
            let mut local = rest.clone();
            for anim in &obj.deformations {
                let t = anim.track.phase(time) as f32;
                if anim.combine == Combine::Chain && anim.stages.len() > 1 {
                    let mut x = rest.clone();
                    for (si, st) in anim.stages.iter().enumerate() {
                        if si == 0 {
                            let f = st.displacement_factor(t);
                            for (&v, d) in st.vertices.iter().zip(&st.displacement) {
                                x[v as usize] += *d * f;
                            }
                        } else {
                            let f = st.phase_at(t);
                            if f == 0.0 {
                                continue;
                            }
                            let pts: Vec<Vec3> = st.region.iter().map(|&v| x[v as usize]).collect();
                            let d = st.deformation.displacements_f32(&pts);
                            for ((&v, d), w) in st.region.iter().zip(d).zip(&st.weights) {
                                x[v as usize] += d * (f * w);
                            }
                        }
                    }
                    for ((l, x), r) in local.iter_mut().zip(&x).zip(rest) {
                        *l += *x - *r;
                    }
                } else {
                    for st in &anim.stages {
                        for (&v, d) in st.vertices.iter().zip(&st.displacement) {
                            local[v as usize] += *d * t;
                        }
                    }
                }
            }
            if let Some(c) = &obj.contact {
                scene.contact(oi, c, time, &mut local, &mut Vec::new());
            }
            let (rot, shift) = obj.transform(time);
            let (rot, shift) = (glam::Mat3::from_quat(rot.as_quat()), shift.as_vec3());
            let normals = csrbf_mesh::triangle_vertex_normals(&local, &obj.triangles);
            out.push((
                local.iter().map(|p| rot * *p + shift).collect(),
                normals.iter().map(|n| rot * *n).collect(),
            ));
        }
        out
    }

    fn bits(v: &[Vec3]) -> Vec<[u32; 3]> {
        v.iter().map(|p| p.to_array().map(f32::to_bits)).collect()
    }

    /// The demos, and the fish with a chained control file of two stages
    /// and an added one of two.
    fn scenes(dir: &std::path::Path) -> Vec<(String, Scene)> {
        let mut out = Vec::new();
        for name in crate::demos::DEMOS.iter().copied().chain(["fish-chained"]) {
            let Some(mut demo) = crate::demos::demo(name.trim_end_matches("-chained")) else {
                continue;
            };
            if name == "fish-chained" {
                let file = |rel: &str| {
                    let (_, bytes) = demo.files.iter().find(|(r, _)| r == rel).expect("file");
                    ControlFile::parse(std::str::from_utf8(bytes).expect("utf-8")).expect("parse")
                };
                let (beak, tail, wings) = (
                    file("controls/beak.json"),
                    file("controls/tail.json"),
                    file("controls/wings.json"),
                );
                let two = |a: &ControlFile, b: &ControlFile, combine| {
                    let specs = a.deformations.iter().chain(&b.deformations).cloned();
                    ControlFile::new(specs.collect(), combine)
                        .to_text()
                        .into_bytes()
                };
                let chained = two(&beak, &tail, Combine::Chain);
                let added = two(&wings, &tail, Combine::Add);
                for (rel, bytes) in &mut demo.files {
                    match rel.as_str() {
                        "controls/beak.json" => *bytes = chained.clone(),
                        "controls/wings.json" => *bytes = added.clone(),
                        _ => {}
                    }
                }
            }
            let path = demo.write(&dir.join(name), name).expect("write demo");
            out.push((name.to_string(), Scene::load(&path).expect("load demo")));
        }
        out
    }

    /// What a frame of a lanes object does: how many wide stages it leaves
    /// to the way out, whether a track is at phase 0, whether its stages
    /// leave vertices unmoved.
    fn shape(obj: &Object, phases: &[f32]) -> (usize, bool, bool) {
        let mut scratch = csrbf_mesh::NormalsScratch::default();
        let fused = Scene::lanes_frame(obj, phases, &mut scratch).2;
        let mut moved = vec![false; obj.mesh.positions.len()];
        for st in obj.deformations.iter().flat_map(|a| &a.stages) {
            for &v in &st.vertices {
                moved[v as usize] = true;
            }
        }
        (fused, phases.contains(&0.0), moved.contains(&false))
    }

    /// Issue 18: frames built in the normals' lanes (dense stages added lane
    /// by lane or as the points are moved out, several in a row, sparse
    /// ones scattered; tracks at phase 0; meshes partly out of every
    /// start's reach) and frames of chains and contact are bit for bit the
    /// plain computation's, one `Frame` reused for all.
    #[test]
    fn frames_are_the_plain_computation_bit_for_bit() {
        let dir = std::env::temp_dir().join(format!("csrbf-frame-lanes-{}", std::process::id()));
        let mut frame = Frame::default();
        // Lanes objects, dense stages, contact, chains, frames with several
        // stages fused, with a track at phase 0, with vertices unmoved.
        let mut kinds = [0; 7];
        for (name, mut scene) in scenes(&dir) {
            let modes = [
                "as loaded",
                "every stage dense",
                "every stage scattered",
                // Dense stages added lane by lane before a scattered one,
                // after one, and as the points move out.
                "dense at even stages",
                "dense at odd stages",
            ];
            for mode in modes {
                for obj in &mut scene.objects {
                    let share = match mode {
                        "as loaded" => DENSE_SHARE,
                        "every stage scattered" => 0,
                        _ => usize::MAX,
                    };
                    obj.lanes =
                        RestLanes::with_share(&obj.mesh.positions, &obj.deformations, share);
                    let odd = mode == "dense at odd stages";
                    for (k, d) in obj.lanes.dense.iter_mut().enumerate() {
                        if mode.starts_with("dense at") && (k % 2 == 1) != odd {
                            *d = None;
                        }
                    }
                }
                for obj in &scene.objects {
                    kinds[0] += obj.lanes.fits(obj) as usize;
                    kinds[1] += obj.lanes.dense.iter().flatten().count();
                    kinds[2] += obj.contact.is_some() as usize;
                    kinds[3] += obj
                        .deformations
                        .iter()
                        .filter(|a| a.combine == Combine::Chain && a.stages.len() > 1)
                        .count();
                }
                let frames = scene.frame_count();
                for k in [0, 1, frames / 7, frames / 3, frames / 2, frames - 1] {
                    let time = k as f64 / scene.file.fps;
                    scene.frame_into(time, &mut frame);
                    let want = reference(&scene, time);
                    assert_eq!(frame.objects.len(), want.len());
                    for (oi, (got, (p, n))) in frame.objects.iter().zip(&want).enumerate() {
                        let at = format!("{name} object {oi} at {time} s ({mode})");
                        assert_eq!(bits(&got.positions), bits(p), "positions of {at}");
                        assert_eq!(bits(&got.normals), bits(n), "normals of {at}");
                        let obj = &scene.objects[oi];
                        if obj.lanes.fits(obj) {
                            let (fused, zero, unmoved) = shape(obj, &got.phases);
                            kinds[4] += (fused > 1) as usize;
                            kinds[5] += zero as usize;
                            kinds[6] += unmoved as usize;
                        }
                    }
                }
            }
        }
        let _ = std::fs::remove_dir_all(&dir);
        assert!(
            kinds.iter().all(|&k| k > 0),
            "every kind of frame compared: {kinds:?}"
        );
    }
}
