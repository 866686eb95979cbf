//! A time to positions: deformations blended by their phase tracks (chains
//! evaluated), contact, the rigid motion, normals.

use glam::Vec3;

use super::{Animated, Frame, FrameObject, Scene};
use csrbf::Combine;

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
            let local = &mut out.positions;
            local.clear();
            local.extend_from_slice(&obj.mesh.positions);
            let controls = &mut out.controls;
            controls.clear();
            for anim in &obj.deformations {
                let t = anim.track.phase(time) as f32;
                if anim.combine == Combine::Chain && anim.stages.len() > 1 {
                    Self::chain_frame(&obj.mesh.positions, anim, t, local);
                }
                for st in &anim.stages {
                    if anim.combine == Combine::Add || anim.stages.len() == 1 {
                        for (&v, d) in st.vertices.iter().zip(&st.displacement) {
                            local[v as usize] += *d * t;
                        }
                    }
                    for (s, g) in st.deformation.starts().iter().zip(&st.targets) {
                        let (s, g) = (s.as_vec3(), g.as_vec3());
                        controls.push((s, s + (g - s) * t, g, st.deformation.radius() as f32));
                    }
                }
            }
            if let Some(c) = &obj.contact {
                self.contact(oi, c, time, local, controls);
            }
            let (rot, shift) = obj.transform(time);
            let (rot32, shift32) = (glam::Mat3::from_quat(rot.as_quat()), shift.as_vec3());
            obj.normals
                .moved_into(local, rot32, shift32, &mut out.scratch, &mut out.normals);
            for (s, p, g, _) in controls.iter_mut() {
                *s = rot32 * *s + shift32;
                *p = rot32 * *p + shift32;
                *g = rot32 * *g + shift32;
            }
        }
    }

    /// Adds what a chained control file does at track phase `t`: each stage after
    /// the first is evaluated at the points this file's stages before it moved
    /// (other files of the part add, as blend shapes do).
    fn chain_frame(rest: &[Vec3], anim: &Animated, t: f32, local: &mut [Vec3]) {
        for (l, d) in local.iter_mut().zip(Self::chain_at(rest, anim, t)) {
            *l += d;
        }
    }

    /// The displacement of every vertex by a chained control file at full
    /// track phase (each stage at its own phase in the file).
    pub fn chained_displacement(rest: &[Vec3], anim: &Animated) -> Vec<Vec3> {
        Self::chain_at(rest, anim, 1.0)
    }

    fn chain_at(rest: &[Vec3], anim: &Animated, t: f32) -> Vec<Vec3> {
        let mut x = rest.to_vec();
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
                let pts: Vec<Vec3> = st.region.iter().map(|&v| x[v as usize]).collect();
                let d = st.deformation.displacements_f32(&pts);
                for ((&v, d), w) in st.region.iter().zip(d).zip(&st.weights) {
                    x[v as usize] += d * (f * w);
                }
            }
        }
        for (x, r) in x.iter_mut().zip(rest) {
            *x -= *r;
        }
        x
    }
}
