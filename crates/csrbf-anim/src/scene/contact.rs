//! Contact: where another object's bounding sphere enters a mesh, its
//! vertices are pushed out by control vectors, solved every frame.

use csrbf::{FitOptions, Polynomial, System};
use glam::Vec3;

use super::{Contact, Scene};

impl Scene {
    /// Pushes the vertices of object `oi` inside the pusher's bounding sphere
    /// out to its surface: control vectors from the collision, system built
    /// and solved for this frame only.
    pub(super) fn contact(
        &self,
        oi: usize,
        c: &Contact,
        time: f64,
        local: &mut [Vec3],
        controls: &mut Vec<(Vec3, Vec3, Vec3, f32)>,
    ) {
        let obj = &self.objects[oi];
        let pusher = &self.objects[c.with];
        let (prot, pshift) = pusher.transform(time);
        let centre_world = prot * pusher.center + pshift;
        let (rot, shift) = obj.transform(time);
        let centre = rot.inverse() * (centre_world - shift);
        // Vertices are pushed a little past the sphere: the faces between
        // them are chords that sag inside it by about h^2 / (8 r) for
        // vertices h apart, and near the rim a chord from a pushed vertex to
        // one left on the wall dips deeper. Four times the sag, h^2 / (2 r),
        // keeps the ball behind the wall (the demo's test checks every frame).
        let margin = c.spacing * c.spacing / (2.0 * pusher.radius);
        let r = pusher.radius + margin;
        let mut starts = Vec::new();
        let mut targets = Vec::new();
        let mut depth: f64 = 0.0;
        for p in local.iter() {
            let d = p.as_dvec3() - centre;
            let dist = d.length();
            if dist < r && dist > 1e-12 {
                starts.push(p.as_dvec3());
                targets.push(centre + d / dist * r);
                depth = depth.max(r - dist);
            }
        }
        if starts.is_empty() {
            return;
        }
        let radius = c.reach * (0.5 * r + depth);
        let opts = FitOptions::new(radius)
            .with_kernel(c.kernel)
            .with_polynomial(Polynomial::None);
        let Ok(def) = System::new(&starts, opts).and_then(|s| s.solve(&targets)) else {
            return;
        };
        let disp = def.displacements_f32(local);
        for (p, d) in local.iter_mut().zip(disp) {
            *p += d;
        }
        for (s, g) in starts.iter().zip(&targets) {
            controls.push((s.as_vec3(), g.as_vec3(), g.as_vec3(), radius as f32));
        }
    }
}
