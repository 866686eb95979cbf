//! The Composer's viewport: the frame at the playhead through the free
//! camera or the scene's, trajectories with their keys, the scene camera
//! and the orientation gizmo; the pointer's navigation and key drags
//! ([`super::key_drag`] holds their logic, window-free).

use csrbf::glam::{DVec3, Vec2, Vec3};
use csrbf_anim::{Camera, Scene};
use csrbf_render::{Line, SceneOptions};
use eframe::egui;

use super::composer::Composer;
use super::gpu::{self, Screen};
use super::key_drag::{self, KeyDrag, Press, Released, Shown};
use super::picker::ViewSettings;
use super::viewport::{PointerInput, polyline};
use crate::Orbit;
use crate::compose::{Playback, Track, world_centre};
use crate::gizmo::{RING_PIXELS, axis_rings};

/// The viewport's size in physical pixels, its rectangle on screen and the
/// pixels per point, as the screen last had them.
type Place = ([u32; 2], egui::Rect, f32);

impl Composer {
    /// The rectangle the scene's camera sees inside `rect` (its aspect), or
    /// `rect` when not looking through it.
    pub(super) fn gate(&self, rect: egui::Rect) -> egui::Rect {
        if !self.through_camera {
            return rect;
        }
        let [w, h] = self.doc.file.size;
        let aspect = w as f32 / h.max(1) as f32;
        let (rw, rh) = (rect.width(), rect.height());
        let size = if rw / rh.max(1.0) > aspect {
            egui::vec2(rh * aspect, rh)
        } else {
            egui::vec2(rw, rw / aspect)
        };
        egui::Rect::from_center_size(rect.center(), size)
    }

    /// The camera the viewport draws with, its size in physical pixels and
    /// its rectangle on screen, in the viewport at `place`.
    pub(super) fn camera(&self, (_, rect, ppp): Place) -> (Camera, [u32; 2], egui::Rect) {
        let gate = self.gate(rect);
        let size = [
            ((gate.width() * ppp).round() as u32).max(1),
            ((gate.height() * ppp).round() as u32).max(1),
        ];
        let cam = if self.through_camera {
            self.scene_camera()
        } else {
            self.orbit.camera()
        };
        (cam, size, gate)
    }

    /// The viewport: where it is goes to `screen`; `axis` is the axis a
    /// move is held to; `view` the shading the Picker's View menu set.
    pub(super) fn viewport_ui(
        &mut self,
        ui: &mut egui::Ui,
        screen: &mut Screen,
        axis: Option<DVec3>,
        view: &ViewSettings,
    ) {
        let rect = ui.available_rect_before_wrap();
        let response = ui.allocate_rect(rect, egui::Sense::click_and_drag());
        let ppp = ui.ctx().pixels_per_point();
        screen.viewport = (
            [
                ((rect.width() * ppp).round() as u32).max(1),
                ((rect.height() * ppp).round() as u32).max(1),
            ],
            rect,
            ppp,
        );
        // The picture covers the viewport but for the scene camera's
        // letterbox: only that is filled (a fill costs on a software
        // rasteriser).
        let gate = self.gate(rect);
        letterbox(ui, rect, gate, self.loaded.scene.is_none());
        if self.loaded.scene.is_none() {
            let text = match &self.loaded.problem {
                Some(p) => p.clone(),
                None => "Add a mesh: Scene > Add object, or drop one here".into(),
            };
            ui.painter().text(
                rect.center(),
                egui::Align2::CENTER_CENTER,
                text,
                egui::FontId::proportional(18.0),
                egui::Color32::LIGHT_GRAY,
            );
            return;
        }
        if !self.framed && rect.width() > 1.0 {
            self.frame_view(rect);
        }
        self.frame_now();
        self.pointer(ui, &response, screen.viewport, axis);
        let error = screen.gpu.as_ref().and_then(gpu::last_error);
        self.paint(ui, screen.viewport, view, error);
    }

    fn pointer(
        &mut self,
        ui: &egui::Ui,
        response: &egui::Response,
        place: Place,
        axis: Option<DVec3>,
    ) {
        let (cam, size, gate) = self.camera(place);
        let ppp = place.2;
        let input = PointerInput::read(ui);
        let hovered = response.hovered() || response.dragged();
        let px_of = |p: egui::Pos2| Vec2::new((p.x - gate.min.x) * ppp, (p.y - gate.min.y) * ppp);
        let v = key_drag::View {
            cam: &cam,
            size,
            ppp,
        };
        if hovered && self.navigate(&input, v, px_of) {
            return;
        }
        let Some(pos) = input.pos else {
            return;
        };
        let px = px_of(pos);
        let Some(scene) = self.loaded.scene.clone() else {
            return;
        };
        // A press that begins a drag is all this frame does.
        if input.pressed && response.hovered() && self.press(&scene, v, px, input.modifiers, axis) {
            return;
        }
        if input.down && input.delta != egui::Vec2::ZERO {
            self.dragged(v, px, input.delta);
        }
        if input.released {
            let drag = self.drag.take();
            self.camera_preview = None;
            match drag.map(|d| key_drag::release(d, v, px)) {
                Some(Released::Edit(edit)) => {
                    self.edit(edit);
                }
                Some(Released::Refused(why)) => self.status = why.into(),
                Some(Released::Revert) => {
                    let file = self.doc.file.clone();
                    self.loaded.preview(file);
                }
                Some(Released::Nothing) | None => {}
            }
        }
    }

    /// The picture (on the GPU) and the key markers, playhead time and GPU
    /// error (`error`) drawn by egui over it.
    fn paint(&mut self, ui: &egui::Ui, place: Place, view: &ViewSettings, error: Option<String>) {
        let (cam, size, gate) = self.camera(place);
        let ppp = place.2;
        let Some(scene) = self.loaded.scene.clone() else {
            return;
        };
        let mut lines = Vec::new();
        let mut overlay = Vec::new();
        self.trajectory_lines(&scene, &mut overlay);
        self.gizmo_lines(&scene, (&cam, size, ppp), &mut overlay);
        // The scene's camera, when looking from elsewhere.
        if !self.through_camera {
            let [w, h] = self.doc.file.size;
            let aspect = w as f32 / h.max(1) as f32;
            csrbf_render::camera_lines(
                &self.scene_camera(),
                aspect,
                [0.55, 0.75, 1.0, 1.0],
                &mut lines,
            );
        }
        // Big meshes are drawn by their stand-ins while the scene moves.
        let moving = self.playback.playing || self.drag.is_some();
        let stand_ins: Vec<_> = self
            .loaded
            .stand_ins
            .iter()
            .zip(&self.loaded.frame.objects)
            .map(|(s, f)| {
                let s = s.as_ref().filter(|_| moving)?;
                let (p, n) = s.shape(&f.positions);
                Some((s.clone(), p, n))
            })
            .collect();
        let mut options = SceneOptions::default();
        options.camera = Some(cam);
        options.draw.flat = view.flat;
        options.draw.wireframe = view.wireframe;
        // What the picture shows, to draw it only when that changes.
        let stamp = picture_stamp(self, moving, &cam, &options, lines.iter().chain(&overlay));
        let paint = gpu::ScenePaint {
            size,
            id: self.loaded.gpu_id,
            samples: self.samples,
            scene: scene.clone(),
            frame: self.loaded.frame.clone(),
            options,
            lines,
            overlay,
            hidden: self.hidden.clone(),
            stand_ins,
            stamp,
        };
        ui.painter()
            .add(eframe::egui_wgpu::Callback::new_paint_callback(gate, paint));
        // Key markers and the playhead's position, drawn by egui on top.
        let painter = ui.painter_at(gate);
        let to_screen = |p: Vec3| {
            cam.project(p, size)
                .map(|(q, _)| egui::pos2(gate.min.x + q.x / ppp, gate.min.y + q.y / ppp))
        };
        self.camera_marks(&painter, &to_screen);
        self.key_marks(&scene, &painter, &to_screen);
        self.time_label(&painter, gate);
        if let Some(e) = error {
            painter.text(
                gate.left_bottom() + egui::vec2(8.0, -8.0),
                egui::Align2::LEFT_BOTTOM,
                e,
                egui::FontId::proportional(13.0),
                egui::Color32::LIGHT_RED,
            );
        }
    }
}

/// The viewport's navigation and key drags.
impl Composer {
    /// Orbit, pan and zoom leave the scene camera's view for the free one.
    fn leave_camera(&mut self) {
        if self.through_camera {
            self.through_camera = false;
            let cam = self.scene_camera();
            let d = cam.target - cam.eye;
            self.orbit.target = cam.target;
            self.orbit.distance = d.length();
            if let csrbf_anim::Projection::Perspective { fov } = cam.projection {
                self.orbit.fov = fov;
            }
            self.orbit.look_from(-d);
        }
    }

    /// Frames the objects (and the scene camera when asked) in a viewport
    /// of `rect`: from the scene camera's side, a little above the objects'
    /// ground (paths in it show as paths, not lines).
    fn frame_view(&mut self, rect: egui::Rect) {
        if let Some((lo, hi)) = self.bounds() {
            let aspect = rect.width() / rect.height().max(1.0);
            let cam = self.scene_camera();
            let up = self.orbit.up;
            let mut d = (cam.eye - cam.target).normalize_or(Vec3::Z);
            if d.dot(up) < 0.35 {
                d = ((d - up * d.dot(up)).normalize_or(Vec3::Z) + up * 0.4).normalize();
            }
            self.orbit = Orbit::new(up, lo, hi, aspect);
            self.orbit.look_from(d);
            // Turned a little, so the scene camera shows from its side.
            self.orbit.yaw += 0.6;
            self.orbit.frame(lo, hi, aspect);
        }
        self.framed = true;
        self.frame_camera = false;
    }

    /// The wheel zooms about the point under the pointer; a secondary or
    /// middle drag orbits (pans with Shift). True when a drag took it.
    fn navigate(
        &mut self,
        input: &PointerInput,
        v: key_drag::View<'_>,
        px_of: impl Fn(egui::Pos2) -> Vec2,
    ) -> bool {
        if input.scroll != 0.0 {
            self.leave_camera();
            let point = input.pos.map_or(self.orbit.target, |p| {
                self.orbit.point_on_target_plane(px_of(p), v.size)
            });
            self.orbit.zoom_about((-input.scroll * 0.002).exp(), point);
        }
        if (input.secondary || input.middle) && input.delta != egui::Vec2::ZERO {
            self.leave_camera();
            if input.modifiers.shift {
                let (dx, dy) = (input.delta.x * v.ppp, input.delta.y * v.ppp);
                self.orbit.pan(dx, dy, v.size[1] as f32);
            } else {
                self.orbit.orbit(input.delta.x, input.delta.y);
            }
            return true;
        }
        false
    }

    /// A primary press at `px`: a drag begins (true), or an object is
    /// selected.
    fn press(
        &mut self,
        scene: &Scene,
        v: key_drag::View<'_>,
        px: Vec2,
        modifiers: egui::Modifiers,
        axis: Option<DVec3>,
    ) -> bool {
        self.drag = None;
        let scope = key_drag::Scope {
            doc: &self.doc,
            scene,
            hidden: &self.hidden,
            key: self.key,
            through_camera: self.through_camera,
            axis,
        };
        match key_drag::press(&scope, v, px, modifiers.alt, modifiers.shift) {
            Press::Drag(d) => {
                if matches!(d, KeyDrag::Orbit | KeyDrag::Pan) {
                    self.leave_camera();
                }
                self.drag = Some(d);
                true
            }
            Press::Key { key, time, drag } => {
                self.selected = Some(key.0);
                self.key = Some(key);
                self.doc.playhead = time;
                self.drag = Some(drag);
                true
            }
            Press::Object(hit) => {
                self.selected = hit;
                if self.key.is_some_and(|k| Some(k.0) != self.selected) {
                    self.key = None;
                }
                false
            }
        }
    }

    /// The pointer moved by `delta` points, to `px`, with the button down.
    fn dragged(&mut self, v: key_drag::View<'_>, px: Vec2, delta: egui::Vec2) {
        match &self.drag {
            Some(KeyDrag::Orbit) => self.orbit.orbit(delta.x, delta.y),
            Some(KeyDrag::Pan) => {
                self.orbit
                    .pan(delta.x * v.ppp, delta.y * v.ppp, v.size[1] as f32);
            }
            Some(d) => match key_drag::moved(d, &self.doc, v, px) {
                Some(Shown::File(file)) => self.loaded.preview(file),
                Some(Shown::Camera(camera)) => self.camera_preview = Some(camera),
                None => {}
            },
            None => {}
        }
    }
}

/// What the Composer's viewport draws over the scene.
impl Composer {
    /// Trajectories: each shown object's centre of gravity over the whole
    /// scene.
    fn trajectory_lines(&self, scene: &Scene, overlay: &mut Vec<Line>) {
        let duration = self.doc.file.duration;
        for (o, obj) in scene.objects.iter().enumerate() {
            if self.hidden.get(o).copied().unwrap_or(false) || obj.trajectory.keys().len() < 2 {
                continue;
            }
            let color = if self.selected == Some(o) {
                [1.0, 0.85, 0.3, 1.0]
            } else {
                [0.7, 0.65, 0.45, 1.0]
            };
            let n = ((duration * self.doc.file.fps * 2.0) as usize).clamp(32, 600);
            let pts: Vec<Vec3> = (0..=n)
                .filter_map(|j| world_centre(scene, o, duration * j as f64 / n as f64))
                .collect();
            polyline(&pts, color, overlay);
        }
    }

    /// The selected orientation key's gizmo, its held ring lit.
    fn gizmo_lines(
        &self,
        scene: &Scene,
        (cam, size, ppp): (&Camera, [u32; 2], f32),
        overlay: &mut Vec<Line>,
    ) {
        let Some((o, Track::Orientation, i)) = self.key else {
            return;
        };
        let Some(centre) = (self.doc.key_times(o, Track::Orientation).get(i))
            .and_then(|&t| world_centre(scene, o, t))
        else {
            return;
        };
        let held = match &self.drag {
            Some(KeyDrag::Turn { axis, .. }) => Some(*axis),
            _ => None,
        };
        for (a, pts, color) in axis_rings(centre, cam, size, RING_PIXELS * ppp) {
            let color = if held == Some(a) {
                [1.0, 1.0, 0.4, 1.0]
            } else {
                color
            };
            polyline(&pts, color, overlay);
        }
    }

    /// The scene camera's eye (a square) and target (a ring), when looking
    /// from elsewhere: drag them.
    fn camera_marks(
        &self,
        painter: &egui::Painter,
        to_screen: &dyn Fn(Vec3) -> Option<egui::Pos2>,
    ) {
        if self.through_camera {
            return;
        }
        let f = self
            .camera_preview
            .as_ref()
            .unwrap_or(&self.doc.file.camera);
        let blue = egui::Color32::from_rgb(140, 190, 255);
        if let Some(q) = to_screen(DVec3::from_array(f.eye).as_vec3()) {
            painter.rect(
                egui::Rect::from_center_size(q, egui::vec2(9.0, 9.0)),
                0.0,
                blue,
                egui::Stroke::new(1.0, egui::Color32::BLACK),
                egui::StrokeKind::Outside,
            );
        }
        if let Some(q) = to_screen(DVec3::from_array(f.target).as_vec3()) {
            painter.circle_stroke(q, 5.0, egui::Stroke::new(2.0, blue));
        }
    }

    /// Position keys' markers (the chosen one with its time) and a ring on
    /// the selected object at the playhead.
    fn key_marks(
        &self,
        scene: &Scene,
        painter: &egui::Painter,
        to_screen: &dyn Fn(Vec3) -> Option<egui::Pos2>,
    ) {
        for (o, of) in self.doc.file.objects.iter().enumerate() {
            if self.hidden.get(o).copied().unwrap_or(false) {
                continue;
            }
            let centre = scene.objects.get(o).map_or(DVec3::ZERO, |x| x.center);
            // While a key is dragged, the loaded scene has its new place.
            let keys = scene
                .objects
                .get(o)
                .map(|x| x.trajectory.keys().to_vec())
                .unwrap_or_default();
            for (i, k) in keys.iter().enumerate() {
                let Some(p) = to_screen((k.position + centre).as_vec3()) else {
                    continue;
                };
                let chosen = self.key == Some((o, Track::Position, i));
                let (radius, fill) = if chosen {
                    (6.0, egui::Color32::from_rgb(255, 220, 80))
                } else {
                    (4.5, egui::Color32::from_rgb(200, 170, 90))
                };
                painter.circle(
                    p,
                    radius,
                    fill,
                    egui::Stroke::new(1.0, egui::Color32::BLACK),
                );
                if of.trajectory.len() == keys.len() && chosen {
                    painter.text(
                        p + egui::vec2(8.0, -8.0),
                        egui::Align2::LEFT_BOTTOM,
                        format!("{:.2} s", k.time),
                        egui::FontId::proportional(12.0),
                        egui::Color32::WHITE,
                    );
                }
            }
            if self.selected == Some(o)
                && let Some(p) = world_centre(scene, o, self.doc.playhead).and_then(to_screen)
            {
                painter.circle_stroke(p, 7.0, egui::Stroke::new(1.5, egui::Color32::WHITE));
            }
        }
    }

    /// The time and frame at the playhead, top left.
    fn time_label(&self, painter: &egui::Painter, gate: egui::Rect) {
        let t = self.doc.playhead;
        let mut label = format!("{t:.2} s  frame {}", Playback::frame_of(&self.doc, t));
        if self.through_camera {
            label.push_str("  (scene camera)");
        }
        painter.text(
            gate.min + egui::vec2(8.0, 6.0),
            egui::Align2::LEFT_TOP,
            label,
            egui::FontId::monospace(13.0),
            egui::Color32::from_gray(220),
        );
    }
}

/// The viewport's grey outside the scene camera's `gate` (all of it when
/// `empty`): only that is filled, as a fill costs on a software rasteriser.
fn letterbox(ui: &egui::Ui, rect: egui::Rect, gate: egui::Rect, empty: bool) {
    let grey = egui::Color32::from_gray(28);
    if empty {
        ui.painter().rect_filled(rect, 0.0, grey);
        return;
    }
    if gate == rect {
        return;
    }
    let p = ui.painter();
    for bar in [
        egui::Rect::from_x_y_ranges(rect.x_range(), rect.top()..=gate.top()),
        egui::Rect::from_x_y_ranges(rect.x_range(), gate.bottom()..=rect.bottom()),
        egui::Rect::from_x_y_ranges(rect.left()..=gate.left(), gate.y_range()),
        egui::Rect::from_x_y_ranges(gate.right()..=rect.right(), gate.y_range()),
    ] {
        p.rect_filled(bar, 0.0, grey);
    }
}

/// A hash of what the Composer's picture shows (the scene's generation,
/// whether it moves, the time, the view and the lines), to draw it only
/// when that changes.
fn picture_stamp<'a>(
    c: &Composer,
    moving: bool,
    cam: &Camera,
    options: &SceneOptions,
    lines: impl Iterator<Item = &'a Line>,
) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    c.loaded.generation().hash(&mut h);
    moving.hash(&mut h);
    c.doc.playhead.to_bits().hash(&mut h);
    format!("{cam:?}{:?}{:?}", options.draw, c.hidden).hash(&mut h);
    for l in lines {
        for v in [l.a, l.b] {
            v.to_array().map(f32::to_bits).hash(&mut h);
        }
        l.color.map(f32::to_bits).hash(&mut h);
    }
    h.finish()
}
