//! The side panel (tools, layers, parameters, the selected control, the
//! handle, diagnostics) and the status bar.

use csrbf::glam::DVec3;
use csrbf::{Handle, Kernel, Polynomial, Region};
use eframe::egui;

use super::picker::{Model, Picker, Tool, count};
use crate::Command;

/// A button of the selection that is not one edit.
enum Action {
    Delete,
    Stamp,
    Mirror(usize),
}

use crate::gizmo::HandleMode;
use crate::tools::VertexTarget;

impl Picker {
    pub(super) fn side_panel(&mut self, ui: &mut egui::Ui) {
        ui.heading("Tool");
        ui.horizontal(|ui| {
            ui.selectable_value(&mut self.tool, Tool::Place, "Place")
                .on_hover_text("P: a click on the surface adds a control vector (a pin); drag to set its destination");
            ui.selectable_value(&mut self.tool, Tool::Select, "Select")
                .on_hover_text("S: click markers to select (Shift adds), drag a box on the background");
            ui.selectable_value(&mut self.tool, Tool::Vertices, "Vertices")
                .on_hover_text("V: drag a box on the surface to choose vertices for a handle, an anchor or a region");
        });
        ui.horizontal(|ui| {
            ui.label("Hold to axis:");
            for (a, name) in ["X", "Y", "Z"].into_iter().enumerate() {
                let on = self.axis == Some(a);
                if ui
                    .selectable_label(on, name)
                    .on_hover_text(format!("{name}: moves go along the {name} axis only"))
                    .clicked()
                {
                    self.set_axis(if on { None } else { Some(a) });
                }
            }
        });
        if self.view.stamp.is_some() && ui.button("Stop stamping (Esc)").clicked() {
            self.view.stamp = None;
        }
        if self.model.is_none() {
            return;
        }
        ui.separator();
        self.layers_ui(ui);
        ui.separator();
        self.parameters_ui(ui);
        ui.separator();
        self.selection_ui(ui);
        ui.separator();
        self.vertices_ui(ui);
        ui.separator();
        self.diagnostics_ui(ui);
    }

    fn layers_ui(&mut self, ui: &mut egui::Ui) {
        ui.heading("Layers");
        let Some(m) = self.model.as_mut() else {
            return;
        };
        let n = m.doc.controls.deformations.len();
        // Some(None): only what is shown changed.
        let mut command = None;
        for l in 0..n {
            ui.horizontal(|ui| {
                if let Some(c) = layer_row(ui, m, l) {
                    command = Some(c);
                }
            });
        }
        if let Some(c) = layer_name_ui(ui, m) {
            command = Some(Some(c));
        }
        if ui.button("Add layer").clicked() {
            command = Some(Some(add_layer(m)));
        }
        match command {
            Some(Some(c)) => {
                self.edit(c, true);
                if let Some(m) = self.model.as_mut() {
                    let last = m.doc.controls.deformations.len() - 1;
                    m.doc.active_layer = m.doc.active_layer.min(last);
                }
            }
            Some(None) => self.refresh(true),
            None => {}
        }
        if let Some(m) = self.model.as_mut()
            && combine_ui(ui, m)
        {
            self.refresh(true);
        }
    }

    fn parameters_ui(&mut self, ui: &mut egui::Ui) {
        let Some(m) = self.model.as_mut() else {
            return;
        };
        let l = m.doc.active_layer;
        let spec = m.doc.controls.deformations[l].clone();
        ui.heading(format!(
            "{} parameters",
            spec.name.clone().unwrap_or_else(|| format!("Layer {l}"))
        ));
        let r = radius_ui(ui, m, &spec);
        self.view.all_spheres = r.dragged() || r.has_focus();
        let drag_stopped = r.drag_stopped();
        let mut commands: Vec<Command> = Vec::new();
        if let Some(radius) = r.radius {
            commands.push(Command::SetRadius { layer: l, radius });
        }
        commands.extend(options_ui(ui, m, &spec));
        let mut global = m.doc.phase;
        ui.add(
            egui::Slider::new(&mut global, 0.0..=1.0)
                .update_while_editing(false)
                .text("phase (all layers)"),
        )
        .on_hover_text("0 shows the rest shape, 1 the full deformation");
        let phase_changed = global != m.doc.phase;
        if phase_changed {
            m.doc.phase = global;
        }
        for c in commands {
            self.edit(c, true);
        }
        if phase_changed {
            self.refresh(false);
        }
        if drag_stopped && let Some(m) = self.model.as_mut() {
            m.history.end_drag();
        }
    }

    fn selection_ui(&mut self, ui: &mut egui::Ui) {
        let Some(m) = self.model.as_mut() else {
            return;
        };
        ui.heading("Selection");
        let sel = m.doc.selection.0.clone();
        if sel.is_empty() {
            ui.label("Nothing selected: click a start (white cross) or a destination");
            return;
        }
        ui.label(format!(
            "{} selected",
            count(sel.len(), "control vector", "control vectors")
        ));
        let commands = match sel[..] {
            [one] => control_ui(ui, m, one),
            _ => Vec::new(),
        };
        let mut action = None;
        ui.horizontal(|ui| {
            if ui.button("Delete").on_hover_text("Del").clicked() {
                action = Some(Action::Delete);
            }
            if ui
                .button("Stamp copies")
                .on_hover_text("Ctrl+D: the next clicks add this displacement elsewhere")
                .clicked()
            {
                action = Some(Action::Stamp);
            }
        });
        if let Some(a) = mirror_ui(ui, m, sel[0]) {
            action = Some(Action::Mirror(a));
        }
        for c in commands {
            self.edit(c, true);
        }
        match action {
            Some(Action::Delete) => self.delete_selected(),
            Some(Action::Stamp) => self.duplicate(),
            Some(Action::Mirror(a)) => self.mirror(a),
            None => {}
        }
    }

    fn vertices_ui(&mut self, ui: &mut egui::Ui) {
        ui.heading("Handle");
        let axis = self.axis;
        let Some(m) = self.model.as_mut() else {
            return;
        };
        ui.label("Vertices tool (V): drag a box, or Ctrl+drag a brush, on the surface; then:");
        ui.horizontal(|ui| {
            ui.radio_value(&mut m.vertex_target, VertexTarget::Handle, "handle");
            ui.radio_value(&mut m.vertex_target, VertexTarget::Anchor, "anchor");
            ui.radio_value(&mut m.vertex_target, VertexTarget::Region, "region");
        });
        ui.label(format!(
            "{} chosen",
            count(m.picked_vertices.len(), "vertex", "vertices")
        ));
        ui.add(
            egui::Slider::new(&mut self.view.brush, 0.002..=0.3)
.update_while_editing(false)
                .logarithmic(true)
                .text("brush")
                .custom_formatter(|v, _| format!("{:.1} %", v * 100.0)),
        )
        .on_hover_text("Ctrl+drag on the surface paints vertices within this share of the diagonal (Shift adds)");
        ui.checkbox(&mut self.view.xray, "select through the model (X-ray)")
            .on_hover_text("A box takes every vertex in it, the far side and the sides of a limb too; else only those facing you");
        let l = m.doc.active_layer;
        let spec = m.doc.controls.deformations[l].clone();
        let mut commands = Vec::new();
        let mut said = None;
        if !m.picked_vertices.is_empty() && ui.button("Apply the chosen vertices").clicked() {
            let (n, target) = (m.picked_vertices.len(), m.vertex_target);
            commands.push(apply_chosen(m, &spec));
            said = Some(match target {
                VertexTarget::Handle => format!(
                    "Layer {} is a handle of {n} vertices: turn it with its rings (Vertices tool)",
                    m.doc.active_layer
                ),
                VertexTarget::Anchor => format!("{n} vertices anchor layer {l}"),
                VertexTarget::Region => format!("Layer {l} acts on {n} vertices"),
            });
        }
        if let Some(h) = spec.handle.clone() {
            ui.label(format!(
                "Layer {} is a handle: with the Vertices tool, drag an axis ring to turn it, or inside the yellow ring to rotate, scale or move it",
                l
            ));
            ui.horizontal(|ui| {
                ui.radio_value(&mut self.handle_mode, HandleMode::Rotate, "rotate");
                ui.radio_value(&mut self.handle_mode, HandleMode::Scale, "scale");
                ui.radio_value(&mut self.handle_mode, HandleMode::Move, "move");
            });
            let view_axis = crate::gizmo::handle_axis(axis, &m.orbit.camera());
            let centroid = {
                let mut own = h.clone();
                if let Some(r) = own.rotate.as_mut() {
                    r.pivot = None;
                }
                let lookup = |n: &str| m.doc.mesh.part_vertices(n);
                own.pivot(&m.doc.mesh.positions, &lookup).ok()
            };
            let (edited, pick) = pivot_ui(ui, &h, centroid, view_axis, m.doc.diagonal());
            if let Some(e) = &edited
                && e.rotate.and_then(|r| r.pivot).is_none()
                && h.rotate.and_then(|r| r.pivot).is_some()
            {
                said = Some(format!(
                    "Layer {}'s handle turns about its selection's centre again",
                    l
                ));
            }
            if pick {
                self.pick_pivot = true;
                self.status =
                    "Click on the surface to put the handle's pivot there (Esc cancels)".into();
            }
            let h = edited.clone().unwrap_or(h);
            if let Some(new) = handle_ui(ui, &h, view_axis, m.doc.diagonal()).or(edited) {
                let mut s = spec.clone();
                s.handle = Some(new);
                commands.push(Command::ReplaceLayer {
                    layer: l,
                    spec: Box::new(s),
                });
            }
            ui.label(match &spec.anchor {
                Some(a) => format!("anchor: {a}"),
                None => "no anchor: pins only where the engine needs them".into(),
            });
        }
        for c in commands {
            self.edit(c, true);
        }
        if let Some(s) = said {
            self.status = s;
        }
    }

    fn diagnostics_ui(&mut self, ui: &mut egui::Ui) {
        let Some(m) = self.model.as_ref() else {
            return;
        };
        ui.heading("Diagnostics");
        let Some(f) = m.preview.latest() else {
            ui.label("fitting…");
            return;
        };
        if let Some(e) = &f.error {
            ui.colored_label(egui::Color32::LIGHT_RED, format!("Refused: {e}"));
            ui.label("(the last good result is shown)");
        }
        let Some(d) = &f.diagnostics else {
            return;
        };
        ui.label(format!(
            "{} vertices moved, the largest by {:.4}",
            d.moved, d.largest_move
        ));
        if !d.inside_out.is_empty() {
            ui.colored_label(
                egui::Color32::from_rgb(255, 90, 90),
                format!(
                    "{} inside out (outlined in red){}",
                    count(d.inside_out.len(), "face", "faces"),
                    d.fold_phase
                        .map(|p| format!(", from phase {p:.2} on"))
                        .unwrap_or_default()
                ),
            );
        } else if d.flipped.is_empty() {
            ui.label("no face turned over");
        } else {
            ui.colored_label(
                egui::Color32::from_rgb(255, 90, 90),
                format!(
                    "{} turned over (outlined in red)",
                    count(d.flipped.len(), "face", "faces")
                ),
            );
        }
        stretch_ui(ui, d);
        match d.self_intersections.as_deref() {
            Some([]) => {
                ui.label("no face passes through another");
            }
            Some(pairs) => {
                ui.colored_label(
                    egui::Color32::from_rgb(255, 160, 40),
                    format!(
                        "{} through each other (outlined in orange)",
                        count(pairs.len(), "pair of faces passes", "pairs of faces pass")
                    ),
                );
            }
            None => {
                ui.label("self-intersections not checked (a mesh this big)");
            }
        }
        for w in &d.warnings {
            ui.colored_label(
                egui::Color32::from_rgb(255, 200, 80),
                format!("! {}", w.numbered(csrbf::Numbering::Editor)),
            );
        }
        if !f.advice.is_empty() {
            ui.colored_label(
                egui::Color32::from_rgb(255, 200, 80),
                format!("! {}", f.advice),
            );
        }
        let dense = m.doc.controls.deformations.iter().any(|s| {
            let n = s.starts.len() as f64;
            n > 500.0 && s.options.radius > m.doc.diagonal() * 0.5
        });
        if dense {
            ui.colored_label(
                egui::Color32::from_rgb(255, 200, 80),
                "! R is over half the diagonal with many controls: the system is nearly dense and slow to fit",
            );
        }
    }
}

/// Layer `l`'s row: select it, show it, move it up or down, remove it.
/// Some(None) when only whether it is shown changed.
fn layer_row(ui: &mut egui::Ui, m: &mut Model, l: usize) -> Option<Option<Command>> {
    let n = m.doc.controls.deformations.len();
    let spec = &m.doc.controls.deformations[l];
    let count = spec.starts.len();
    let handle = if spec.handle.is_some() {
        " + handle"
    } else {
        ""
    };
    let name = spec.name.clone().unwrap_or_else(|| format!("Layer {l}"));
    if ui
        .selectable_label(m.doc.active_layer == l, format!("{name} ({count}{handle})"))
        .on_hover_text("New controls go to the active layer")
        .clicked()
    {
        m.doc.active_layer = l;
    }
    let mut command = None;
    let mut shown = !m.hidden[l];
    if ui
        .checkbox(&mut shown, "")
        .on_hover_text("Show this layer's deformation")
        .changed()
    {
        m.hidden[l] = !shown;
        command = Some(None);
    }
    let button = |ui: &mut egui::Ui, label: &str, hover: &str| {
        ui.small_button(label).on_hover_text(hover).clicked()
    };
    if l > 0 && button(ui, "up", "Earlier in the chain") {
        command = Some(Command::move_layer(&m.doc, l, l - 1));
    }
    if l + 1 < n && button(ui, "down", "Later in the chain") {
        command = Some(Command::move_layer(&m.doc, l, l + 1));
    }
    if n > 1 && button(ui, "remove", "Remove this layer") {
        command = Some(Some(Command::RemoveLayer { layer: l }));
    }
    command
}

/// The active layer's name (saved as the deformation's "name"): the
/// rename when the field lost focus changed.
fn layer_name_ui(ui: &mut egui::Ui, m: &Model) -> Option<Command> {
    let active = m.doc.active_layer;
    let old = m.doc.controls.deformations[active]
        .name
        .clone()
        .unwrap_or_default();
    let mut name = old.clone();
    let mut command = None;
    ui.horizontal(|ui| {
        ui.label("name");
        let r = ui.add(
            egui::TextEdit::singleline(&mut name)
                .hint_text(format!("Layer {active}"))
                .desired_width(160.0),
        );
        if r.lost_focus() && name != old {
            let mut spec = m.doc.controls.deformations[active].clone();
            spec.name = (!name.trim().is_empty()).then(|| name.trim().to_string());
            command = Some(Command::ReplaceLayer {
                layer: active,
                spec: Box::new(spec),
            });
        }
    });
    command
}

/// A new empty layer after the others, with the active one's options; it
/// becomes the active layer.
fn add_layer(m: &mut Model) -> Command {
    let mut spec = m.doc.controls.deformations[m.doc.active_layer].clone();
    spec.starts.clear();
    spec.targets.clear();
    spec.handle = None;
    spec.anchor = None;
    spec.region = Region::All;
    spec.name = None;
    let layer = m.doc.controls.deformations.len();
    m.doc.active_layer = layer;
    Command::InsertLayer {
        layer,
        spec: Box::new(spec),
    }
}

/// How the layers combine (chain or add); true when it changed.
fn combine_ui(ui: &mut egui::Ui, m: &mut Model) -> bool {
    let mut combine = m.doc.controls.combine;
    ui.horizontal(|ui| {
        ui.label("Layers combine:");
        ui.radio_value(&mut combine, csrbf::Combine::Chain, "chain")
            .on_hover_text("Each layer moves the points the one before moved");
        ui.radio_value(&mut combine, csrbf::Combine::Add, "add")
            .on_hover_text("The layers' displacements add up, each on the rest shape");
    });
    let changed = combine != m.doc.controls.combine;
    if changed {
        m.doc.controls.combine = combine;
        m.doc.dirty = true;
    }
    changed
}

/// The radius slider's response, and the new radius when it changed.
struct RadiusEdit {
    response: egui::Response,
    radius: Option<f64>,
}

impl std::ops::Deref for RadiusEdit {
    type Target = egui::Response;
    fn deref(&self) -> &egui::Response {
        &self.response
    }
}

/// The active layer's radius of support, on a log slider; a drag of it is
/// one undo step.
fn radius_ui(
    ui: &mut egui::Ui,
    m: &mut Model,
    spec: &csrbf_edit::controls::ControlSpec,
) -> RadiusEdit {
    let diag = m.doc.diagonal().max(1e-12);
    let mut radius = spec.options.radius;
    // The range takes in the radius in use, however far out (a file's
    // radius is never shown clamped to the slider's ends).
    let range = (diag * 0.002).min(radius)..=(diag * 2.0).max(radius);
    let response = ui
        .add(
            egui::Slider::new(&mut radius, range)
                .update_while_editing(false)
                .logarithmic(true)
                .text("radius R")
                .custom_formatter(|v, _| format!("{v:.4}")),
        )
        .on_hover_text("Radius of support: each control moves the points within R of its start");
    ui.label(format!(
        "R = {:.4} = {:.1} % of the diagonal ({diag:.4})",
        radius,
        radius / diag * 100.0
    ));
    if response.drag_started() {
        m.history.begin_drag();
    }
    let changed =
        response.changed() && radius > 0.0 && radius.is_finite() && radius != spec.options.radius;
    RadiusEdit {
        response,
        radius: changed.then_some(radius),
    }
}

/// The active layer's kernel, polynomial, phase, region and sweep: the commands
/// their changes make.
fn options_ui(
    ui: &mut egui::Ui,
    m: &Model,
    spec: &csrbf_edit::controls::ControlSpec,
) -> Vec<Command> {
    let l = m.doc.active_layer;
    let diag = m.doc.diagonal().max(1e-12);
    let mut commands = Vec::new();
    let mut kernel = spec.options.kernel;
    egui::ComboBox::from_label("kernel")
        .selected_text(kernel.name())
        .show_ui(ui, |ui| {
            for k in Kernel::ALL {
                ui.selectable_value(&mut kernel, k, k.name());
            }
        })
        .response
        .on_hover_text("Wendland function: C0 is continuous only; C2, C4, C6 are smoother");
    if kernel != spec.options.kernel {
        commands.push(Command::SetKernel { layer: l, kernel });
    }
    let mut poly = spec.options.polynomial;
    egui::ComboBox::from_label("polynomial")
        .selected_text(poly.name())
        .show_ui(ui, |ui| {
            for p in Polynomial::ALL {
                ui.selectable_value(&mut poly, p, p.name());
            }
        })
        .response
        .on_hover_text(
            "none: edits stay local; linear: affine maps reproduced, but the whole model may move",
        );
    let mut phase = spec.phase;
    ui.add(
        egui::Slider::new(&mut phase, 0.0..=1.0)
            .update_while_editing(false)
            .text("layer phase"),
    );
    let mut region = spec.region.clone();
    let bounds = m
        .doc
        .bounds()
        .map(|(a, b)| (a.as_dvec3(), b.as_dvec3()))
        .unwrap_or((DVec3::ZERO, DVec3::ONE));
    let groups: Vec<&str> = m.doc.mesh.parts.iter().map(|p| p.name.as_str()).collect();
    region_ui(
        ui,
        "region",
        &mut region,
        bounds,
        (&groups, true),
        diag,
        "Where this layer acts; chosen vertices come from the Vertices tool",
    );
    // Newly along the surface on a handle's layer: from the handle, as a
    // file without "from" reads.
    if spec.handle.is_some() && region.origin().is_some() && spec.region.origin().is_none() {
        region = from_handle(region);
    }
    let mut sweep = spec.sweep.is_some();
    ui.checkbox(&mut sweep, "fold-free sweep").on_hover_text(
        "Take the layer as a chain of small steps along each control's path, each certified not to fold: \
         no face turns inside out at any phase, and a handle's half phase is a half turn",
    );
    let sweep_changed = sweep != spec.sweep.is_some();
    if poly != spec.options.polynomial
        || phase != spec.phase
        || region != spec.region
        || sweep_changed
    {
        let mut new = spec.clone();
        new.options.polynomial = poly;
        new.phase = phase;
        new.region = region;
        if sweep_changed {
            new.sweep = sweep.then(csrbf::SweepOptions::default);
        }
        commands.push(Command::ReplaceLayer {
            layer: l,
            spec: Box::new(new),
        });
    }
    commands
}

/// Mirror across X, Y or Z (the axis asked for), and, folded away, the
/// three planes: the model's plane of symmetry until one is typed, or the
/// plane through the `first` selected control's start.
fn mirror_ui(ui: &mut egui::Ui, m: &mut Model, first: (usize, usize)) -> Option<usize> {
    let mut asked = None;
    ui.horizontal(|ui| {
        ui.label("Mirror across:");
        for (a, name) in ["X", "Y", "Z"].into_iter().enumerate() {
            if ui
                .button(name)
                .on_hover_text(
                    "Adds the mirror images across the mirror plane normal to this axis (M: X)",
                )
                .clicked()
            {
                asked = Some(a);
            }
        }
        if ui
            .button("Plane")
            .on_hover_text("Adds the mirror images across the plane of any orientation below: the model's own plane of symmetry (a scan turned in its frame), typed, or through three starts")
            .clicked()
        {
            asked = Some(3);
        }
    });
    egui::CollapsingHeader::new("mirror planes").show(ui, |ui| planes_ui(ui, m, first));
    asked
}

/// The mirror planes, one row each: found as the model's plane of
/// symmetry; typed; or through the `first` selected control's start.
fn planes_ui(ui: &mut egui::Ui, m: &mut Model, first: (usize, usize)) {
    let start =
        (m.doc.controls.deformations.get(first.0)).and_then(|s| s.starts.get(first.1).copied());
    let diag = m.doc.diagonal();
    for (a, name) in ["X", "Y", "Z"].into_iter().enumerate() {
        let Some(mut plane) = m.mirror_plane(a) else {
            continue;
        };
        ui.horizontal(|ui| {
            ui.label(format!("{name} ="));
            ui.add(
                egui::DragValue::new(&mut plane)
                    .update_while_editing(false)
                    .speed(diag * 1e-3)
                    .max_decimals(5),
            )
            .on_hover_text("Found as the model's plane of symmetry; drag or type to move it");
            if ui
                .small_button("symmetry")
                .on_hover_text("The model's own plane of symmetry, found from the mesh")
                .clicked()
            {
                m.mirror_planes[a] = None;
                plane = m.mirror_plane(a).unwrap_or(plane);
            }
            if let Some(p) = start
                && ui
                    .small_button("start")
                    .on_hover_text("The plane through the selected control's start")
                    .clicked()
            {
                plane = p[a];
            }
        });
        if plane.is_finite() {
            m.mirror_planes[a] = Some(plane);
        }
    }
    any_plane_ui(ui, m);
}

/// The plane of any orientation: a point and a normal, typed; the model's
/// own plane of symmetry; or the plane through the starts of the first
/// three selected controls.
fn any_plane_ui(ui: &mut egui::Ui, m: &mut Model) {
    let Some(mut plane) = m.mirror_plane_any() else {
        return;
    };
    let speed = m.doc.diagonal() * 1e-3;
    ui.label("Plane (any orientation):");
    let mut point = plane.point;
    let mut normal = plane.normal;
    let typed = vec3_ui(ui, "point", &mut point, speed) | vec3_ui(ui, "normal", &mut normal, 1e-3);
    if typed && let Some(p) = crate::symmetry::Plane::new(point, normal) {
        plane = p;
    }
    ui.horizontal(|ui| {
        if ui
            .small_button("symmetry")
            .on_hover_text(
                "The model's own plane of symmetry, of any orientation, found from the mesh",
            )
            .clicked()
        {
            m.mirror_any = None;
            plane = m.mirror_plane_any().unwrap_or(plane);
        }
        let starts: Vec<DVec3> = (m.doc.selection.0.iter())
            .filter_map(|&(l, i)| m.doc.controls.deformations.get(l)?.starts.get(i).copied())
            .take(3)
            .collect();
        let through = (starts.len() == 3)
            .then(|| crate::symmetry::Plane::through(starts[0], starts[1], starts[2]))
            .flatten();
        if ui
            .add_enabled(through.is_some(), egui::Button::new("3 starts").small())
            .on_hover_text("The plane through the starts of the first three selected controls")
            .on_disabled_hover_text("Select three controls whose starts are not on one line")
            .clicked()
            && let Some(p) = through
        {
            plane = p;
        }
    });
    m.mirror_any = Some(plane);
}

/// The one selected control's start and destination, typed, and Make it
/// a pin: the commands they make.
fn control_ui(ui: &mut egui::Ui, m: &Model, (layer, index): (usize, usize)) -> Vec<Command> {
    let mut commands = Vec::new();
    let Some(spec) = m.doc.controls.deformations.get(layer) else {
        return commands;
    };
    let (Some(&start), Some(&target)) = (spec.starts.get(index), spec.targets.get(index)) else {
        return commands;
    };
    let (mut s, mut t) = (start, target);
    ui.label(format!("Layer {layer}, control {index}"));
    let speed = m.doc.diagonal() * 1e-3;
    let changed_s = vec3_ui(ui, "start", &mut s, speed);
    let changed_t = vec3_ui(ui, "destination", &mut t, speed);
    let d = t - s;
    ui.label(format!(
        "move ({:.4}, {:.4}, {:.4}), length {:.4}",
        d.x,
        d.y,
        d.z,
        d.length()
    ));
    if changed_s {
        commands.push(Command::SetStart {
            layer,
            index,
            start: s,
        });
    }
    if changed_t {
        commands.push(Command::SetTarget {
            layer,
            index,
            target: t,
        });
    }
    if ui
        .button("Make it a pin")
        .on_hover_text("Destination = start: this point stays put")
        .clicked()
    {
        commands.push(Command::SetTarget {
            layer,
            index,
            target: s,
        });
    }
    commands
}

/// The chosen vertices made what the vertex target says (see
/// [`Command::use_vertices`]); a new handle layer becomes the active one.
fn apply_chosen(m: &mut Model, spec: &csrbf_edit::controls::ControlSpec) -> Command {
    let chosen = std::mem::take(&mut m.picked_vertices);
    let command = Command::use_vertices(&m.doc, spec, chosen, m.vertex_target);
    if let Command::InsertLayer { layer, .. } = &command {
        m.doc.active_layer = *layer;
    }
    command
}

/// A handle's pivot: its own (typed, or picked on the surface: `pick`), or
/// the centre of its selection (`centroid`); the new handle when it changed.
fn pivot_ui(
    ui: &mut egui::Ui,
    h: &Handle,
    centroid: Option<DVec3>,
    view_axis: DVec3,
    diagonal: f64,
) -> (Option<Handle>, bool) {
    let own = h.rotate.and_then(|r| r.pivot);
    let mut pick = false;
    let mut new = None;
    ui.horizontal(|ui| {
        ui.label(match own {
            Some(_) => "pivot: its own",
            None => "pivot: the selection's centre",
        });
        if ui
            .small_button("pick on the surface")
            .on_hover_text("The next click on the model puts the pivot there (a shoulder, a hinge)")
            .clicked()
        {
            pick = true;
        }
        if own.is_some() && ui.small_button("selection's centre").clicked() {
            let mut h = h.clone();
            if let Some(r) = h.rotate.as_mut() {
                r.pivot = None;
            }
            new = Some(h);
        }
    });
    let mut p = own.or(centroid).unwrap_or(DVec3::ZERO);
    if vec3_ui(ui, "pivot", &mut p, diagonal * 1e-3) && p.is_finite() {
        let mut h = h.clone();
        let r = h
            .rotate
            .unwrap_or_else(|| csrbf::Rotation::new(view_axis, 0.0));
        h.rotate = Some(r.with_pivot(p));
        new = Some(h);
    }
    (new, pick)
}

/// A handle's angle, axis (`view_axis` until it has one), scale and move;
/// the new handle when any changed.
fn handle_ui(ui: &mut egui::Ui, h: &Handle, view_axis: DVec3, diagonal: f64) -> Option<Handle> {
    let mut new = h.clone();
    let mut rot = h
        .rotate
        .unwrap_or_else(|| csrbf::Rotation::new(view_axis, 0.0));
    let mut angle = rot.angle_deg;
    ui.add(
        egui::Slider::new(&mut angle, -180.0..=180.0)
            .update_while_editing(false)
            .text("angle")
            .suffix("°"),
    )
    .on_hover_text("Turn about the axis through the pivot, degrees");
    let mut ax = rot.axis;
    let axis_changed = vec3_ui(ui, "axis", &mut ax, 0.01);
    let mut scale = h.scale.unwrap_or(1.0);
    ui.add(
        egui::DragValue::new(&mut scale)
            .update_while_editing(false)
            .speed(0.005)
            .range(0.01..=100.0)
            .prefix("scale "),
    );
    let mut t = h.translate.unwrap_or(DVec3::ZERO);
    let t_changed = vec3_ui(ui, "move", &mut t, diagonal * 1e-3);
    if angle != rot.angle_deg || axis_changed {
        rot.angle_deg = angle;
        if ax.length() > 0.0 && ax.is_finite() {
            rot.axis = ax;
        }
        new.rotate = Some(rot);
    }
    if scale != h.scale.unwrap_or(1.0) && scale > 0.0 {
        new.scale = Some(scale);
    }
    if t_changed {
        new.translate = Some(t);
    }
    (new != *h).then_some(new)
}

/// The largest stretch of a face and the faces stretched past the limit
/// (outlined in magenta in the viewport).
fn stretch_ui(ui: &mut egui::Ui, d: &csrbf::Diagnostics) {
    let text = format!(
        "largest stretch {:.2}x{}",
        d.largest_stretch,
        d.largest_stretch_face
            .map(|t| format!(" (triangle {t})"))
            .unwrap_or_default()
    );
    if d.stretched.is_empty() {
        ui.label(format!("{text}; none past {}x", d.stretch_limit));
    } else {
        ui.colored_label(
            egui::Color32::from_rgb(230, 110, 230),
            format!(
                "{text}; {} past {}x (outlined in magenta)",
                count(d.stretched.len(), "face", "faces"),
                d.stretch_limit
            ),
        );
    }
}

/// The Picker's status: the model's size, the solver, the last fit, the
/// frame's time, unsaved.
pub(super) fn pick_status(ui: &mut egui::Ui, m: &Model, frame: &str) {
    let controls: usize = m
        .doc
        .controls
        .deformations
        .iter()
        .map(|s| s.starts.len())
        .sum();
    // A handle's vectors are made on the mesh: counted as the fit used them.
    let made = m.preview.latest().map_or(0, |f| f.controls);
    let handles = m
        .doc
        .controls
        .deformations
        .iter()
        .any(|s| s.handle.is_some());
    let controls = if handles && made > controls {
        format!("{made} controls ({} from handles)", made - controls)
    } else {
        format!("{controls} controls")
    };
    ui.label(format!(
        "{} vertices · {} triangles · {controls}",
        m.doc.mesh.positions.len(),
        m.picking.bvh.triangles().len(),
    ));
    ui.separator();
    let solver = m
        .doc
        .controls
        .deformations
        .get(m.doc.active_layer)
        .map(|s| format!("{:?}", s.options.solver).to_lowercase())
        .unwrap_or_default();
    ui.label(format!("solver {solver}"));
    if let Some(f) = m.preview.latest() {
        ui.separator();
        ui.label(format!(
            "fit {:.1} ms · {} factorisations",
            f.took.as_secs_f64() * 1e3,
            f.factorisations
        ));
    }
    if !m.preview.is_settled() {
        ui.spinner();
        ui.label("fitting…");
    }
    ui.separator();
    ui.label(frame);
    if m.doc.dirty {
        ui.separator();
        ui.label("unsaved");
    }
    ui.separator();
}

pub(super) fn vec3_ui(ui: &mut egui::Ui, label: &str, v: &mut DVec3, speed: f64) -> bool {
    let mut changed = false;
    ui.horizontal(|ui| {
        ui.label(label);
        for k in 0..3 {
            changed |= ui
                .add(
                    egui::DragValue::new(&mut v[k])
                        .update_while_editing(false)
                        .speed(speed)
                        .max_decimals(5)
                        .prefix(["x ", "y ", "z "][k]),
                )
                .changed();
        }
    });
    changed && v.is_finite()
}

/// The numbers of a region of the kind it is (a sphere's centre and
/// radius, a box's corners, a connected region's distance and origin).
fn region_fields_ui(ui: &mut egui::Ui, region: &mut Region, diag: f64) {
    match region {
        Region::Sphere { center, radius } => {
            vec3_ui(ui, "centre", center, diag * 1e-3);
            ui.add(
                egui::DragValue::new(radius)
                    .update_while_editing(false)
                    .speed(diag * 1e-3)
                    .range(diag * 1e-4..=diag * 10.0)
                    .prefix("radius "),
            );
        }
        Region::Box { min, max } => {
            let (mut a, mut b) = (*min, *max);
            vec3_ui(ui, "min", &mut a, diag * 1e-3);
            vec3_ui(ui, "max", &mut b, diag * 1e-3);
            if a.cmple(b).all() {
                *min = a;
                *max = b;
            }
        }
        Region::Vertices(v) => {
            ui.label(format!("{} vertices", v.len()));
        }
        Region::Connected { distance, from } => {
            ui.add(
                egui::DragValue::new(distance)
                    .update_while_editing(false)
                    .speed(diag * 1e-3)
                    .range(0.0..=diag * 10.0)
                    .prefix("distance "),
            )
            .on_hover_text("How far along the surface the edit reaches");
            ui.horizontal(|ui| {
                ui.label("from");
                ui.radio_value(from, csrbf::Origin::Starts, "the moving starts");
                ui.radio_value(from, csrbf::Origin::Handle, "the handle");
            });
        }
        Region::Weights { vertices, .. } => {
            ui.label(format!("{} weighted vertices", vertices.len()));
        }
        _ => {}
    }
}

/// `region` (along the surface, maybe in a falloff) measured from the
/// handle's selection.
fn from_handle(region: Region) -> Region {
    match region {
        Region::Connected { distance, .. } => Region::Connected {
            distance,
            from: csrbf::Origin::Handle,
        },
        Region::Falloff { inner, width } => Region::Falloff {
            inner: Box::new(from_handle(*inner)),
            width,
        },
        other => other,
    }
}

/// A region chooser: the whole mesh, a sphere or a box (with their
/// numbers), one of the mesh's `groups`, or (with `surface`: a
/// deformation's region) the vertices within a distance along the surface,
/// and a falloff at its edge; `bounds` and `diag` (the mesh's
/// box and diagonal) size a new sphere or box and the drag speeds. `label`
/// names the combo box (and is its id within `ui`).
pub(super) fn region_ui(
    ui: &mut egui::Ui,
    label: &str,
    region: &mut Region,
    (lo, hi): (DVec3, DVec3),
    (groups, surface): (&[&str], bool),
    diag: f64,
    hover: &str,
) {
    // A falloff is its region with a blend at the edge: the chooser works on
    // the region inside, the blend is a field of its own.
    let (mut inner, mut width) = match &*region {
        Region::Falloff { inner, width } => ((**inner).clone(), *width),
        other => (other.clone(), 0.0),
    };
    region_kind_ui(
        ui,
        label,
        &mut inner,
        (lo, hi),
        (groups, surface),
        diag,
        hover,
    );
    if surface && inner != Region::All {
        ui.horizontal(|ui| {
            let name = ui.label("falloff");
            ui.add(
                egui::DragValue::new(&mut width)
                    .update_while_editing(false)
                    .speed(diag * 1e-3)
                    .range(0.0..=diag * 10.0),
            )
            .labelled_by(name.id)
            .on_hover_text(
                "A blend this wide at the region's edge: the edit fades out instead of stopping \
                 at a seam that stretches (0: a hard cut)",
            );
        });
    }
    let new = if surface && width > 0.0 && inner != Region::All {
        Region::Falloff {
            inner: Box::new(inner),
            width,
        }
    } else {
        inner
    };
    if new != *region {
        *region = new;
    }
}

/// [`region_ui`]'s chooser and fields for a region that is not a falloff.
fn region_kind_ui(
    ui: &mut egui::Ui,
    label: &str,
    region: &mut Region,
    (lo, hi): (DVec3, DVec3),
    (groups, surface): (&[&str], bool),
    diag: f64,
    hover: &str,
) {
    let kind = match region {
        Region::All => "whole mesh",
        Region::Sphere { .. } => "sphere",
        Region::Box { .. } => "box",
        Region::Vertices(_) => "chosen vertices",
        Region::Group(_) => "part",
        Region::Connected { .. } => "along the surface",
        Region::Weights { .. } => "weights",
        _ => "other",
    };
    egui::ComboBox::from_label(label)
        .selected_text(kind)
        .show_ui(ui, |ui| {
            if ui
                .selectable_label(kind == "whole mesh", "whole mesh")
                .clicked()
            {
                *region = Region::All;
            }
            if ui.selectable_label(kind == "sphere", "sphere").clicked() {
                *region = Region::Sphere {
                    center: (lo + hi) * 0.5,
                    radius: diag * 0.25,
                };
            }
            if ui.selectable_label(kind == "box", "box").clicked() {
                *region = Region::Box { min: lo, max: hi };
            }
            if surface
                && ui
                .selectable_label(kind == "along the surface", "along the surface")
                .on_hover_text(
                    "Connected only: the vertices within a distance along the mesh of the moving \
                     starts (or the handle): a limb's edit leaves the torso beside it alone",
                )
                .clicked()
            {
                *region = Region::Connected {
                    distance: diag * 0.15,
                    from: csrbf::Origin::default(),
                };
            }
            for &name in groups {
                if ui
                    .selectable_label(
                        matches!(region, Region::Group(g) if g == name),
                        format!("part {name}"),
                    )
                    .clicked()
                {
                    *region = Region::Group(name.to_string());
                }
            }
        })
        .response
        .on_hover_text(hover);
    region_fields_ui(ui, region, diag);
}
