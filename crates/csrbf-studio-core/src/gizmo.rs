//! The rotate gizmo's geometry, shared by the Picker (a handle's turn) and
//! the Composer (an orientation key's turn): three rings about a centre, a
//! fixed size on screen ([`RING_PIXELS`]), which ring is under the pointer,
//! and how a turn is added to a rotation. Plain functions of a camera and
//! pixels, tested without a window.

use csrbf::Handle;
use csrbf::glam::{DQuat, DVec3, Vec2, Vec3};
use csrbf_anim::Camera;

/// The gizmo rings' radius, in points (the Picker's handle and the
/// Composer's orientation keys alike).
pub const RING_PIXELS: f32 = 40.0;

/// World length of one pixel at `centre`.
pub fn world_per_pixel(centre: Vec3, cam: &Camera, size: [u32; 2]) -> Option<f32> {
    let (c, _) = cam.project(centre, size)?;
    let (right, _, _) = cam.basis();
    let (q, _) = cam.project(centre + right * 0.01, size)?;
    let per_unit = (q - c).length() / 0.01;
    (per_unit > 0.0 && per_unit.is_finite()).then(|| 1.0 / per_unit)
}

/// The gizmo's three rings about `centre`, `radius` pixels wide: for X, Y
/// and Z, the axis, the ring's points (closed) and its colour.
pub fn axis_rings(
    centre: Vec3,
    cam: &Camera,
    size: [u32; 2],
    radius: f32,
) -> Vec<(Vec3, Vec<Vec3>, [f32; 4])> {
    let Some(w) = world_per_pixel(centre, cam, size) else {
        return Vec::new();
    };
    let r = radius * w;
    [
        (Vec3::X, [0.95, 0.3, 0.25, 1.0]),
        (Vec3::Y, [0.35, 0.9, 0.35, 1.0]),
        (Vec3::Z, [0.35, 0.55, 1.0, 1.0]),
    ]
    .into_iter()
    .map(|(axis, color)| {
        let u = axis.any_orthonormal_vector();
        let v = axis.cross(u);
        let pts = (0..=64)
            .map(|j| {
                let a = j as f32 / 64.0 * std::f32::consts::TAU;
                centre + (u * a.cos() + v * a.sin()) * r
            })
            .collect();
        (axis, pts, color)
    })
    .collect()
}

/// The pointer's distance in pixels to a polyline as drawn (None when it
/// is behind the camera).
pub fn polyline_distance(cam: &Camera, size: [u32; 2], pts: &[Vec3], px: Vec2) -> Option<f32> {
    let screen: Vec<Vec2> = pts
        .iter()
        .map(|p| cam.project(*p, size).map(|q| q.0))
        .collect::<Option<_>>()?;
    screen
        .windows(2)
        .map(|w| {
            let (a, b) = (w[0], w[1]);
            let ab = b - a;
            let t = ((px - a).dot(ab) / ab.length_squared().max(1e-12)).clamp(0.0, 1.0);
            px.distance(a + ab * t)
        })
        .min_by(f32::total_cmp)
}

/// The axis of the ring about `centre` (`radius` pixels wide) nearest the
/// pixel `px`, when one is within `tolerance` pixels of it.
pub fn ring_under(
    centre: Vec3,
    cam: &Camera,
    size: [u32; 2],
    radius: f32,
    px: Vec2,
    tolerance: f32,
) -> Option<Vec3> {
    axis_rings(centre, cam, size, radius)
        .into_iter()
        .filter_map(|(a, pts, _)| {
            let d = polyline_distance(cam, size, &pts, px)?;
            (d < tolerance).then_some((d, a))
        })
        .min_by(|x, y| x.0.total_cmp(&y.0))
        .map(|(_, a)| a)
}

/// `turn` degrees about `axis` after the rotation `before`: added to its
/// angle when the axes agree, else composed (as quaternions).
pub fn compose_turn(before: Option<csrbf::Rotation>, axis: DVec3, turn: f64) -> csrbf::Rotation {
    let axis = axis.normalize();
    let Some(r) = before else {
        return csrbf::Rotation::new(axis, turn);
    };
    let old = r.axis.normalize_or_zero();
    let along = old.dot(axis);
    let mut out = if along.abs() > 1.0 - 1e-9 {
        csrbf::Rotation::new(r.axis, r.angle_deg + turn * along.signum())
    } else {
        let q = DQuat::from_axis_angle(axis, turn.to_radians())
            * DQuat::from_axis_angle(old, r.angle_deg.to_radians());
        let (a, angle) = q.to_axis_angle();
        csrbf::Rotation::new(a, angle.to_degrees())
    };
    out.pivot = r.pivot;
    out
}

/// What a drag from a handle's pivot (inside its outer ring, off the axis
/// rings) does.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum HandleMode {
    /// Turn about the held axis (X, Y, Z) or the view axis.
    #[default]
    Rotate,
    /// Scale about the pivot.
    Scale,
    /// Move on the plane facing the camera (or along the held axis).
    Move,
}

/// A drag of a handle's gizmo: what it grabbed and where.
#[derive(Clone, Debug)]
pub struct HandleDrag {
    /// The handle when the drag began.
    pub start: Handle,
    /// The axis ring grabbed (a turn about it), else the mode applies.
    pub ring: Option<DVec3>,
    /// The pivot on screen and the pointer's pixel at the press.
    pub pivot_px: Vec2,
    /// The pointer's pixel at the press.
    pub pressed: Vec2,
    /// The pivot dragged (its origin is the pivot).
    pub tool: crate::DragTool,
}

impl HandleDrag {
    /// The handle with the pointer at `px`: a ring turns about its axis,
    /// composed with the turn so far; else `mode` turns about the rotation's
    /// axis (the held one, `axis`, or the view's for a new turn), scales by
    /// the pointer's distance to the pivot, or moves the pivot.
    pub fn moved(
        &self,
        mode: HandleMode,
        axis: Option<usize>,
        (cam, size): (&Camera, [u32; 2]),
        px: Vec2,
    ) -> Handle {
        let (start, pressed, origin) = (&self.start, self.pressed, self.tool.origin);
        let mut h = start.clone();
        if let Some(ring) = self.ring {
            let turn = crate::swept_angle(cam, size, origin, ring, pressed, px);
            h.rotate = Some(compose_turn(start.rotate, ring, turn.to_degrees()));
            return h;
        }
        match mode {
            HandleMode::Rotate => {
                let mut r = h
                    .rotate
                    .unwrap_or_else(|| csrbf::Rotation::new(handle_axis(axis, cam), 0.0));
                let turn = crate::swept_angle(cam, size, origin, r.axis, pressed, px);
                r.angle_deg = start.rotate.map_or(0.0, |r| r.angle_deg) + turn.to_degrees();
                h.rotate = Some(r);
            }
            HandleMode::Scale => {
                let d0 = (pressed - self.pivot_px).length();
                let d1 = (px - self.pivot_px).length();
                if d0 > 1.0 {
                    h.scale = Some(start.scale.unwrap_or(1.0) * (d1 / d0) as f64);
                }
            }
            HandleMode::Move => {
                if let Some(p) = self.tool.moved_to(cam, size, px) {
                    h.translate = Some(start.translate.unwrap_or(DVec3::ZERO) + (p - origin));
                }
            }
        }
        h
    }
}

/// The rotation axis of a new handle turn: the held axis, else the view's.
pub fn handle_axis(axis: Option<usize>, cam: &Camera) -> DVec3 {
    match axis {
        Some(a) => {
            let mut v = DVec3::ZERO;
            v[a] = 1.0;
            v
        }
        None => -cam.basis().2.as_dvec3(),
    }
}

/// The orientation `start` turned about `axis` through `centre` by the
/// angle the pointer swept on the ring's plane from `pressed` to `px`.
pub fn turned(
    cam: &Camera,
    size: [u32; 2],
    centre: Vec3,
    axis: Vec3,
    start: DQuat,
    pressed: Vec2,
    px: Vec2,
) -> DQuat {
    let angle = crate::swept_angle(cam, size, centre.as_dvec3(), axis.as_dvec3(), pressed, px);
    (DQuat::from_axis_angle(axis.as_dvec3().normalize(), angle) * start).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn turns_about_the_same_axis_add_and_about_another_compose() {
        let r = compose_turn(None, DVec3::Z * 2.0, 30.0);
        assert_eq!((r.axis, r.angle_deg), (DVec3::Z, 30.0));
        let r = compose_turn(Some(r), DVec3::NEG_Z, 10.0);
        assert!(
            (r.angle_deg - 20.0).abs() < 1e-12,
            "opposite axis subtracts"
        );
        // 90 about Z then 90 about X: the composite maps X to Z.
        let r = compose_turn(Some(csrbf::Rotation::new(DVec3::Z, 90.0)), DVec3::X, 90.0);
        let q = DQuat::from_axis_angle(r.axis, r.angle_deg.to_radians());
        assert!(
            (q * DVec3::X - DVec3::Z).length() < 1e-9,
            "{:?}",
            q * DVec3::X
        );
        // The pivot is kept.
        let with_pivot = csrbf::Rotation::new(DVec3::Y, 5.0).with_pivot(DVec3::ONE);
        assert_eq!(
            compose_turn(Some(with_pivot), DVec3::X, 5.0).pivot,
            Some(DVec3::ONE)
        );
    }

    #[test]
    fn the_ring_facing_the_camera_is_under_the_pointer_at_its_radius() {
        let cam = Camera::perspective(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y, 40.0);
        let size = [400, 300];
        let rings = axis_rings(Vec3::ZERO, &cam, size, 40.0);
        assert_eq!(rings.len(), 3);
        let c = Camera::centre_pixel(size);
        let on_z = c + Vec2::new(40.0, 0.0).rotate(Vec2::from_angle(0.7));
        let d: Vec<f32> = rings
            .iter()
            .map(|(_, pts, _)| polyline_distance(&cam, size, pts, on_z).expect("in front"))
            .collect();
        assert!(d[2] < 1.0, "{d:?}");
        assert!(d[0] > 7.0 && d[1] > 7.0, "{d:?}");
        assert_eq!(
            ring_under(Vec3::ZERO, &cam, size, 40.0, on_z, 6.0),
            Some(Vec3::Z)
        );
        assert_eq!(
            ring_under(Vec3::ZERO, &cam, size, 40.0, c + Vec2::new(20.0, 20.0), 6.0),
            None
        );
    }

    #[test]
    fn a_quarter_of_the_ring_swept_turns_a_quarter_turn_about_its_axis() {
        let cam = Camera::perspective(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y, 40.0);
        let size = [400, 300];
        let c = Camera::centre_pixel(size);
        let r = RING_PIXELS;
        let q = turned(
            &cam,
            size,
            Vec3::ZERO,
            Vec3::Z,
            DQuat::IDENTITY,
            c + Vec2::new(r, 0.0),
            c + Vec2::new(0.0, -r),
        );
        let (axis, angle) = q.to_axis_angle();
        assert!(
            (angle.to_degrees() - 90.0).abs() < 0.5,
            "{}",
            angle.to_degrees()
        );
        assert!(axis.dot(DVec3::Z).abs() > 0.999, "{axis}");
        // A pixel is one pixel's worth of world at the centre.
        let w = world_per_pixel(Vec3::ZERO, &cam, size).expect("in view");
        let (p, _) = cam.project(Vec3::X * w * 10.0, size).expect("in view");
        assert!((p.distance(c) - 10.0).abs() < 1e-2, "{}", p.distance(c));
    }

    #[test]
    fn a_handle_drag_scales_by_the_pointer_moves_the_pivot_and_turns_on_a_ring() {
        let cam = Camera::perspective(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y, 40.0);
        let size = [400, 300];
        let c = Camera::centre_pixel(size);
        let start = Handle::new(csrbf::Region::All).with_scale(2.0);
        let pressed = c + Vec2::new(20.0, 0.0);
        let drag = HandleDrag {
            start: start.clone(),
            ring: None,
            pivot_px: c,
            pressed,
            tool: crate::DragTool::begin(&cam, size, pressed, DVec3::ZERO, None),
        };
        let view = (&cam, size);
        // Twice as far from the pivot: twice the scale.
        let h = drag.moved(HandleMode::Scale, None, view, c + Vec2::new(40.0, 0.0));
        assert!((h.scale.expect("scaled") - 4.0).abs() < 1e-9);
        // Moved: the translation follows the pointer on the plane facing the
        // camera (right on screen is +X here).
        let h = drag.moved(HandleMode::Move, None, view, pressed + Vec2::new(30.0, 0.0));
        let t = h.translate.expect("moved");
        assert!(t.x > 0.0 && t.y.abs() < 1e-9 && t.z.abs() < 1e-9, "{t}");
        // Rotate mode with Z held: a quarter of the way round the pivot.
        let h = drag.moved(HandleMode::Rotate, Some(2), view, c + Vec2::new(0.0, -20.0));
        let r = h.rotate.expect("turned");
        assert_eq!(r.axis, DVec3::Z);
        assert!((r.angle_deg.abs() - 90.0).abs() < 0.5, "{}", r.angle_deg);
        // On a ring: about the ring's axis, added to the turn so far.
        let turned = HandleDrag {
            start: start.with_rotation(csrbf::Rotation::new(DVec3::Z, 10.0)),
            ring: Some(DVec3::Z),
            ..drag
        };
        let h = turned.moved(HandleMode::Scale, None, view, c + Vec2::new(0.0, -20.0));
        let r = h.rotate.expect("turned");
        assert_eq!(r.axis, DVec3::Z);
        assert!(
            ((r.angle_deg - 10.0).abs() - 90.0).abs() < 0.5,
            "{}",
            r.angle_deg
        );
    }
}
