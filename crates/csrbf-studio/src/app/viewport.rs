//! The viewport: what the pointer does (place, select, drag, box, orbit,
//! pan, zoom) and what is drawn (the model through `csrbf-render`, the
//! control vectors, the flipped faces, the gizmo).

use csrbf::glam::{DVec3, Vec2, Vec3};
use csrbf_anim::{Camera, ViewPreset};
use csrbf_render::{DrawOptions, Line, axis_gizmo, circle_lines, control_lines};
use eframe::egui;

use super::gpu::{self, Screen};
use super::pick_press::{Begin, Press, begin};
use super::picker::{Display, Gesture, Model, Picker, Tool, ViewSettings, count};
use crate::gizmo::{RING_PIXELS, axis_rings, world_per_pixel};
use crate::tools::VertexTarget;
use crate::{Command, DragTool, End, MarkerHit, SurfacePoint, pick_surface_on, vertices_in_box};

/// The pointer's state this frame, as the viewports read it.
pub(super) struct PointerInput {
    pub pressed: bool,
    pub down: bool,
    pub released: bool,
    pub pos: Option<egui::Pos2>,
    pub modifiers: egui::Modifiers,
    /// Vertical wheel, points.
    pub scroll: f32,
    pub secondary: bool,
    pub middle: bool,
    pub delta: egui::Vec2,
}

impl PointerInput {
    pub(super) fn read(ui: &egui::Ui) -> PointerInput {
        ui.input(|i| PointerInput {
            pressed: i.pointer.primary_pressed(),
            down: i.pointer.primary_down(),
            released: i.pointer.primary_released(),
            pos: i.pointer.interact_pos(),
            modifiers: i.modifiers,
            scroll: i.smooth_scroll_delta.y,
            secondary: i.pointer.secondary_down(),
            middle: i.pointer.middle_down(),
            delta: i.pointer.delta(),
        })
    }
}

impl Picker {
    pub(super) fn view_menu(&mut self, ui: &mut egui::Ui, size: [u32; 2]) {
        let v = &mut self.view;
        ui.radio_value(&mut v.display, Display::Deformed, "Deformed");
        ui.radio_value(&mut v.display, Display::Rest, "Rest");
        ui.radio_value(&mut v.display, Display::Both, "Both (rest as ghost)");
        ui.separator();
        ui.checkbox(&mut v.wireframe, "Wireframe");
        ui.checkbox(&mut v.flat, "Flat shading");
        ui.checkbox(&mut v.starts, "Starts");
        ui.checkbox(&mut v.arrows, "Arrows");
        ui.checkbox(&mut v.spheres, "Support spheres of the selection");
        ui.checkbox(&mut v.gizmo, "Axis gizmo");
        ui.checkbox(&mut v.orbit_selection, "Orbit about the selection")
            .on_hover_text("Orbiting turns about the selected controls' starts, which stay where they are in the view");
        ui.separator();
        if ui.button("Frame all  Shift+F").clicked() {
            self.frame_view(false, size);
        }
        if ui.button("Frame selection  F").clicked() {
            self.frame_view(true, size);
        }
        let Some(m) = self.model.as_mut() else {
            return;
        };
        for (name, p) in [
            ("Front", ViewPreset::Front),
            ("Back", ViewPreset::Back),
            ("Left", ViewPreset::Left),
            ("Right", ViewPreset::Right),
            ("Top", ViewPreset::Top),
            ("Bottom", ViewPreset::Bottom),
            ("Three-quarter", ViewPreset::Iso),
        ] {
            if ui.button(name).clicked() {
                m.orbit.preset(p);
            }
        }
        ui.checkbox(&mut m.orbit.orthographic, "Orthographic");
        ui.separator();
        ui.label(format!(
            "Model up axis: {} ({})",
            csrbf_anim::camera::axis_name(m.orbit.up),
            m.up.1
        ));
        ui.horizontal(|ui| {
            for (name, up) in crate::orbit::UP_AXES {
                if ui.selectable_label(m.orbit.up == up, name).clicked() {
                    m.orbit.up = up;
                    m.up.1 = "chosen";
                    m.orbit.preset(ViewPreset::Front);
                }
            }
        });
        // A scan standing tilted in its frame: any direction, typed.
        let mut status = None;
        ui.horizontal(|ui| {
            ui.label("Up direction");
            let r = ui
                .add(
                    egui::TextEdit::singleline(&mut m.up_text)
                        .hint_text("X,Y,Z")
                        .desired_width(120.0),
                )
                .on_hover_text("Any direction as three numbers (a scan standing tilted in its frame); Enter applies");
            if r.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter)) {
                status = Some(match csrbf_anim::camera::parse_axis(&m.up_text) {
                    Ok(up) => {
                        m.orbit.up = up;
                        m.up.1 = "typed";
                        m.orbit.preset(ViewPreset::Front);
                        format!("Model up axis: {}", csrbf_anim::camera::axis_name(up))
                    }
                    Err(e) => format!("Not done: {e}"),
                });
            }
        });
        if let Some(s) = status {
            self.status = s;
        }
    }

    pub(super) fn viewport_ui(&mut self, ui: &mut egui::Ui, screen: &mut Screen) {
        let rect = ui.available_rect_before_wrap();
        let response = ui.allocate_rect(rect, egui::Sense::click_and_drag());
        let ppp = ui.ctx().pixels_per_point();
        let size = [
            ((rect.width() * ppp).round() as u32).max(1),
            ((rect.height() * ppp).round() as u32).max(1),
        ];
        screen.viewport = (size, rect, ppp);
        if self.model.is_none() {
            ui.painter()
                .rect_filled(rect, 0.0, egui::Color32::from_gray(40));
            ui.painter().text(
                rect.center(),
                egui::Align2::CENTER_CENTER,
                "Open a mesh (Ctrl+O) or drop one here",
                egui::FontId::proportional(18.0),
                egui::Color32::LIGHT_GRAY,
            );
            return;
        }
        // The first picture of a mesh frames it for the viewport's real shape.
        // (the rest shape: the same picture whenever the preview arrives).
        if let Some(m) = self.model.as_mut()
            && !m.framed
            && size[0] > 1
            && size[1] > 1
            && let Some((lo, hi)) = m.doc.bounds()
        {
            m.orbit.frame(lo, hi, size[0] as f32 / size[1] as f32);
            m.framed = true;
        }
        self.pointer(ui, &response, rect, ppp, size);
        // A drag step sent just now is drawn now when the worker answers
        // in good time for a frame (else the next frame shows it).
        if let Some(m) = self.model.as_mut() {
            screen.waited = m
                .preview
                .catch_up(crate::preview::catch_up_budget(screen.frame_cost()));
            m.take_frame();
        }
        // A model whose frames are slow while it moves is drawn light.
        if !matches!(self.gesture, Gesture::None | Gesture::Box { .. })
            && let Some(m) = self.model.as_mut()
        {
            m.moved_in(screen.frame_cost());
        }
        self.paint(ui, rect, ppp, size, screen.gpu.is_some());
    }

    /// The pixel (physical, from the viewport's corner) of a screen position.
    fn pixel(pos: egui::Pos2, rect: egui::Rect, ppp: f32) -> Vec2 {
        Vec2::new((pos.x - rect.min.x) * ppp, (pos.y - rect.min.y) * ppp)
    }

    pub(super) fn axis_vector(&self) -> Option<DVec3> {
        self.axis.map(|a| {
            let mut v = DVec3::ZERO;
            v[a] = 1.0;
            v
        })
    }

    fn pointer(
        &mut self,
        ui: &egui::Ui,
        response: &egui::Response,
        rect: egui::Rect,
        ppp: f32,
        size: [u32; 2],
    ) {
        let PointerInput {
            pressed,
            down,
            released,
            pos,
            modifiers,
            scroll,
            secondary,
            middle,
            delta,
        } = PointerInput::read(ui);
        let hovered = response.hovered() || response.dragged();
        // Zoom towards the point under the pointer.
        if hovered
            && scroll != 0.0
            && let Some(pos) = pos
        {
            let Some(m) = self.model.as_mut() else {
                return;
            };
            let px = Self::pixel(pos, rect, ppp);
            let cam = m.orbit.camera();
            let display = self.view.display;
            let drawn = m.drawn(display).0.clone();
            let point = (m.picking.fitted(display, &drawn))
                .cast(&drawn, &cam.ray(px, size))
                .map(|h| h.point)
                .unwrap_or_else(|| m.orbit.point_on_target_plane(px, size));
            m.orbit.zoom_about((-scroll * 0.002).exp(), point);
        }
        // Orbit and pan: right or middle button, Shift to pan; Alt+left orbits.
        if hovered && (secondary || middle) && delta != egui::Vec2::ZERO {
            let Some(m) = self.model.as_mut() else {
                return;
            };
            if modifiers.shift || (middle && modifiers.ctrl) {
                m.orbit.pan(delta.x * ppp, delta.y * ppp, size[1] as f32);
            } else {
                m.orbit_by(delta, self.view.orbit_selection);
            }
            return;
        }
        let Some(pos) = pos else {
            return;
        };
        let px = Self::pixel(pos, rect, ppp);
        if pressed && rect.contains(pos) && response.hovered() {
            if modifiers.alt && modifiers.shift {
                self.gesture = Gesture::Pan;
            } else if modifiers.alt {
                self.gesture = Gesture::Orbit;
            } else {
                self.press(px, pos, modifiers, size, ppp);
            }
        }
        if down && delta != egui::Vec2::ZERO {
            self.moved((px, pos, delta), size, ppp, modifiers.command);
        }
        if released {
            self.release(pos, rect, ppp, size);
        }
    }

    fn press(
        &mut self,
        px: Vec2,
        pos: egui::Pos2,
        modifiers: egui::Modifiers,
        size: [u32; 2],
        ppp: f32,
    ) {
        let press = Press {
            px,
            tool: self.tool,
            shift: modifiers.shift,
            command: modifiers.command,
            axis: self.axis_vector(),
            size,
            ppp,
        };
        let stamp = self.view.stamp;
        if self.pick_pivot {
            return self.place_pivot(px, size);
        }
        let Some(m) = self.model.as_mut() else {
            return;
        };
        let cam = m.orbit.camera();
        let handle = active_handle(m);
        // The picking tree is refitted to what is drawn only when a press
        // asks for the surface.
        let display = self.view.display;
        let drawn = m.drawn(display).0.clone();
        let (picking, doc) = (&mut m.picking, &m.doc);
        let surface = |px| {
            let bvh = picking.fitted(display, &drawn);
            pick_surface_on(&cam, size, px, bvh, &drawn, &doc.mesh.positions)
        };
        match begin(press, &cam, doc, handle, surface) {
            Begin::Handle { layer, drag } => {
                m.history.begin_drag();
                self.gesture = Gesture::Handle { layer, drag };
            }
            Begin::Brush { fresh } => {
                if fresh {
                    m.picked_vertices.clear();
                }
                self.gesture = Gesture::Brush;
                self.brush(px, size);
            }
            Begin::Marker { hit, add, tool } => {
                select_marker(&mut m.doc, hit, add);
                m.history.begin_drag();
                if hit.end == End::Start {
                    let drawn = m.drawn(display).0.clone();
                    m.picking.hold(display, &drawn);
                }
                self.gesture = Gesture::Marker {
                    layer: hit.layer,
                    index: hit.index,
                    end: hit.end,
                    tool,
                    moved: false,
                };
            }
            Begin::Place(hit) => self.place(hit, stamp, (&cam, size, px, press.axis)),
            Begin::Box { add } => {
                if !add && press.tool != Tool::Vertices {
                    m.doc.selection.0.clear();
                }
                self.gesture = Gesture::Box { from: pos, add };
            }
        }
    }

    /// The active handle's pivot put where the pointer meets the surface
    /// (at rest), its rotation kept (about the view's axis if it had none).
    fn place_pivot(&mut self, px: Vec2, size: [u32; 2]) {
        self.pick_pivot = false;
        let display = self.view.display;
        let Some(m) = self.model.as_mut() else {
            return;
        };
        let cam = m.orbit.camera();
        let drawn = m.drawn(display).0.clone();
        let bvh = m.picking.fitted(display, &drawn);
        let Some(hit) = pick_surface_on(&cam, size, px, bvh, &drawn, &m.doc.mesh.positions) else {
            self.status = "No surface there: the pivot is where it was".into();
            return;
        };
        let layer = m.doc.active_layer;
        let Some(mut spec) = m.doc.controls.deformations.get(layer).cloned() else {
            return;
        };
        let Some(h) = spec.handle.as_mut() else {
            return;
        };
        let axis = crate::gizmo::handle_axis(self.axis, &cam);
        let rot = h.rotate.unwrap_or_else(|| csrbf::Rotation::new(axis, 0.0));
        h.rotate = Some(rot.with_pivot(hit.rest));
        self.edit(
            Command::ReplaceLayer {
                layer,
                spec: Box::new(spec),
            },
            true,
        );
        self.status = format!(
            "Pivot of layer {} at ({:.4}, {:.4}, {:.4})",
            layer, hit.rest.x, hit.rest.y, hit.rest.z
        );
    }

    /// A control vector added at `hit` (its destination `stamp` away when
    /// stamping, else dragged from there: `view` is where the press was).
    fn place(
        &mut self,
        hit: SurfacePoint,
        stamp: Option<DVec3>,
        (cam, size, px, axis): (&Camera, [u32; 2], Vec2, Option<DVec3>),
    ) {
        let Some(layer) = self.model.as_ref().map(|m| m.doc.active_layer) else {
            return;
        };
        let count = |p: &Picker| {
            p.model
                .as_ref()
                .map_or(0, |m| m.doc.controls.deformations[layer].starts.len())
        };
        let index = count(self);
        let target = hit.rest + stamp.unwrap_or(DVec3::ZERO);
        // A drag from the press sets the destination: the insert and the
        // drag are one undo step.
        if stamp.is_none()
            && let Some(m) = self.model.as_mut()
        {
            m.history.begin_drag();
        }
        self.edit(Command::add(layer, hit.rest, target), true);
        let added = count(self) > index;
        let Some(m) = self.model.as_mut() else {
            return;
        };
        if !added {
            m.history.end_drag();
            return;
        }
        m.doc.selection.0 = vec![(layer, index)];
        if stamp.is_none() {
            self.gesture = Gesture::Marker {
                layer,
                index,
                end: End::Target,
                tool: DragTool::begin(cam, size, px, hit.rest, axis),
                moved: false,
            };
        }
        self.status = format!(
            "Control {} of layer {} at ({:.4}, {:.4}, {:.4}), triangle {}: drag to set its destination",
            index, layer, hit.rest.x, hit.rest.y, hit.rest.z, hit.triangle
        );
    }

    /// The pointer moved to `px` with the button down (`alone`: Ctrl, a
    /// start dragged without its vector).
    fn moved(
        &mut self,
        (px, pos, delta): (Vec2, egui::Pos2, egui::Vec2),
        size: [u32; 2],
        ppp: f32,
        alone: bool,
    ) {
        let Some(m) = self.model.as_mut() else {
            return;
        };
        let cam = m.orbit.camera();
        match self.gesture.clone() {
            Gesture::Marker {
                layer,
                index,
                end,
                tool,
                ..
            } => {
                let Some(p) = tool.moved_to(&cam, size, px) else {
                    return;
                };
                let command = match end {
                    End::Target => Command::SetTarget {
                        layer,
                        index,
                        target: p,
                    },
                    End::Start => {
                        let display = self.view.display;
                        start_moved(
                            m,
                            (layer, index),
                            (&cam, size, px),
                            (&tool, p, display),
                            alone,
                        )
                    }
                };
                if let Gesture::Marker { moved, .. } = &mut self.gesture {
                    *moved = true;
                }
                // A destination moving is a drag step; a start needs a refit.
                self.edit(command, end == End::Start);
            }
            Gesture::Handle { layer, drag } => {
                let h = drag.moved(self.handle_mode, self.axis, (&cam, size), px);
                let mut spec = m.doc.controls.deformations[layer].clone();
                spec.handle = Some(h);
                let command = Command::ReplaceLayer {
                    layer,
                    spec: Box::new(spec),
                };
                self.edit(command, false);
            }
            Gesture::Orbit => m.orbit_by(delta, self.view.orbit_selection),
            Gesture::Pan => m.orbit.pan(delta.x * ppp, delta.y * ppp, size[1] as f32),
            Gesture::Brush => self.brush(px, size),
            Gesture::Box { .. } | Gesture::None => {
                let _ = pos;
            }
        }
    }

    /// Adds the vertices within the brush's radius of the surface point
    /// under `px` (as shown) to the chosen vertices.
    fn brush(&mut self, px: Vec2, size: [u32; 2]) {
        let radius = self.view.brush * self.model.as_ref().map_or(0.0, |m| m.doc.diagonal()) as f32;
        let Some(m) = self.model.as_mut() else {
            return;
        };
        let cam = m.orbit.camera();
        let display = self.view.display;
        let drawn = m.drawn(display).0.clone();
        let Some(hit) = (m.picking.fitted(display, &drawn)).cast(&drawn, &cam.ray(px, size)) else {
            return;
        };
        let r2 = radius * radius;
        let before = m.picked_vertices.len();
        m.picked_vertices.extend(
            drawn
                .iter()
                .enumerate()
                .filter(|(_, p)| p.distance_squared(hit.point) <= r2)
                .map(|(i, _)| i as u32),
        );
        if m.picked_vertices.len() != before {
            m.picked_vertices.sort_unstable();
            m.picked_vertices.dedup();
        }
        self.status = format!(
            "{} chosen (brush {:.1} % of the diagonal)",
            count(m.picked_vertices.len(), "vertex", "vertices"),
            self.view.brush * 100.0
        );
    }

    fn release(&mut self, pos: egui::Pos2, rect: egui::Rect, ppp: f32, size: [u32; 2]) {
        let gesture = std::mem::replace(&mut self.gesture, Gesture::None);
        let (tool, display, xray) = (self.tool, self.view.display, self.view.xray);
        let Some(m) = self.model.as_mut() else {
            return;
        };
        match gesture {
            Gesture::Marker {
                layer, index, end, ..
            } => {
                m.picking.let_go();
                m.history.end_drag();
                self.status = made_status(m, (layer, index), end);
                // The release diagnoses what the drag made.
                self.refresh(true);
            }
            Gesture::Handle { .. } => {
                m.history.end_drag();
                self.refresh(true);
            }
            Gesture::Box { from, add } => {
                let a = Self::pixel(from, rect, ppp);
                let b = Self::pixel(pos, rect, ppp);
                let (lo, hi) = (a.min(b), a.max(b));
                if (hi - lo).length() < 3.0 * ppp {
                    return;
                }
                let cam = m.orbit.camera();
                if tool == Tool::Vertices {
                    // Vertices in the box as drawn (rest in View > Rest):
                    // those facing the camera, or all with X-ray.
                    let (p, n) = m.drawn(display);
                    let mut chosen = vertices_in_box(&cam, size, (lo, hi), (p, n), xray);
                    if add {
                        chosen.extend_from_slice(&m.picked_vertices);
                    }
                    chosen.sort_unstable();
                    chosen.dedup();
                    let n = chosen.len();
                    m.picked_vertices = chosen;
                    self.status = format!(
                        "{} chosen; apply them as a {} in the side panel",
                        count(n, "vertex", "vertices"),
                        match m.vertex_target {
                            VertexTarget::Handle => "handle",
                            VertexTarget::Anchor => "handle's anchor",
                            VertexTarget::Region => "layer's region",
                        }
                    );
                    return;
                }
                for (layer, spec) in m.doc.controls.deformations.iter().enumerate() {
                    for (index, s) in spec.starts.iter().enumerate() {
                        if let Some((q, _)) = cam.project(s.as_vec3(), size)
                            && q.cmpge(lo).all()
                            && q.cmple(hi).all()
                            && !m.doc.selection.contains(layer, index)
                        {
                            m.doc.selection.0.push((layer, index));
                        }
                    }
                }
                self.status = format!("{} selected", m.doc.selection.0.len());
            }
            Gesture::Orbit | Gesture::Pan | Gesture::Brush | Gesture::None => {}
        }
    }

    fn paint(&mut self, ui: &egui::Ui, rect: egui::Rect, ppp: f32, size: [u32; 2], gpu: bool) {
        let v = self.view.clone();
        let Some(m) = self.model.as_ref() else {
            return;
        };
        let cam = m.orbit.camera();
        let (positions, normals) = match v.display {
            Display::Rest => (m.rest_positions.clone(), m.rest_normals.clone()),
            _ => (m.shown.clone(), m.shown_normals.clone()),
        };
        let mut overlay = Vec::new();
        let mut lines = Vec::new();
        control_overlay(m, &v, &mut overlay);
        // The active layer's region, if it is a sphere or a box.
        if let Some(spec) = m.doc.controls.deformations.get(m.doc.active_layer) {
            region_lines(&spec.region, &mut overlay);
        }
        if v.display != Display::Rest {
            fold_lines(m, &positions, &mut lines);
        }
        if v.display == Display::Both {
            rest_edges(m, &mut overlay);
        }
        handle_gizmo(m, (&cam, size, ppp), &mut overlay);
        if v.gizmo {
            axis_gizmo(&cam, size, &mut overlay);
        }
        let mut options = DrawOptions::default();
        options.flat = v.flat;
        options.wireframe = v.wireframe;
        if gpu {
            // A model moving (a gesture, a fit under way) is drawn light
            // when it is big or its frames were slow.
            let moving = !matches!(self.gesture, Gesture::None | Gesture::Box { .. })
                || !m.preview.is_settled()
                || ui.input(|i| {
                    i.pointer.secondary_down()
                        || i.pointer.middle_down()
                        || i.smooth_scroll_delta != egui::Vec2::ZERO
                });
            let (mut positions, mut normals, mut stand_in) = (positions, normals, None);
            if let Some(light) = m.stand_in.as_ref().filter(|_| moving) {
                let (p, n) = light.shape(&positions);
                positions = std::sync::Arc::new(p);
                normals = std::sync::Arc::new(n);
                stand_in = Some(light.clone());
            }
            if moving && (stand_in.is_some() || m.light_while_moving) {
                // Come back for the full picture once the pointer rests.
                ui.ctx()
                    .request_repaint_after(std::time::Duration::from_millis(150));
            }
            let paint = gpu::ViewportPaint {
                // Slow frames while moving: a quarter of the pixels to fill.
                size: if moving && m.light_while_moving {
                    size.map(|n| n.div_ceil(2))
                } else {
                    size
                },
                mesh: m.gpu_mesh.clone(),
                stand_in,
                positions,
                normals,
                camera: cam,
                lines,
                overlay,
                options,
                background: [0.13, 0.14, 0.16],
            };
            ui.painter()
                .add(eframe::egui_wgpu::Callback::new_paint_callback(rect, paint));
        } else {
            ui.painter()
                .rect_filled(rect, 0.0, egui::Color32::from_gray(40));
        }
        self.paint_marks(ui, rect, (&cam, size, ppp));
    }

    /// Chosen vertices, the selection box and the held axis, drawn by egui
    /// on top.
    fn paint_marks(
        &self,
        ui: &egui::Ui,
        rect: egui::Rect,
        (cam, size, ppp): (&Camera, [u32; 2], f32),
    ) {
        let Some(m) = self.model.as_ref() else {
            return;
        };
        let painter = ui.painter_at(rect);
        let to_screen = |q: Vec2| egui::pos2(rect.min.x + q.x / ppp, rect.min.y + q.y / ppp);
        for &i in m.picked_vertices.iter().take(20_000) {
            if let Some(p) = m.shown.get(i as usize)
                && let Some((q, _)) = cam.project(*p, size)
            {
                painter.circle_filled(to_screen(q), 1.5, egui::Color32::from_rgb(255, 200, 40));
            }
        }
        if let Gesture::Box { from, .. } = &self.gesture
            && let Some(pos) = ui.input(|i| i.pointer.interact_pos())
        {
            painter.rect_stroke(
                egui::Rect::from_two_pos(*from, pos),
                0.0,
                egui::Stroke::new(1.0, egui::Color32::WHITE),
                egui::StrokeKind::Inside,
            );
        }
        if let Some(a) = self.axis {
            painter.text(
                rect.left_top() + egui::vec2(8.0, 8.0),
                egui::Align2::LEFT_TOP,
                format!("held to {}", ["X", "Y", "Z"][a]),
                egui::FontId::proportional(14.0),
                egui::Color32::YELLOW,
            );
        }
    }
}

/// Control vectors: start, arrow to the destination, support spheres of the
/// selection (all of the active layer's while R changes).
fn control_overlay(m: &Model, v: &ViewSettings, overlay: &mut Vec<Line>) {
    let diag = m.doc.diagonal() as f32;
    for (layer, spec) in m.doc.controls.deformations.iter().enumerate() {
        if m.hidden.get(layer).copied().unwrap_or(false) {
            continue;
        }
        let r = spec.options.radius as f32;
        let mut plain = Vec::new();
        let mut selected = Vec::new();
        for (i, (s, t)) in spec.starts.iter().zip(&spec.targets).enumerate() {
            let now = *s + (*t - *s) * (spec.phase * m.doc.phase);
            let c = (s.as_vec3(), now.as_vec3(), t.as_vec3(), r);
            let show_sphere = (v.spheres && m.doc.selection.contains(layer, i))
                || (v.all_spheres && layer == m.doc.active_layer);
            if show_sphere {
                selected.push(c);
            } else {
                plain.push(c);
            }
        }
        let mut drawn = Vec::new();
        if v.arrows || v.starts {
            control_lines(&plain, diag, false, &mut drawn);
        }
        // Spheres are drawn for moving vectors only by the renderer's
        // helper; a pin's sphere is shown too here, so draw them as if
        // moving (the arrow of a pin has no length anyway).
        let nudged: Vec<_> = selected
            .iter()
            .map(|&(s, now, t, r)| {
                let t = if t.distance(s) < 1e-6 * r {
                    s + Vec3::splat(1e-5 * r)
                } else {
                    t
                };
                (s, now, t, r)
            })
            .collect();
        control_lines(&nudged, diag, true, &mut drawn);
        if !v.arrows {
            drawn.retain(|l| l.color[0] == 1.0 && l.color[1] == 1.0);
        }
        overlay.extend(drawn);
    }
}

/// Faces inside out and creases in red, faces stretched past the limit in
/// magenta, faces passing through each other in orange, over the surface
/// at `positions`.
fn fold_lines(m: &Model, positions: &[Vec3], lines: &mut Vec<Line>) {
    let Some(d) = m.preview.latest().and_then(|f| f.diagnostics.as_ref()) else {
        return;
    };
    let tris = m.picking.bvh.triangles();
    let red = [1.0, 0.1, 0.1, 1.0];
    let magenta = [0.85, 0.25, 0.85, 1.0];
    let folded = d.inside_out.iter().chain(&d.flipped).map(|&t| (t, red));
    let stretched = d.stretched.iter().map(|&t| (t, magenta));
    let orange = [1.0, 0.6, 0.1, 1.0];
    let crossing = (d.self_intersections.iter().flatten()).flat_map(|p| p.map(|t| (t, orange)));
    for (t, color) in folded.chain(stretched).chain(crossing).take(50_000) {
        let Some(t) = tris.get(t as usize) else {
            continue;
        };
        let p = |k: usize| positions.get(t[k] as usize).copied().unwrap_or_default();
        for (a, b) in [(0, 1), (1, 2), (2, 0)] {
            lines.push(Line {
                a: p(a),
                b: p(b),
                color,
            });
        }
    }
}

/// The rest shape's edges, faint (up to 300k edges).
fn rest_edges(m: &Model, overlay: &mut Vec<Line>) {
    let rest = &m.doc.mesh.positions;
    for t in m.picking.bvh.triangles().iter().take(100_000) {
        for (a, b) in [(0, 1), (1, 2), (2, 0)] {
            overlay.push(Line {
                a: rest[t[a] as usize],
                b: rest[t[b] as usize],
                color: [0.6, 0.8, 1.0, 0.25],
            });
        }
    }
}

/// The active handle's gizmo about its pivot: the outer ring (the panel's
/// mode) and a ring per axis.
fn handle_gizmo(m: &Model, (cam, size, ppp): (&Camera, [u32; 2], f32), overlay: &mut Vec<Line>) {
    let Some((_, _, pivot)) = active_handle(m) else {
        return;
    };
    let outer = (RING_PIXELS + 8.0) * ppp;
    ring(
        pivot.as_vec3(),
        cam,
        size,
        outer,
        [1.0, 0.8, 0.2, 1.0],
        overlay,
    );
    for (_, pts, color) in axis_rings(pivot.as_vec3(), cam, size, RING_PIXELS * ppp) {
        polyline(&pts, color, overlay);
    }
}

/// The segments of a polyline, all of one colour.
pub(super) fn polyline(pts: &[Vec3], color: [f32; 4], out: &mut Vec<Line>) {
    for w in pts.windows(2) {
        out.push(Line {
            a: w[0],
            b: w[1],
            color,
        });
    }
}

/// Green outlines of a sphere or box region (its inner shape for a falloff).
fn region_lines(region: &csrbf::Region, out: &mut Vec<Line>) {
    const GREEN: [f32; 4] = [0.35, 0.95, 0.45, 0.8];
    match region {
        csrbf::Region::Sphere { center, radius } => {
            csrbf_render::sphere_lines(center.as_vec3(), *radius as f32, GREEN, out);
        }
        csrbf::Region::Box { min, max } => {
            let (lo, hi) = (min.as_vec3(), max.as_vec3());
            let corner = |k: usize| {
                Vec3::new(
                    if k & 1 == 0 { lo.x } else { hi.x },
                    if k & 2 == 0 { lo.y } else { hi.y },
                    if k & 4 == 0 { lo.z } else { hi.z },
                )
            };
            for a in 0..8usize {
                for bit in [1, 2, 4] {
                    if a & bit == 0 {
                        out.push(Line {
                            a: corner(a),
                            b: corner(a | bit),
                            color: GREEN,
                        });
                    }
                }
            }
        }
        csrbf::Region::Falloff { inner, .. } => region_lines(inner, out),
        _ => {}
    }
}

/// Refits the picking tree to the shown positions if they changed since.
/// The command a start dragged to `p` makes: on the surface under the
/// pointer when it meets it (unless held to an axis), its vector carried
/// along, or (`alone`, Ctrl) the start alone.
fn start_moved(
    m: &mut Model,
    (layer, index): (usize, usize),
    (cam, size, px): (&Camera, [u32; 2], Vec2),
    (tool, p, display): (&DragTool, DVec3, Display),
    alone: bool,
) -> Command {
    let start = if tool.axis.is_some() {
        p
    } else if let Some((bvh, held)) = m.picking.held() {
        // The surface as it was drawn when the drag began.
        pick_surface_on(cam, size, px, bvh, held, &m.doc.mesh.positions).map_or(p, |h| h.rest)
    } else {
        let drawn = m.drawn(display).0.clone();
        let bvh = m.picking.fitted(display, &drawn);
        pick_surface_on(cam, size, px, bvh, &drawn, &m.doc.mesh.positions).map_or(p, |h| h.rest)
    };
    if alone {
        return Command::SetStart {
            layer,
            index,
            start,
        };
    }
    // The destination keeps its offset from the start.
    let s = &m.doc.controls.deformations[layer];
    let (from, to) = (s.starts[index], s.targets[index]);
    Command::MoveControl {
        layer,
        index,
        start,
        target: to + (start - from),
    }
}

/// What a drag of control `index` of `layer` made (its `end` moved): its
/// length and share of R, or a pin.
fn made_status(m: &Model, (layer, index): (usize, usize), end: End) -> String {
    let Some(s) = m.doc.controls.deformations.get(layer) else {
        return String::new();
    };
    let (Some(a), Some(b)) = (s.starts.get(index), s.targets.get(index)) else {
        return String::new();
    };
    let moved = if end == End::Start {
        "start"
    } else {
        "destination"
    };
    let length = (*b - *a).length();
    if length == 0.0 {
        format!(
            "Control {} of layer {}: a pin (its destination is its start)",
            index, layer
        )
    } else {
        format!(
            "Control {} of layer {}: {moved} set; it moves {length:.4} ({:.1} % of R)",
            index,
            layer,
            length / s.options.radius * 100.0
        )
    }
}

/// A press on `hit`'s marker: Shift (`add`) toggles it in the selection;
/// else it becomes the selection unless it is in it already (so a drag
/// moves every selected control). Its layer becomes the active one.
fn select_marker(doc: &mut crate::Document, hit: MarkerHit, add: bool) {
    let key = (hit.layer, hit.index);
    if add {
        if let Some(k) = doc.selection.0.iter().position(|&s| s == key) {
            doc.selection.0.remove(k);
        } else {
            doc.selection.0.push(key);
        }
    } else if !doc.selection.contains(hit.layer, hit.index) {
        doc.selection.0 = vec![key];
    }
    doc.active_layer = hit.layer;
}

/// The active layer's handle and where its gizmo is: its pivot (the
/// rotation's own, else the centroid of its selection at rest: what the
/// engine turns it about) carried by its move, so the rings stay on the
/// part they turn.
pub(super) fn active_handle(m: &Model) -> Option<(usize, csrbf::Handle, DVec3)> {
    let layer = m.doc.active_layer;
    let h = m.doc.controls.deformations.get(layer)?.handle.clone()?;
    let lookup = |n: &str| m.doc.mesh.part_vertices(n);
    let pivot = h.pivot(&m.doc.mesh.positions, &lookup).ok()?;
    let moved = pivot + h.translate.unwrap_or(DVec3::ZERO);
    Some((layer, h, moved))
}

/// A circle of `radius` pixels about `centre` facing the camera.
fn ring(
    centre: Vec3,
    cam: &csrbf_anim::Camera,
    size: [u32; 2],
    radius: f32,
    color: [f32; 4],
    out: &mut Vec<Line>,
) {
    let Some(w) = world_per_pixel(centre, cam, size) else {
        return;
    };
    let (right, up, _) = cam.basis();
    circle_lines(centre, (right, up), radius * w, 48, color, out);
}
