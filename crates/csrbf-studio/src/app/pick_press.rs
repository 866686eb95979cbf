//! What a press in the Picker's viewport begins, decided without a window:
//! the active handle's gizmo (a ring, or inside the outer ring the panel's
//! mode), a brush of vertices (Ctrl in the vertex tool), a marker's end, a
//! new control vector on the surface (Place), else a selection box. The
//! viewport ([`super::viewport`]) reads the pointer, asks [`begin`] and
//! carries the drag out; the release's work is in the viewport too.
//! Plain values in, plain values out, tested here.

use csrbf::Handle;
use csrbf::glam::{DVec3, Vec2};
use csrbf_anim::Camera;

use super::picker::Tool;
use crate::gizmo::{HandleDrag, RING_PIXELS, ring_under};
use crate::{Document, DragTool, MarkerHit, SurfacePoint, pick_marker};

/// How near a marker a press must be, in points.
pub(super) const TOLERANCE_POINTS: f32 = 9.0;

/// The press: where, with which tool and keys, in which view.
#[derive(Clone, Copy, Debug)]
pub(super) struct Press {
    /// The pixel (physical, from the viewport's corner).
    pub px: Vec2,
    pub tool: Tool,
    pub shift: bool,
    /// Ctrl (Cmd on a Mac).
    pub command: bool,
    /// The axis moves are held to, if any.
    pub axis: Option<DVec3>,
    /// The viewport's size in pixels and its pixels per point.
    pub size: [u32; 2],
    pub ppp: f32,
}

/// What a press begins.
#[derive(Clone, Debug)]
pub(super) enum Begin {
    /// The active handle's gizmo grabbed: a ring turned, or the pivot
    /// rotated, scaled or moved.
    Handle { layer: usize, drag: Box<HandleDrag> },
    /// Painting vertices under a brush; `fresh`: the chosen vertices are
    /// cleared first.
    Brush { fresh: bool },
    /// One end of a control vector grabbed (`add`: Shift toggles it in the
    /// selection), dragged from `origin`.
    Marker {
        hit: MarkerHit,
        add: bool,
        tool: DragTool,
    },
    /// A new control vector at this point of the surface (Place).
    Place(SurfacePoint),
    /// A selection box; `add`: added to the selection, else it replaces it
    /// (markers) or the chosen vertices (the vertex tool).
    Box { add: bool },
}

/// What `press` begins on `doc` seen through `cam`. `handle`: the active
/// layer's handle with its layer and pivot, if it has one; `surface`: the
/// surface point under a pixel (the Place tool asks it).
pub(super) fn begin(
    press: Press,
    cam: &Camera,
    doc: &Document,
    handle: Option<(usize, Handle, DVec3)>,
    surface: impl FnOnce(Vec2) -> Option<SurfacePoint>,
) -> Begin {
    let Press {
        px,
        tool,
        shift,
        command,
        axis,
        size,
        ppp,
    } = press;
    if tool == Tool::Vertices
        && let Some(drag) = handle.and_then(|h| grab_handle(press, cam, h))
    {
        return drag;
    }
    if tool == Tool::Vertices && command {
        return Begin::Brush { fresh: !shift };
    }
    if tool != Tool::Vertices
        && let Some(hit) = pick_marker(cam, size, px, doc, TOLERANCE_POINTS * ppp)
    {
        let spec = &doc.controls.deformations[hit.layer];
        let origin = match hit.end {
            crate::End::Start => spec.starts[hit.index],
            crate::End::Target => spec.targets[hit.index],
        };
        return Begin::Marker {
            hit,
            add: shift,
            tool: DragTool::begin(cam, size, px, origin, axis),
        };
    }
    if tool == Tool::Place
        && let Some(hit) = surface(px)
    {
        return Begin::Place(hit);
    }
    Begin::Box { add: shift }
}

/// The handle's gizmo under the press: an axis ring turns about that axis;
/// inside the outer ring, the panel's mode applies.
fn grab_handle(
    press: Press,
    cam: &Camera,
    (layer, handle, pivot): (usize, Handle, DVec3),
) -> Option<Begin> {
    let Press {
        px,
        size,
        ppp,
        axis,
        ..
    } = press;
    let (pivot_px, _) = cam.project(pivot.as_vec3(), size)?;
    let ring = ring_under(pivot.as_vec3(), cam, size, RING_PIXELS * ppp, px, 7.0 * ppp)
        .map(|a| a.as_dvec3());
    if ring.is_none() && pivot_px.distance(px) >= (RING_PIXELS + 8.0) * ppp {
        return None;
    }
    let drag = HandleDrag {
        start: handle,
        ring,
        pivot_px,
        pressed: px,
        tool: DragTool::begin(cam, size, px, pivot, axis),
    };
    Some(Begin::Handle {
        layer,
        drag: Box::new(drag),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Command, End};
    use csrbf::glam::Vec3;
    use std::path::PathBuf;

    const SIZE: [u32; 2] = [400, 300];

    fn camera() -> Camera {
        Camera::perspective(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y, 40.0)
    }

    fn pixel_of(cam: &Camera, p: DVec3) -> Vec2 {
        cam.project(p.as_vec3(), SIZE).expect("in front").0
    }

    fn press(px: Vec2, tool: Tool) -> Press {
        Press {
            px,
            tool,
            shift: false,
            command: false,
            axis: None,
            size: SIZE,
            ppp: 1.0,
        }
    }

    /// A unit sphere with one control vector from its front, moved up.
    fn doc() -> Document {
        let mesh = csrbf_mesh::shapes::uv_sphere(1.0, 16, 32);
        let mut doc = Document::new(mesh, PathBuf::from("s.obj"), 0.8);
        Command::add(0, DVec3::Z, DVec3::new(0.0, 0.6, 1.0))
            .apply(&mut doc)
            .expect("add");
        doc
    }

    fn a_point(px: Vec2) -> SurfacePoint {
        SurfacePoint {
            shown: Vec3::new(px.x, px.y, 0.0),
            rest: DVec3::new(0.5, 0.5, 0.7),
            triangle: 3,
            vertex: 0,
        }
    }

    #[test]
    fn a_marker_is_grabbed_in_place_and_select_but_not_in_the_vertex_tool() {
        let (cam, doc) = (camera(), doc());
        let on_target = pixel_of(&cam, DVec3::new(0.0, 0.6, 1.0));
        for tool in [Tool::Place, Tool::Select] {
            match begin(press(on_target, tool), &cam, &doc, None, |_| None) {
                Begin::Marker { hit, add, tool } => {
                    assert_eq!((hit.layer, hit.index, hit.end), (0, 0, End::Target));
                    assert!(!add);
                    // The drag starts from the destination itself.
                    let at = tool.moved_to(&cam, SIZE, on_target).expect("on the plane");
                    assert!((at - DVec3::new(0.0, 0.6, 1.0)).length() < 1e-3, "{at}");
                }
                other => panic!("{tool:?}: {other:?}"),
            }
        }
        // The vertex tool boxes over markers; Shift adds to the choice.
        let mut p = press(on_target, Tool::Vertices);
        p.shift = true;
        assert!(matches!(
            begin(p, &cam, &doc, None, |_| None),
            Begin::Box { add: true }
        ));
    }

    #[test]
    fn place_adds_on_the_surface_and_a_miss_draws_a_box() {
        let (cam, doc) = (camera(), doc());
        let px = Vec2::new(150.0, 200.0);
        match begin(press(px, Tool::Place), &cam, &doc, None, |p| {
            Some(a_point(p))
        }) {
            Begin::Place(hit) => assert_eq!(hit.triangle, 3),
            other => panic!("{other:?}"),
        }
        // Off the surface (or in Select), a box that replaces the selection.
        for tool in [Tool::Place, Tool::Select] {
            let got = begin(press(px, tool), &cam, &doc, None, |_| None);
            assert!(matches!(got, Begin::Box { add: false }), "{got:?}");
        }
        // Select never places, even over the surface.
        let got = begin(press(px, Tool::Select), &cam, &doc, None, |p| {
            Some(a_point(p))
        });
        assert!(matches!(got, Begin::Box { .. }), "{got:?}");
    }

    #[test]
    fn ctrl_in_the_vertex_tool_paints_and_shift_keeps_the_chosen() {
        let (cam, doc) = (camera(), doc());
        let mut p = press(Vec2::new(10.0, 10.0), Tool::Vertices);
        p.command = true;
        assert!(matches!(
            begin(p, &cam, &doc, None, |_| None),
            Begin::Brush { fresh: true }
        ));
        p.shift = true;
        assert!(matches!(
            begin(p, &cam, &doc, None, |_| None),
            Begin::Brush { fresh: false }
        ));
    }

    #[test]
    fn the_handles_pivot_is_grabbed_near_it_and_not_far_away() {
        let (cam, doc) = (camera(), doc());
        let pivot = DVec3::new(0.3, -0.2, 0.5);
        let handle = Handle::new(csrbf::Region::All);
        let near = pixel_of(&cam, pivot) + Vec2::new(4.0, 0.0);
        let h = Some((0, handle.clone(), pivot));
        match begin(press(near, Tool::Vertices), &cam, &doc, h.clone(), |_| None) {
            Begin::Handle { layer, drag } => {
                assert_eq!(layer, 0);
                assert_eq!(drag.pressed, near);
            }
            other => panic!("{other:?}"),
        }
        // Far from the gizmo the vertex tool draws a box, and other tools
        // never grab the handle.
        let far = pixel_of(&cam, pivot) + Vec2::new(150.0, 0.0);
        assert!(matches!(
            begin(press(far, Tool::Vertices), &cam, &doc, h.clone(), |_| None),
            Begin::Box { .. }
        ));
        assert!(!matches!(
            begin(press(near, Tool::Select), &cam, &doc, h, |_| None),
            Begin::Handle { .. }
        ));
    }
}
