//! The Composer's menu and side panel: the scene (size, background,
//! camera), its objects (add, remove, rename, hide, scale, parts with their
//! colour and texture, deformations, contact) and the selected key's value,
//! time and TCB. Every change is a [`SceneEdit`]; a value dragged is one
//! undo step.

use std::path::Path;

use csrbf::glam::{DQuat, DVec3, EulerRot};
use csrbf_anim::{ContactFile, DeformationFile, Easing, Interpolation, LightFile, ObjectFile};
use eframe::egui;

use super::composer::Composer;
use super::files::Purpose;
use super::panel::{region_ui, vec3_ui};
use super::request::Request;
use crate::compose::{KeyValue, SceneEdit, Track, key_value};

impl Composer {
    /// Sets the texture of the part chosen in the panel.
    pub(super) fn set_texture(&mut self, path: &Path) {
        let Some((o, p)) = self.part_target.take() else {
            return;
        };
        let Some(mut object) = self.doc.file.objects.get(o).cloned() else {
            return;
        };
        let Some(part) = object.parts.get_mut(p) else {
            return;
        };
        part.texture = Some(self.doc.name_of(path));
        if self.edit(SceneEdit::ReplaceObject(o, Box::new(object))) {
            self.status = format!("Texture {}", path.display());
        }
    }

    /// Adds a control file as a deformation of the part chosen in the panel
    /// (or the selected object's first part), phased in over the scene.
    pub(super) fn add_deformation(&mut self, path: &Path) {
        let target = self.part_target.take().or(self.selected.map(|o| (o, 0)));
        let Some((o, p)) = target else {
            return self.outbox.error(
                "No object chosen",
                format!(
                    "{}: select the object whose deformation this is first",
                    path.display()
                ),
            );
        };
        let Some(mut object) = self.doc.file.objects.get(o).cloned() else {
            return;
        };
        if object.parts.is_empty() {
            object.parts.push(crate::compose::whole_part());
        }
        let Some(part) = object.parts.get_mut(p) else {
            return;
        };
        part.deformations.push(DeformationFile {
            controls: self.doc.name_of(path),
            phase: Vec::new(),
            easing: Easing::default(),
        });
        if self.edit(SceneEdit::ReplaceObject(o, Box::new(object))) {
            self.status = format!(
                "Added {} (phase 1 throughout until it has phase keys)",
                path.display()
            );
        }
    }

    /// The Composer's side panel.
    pub(super) fn scene_panel(&mut self, ui: &mut egui::Ui) {
        ui.heading("Scene");
        ui.label(
            self.doc
                .path
                .as_ref()
                .map_or("(not saved yet)".into(), |p| p.display().to_string()),
        );
        if let Some(p) = &self.loaded.problem {
            ui.colored_label(egui::Color32::LIGHT_RED, p);
        }
        let look = look_ui(ui, self);
        ui.separator();
        ui.heading("Camera");
        let camera = camera_ui(ui, self);
        ui.separator();
        let lights_edit = lights_ui(ui, &self.doc.file.lights, self.scene_camera());
        ui.separator();
        ui.heading("Objects");
        let (add, remove) = objects_ui(ui, self);
        let selected = self.selected;
        // Apply what was asked, one edit each.
        if let Some((size, background)) = look {
            self.edit_merging(SceneEdit::SetLook { size, background }, Some("look"));
        }
        if let Some(camera) = camera {
            self.edit_merging(SceneEdit::SetCamera(camera), Some("camera"));
        }
        if let Some(lights) = lights_edit {
            self.edit_merging(SceneEdit::SetLights(lights), Some("lights"));
        }
        if add {
            self.outbox.push(Request::Ask(Purpose::AddObject));
        }
        if let Some(k) = remove
            && self.edit(SceneEdit::RemoveObject(k))
        {
            self.selected = None;
            self.key = None;
        }
        if let Some(o) = selected {
            ui.separator();
            self.object_ui(ui, o);
        }
        ui.separator();
        self.key_ui(ui);
    }

    fn object_ui(&mut self, ui: &mut egui::Ui, o: usize) {
        let Some(original) = self.doc.file.objects.get(o).cloned() else {
            return;
        };
        let mut object = original.clone();
        ui.heading(format!("Object {:?}", object.name));
        let mut out = ObjectOut {
            rename: name_ui(ui, self, o, &object.name),
            ..ObjectOut::default()
        };
        ui.label(format!("Mesh {}", object.mesh));
        scale_ui(ui, &mut object, &mut out);
        base_rotation_ui(ui, &mut object, &mut out);
        let others: Vec<String> = (self.doc.file.objects.iter().enumerate())
            .filter(|(k, _)| *k != o)
            .map(|(_, x)| x.name.clone())
            .collect();
        contact_ui(ui, &mut object, &others, &mut out);
        let shape = part_shape(self, o);
        let parts = object.parts.len();
        for (pi, part) in object.parts.iter_mut().enumerate() {
            part_ui(ui, (pi, part), parts, shape.as_ref(), &mut out);
        }
        if let Some(pi) = out.remove_part {
            object.parts.remove(pi);
            out.tag = Some("parts");
        }
        if ui
            .button("Add part")
            .on_hover_text("A part carved out of the others (to start, a sphere about the surface point nearest the mesh's middle), with its own colour, texture and deformations")
            .clicked()
        {
            add_part(&mut object, shape.as_ref());
            out.tag = Some("parts");
        }
        self.apply_object(o, &original, object, out);
    }

    /// What the object's panel asked for, applied after drawing it.
    fn apply_object(
        &mut self,
        o: usize,
        original: &ObjectFile,
        object: ObjectFile,
        out: ObjectOut,
    ) {
        if let Some((pi, purpose)) = out.choose {
            self.part_target = Some((o, pi));
            self.outbox.push(Request::Ask(purpose));
        }
        // A refused name goes back to the object's.
        if let Some(name) = out.rename
            && !self.edit(SceneEdit::RenameObject(o, name))
        {
            self.renaming = None;
        }
        if let Some(tag) = out.tag
            && object != *original
        {
            // A removed deformation shifts the phase tracks: a step of its own.
            let merge = (!matches!(tag, "deformations" | "contact" | "parts")).then_some(tag);
            self.edit_merging(SceneEdit::ReplaceObject(o, Box::new(object)), merge);
        }
        if let Some((pi, di)) = out.picker {
            self.outbox.push(Request::EditInPicker(o, pi, di));
        }
    }

    fn key_ui(&mut self, ui: &mut egui::Ui) {
        let Some((o, track, i)) = self.key else {
            ui.label("Select a key on the timeline or in the viewport to edit it.");
            return;
        };
        let Some(of) = self.doc.file.objects.get(o) else {
            return;
        };
        let Some(time) = self.doc.key_times(o, track).get(i).copied() else {
            return;
        };
        ui.heading(format!("{} of {:?}", key_name(of, track), of.name));
        let mut edits = Vec::new();
        let mut t = time;
        ui.horizontal(|ui| {
            ui.label("Time");
            let drag = egui::DragValue::new(&mut t)
                .update_while_editing(false)
                .speed(1.0 / self.doc.file.fps)
                .range(0.0..=self.doc.file.duration)
                .suffix(" s")
                .max_decimals(4);
            if ui.add(drag).changed() {
                let edit = SceneEdit::MoveKey {
                    object: o,
                    track,
                    index: i,
                    time: t,
                };
                edits.push((edit, "key time"));
            }
        });
        key_value_ui(ui, (o, of), (track, i), &mut edits);
        let (mut delete, mut copy) = (false, false);
        ui.horizontal(|ui| {
            delete = ui.button("Delete key").clicked();
            copy = ui.button("Copy to the playhead").clicked();
        });
        for (edit, tag) in edits {
            let moved = match &edit {
                SceneEdit::MoveKey { time, .. } => Some(*time),
                _ => None,
            };
            if self.edit_merging(edit, Some(tag))
                && let Some(t) = moved
            {
                // Passing another key reorders: follow the key.
                let index = self.doc.key_times(o, track).iter().position(|&k| k == t);
                self.key = index.map(|k| (o, track, k));
            }
        }
        if delete {
            self.delete_key();
        }
        if copy {
            self.copy_key();
        }
    }
}

/// "Position key", "Orientation key" or "Phase key of CONTROLS".
fn key_name(of: &ObjectFile, track: Track) -> String {
    match track {
        Track::Position => "Position key".to_string(),
        Track::Orientation => "Orientation key".to_string(),
        Track::Phase { part, deformation } => format!(
            "Phase key of {}",
            of.parts
                .get(part)
                .and_then(|p| p.deformations.get(deformation))
                .map_or("?", |d| d.controls.as_str())
        ),
    }
}

/// A key's value (a position and its TCB, a turn in degrees, a phase), the
/// edits it asks for pushed to `edits` with their merge tags.
fn key_value_ui(
    ui: &mut egui::Ui,
    (o, of): (usize, &ObjectFile),
    (track, i): (Track, usize),
    edits: &mut Vec<(SceneEdit, &'static str)>,
) {
    let set = |value| SceneEdit::SetKey {
        object: o,
        track,
        index: i,
        value,
    };
    match key_value(of, track, i) {
        Some(KeyValue::Position(p)) => {
            let mut v = DVec3::from_array(p);
            if vec3_ui(ui, "Position", &mut v, 0.01) {
                edits.push((set(KeyValue::Position(v.to_array())), "key value"));
            }
            let k = of.trajectory[i];
            let mut tcb = [k.tension, k.continuity, k.bias];
            let mut changed = false;
            for (j, label) in ["Tension", "Continuity", "Bias"].into_iter().enumerate() {
                changed |= ui
                    .add(
                        egui::Slider::new(&mut tcb[j], -1.0..=1.0)
                            .update_while_editing(false)
                            .text(label),
                    )
                    .changed();
            }
            if changed {
                let edit = SceneEdit::SetTcb {
                    object: o,
                    index: i,
                    tcb,
                };
                edits.push((edit, "tcb"));
            }
        }
        Some(KeyValue::Orientation(q)) => {
            let (x, y, z) = DQuat::from_array(q).to_euler(EulerRot::XYZ);
            let mut e = DVec3::new(x, y, z) * (180.0 / std::f64::consts::PI);
            if vec3_ui(ui, "Turn (°, XYZ)", &mut e, 0.5) {
                let r = e * (std::f64::consts::PI / 180.0);
                let q = DQuat::from_euler(EulerRot::XYZ, r.x, r.y, r.z);
                edits.push((set(KeyValue::Orientation(q.to_array())), "key value"));
            }
            ui.label("Drag a ring of the gizmo in the viewport to turn it about X, Y or Z.");
        }
        Some(KeyValue::Phase(p)) => {
            let mut p = p;
            if ui
                .add(
                    egui::Slider::new(&mut p, 0.0..=1.0)
                        .update_while_editing(false)
                        .text("Phase"),
                )
                .changed()
            {
                edits.push((set(KeyValue::Phase(p)), "key value"));
            }
        }
        None => {}
    }
}

/// The scene's lights: each one's direction, colour and intensity, a
/// remove button, and Add. A scene without lights is drawn with the
/// renderer's default key and fill lights placed from the scene camera;
/// the first Add writes those two out, so the picture does not change
/// until they are edited. Returns the new list when something changed.
fn lights_ui(
    ui: &mut egui::Ui,
    lights: &[LightFile],
    camera: csrbf_anim::Camera,
) -> Option<Vec<LightFile>> {
    ui.heading("Lights");
    let mut out = lights.to_vec();
    let mut changed = false;
    let mut remove = None;
    if out.is_empty() {
        ui.label(
            "The default: a key light from the camera's upper left and a fill from its right.",
        );
    }
    for (i, l) in out.iter_mut().enumerate() {
        ui.push_id(("light", i), |ui| {
            let mut d = DVec3::from_array(l.direction);
            ui.horizontal(|ui| {
                ui.label(format!("{}", i + 1));
                changed |= ui.color_edit_button_rgb(&mut l.color).changed();
                changed |= ui
                    .add(
                        egui::DragValue::new(&mut l.intensity)
                            .update_while_editing(false)
                            .range(0.0..=10.0)
                            .speed(0.01)
                            .prefix("intensity "),
                    )
                    .changed();
                if ui.button("Remove").clicked() {
                    remove = Some(i);
                }
            });
            if vec3_ui(ui, "   direction", &mut d, 0.01) && d.length() > 0.0 {
                l.direction = d.to_array();
                changed = true;
            }
        });
    }
    if let Some(i) = remove {
        out.remove(i);
        changed = true;
    }
    if ui
        .button("Add light")
        .on_hover_text("A directional light (the first one writes out the default two)")
        .clicked()
    {
        if out.is_empty() {
            out = csrbf_render::default_lights(camera)
                .into_iter()
                .map(|l| LightFile {
                    direction: l.direction.as_dvec3().to_array(),
                    color: [1.0; 3],
                    intensity: l.color.max_element(),
                })
                .collect();
        } else {
            out.push(LightFile {
                direction: [0.0, -1.0, 0.0],
                color: [1.0; 3],
                intensity: 0.5,
            });
        }
        changed = true;
    }
    changed.then_some(out)
}

/// A part's `select` as a region (`"all"` is the whole mesh); None for one
/// the chooser cannot show.
fn select_region(select: &serde_json::Value) -> Option<csrbf::Region> {
    if select.as_str() == Some("all") {
        return Some(csrbf::Region::All);
    }
    csrbf_edit::controls::parse_region(select, "select").ok()
}

/// A region as a part's `select` writes it.
fn select_json(region: &csrbf::Region) -> serde_json::Value {
    match region {
        csrbf::Region::All => "all".into(),
        r => csrbf_edit::controls::region_json(r),
    }
}

/// The picture's size and background; the new pair when either changed.
fn look_ui(ui: &mut egui::Ui, c: &Composer) -> Option<([u32; 2], [f32; 3])> {
    let mut size = c.doc.file.size;
    let mut background = c.doc.file.background;
    let mut look = false;
    ui.horizontal(|ui| {
        ui.label("Picture");
        look |= ui.add(pixels(&mut size[0])).changed();
        ui.label("x");
        look |= ui.add(pixels(&mut size[1])).changed();
        look |= ui.color_edit_button_rgb(&mut background).changed();
        ui.label("background");
    });
    look.then_some((size, background))
}

/// A picture side, in pixels.
fn pixels(v: &mut u32) -> egui::DragValue<'_> {
    egui::DragValue::new(v)
        .update_while_editing(false)
        .range(16..=8192)
        .suffix(" px")
}

/// The scene camera: eye, target, field of view, set from the view, look
/// through it; the new camera when it changed.
fn camera_ui(ui: &mut egui::Ui, c: &mut Composer) -> Option<csrbf_anim::CameraFile> {
    let mut camera = c.doc.file.camera.clone();
    let mut eye = DVec3::from_array(camera.eye);
    let mut target = DVec3::from_array(camera.target);
    let speed = c
        .loaded
        .scene
        .as_ref()
        .and_then(|s| s.objects.iter().map(|o| o.radius).reduce(f64::max))
        .unwrap_or(1.0)
        * 0.01;
    let mut changed = vec3_ui(ui, "Eye", &mut eye, speed);
    changed |= vec3_ui(ui, "Target", &mut target, speed);
    ui.horizontal(|ui| {
        ui.label("Field of view");
        let fov = egui::DragValue::new(&mut camera.fov)
            .update_while_editing(false)
            .range(2.0..=178.0)
            .suffix("°");
        changed |= ui.add(fov).changed();
    });
    let mut from_view = false;
    ui.horizontal(|ui| {
        from_view = ui
            .button("Set from the view")
            .on_hover_text("The scene camera takes the viewport's eye, target and field of view")
            .clicked();
        ui.checkbox(&mut c.through_camera, "Look through it (C)");
    });
    if from_view {
        let cam = c.orbit.camera();
        eye = cam.eye.as_dvec3();
        target = cam.target.as_dvec3();
        camera.up = c.orbit.up.as_dvec3().to_array();
        camera.fov = c.orbit.fov as f64;
        changed = true;
    }
    camera.eye = eye.to_array();
    camera.target = target.to_array();
    changed.then_some(camera)
}

/// The objects, each shown or hidden and selectable; Add object and Remove
/// (whether Add was clicked, and the object to remove).
fn objects_ui(ui: &mut egui::Ui, c: &mut Composer) -> (bool, Option<usize>) {
    let mut select = None;
    let names: Vec<String> = c.doc.file.objects.iter().map(|o| o.name.clone()).collect();
    for (k, name) in names.iter().enumerate() {
        ui.horizontal(|ui| {
            let mut shown = !c.hidden.get(k).copied().unwrap_or(false);
            if ui
                .checkbox(&mut shown, "")
                .on_hover_text("Shown in the viewport (a view setting: movies show every object)")
                .changed()
                && let Some(h) = c.hidden.get_mut(k)
            {
                *h = !shown;
            }
            if ui.selectable_label(c.selected == Some(k), name).clicked() {
                select = Some(k);
            }
        });
    }
    if let Some(k) = select {
        c.selected = Some(k);
        c.renaming = None;
    }
    let mut add = false;
    let mut remove = None;
    ui.horizontal(|ui| {
        add = ui.button("Add object…").clicked();
        if let Some(k) = c.selected
            && ui.button("Remove").clicked()
        {
            remove = Some(k);
        }
    });
    (add, remove)
}

/// What an object's panel asked for this frame.
#[derive(Default)]
struct ObjectOut {
    /// The edit's merge tag, when the object changed.
    tag: Option<&'static str>,
    /// A new name typed.
    rename: Option<String>,
    /// A part and deformation to edit in the Picker.
    picker: Option<(usize, usize)>,
    /// A file to choose for a part.
    choose: Option<(usize, Purpose)>,
    remove_part: Option<usize>,
}

/// The object's name, typed; the new one when the field lost focus changed.
fn name_ui(ui: &mut egui::Ui, c: &mut Composer, o: usize, name: &str) -> Option<String> {
    let mut rename = None;
    ui.horizontal(|ui| {
        ui.label("Name");
        let text = match &mut c.renaming {
            Some((k, t)) if *k == o => t,
            _ => &mut c.renaming.insert((o, name.to_string())).1,
        };
        let r = ui.add(egui::TextEdit::singleline(text).desired_width(180.0));
        if r.lost_focus() && *text != name {
            rename = Some(text.clone());
        }
    });
    rename
}

/// The object's scale and how it turns between orientation keys.
fn scale_ui(ui: &mut egui::Ui, object: &mut ObjectFile, out: &mut ObjectOut) {
    ui.horizontal(|ui| {
        ui.label("Scale");
        let scale = egui::DragValue::new(&mut object.scale)
            .update_while_editing(false)
            .speed(0.01)
            .range(1e-6..=1e6);
        if ui.add(scale).changed() {
            out.tag = Some("scale");
        }
        ui.label("Turning");
        egui::ComboBox::from_id_salt("interpolation")
            .selected_text(format!("{:?}", object.interpolation).to_lowercase())
            .show_ui(ui, |ui| {
                for i in [Interpolation::Squad, Interpolation::Slerp] {
                    let name = format!("{i:?}").to_lowercase();
                    if ui
                        .selectable_value(&mut object.interpolation, i, name)
                        .changed()
                    {
                        out.tag = Some("interpolation");
                    }
                }
            });
    });
}

/// The object's base rotation (its mesh placed before the orientation
/// keys turn it) as Euler angles, and the usual fixes for a model made
/// with another up axis.
fn base_rotation_ui(ui: &mut egui::Ui, object: &mut ObjectFile, out: &mut ObjectOut) {
    let given = object.rotation.and_then(|r| r.euler_degrees());
    let mut euler = given.unwrap_or([0.0; 3]);
    let mut changed = false;
    ui.horizontal(|ui| {
        ui.label("Base rotation")
            .on_hover_text("Turns the mesh in place before its orientation keys (degrees about X, then Y, then Z); its control files stay in the mesh's own axes");
        for (v, axis) in euler.iter_mut().zip(["X", "Y", "Z"]) {
            let drag = egui::DragValue::new(v)
                .update_while_editing(false)
                .prefix(format!("{axis} "))
                .suffix("°")
                .speed(1.0)
                .range(-360.0..=360.0);
            changed |= ui.add(drag).changed();
        }
    });
    ui.horizontal(|ui| {
        for (name, e, hint) in [
            (
                "Z-up to Y-up",
                [-90.0, 0.0, 0.0],
                "A model made with +Z up (Blender, CAD) stands up in a +Y-up scene",
            ),
            (
                "-Z-up to Y-up",
                [90.0, 0.0, 0.0],
                "A model whose up is -Z stands up",
            ),
            (
                "X-up to Y-up",
                [0.0, 0.0, 90.0],
                "A model whose up is +X stands up",
            ),
            ("None", [0.0; 3], "No base rotation"),
        ] {
            if ui.button(name).on_hover_text(hint).clicked() {
                euler = e;
                changed = true;
            }
        }
    });
    if changed && Some(euler) != given {
        object.rotation = (euler != [0.0; 3]).then(|| csrbf_anim::RotationFile {
            euler: Some(euler),
            ..Default::default()
        });
        out.tag = Some("rotation");
    }
}

/// Contact: pushed by another object's bounding sphere, and its reach.
fn contact_ui(ui: &mut egui::Ui, object: &mut ObjectFile, others: &[String], out: &mut ObjectOut) {
    ui.horizontal(|ui| {
        ui.label("Pushed by");
        let current = object
            .contact
            .as_ref()
            .map_or("nothing".to_string(), |x| x.with.clone());
        egui::ComboBox::from_id_salt("contact")
            .selected_text(current)
            .show_ui(ui, |ui| {
                if ui
                    .selectable_label(object.contact.is_none(), "nothing")
                    .clicked()
                {
                    object.contact = None;
                    out.tag = Some("contact");
                }
                for n in others {
                    let on = object.contact.as_ref().is_some_and(|x| &x.with == n);
                    if ui.selectable_label(on, n).clicked() {
                        object.contact = Some(ContactFile {
                            with: n.clone(),
                            kernel: Default::default(),
                            reach: 1.5,
                        });
                        out.tag = Some("contact");
                    }
                }
            });
        if let Some(x) = object.contact.as_mut()
            && ui
                .add(
                    egui::DragValue::new(&mut x.reach)
                        .update_while_editing(false)
                        .speed(0.01)
                        .range(0.1..=10.0)
                        .prefix("reach "),
                )
                .on_hover_text(
                    "Radius of support: this many times the depth plus the pusher's radius",
                )
                .changed()
        {
            out.tag = Some("reach");
        }
    });
}

/// The object's mesh as loaded (scaled), for its parts' face selections:
/// its box, groups, diagonal, and where a new part starts.
struct Shape {
    bounds: (DVec3, DVec3),
    groups: Vec<String>,
    diag: f64,
    /// The surface point nearest the box's middle (the middle itself is
    /// inside a closed mesh, no face there).
    seed: DVec3,
}

fn part_shape(c: &Composer, o: usize) -> Option<Shape> {
    let x = c.loaded.scene.as_ref()?.objects.get(o)?;
    let (lo, hi) = x
        .mesh
        .bounds()
        .map(|(a, b)| (a.as_dvec3(), b.as_dvec3()))
        .unwrap_or((DVec3::ZERO, DVec3::ONE));
    let mid = (lo + hi) * 0.5;
    let seed = x
        .mesh
        .positions
        .iter()
        .map(|p| p.as_dvec3())
        .min_by(|a, b| a.distance(mid).total_cmp(&b.distance(mid)))
        .unwrap_or(mid);
    Some(Shape {
        bounds: (lo, hi),
        groups: x.mesh.parts.iter().map(|p| p.name.clone()).collect(),
        diag: (hi - lo).length().max(1e-9),
        seed,
    })
}

/// A new part: a sphere about the shape's seed, or the whole mesh.
fn add_part(object: &mut ObjectFile, shape: Option<&Shape>) {
    let name = (1..)
        .map(|k| format!("part {k}"))
        .find(|n| !object.parts.iter().any(|p| &p.name == n))
        .expect("a free name");
    let select = shape.map_or("all".into(), |s| {
        select_json(&csrbf::Region::Sphere {
            center: s.seed,
            radius: s.diag * 0.15,
        })
    });
    object.parts.push(csrbf_anim::PartFile {
        name,
        select,
        color: Some(csrbf_anim::Color([0.85, 0.35, 0.3, 1.0])),
        texture: None,
        wireframe: false,
        deformations: Vec::new(),
    });
}

/// One part: its faces, colour, edges, texture and deformations.
fn part_ui(
    ui: &mut egui::Ui,
    (pi, part): (usize, &mut csrbf_anim::PartFile),
    parts: usize,
    shape: Option<&Shape>,
    out: &mut ObjectOut,
) {
    ui.horizontal(|ui| {
        ui.label(egui::RichText::new(format!("Part {:?}", part.name)).strong());
        if parts > 1 && ui.small_button("Remove part").clicked() {
            out.remove_part = Some(pi);
        }
    });
    if let Some(shape) = shape {
        faces_ui(ui, (pi, part), shape, out);
    }
    ui.horizontal(|ui| {
        let mut rgba = part.color.map_or(csrbf_anim::DEFAULT_PART_COLOR, |c| c.0);
        if ui.color_edit_button_rgba_unmultiplied(&mut rgba).changed() {
            part.color = Some(csrbf_anim::Color(rgba));
            out.tag = Some("colour");
        }
        ui.label("colour");
        if ui.checkbox(&mut part.wireframe, "edges").changed() {
            out.tag = Some("edges");
        }
    });
    ui.horizontal(|ui| {
        ui.label(format!(
            "Texture {}",
            part.texture.as_deref().unwrap_or("none")
        ));
        if ui.button("Texture…").clicked() {
            out.choose = Some((pi, Purpose::Texture));
        }
        if part.texture.is_some() && ui.button("None").clicked() {
            part.texture = None;
            out.tag = Some("texture");
        }
    });
    deformations_ui(ui, (pi, part), out);
    if ui.button("Add deformation…").clicked() {
        out.choose = Some((pi, Purpose::AddControls));
    }
}

/// The faces a part selects, as a region editor (or its text when it is not
/// one the editor shows).
fn faces_ui(
    ui: &mut egui::Ui,
    (pi, part): (usize, &mut csrbf_anim::PartFile),
    shape: &Shape,
    out: &mut ObjectOut,
) {
    let Some(mut region) = select_region(&part.select) else {
        ui.label(format!("faces: {}", part.select));
        return;
    };
    let before = region.clone();
    let names: Vec<&str> = shape.groups.iter().map(String::as_str).collect();
    ui.push_id(("faces", pi), |ui| {
        region_ui(
            ui,
            "faces",
            &mut region,
            shape.bounds,
            (&names, false),
            shape.diag,
            "Which faces this part has: the whole mesh, a group of it, or \
             the faces whose corners all lie in a sphere or box (in the \
             mesh's coordinates, scaled). A face belongs to the last part \
             that selects it.",
        );
    });
    if region != before {
        part.select = select_json(&region);
        out.tag = Some("faces");
    }
}

/// A part's deformations: easing, Edit in Picker, Remove.
fn deformations_ui(
    ui: &mut egui::Ui,
    (pi, part): (usize, &mut csrbf_anim::PartFile),
    out: &mut ObjectOut,
) {
    let mut drop = None;
    for (di, d) in part.deformations.iter_mut().enumerate() {
        ui.horizontal(|ui| {
            ui.label(format!("Deformation {}", d.controls));
        });
        ui.horizontal(|ui| {
            egui::ComboBox::from_id_salt(("easing", pi, di))
                .selected_text(format!("{:?}", d.easing).to_lowercase())
                .show_ui(ui, |ui| {
                    for e in [Easing::Smooth, Easing::Linear] {
                        if ui
                            .selectable_value(&mut d.easing, e, format!("{e:?}").to_lowercase())
                            .changed()
                        {
                            out.tag = Some("easing");
                        }
                    }
                });
            if ui
                .button("Edit in Picker")
                .on_hover_text("Open this control file on the mesh in the Picker; File > Back to the Composer returns")
                .clicked()
            {
                out.picker = Some((pi, di));
            }
            if ui.button("Remove").clicked() {
                drop = Some(di);
            }
        });
    }
    if let Some(di) = drop {
        part.deformations.remove(di);
        out.tag = Some("deformations");
    }
}
