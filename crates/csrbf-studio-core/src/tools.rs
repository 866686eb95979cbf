//! Pointer events in, points out: where a click meets the deformed surface
//! (and where that point is at rest, which is what a control's start must
//! be), which control marker lies under the pointer, and where a dragged
//! destination goes.
//!
//! Pixels are the renderer's: x right, y down, (0, 0) the top-left corner of
//! a picture `size` pixels wide and high, as [`Camera::ray`] takes them.

use csrbf::glam::{DVec3, Vec2, Vec3};
use csrbf_anim::Camera;
use csrbf_mesh::Bvh;

use crate::live::Live;
use crate::state::Document;

/// A point of the surface under the pointer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    /// Where it is as shown (deformed).
    pub shown: Vec3,
    /// The same surface point at rest: a control vector added here starts
    /// at this point.
    pub rest: DVec3,
    /// The triangle hit.
    pub triangle: u32,
    /// The corner of that triangle nearest the hit.
    pub vertex: u32,
}

/// The surface under `pixel`, cast against the preview's deformed positions
/// and carried back to rest by the hit's barycentric weights (None also for
/// a preview without a picking tree).
pub fn pick_surface(
    camera: &Camera,
    size: [u32; 2],
    pixel: Vec2,
    live: &Live,
    rest: &[Vec3],
) -> Option<SurfacePoint> {
    pick_surface_on(camera, size, pixel, live.bvh()?, live.positions(), rest)
}

/// [`pick_surface`] against a tree the caller keeps fitted to `shown` (the
/// app refits its own copy to each preview frame it draws).
pub fn pick_surface_on(
    camera: &Camera,
    size: [u32; 2],
    pixel: Vec2,
    bvh: &Bvh,
    shown: &[Vec3],
    rest: &[Vec3],
) -> Option<SurfacePoint> {
    let ray = camera.ray(pixel, size);
    let hit = bvh.cast(shown, &ray)?;
    let triangles = bvh.triangles();
    Some(SurfacePoint {
        shown: hit.point,
        rest: hit.point_in(triangles, rest).as_dvec3(),
        triangle: hit.triangle,
        vertex: hit.nearest_vertex(triangles),
    })
}

/// Which end of a control vector a marker stands for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum End {
    /// The start (at rest).
    Start,
    /// The destination.
    Target,
}

/// A control marker under the pointer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MarkerHit {
    /// The layer.
    pub layer: usize,
    /// The control in it.
    pub index: usize,
    /// Which end.
    pub end: End,
}

/// What the vertices chosen with the vertex tool become.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VertexTarget {
    /// A handle's selection (a new handle layer).
    Handle,
    /// The active handle's anchor.
    Anchor,
    /// The active layer's region.
    Region,
}

/// The control marker nearest `pixel` within `tolerance` pixels, nearer
/// markers to the eye winning ties; destinations are tried before starts, as
/// they are what a user drags. Handles' generated controls are not markers.
pub fn pick_marker(
    camera: &Camera,
    size: [u32; 2],
    pixel: Vec2,
    doc: &Document,
    tolerance: f32,
) -> Option<MarkerHit> {
    let mut best: Option<(f32, f32, MarkerHit)> = None;
    for (layer, spec) in doc.controls.deformations.iter().enumerate() {
        for index in 0..spec.starts.len() {
            for (end, p) in [
                (End::Target, spec.targets[index]),
                (End::Start, spec.starts[index]),
            ] {
                let Some((at, depth)) = camera.project(p.as_vec3(), size) else {
                    continue;
                };
                let d = at.distance(pixel);
                let better = best
                    .is_none_or(|(bd, bdepth, _)| d < bd - 0.5 || (d < bd + 0.5 && depth < bdepth));
                if d <= tolerance && better {
                    best = Some((d, depth, MarkerHit { layer, index, end }));
                }
            }
        }
    }
    best.map(|(_, _, hit)| hit)
}

/// Moving a point with the pointer: on the plane through it facing the
/// camera, or along one axis through it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DragTool {
    /// Where the point was when the drag began.
    pub origin: DVec3,
    /// The axis it is held to (unit), if any.
    pub axis: Option<DVec3>,
    /// What the pointer grabbed minus the point (so the point does not jump
    /// to the pointer).
    offset: DVec3,
}

impl DragTool {
    /// A drag of the point `origin` grabbed at `pixel`; `axis` holds it to a
    /// line (a zero axis is taken as none).
    pub fn begin(
        camera: &Camera,
        size: [u32; 2],
        pixel: Vec2,
        origin: DVec3,
        axis: Option<DVec3>,
    ) -> DragTool {
        let axis = axis.and_then(|a| a.try_normalize());
        let mut tool = DragTool {
            origin,
            axis,
            offset: DVec3::ZERO,
        };
        if let Some(grabbed) = tool.point_at(camera, size, pixel) {
            tool.offset = grabbed - origin;
        }
        tool
    }

    /// Where the point goes with the pointer at `pixel`; None when the
    /// pointer's ray does not meet the plane in front of the camera, or runs
    /// along the axis.
    pub fn moved_to(&self, camera: &Camera, size: [u32; 2], pixel: Vec2) -> Option<DVec3> {
        self.point_at(camera, size, pixel).map(|p| p - self.offset)
    }

    /// The point of the plane or the axis under the pointer (no offset).
    fn point_at(&self, camera: &Camera, size: [u32; 2], pixel: Vec2) -> Option<DVec3> {
        let ray = camera.ray(pixel, size);
        let (o, d) = (ray.origin.as_dvec3(), ray.dir.as_dvec3());
        let forward = camera.basis().2.as_dvec3();
        match self.axis {
            None => {
                // The plane through the origin with the view direction as normal.
                let denom = d.dot(forward);
                if denom.abs() < 1e-9 {
                    return None;
                }
                let t = (self.origin - o).dot(forward) / denom;
                (t >= 0.0).then(|| o + d * t)
            }
            Some(a) => {
                // The point of the axis closest to the ray.
                let w = self.origin - o;
                let (ad, aw, dw) = (a.dot(d), a.dot(w), d.dot(w));
                let denom = 1.0 - ad * ad;
                if denom < 1e-6 {
                    return None;
                }
                let s = (ad * dw - aw) / denom;
                Some(self.origin + a * s)
            }
        }
    }
}

/// The angle in radians, right-handed about `axis`, that the pointer swept
/// about `centre` going from `pressed` to `pixel`: a rotate ring's turn.
///
/// Measured where the pointer's rays meet the plane through `centre` normal
/// to `axis`, so the turn follows the ring under the pointer whatever the
/// view. A plane seen nearly edge-on (the rays graze it) falls back to the
/// angle swept about the centre's pixel on screen, signed the same way.
pub fn swept_angle(
    camera: &Camera,
    size: [u32; 2],
    centre: DVec3,
    axis: DVec3,
    pressed: Vec2,
    pixel: Vec2,
) -> f64 {
    let Some(axis) = axis.try_normalize() else {
        return 0.0;
    };
    let on_plane = |p: Vec2| {
        let ray = camera.ray(p, size);
        let (o, d) = (ray.origin.as_dvec3(), ray.dir.as_dvec3());
        let denom = d.dot(axis);
        let t = (centre - o).dot(axis) / denom;
        (denom.abs() > 0.15 && t > 0.0).then(|| o + d * t - centre)
    };
    if let (Some(a), Some(b)) = (on_plane(pressed), on_plane(pixel))
        && a.length() > 1e-9
        && b.length() > 1e-9
    {
        return a.cross(b).dot(axis).atan2(a.dot(b));
    }
    let Some((c, _)) = camera.project(centre.as_vec3(), size) else {
        return 0.0;
    };
    let (a, b) = ((pressed - c).as_dvec2(), (pixel - c).as_dvec2());
    // Screen y points down, so a counter-clockwise sweep on screen is
    // right-handed about the axis towards the eye.
    let on_screen = a.perp_dot(b).atan2(a.dot(b));
    let towards_eye = -camera.basis().2.as_dvec3();
    if axis.dot(towards_eye) >= 0.0 {
        -on_screen
    } else {
        on_screen
    }
}

/// The vertices of `positions` (with their `normals`) seen in the box from
/// pixel `lo` to pixel `hi` of `camera`'s picture of `size`: those facing
/// the camera, or every one in the box when `through` (X-ray: the far side
/// and the sides of a limb too).
pub fn vertices_in_box(
    camera: &Camera,
    size: [u32; 2],
    (lo, hi): (Vec2, Vec2),
    (positions, normals): (&[Vec3], &[Vec3]),
    through: bool,
) -> Vec<u32> {
    let forward = camera.basis().2;
    let perspective = matches!(
        camera.projection,
        csrbf_anim::Projection::Perspective { .. }
    );
    let facing = |p: Vec3, n: Vec3| {
        if perspective {
            n.dot(p - camera.eye) < 0.0
        } else {
            n.dot(forward) < 0.0
        }
    };
    positions
        .iter()
        .zip(normals)
        .enumerate()
        .filter(|&(_, (&p, &n))| {
            (through || facing(p, n))
                && camera
                    .project(p, size)
                    .is_some_and(|(q, _)| q.cmpge(lo).all() && q.cmple(hi).all())
        })
        .map(|(i, _)| i as u32)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    const SIZE: [u32; 2] = [400, 300];

    fn camera() -> Camera {
        Camera::perspective(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y, 40.0)
    }

    fn pixel_of(camera: &Camera, p: DVec3) -> Vec2 {
        camera.project(p.as_vec3(), SIZE).expect("in front").0
    }

    #[test]
    fn a_click_on_the_deformed_surface_gives_its_rest_point() {
        let mesh = csrbf_mesh::shapes::uv_sphere(1.0, 24, 48);
        let mut doc = crate::Document::new(mesh, PathBuf::from("s.obj"), 1.2);
        // Push the front of the sphere towards the camera.
        crate::Command::add(0, DVec3::Z, DVec3::Z * 1.4)
            .apply(&mut doc)
            .expect("add");
        crate::Command::add(0, DVec3::NEG_Z, DVec3::NEG_Z)
            .apply(&mut doc)
            .expect("add");
        let mut live = Live::new(&doc);
        live.update(&doc).expect("update");
        let cam = camera();
        let centre = Vec2::new(200.0, 150.0);
        let hit = pick_surface(&cam, SIZE, centre, &live, &doc.mesh.positions).expect("hit");
        // Shown where it was pushed to, and at rest on the unit sphere's front.
        assert!((hit.shown.z - 1.4).abs() < 0.02, "{:?}", hit.shown);
        assert!((hit.rest - DVec3::Z).length() < 0.02, "{:?}", hit.rest);
        assert!(
            pick_surface(&cam, SIZE, Vec2::new(2.0, 2.0), &live, &doc.mesh.positions).is_none()
        );

        // The destination's marker is found at its pixel, the start's at its.
        let target = pick_marker(&cam, SIZE, pixel_of(&cam, DVec3::Z * 1.4), &doc, 6.0);
        assert_eq!(
            target,
            Some(MarkerHit {
                layer: 0,
                index: 0,
                end: End::Target
            })
        );
        let side = DVec3::new(0.9, 0.0, 0.0);
        crate::Command::add(0, side, side)
            .apply(&mut doc)
            .expect("add");
        let start = pick_marker(
            &cam,
            SIZE,
            pixel_of(&cam, side) + Vec2::new(3.0, 0.0),
            &doc,
            6.0,
        );
        assert_eq!(start.map(|m| m.index), Some(2));
        assert!(pick_marker(&cam, SIZE, Vec2::new(5.0, 5.0), &doc, 6.0).is_none());
    }

    /// The turn `swept_angle` gives, applied to where the press met the
    /// ring's plane, lands where the pointer now meets it: for a camera
    /// seeing the ring face on, at a slant, from behind, and for every axis.
    #[test]
    fn a_ring_turn_follows_the_pointer_on_the_ring_plane() {
        let centre = DVec3::new(0.2, -0.1, 0.3);
        let cams = [
            camera(),
            Camera::perspective(Vec3::new(3.0, 2.5, 4.0), Vec3::ZERO, Vec3::Y, 40.0),
            Camera::perspective(Vec3::new(-1.0, -0.5, -5.0), Vec3::ZERO, Vec3::Y, 40.0),
        ];
        let mut checked = 0;
        for cam in &cams {
            for axis in [
                DVec3::X,
                DVec3::Y,
                DVec3::Z,
                DVec3::new(1.0, 2.0, -0.5).normalize(),
            ] {
                // Two points of the ring (radius 0.5) a known turn apart.
                let u = axis.any_orthonormal_vector();
                for turn in [0.4f64, -1.1, 2.5] {
                    let from = centre + u * 0.5;
                    let to = centre + csrbf::glam::DQuat::from_axis_angle(axis, turn) * u * 0.5;
                    let (Some((a, _)), Some((b, _))) = (
                        cam.project(from.as_vec3(), SIZE),
                        cam.project(to.as_vec3(), SIZE),
                    ) else {
                        continue;
                    };
                    let grazing = |p: Vec2| cam.ray(p, SIZE).dir.as_dvec3().dot(axis).abs() < 0.2;
                    if grazing(a) || grazing(b) {
                        continue; // edge-on: the screen fallback, checked below
                    }
                    let got = swept_angle(cam, SIZE, centre, axis, a, b);
                    let diff = (got - turn + std::f64::consts::PI)
                        .rem_euclid(std::f64::consts::TAU)
                        - std::f64::consts::PI;
                    assert!(diff.abs() < 1e-3, "axis {axis} turn {turn}: got {got}");
                    checked += 1;
                }
            }
        }
        assert!(checked >= 20, "only {checked} cases seen face on");

        // Nearly edge-on (the Y axis tilted a little towards the eye, seen
        // level): the sweep on screen, with the sign of a ring seen face on
        // from the same side.
        let cam = camera();
        let c = pixel_of(&cam, DVec3::ZERO);
        let ccw = swept_angle(
            &cam,
            SIZE,
            DVec3::ZERO,
            DVec3::Z,
            c + Vec2::new(30.0, 0.0),
            c + Vec2::new(0.0, -30.0),
        );
        // Seen along -Z, the Z axis points at the eye: a counter-clockwise
        // sweep on screen is a positive turn about Z.
        assert!((ccw - std::f64::consts::FRAC_PI_2).abs() < 1e-3, "{ccw}");
        let edge = swept_angle(
            &cam,
            SIZE,
            DVec3::ZERO,
            DVec3::new(0.0, 1.0, 0.05).normalize(),
            c + Vec2::new(30.0, 0.0),
            c + Vec2::new(0.0, -30.0),
        );
        assert!((edge - std::f64::consts::FRAC_PI_2).abs() < 1e-3, "{edge}");
    }

    #[test]
    fn a_drag_follows_the_pointer_on_the_plane_or_the_axis() {
        let cam = camera();
        let origin = DVec3::new(0.3, -0.2, 0.5);
        let at = pixel_of(&cam, origin);
        // Grabbed slightly off the point: the point does not jump.
        let grab = at + Vec2::new(4.0, -3.0);
        let free = DragTool::begin(&cam, SIZE, grab, origin, None);
        let still = free.moved_to(&cam, SIZE, grab).expect("on the plane");
        assert!((still - origin).length() < 1e-5, "{still}");
        // Moved: stays on the plane facing the camera, under the pointer.
        let moved = free
            .moved_to(&cam, SIZE, grab + Vec2::new(50.0, 20.0))
            .expect("on the plane");
        assert!((moved.z - origin.z).abs() < 1e-6);
        let back = pixel_of(&cam, moved) + Vec2::new(4.0, -3.0);
        assert!(back.distance(grab + Vec2::new(50.0, 20.0)) < 0.05, "{back}");

        // Held to X: only x changes, whatever the pointer does; with the
        // pointer on the axis's image, the point lands under it.
        let on_x = DragTool::begin(&cam, SIZE, at, origin, Some(DVec3::X));
        let p = on_x
            .moved_to(&cam, SIZE, at + Vec2::new(40.0, 25.0))
            .expect("on the axis");
        assert!(
            (p.y - origin.y).abs() < 1e-9 && (p.z - origin.z).abs() < 1e-9,
            "{p}"
        );
        assert!(p.x > origin.x);
        let on_image = pixel_of(&cam, origin + DVec3::X * 0.4);
        let q = on_x.moved_to(&cam, SIZE, on_image).expect("on the axis");
        assert!((q - (origin + DVec3::X * 0.4)).length() < 1e-4, "{q}");
        // An axis along the view is no drag.
        let along = DragTool::begin(&cam, SIZE, at, DVec3::ZERO, Some(DVec3::Z));
        assert!(
            along
                .moved_to(&cam, SIZE, Camera::centre_pixel(SIZE))
                .is_none()
        );
    }
    #[test]
    fn a_box_takes_the_vertices_facing_the_camera_or_all_of_them_through_the_model() {
        let mesh = csrbf_mesh::shapes::uv_sphere(1.0, 12, 24);
        let normals = csrbf_mesh::triangle_vertex_normals(&mesh.positions, &mesh.faces.triangles());
        let cam = camera();
        let whole = (Vec2::ZERO, Vec2::new(SIZE[0] as f32, SIZE[1] as f32));
        let data = (&mesh.positions[..], &normals[..]);
        let front = vertices_in_box(&cam, SIZE, whole, data, false);
        let all = vertices_in_box(&cam, SIZE, whole, data, true);
        // The front half faces the camera at z = 5; X-ray takes every vertex.
        assert_eq!(all.len(), mesh.positions.len());
        assert!(!front.is_empty() && front.len() < all.len());
        for &i in &front {
            assert!(mesh.positions[i as usize].z > -0.05, "{i}");
        }
        // A box over the right half only takes vertices with x > 0.
        let right = (Vec2::new(SIZE[0] as f32 / 2.0 + 1.0, 0.0), whole.1);
        for &i in &vertices_in_box(&cam, SIZE, right, data, true) {
            assert!(mesh.positions[i as usize].x > 0.0, "{i}");
        }
        // A box off the model takes nothing.
        let corner = (Vec2::ZERO, Vec2::new(5.0, 5.0));
        assert!(vertices_in_box(&cam, SIZE, corner, data, true).is_empty());
    }
}
