//! The shell: the window's one `eframe::App`. It owns the file dialogs,
//! messages, questions about unsaved changes, recovery offers, recent files
//! and the title, and switches between the rooms it holds (the Picker, the
//! Composer), drawing each one's panels and viewport and doing what their
//! outboxes ask ([`Request`]). It owns no algorithm: picking, fitting,
//! diagnostics and handles are library calls in the rooms' editor cores.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use csrbf::glam::Vec3;
use eframe::egui;

use super::composer::{self, Mode};
use super::files::{
    self, Choice, FileDialog, MESH_ENDINGS, Purpose, Recovery, SceneRecovery, VOLUME_ENDINGS,
    state_dir,
};
use super::gpu::{self, Screen};
use super::picker::{Gesture, Picker, Tool, ViewSettings};
use super::request::Request;
use super::{help, panel, timeline};
use crate::{Document, PreviewFrame};

/// What the command line asked to open.
#[derive(Clone, Debug, Default)]
pub struct Args {
    /// A mesh.
    pub mesh: Option<PathBuf>,
    /// A control file on it.
    pub controls: Option<PathBuf>,
}

/// Something waiting for the person's answer about unsaved changes.
#[derive(Clone, Debug)]
pub(super) enum Pending {
    Open(PathBuf),
    Close,
    NewScene,
    OpenScene(PathBuf),
    BackToComposer,
    /// Object, part, deformation.
    EditInPicker(usize, usize, usize),
}

/// The shell around the rooms: file dialogs, messages, questions about
/// unsaved changes, recovery offers, recent files, the title, the status
/// line.
pub(super) struct Shell {
    pub(super) dialog: Option<FileDialog>,
    pub(super) message: Option<(String, String)>,
    pub(super) pending: Option<Pending>,
    pub(super) recovery_offer: Option<Recovery>,
    pub(super) scene_recovery_offer: Option<SceneRecovery>,
    pub(super) recent: Vec<PathBuf>,
    /// Where recent files and the recovery file are kept.
    pub(super) state: Option<PathBuf>,
    /// The window's title as last set.
    pub(super) title: String,
    pub(super) allow_close: bool,
    /// The window was asked to close while an export runs: ask what to do.
    pub(super) close_during_export: bool,
    /// Quit once the running export has finished.
    pub(super) quit_after_export: bool,
    /// The keys-and-mouse window is open (F1, ?, Help).
    pub(super) help: bool,
    /// What "Save" in the unsaved-changes question was asked before, when
    /// the save went to a file dialog: done once that save succeeds.
    pub(super) after_save: Option<Pending>,
}

/// `csrbf-studio`: the shell, the Picker, the Composer (when a scene is
/// open) and the screen they share.
pub struct StudioApp {
    pub(super) shell: Shell,
    pub(super) screen: Screen,
    pub(super) picker: Picker,
    /// Picker or Composer.
    pub(super) mode: Mode,
    /// The Composer's scene, when one is open.
    pub(super) composer: Option<composer::Composer>,
}

impl StudioApp {
    /// The app, opening what `args` names (errors are shown in a dialog),
    /// keeping its recent files and recovery file in [`state_dir`].
    pub fn new(cc: &eframe::CreationContext<'_>, args: Args) -> StudioApp {
        StudioApp::with_state_dir(cc, args, state_dir())
    }

    /// [`StudioApp::new`] with its own state folder (None: keep nothing).
    pub fn with_state_dir(
        cc: &eframe::CreationContext<'_>,
        args: Args,
        state: Option<PathBuf>,
    ) -> StudioApp {
        let gpu = cc.wgpu_render_state.clone();
        if let Some(state) = &gpu {
            gpu::install(state);
        }
        let software = gpu
            .as_ref()
            .is_none_or(|g| g.adapter.get_info().device_type == eframe::wgpu::DeviceType::Cpu);
        let mut app = StudioApp {
            shell: Shell {
                dialog: None,
                message: None,
                pending: None,
                recovery_offer: None,
                scene_recovery_offer: None,
                recent: files::recent_files(state.as_deref()),
                state,
                title: String::new(),
                allow_close: false,
                close_during_export: false,
                quit_after_export: false,
                help: false,
                after_save: None,
            },
            screen: Screen {
                gpu,
                frame_time: Duration::ZERO,
                frame_start: None,
                frame_interval: None,
                recent_frames: Vec::new(),
                waited: Duration::ZERO,
                trace: std::env::var_os("CSRBF_STUDIO_TRACE").is_some(),
                viewport: ([1, 1], egui::Rect::NOTHING, 1.0),
                software,
                ctx: cc.egui_ctx.clone(),
            },
            picker: Picker {
                model: None,
                tool: Tool::Place,
                axis: None,
                view: ViewSettings::default(),
                gesture: Gesture::None,
                handle_mode: crate::gizmo::HandleMode::default(),
                pick_pivot: false,
                status: "Open a mesh: File > Open mesh (Ctrl+O), or drop a file here".into(),
            },
            mode: Mode::Pick,
            composer: None,
        };
        let ctx = cc.egui_ctx.clone();
        if let Some(scene) = args.mesh.as_ref().filter(|p| is_scene(p)) {
            app.open_scene_now(scene);
        } else if let Some(mesh) = &args.mesh {
            app.open_mesh(&ctx, mesh);
            if let Some(c) = &args.controls
                && app.picker.model.is_some()
            {
                app.open_controls(c);
            }
        } else if let Some(r) = SceneRecovery::load(app.shell.state.as_deref()) {
            app.shell.scene_recovery_offer = Some(r);
        } else if let Some(r) = Recovery::load(app.shell.state.as_deref()) {
            app.shell.recovery_offer = Some(r);
        }
        app
    }

    /// The document, if a mesh is open (for tests and tools).
    pub fn document(&self) -> Option<&Document> {
        self.picker.model.as_ref().map(|m| &m.doc)
    }

    /// Steps that can be undone.
    pub fn undo_steps(&self) -> usize {
        self.picker
            .model
            .as_ref()
            .map_or(0, |m| m.history.undo_steps())
    }

    /// The positions shown in the viewport.
    pub fn shown_positions(&self) -> Option<&[Vec3]> {
        self.picker.model.as_ref().map(|m| &m.shown[..])
    }

    /// The newest preview frame.
    pub fn preview_frame(&self) -> Option<&PreviewFrame> {
        self.picker.model.as_ref().and_then(|m| m.preview.latest())
    }

    /// Waits until the preview shows the document as it stands (tests,
    /// saving); false if it did not within `limit`.
    pub fn settle(&mut self, limit: Duration) -> bool {
        let Some(m) = self.picker.model.as_mut() else {
            return true;
        };
        let ok = m.preview.wait(limit);
        m.take_frame();
        ok
    }

    /// The camera of the viewport as last drawn, with its size in physical
    /// pixels and where its top-left corner is in points, and the points per
    /// pixel: what a test needs to aim at the model.
    pub fn viewport_camera(&self) -> Option<(csrbf_anim::Camera, [u32; 2], egui::Pos2, f32)> {
        let m = self.picker.model.as_ref()?;
        let (size, rect, ppp) = self.screen.viewport;
        Some((m.orbit.camera(), size, rect.min, ppp))
    }

    /// The vertices chosen with the Vertices tool (box or brush).
    pub fn chosen_vertices(&self) -> &[u32] {
        self.picker
            .model
            .as_ref()
            .map_or(&[], |m| &m.picked_vertices)
    }

    /// The dialog message shown, if any (title, text).
    pub fn message(&self) -> Option<&(String, String)> {
        self.shell.message.as_ref()
    }

    /// The line in the status bar.
    pub fn status(&self) -> &str {
        match (self.mode, self.composer.as_ref()) {
            (Mode::Compose, Some(c)) => &c.status,
            _ => &self.picker.status,
        }
    }

    /// The status line of the room shown.
    pub(super) fn status_mut(&mut self) -> &mut String {
        match (self.mode, self.composer.as_mut()) {
            (Mode::Compose, Some(c)) => &mut c.status,
            _ => &mut self.picker.status,
        }
    }

    /// Where the control file was opened from or saved to.
    pub fn controls_path(&self) -> Option<&Path> {
        self.picker.model.as_ref()?.controls_path.as_deref()
    }

    /// Does what the rooms asked for (see [`Request`]), including what
    /// that asks in turn.
    pub(super) fn serve(&mut self) {
        loop {
            let requests = self
                .composer
                .as_mut()
                .map(|c| c.outbox.take())
                .unwrap_or_default();
            if requests.is_empty() {
                return;
            }
            for r in requests {
                self.serve_one(r);
            }
        }
    }

    pub(super) fn serve_one(&mut self, request: Request) {
        match request {
            Request::Ask(purpose) => self.ask(purpose),
            Request::Error { title, text } => self.show_error(&title, text),
            Request::EditInPicker(o, p, d) => self.edit_in_picker(o, p, d),
        }
    }

    /// Opens `path` by what it is: a scene, a mesh or a control file.
    pub(super) fn open_path(&mut self, path: &Path) {
        let is_mesh = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .is_some_and(|e| {
                MESH_ENDINGS.contains(&e.as_str()) || VOLUME_ENDINGS.contains(&e.as_str())
            });
        if is_scene(path) {
            self.open_scene(path);
        } else if is_mesh {
            let ctx = self.screen.ctx.clone();
            self.open_mesh(&ctx, path);
        } else {
            self.open_controls(path);
        }
    }

    pub(super) fn show_error(&mut self, title: &str, text: impl Into<String>) {
        let text = text.into();
        *self.status_mut() = format!("{title}: {text}");
        self.shell.message = Some((title.into(), text));
    }

    pub(super) fn ask(&mut self, purpose: Purpose) {
        let near = self.picker.model.as_ref().map(|m| match purpose {
            Purpose::SaveControls | Purpose::OpenControls => m
                .controls_path
                .clone()
                .unwrap_or_else(|| m.doc.mesh_path.with_extension("controls.json")),
            // A volume mesh exported as one keeps its cells.
            Purpose::ExportMesh if m.volume.is_some() => {
                let ext = m.doc.mesh_path.extension().unwrap_or_default();
                m.doc
                    .mesh_path
                    .with_extension(format!("deformed.{}", ext.to_string_lossy()))
            }
            Purpose::ExportMesh => m.doc.mesh_path.with_extension("deformed.obj"),
            Purpose::ExportFitted => m.doc.mesh_path.with_extension("csrbf"),
            _ => m.doc.mesh_path.clone(),
        });
        let scene_path = self.composer.as_ref().and_then(|c| c.doc.path.clone());
        let near = match purpose {
            Purpose::SaveScene => {
                Some(scene_path.unwrap_or_else(|| PathBuf::from("untitled.scene.json")))
            }
            Purpose::ExportMovie => Some(
                scene_path
                    .map(|p| movie_name(&p, "mp4"))
                    .unwrap_or_else(|| PathBuf::from("movie.mp4")),
            ),
            Purpose::ExportGltf => Some(
                scene_path
                    .map(|p| movie_name(&p, "glb"))
                    .unwrap_or_else(|| PathBuf::from("scene.glb")),
            ),
            Purpose::OpenScene | Purpose::AddObject | Purpose::Texture | Purpose::AddControls => {
                scene_path.or(near)
            }
            _ => near,
        };
        self.shell.dialog = Some(FileDialog::new(purpose, near.as_deref()));
    }

    pub(super) fn handle_keys(&mut self, ctx: &egui::Context) {
        if ctx.egui_wants_keyboard_input() {
            return;
        }
        use egui::{Key, KeyboardShortcut, Modifiers};
        let shortcut = |m: Modifiers, k: Key| {
            ctx.input_mut(|i| i.consume_shortcut(&KeyboardShortcut::new(m, k)))
        };
        match undo_keys(ctx) {
            Some(true) => self.picker.undo(true),
            Some(false) => self.picker.undo(false),
            None => {}
        }
        if shortcut(Modifiers::COMMAND | Modifiers::SHIFT, Key::S) {
            self.ask(Purpose::SaveControls);
        }
        if shortcut(Modifiers::COMMAND, Key::S) {
            self.save();
        }
        if shortcut(Modifiers::COMMAND, Key::O) {
            self.ask(Purpose::OpenMesh);
        }
        if shortcut(Modifiers::COMMAND, Key::D) {
            self.picker.duplicate();
        }
        if shortcut(Modifiers::COMMAND, Key::A) {
            self.picker.select_all();
        }
        let plain = |k: Key| ctx.input_mut(|i| i.consume_key(Modifiers::NONE, k));
        if plain(Key::Delete) || plain(Key::Backspace) {
            self.picker.delete_selected();
        }
        if plain(Key::F) {
            self.picker.frame_view(true, self.screen.viewport.0);
        }
        if ctx.input_mut(|i| i.consume_key(Modifiers::SHIFT, Key::F)) {
            self.picker.frame_view(false, self.screen.viewport.0);
        }
        for (k, axis) in [(Key::X, 0), (Key::Y, 1), (Key::Z, 2)] {
            if plain(k) {
                self.picker.set_axis(if self.picker.axis == Some(axis) {
                    None
                } else {
                    Some(axis)
                });
            }
        }
        if plain(Key::M) {
            self.picker.mirror(0);
        }
        if plain(Key::P) {
            self.picker.tool = Tool::Place;
        }
        if plain(Key::S) {
            self.picker.tool = Tool::Select;
        }
        if plain(Key::V) {
            self.picker.tool = Tool::Vertices;
        }
        if plain(Key::Escape) {
            if let Some(m) = self.picker.model.as_mut() {
                m.doc.selection.0.clear();
            }
            self.picker.gesture = Gesture::None;
            self.picker.view.stamp = None;
            self.picker.pick_pivot = false;
        }
    }

    /// The open file dialog, message, unsaved-changes question and
    /// recovery offers, each a modal of its own.
    pub(super) fn dialogs(&mut self, ctx: &egui::Context) {
        self.file_dialog(ctx);
        self.message_modal(ctx);
        self.unsaved_modal(ctx);
        self.recovery_offers(ctx);
    }

    pub(super) fn file_dialog(&mut self, ctx: &egui::Context) {
        let Some(d) = self.shell.dialog.as_mut() else {
            return;
        };
        let Some(choice) = d.show(ctx) else {
            return;
        };
        let purpose = d.purpose;
        self.shell.dialog = None;
        // This frame was drawn with the dialog open: draw the result.
        ctx.request_repaint();
        let after_save = self.shell.after_save.take();
        let Choice::File(p) = choice else {
            return;
        };
        match purpose {
            Purpose::OpenMesh => self.open_mesh(ctx, &p),
            Purpose::OpenControls => self.open_controls(&p),
            Purpose::SaveControls => self.save_to(&p),
            Purpose::ExportMesh => self.export_mesh(&p),
            Purpose::ExportFitted => self.export_fitted(&p),
            Purpose::OpenScene => self.open_scene(&p),
            Purpose::SaveScene => self.save_scene_to(&p),
            Purpose::AddObject => self.add_object(&p),
            Purpose::Texture => self.with_composer(|c| c.set_texture(&p)),
            Purpose::AddControls => self.with_composer(|c| c.add_deformation(&p)),
            Purpose::ExportMovie => self.export_movie(&p),
            Purpose::ExportGltf => self.export_gltf(&p),
        }
        // What the unsaved-changes question held back, once saved.
        if let Some(pending) = after_save {
            let scene = purpose == Purpose::SaveScene;
            if matches!(purpose, Purpose::SaveControls | Purpose::SaveScene) && self.saved(scene) {
                self.resume(ctx, pending);
            }
        }
    }

    pub(super) fn message_modal(&mut self, ctx: &egui::Context) {
        let Some((title, text)) = self.shell.message.clone() else {
            return;
        };
        let mut close = false;
        egui::Modal::new(egui::Id::unique("message")).show(ctx, |ui| {
            ui.set_max_width(520.0);
            ui.heading(&title);
            ui.label(&text);
            // A button only: the Enter that confirmed a file dialog is
            // still in this frame's input.
            if ui.button("OK").clicked() {
                close = true;
            }
        });
        if close {
            self.shell.message = None;
        }
    }

    /// Save, Discard or Cancel before what is pending (open, close, ...).
    pub(super) fn unsaved_modal(&mut self, ctx: &egui::Context) {
        let Some(pending) = self.shell.pending.clone() else {
            return;
        };
        let scene = matches!(pending, Pending::NewScene | Pending::OpenScene(_))
            || (matches!(pending, Pending::Close)
                && self.composer.as_ref().is_some_and(|c| c.doc.dirty));
        match unsaved_question(ctx, scene) {
            Some(Answer::Save) => {
                self.shell.pending = None;
                if scene {
                    self.save_scene();
                } else {
                    self.save();
                }
                if self.saved(scene) {
                    self.resume(ctx, pending);
                } else if self.shell.dialog.is_some() {
                    // A file never saved: the dialog asks where first.
                    self.shell.after_save = Some(pending);
                }
            }
            Some(Answer::Discard) => {
                self.shell.pending = None;
                self.discard(scene);
                self.resume(ctx, pending);
            }
            Some(Answer::Cancel) => self.shell.pending = None,
            None => {}
        }
    }

    /// Whether the scene (`scene`) or the controls have no unsaved changes.
    fn saved(&self, scene: bool) -> bool {
        if scene {
            self.composer.as_ref().is_some_and(|c| !c.doc.dirty)
        } else {
            self.picker.model.as_ref().is_some_and(|m| !m.doc.dirty)
        }
    }

    /// Forgets the unsaved changes of the scene (`scene`) or the controls.
    pub(super) fn discard(&mut self, scene: bool) {
        if scene {
            if let Some(c) = self.composer.as_mut() {
                c.doc.dirty = false;
            }
            SceneRecovery::clear(self.shell.state.as_deref());
        } else {
            if let Some(m) = self.picker.model.as_mut() {
                m.doc.dirty = false;
            }
            Recovery::clear(self.shell.state.as_deref());
        }
    }

    /// What the recovery files kept from a session that closed unsaved.
    pub(super) fn recovery_offers(&mut self, ctx: &egui::Context) {
        if let Some(r) = self.shell.scene_recovery_offer.clone() {
            let text = format!(
                "The studio closed with unsaved changes to the scene {}.",
                r.path
                    .as_ref()
                    .map_or("(never saved)".into(), |p| p.display().to_string())
            );
            match restore_question(ctx, "Restore the last scene?", &text) {
                Some(true) => {
                    self.shell.scene_recovery_offer = None;
                    self.restore_scene(&r);
                }
                Some(false) => {
                    self.shell.scene_recovery_offer = None;
                    SceneRecovery::clear(self.shell.state.as_deref());
                }
                None => {}
            }
        }
        if let Some(r) = self.shell.recovery_offer.clone() {
            let text = format!(
                "The studio closed with unsaved changes to the controls of {}.",
                r.mesh.display()
            );
            match restore_question(ctx, "Restore the last session?", &text) {
                Some(true) => {
                    self.shell.recovery_offer = None;
                    self.restore(ctx, &r);
                }
                Some(false) => {
                    self.shell.recovery_offer = None;
                    Recovery::clear(self.shell.state.as_deref());
                }
                None => {}
            }
        }
    }

    pub(super) fn resume(&mut self, ctx: &egui::Context, pending: Pending) {
        match pending {
            Pending::Open(p) => self.open_mesh_now(ctx, &p),
            Pending::Close => {
                // Both documents are asked about, one after the other.
                let other = if self.composer.as_ref().is_some_and(|c| c.doc.dirty) {
                    true
                } else {
                    self.picker.model.as_ref().is_some_and(|m| m.doc.dirty)
                };
                if other {
                    self.shell.pending = Some(Pending::Close);
                } else {
                    self.shell.allow_close = true;
                    ctx.send_viewport_cmd(egui::ViewportCommand::Close);
                }
            }
            Pending::NewScene => {
                if let Some(c) = self.composer.as_mut() {
                    c.doc.dirty = false;
                }
                self.new_scene();
            }
            Pending::OpenScene(p) => self.open_scene_now(&p),
            Pending::BackToComposer => self.back_to_composer(),
            Pending::EditInPicker(o, p, d) => self.edit_in_picker(o, p, d),
        }
    }

    pub(super) fn menu(&mut self, ui: &mut egui::Ui) {
        if self.mode == Mode::Compose {
            return self.compose_menu(ui);
        }
        egui::MenuBar::new().ui(ui, |ui| {
            self.mode_switch(ui);
            ui.menu_button("File", |ui| self.file_menu(ui));
            ui.menu_button("Edit", |ui| self.edit_menu(ui));
            ui.menu_button("View", |ui| {
                self.picker.view_menu(ui, self.screen.viewport.0)
            });
            ui.menu_button("Help", |ui| help::menu(ui, &mut self.shell.help));
        });
    }

    /// Picker | Composer.
    pub(super) fn mode_switch(&mut self, ui: &mut egui::Ui) {
        let has_scene = self.composer.is_some();
        if ui
            .selectable_label(self.mode == Mode::Pick, "Picker")
            .on_hover_text("Control vectors on one mesh")
            .clicked()
            && self.mode != Mode::Pick
        {
            self.mode = Mode::Pick;
        }
        if ui
            .selectable_label(self.mode == Mode::Compose, "Composer")
            .on_hover_text("Scenes: objects, keys, timing, playback, export")
            .clicked()
            && self.mode != Mode::Compose
        {
            if has_scene {
                self.back_to_composer();
            } else {
                self.new_scene();
            }
        }
        ui.separator();
    }

    pub(super) fn compose_menu(&mut self, ui: &mut egui::Ui) {
        egui::MenuBar::new().ui(ui, |ui| {
            self.mode_switch(ui);
            ui.menu_button("File", |ui| self.compose_file_menu(ui));
            ui.menu_button("Edit", |ui| self.compose_edit_menu(ui));
            ui.menu_button("Scene", |ui| {
                if ui.button("Add object…").clicked() {
                    self.ask(Purpose::AddObject);
                }
                if ui.button("Play / pause  Space").clicked() {
                    self.toggle_play();
                }
            });
            ui.menu_button("View", |ui| {
                if let Some(c) = self.composer.as_mut() {
                    ui.checkbox(&mut c.through_camera, "Look through the scene camera  C");
                    if ui
                        .button("Frame everything  F")
                        .on_hover_text("The objects over the whole scene, and the scene camera")
                        .clicked()
                    {
                        c.frame_everything();
                    }
                }
                ui.checkbox(&mut self.picker.view.flat, "Flat shading");
                ui.checkbox(&mut self.picker.view.wireframe, "Wireframe");
            });
            ui.menu_button("Help", |ui| help::menu(ui, &mut self.shell.help));
        });
    }

    /// The Composer's File menu.
    pub(super) fn compose_file_menu(&mut self, ui: &mut egui::Ui) {
        if ui.button("New scene").clicked() {
            self.new_scene();
        }
        if ui.button("Open scene…  Ctrl+O").clicked() {
            self.ask(Purpose::OpenScene);
        }
        if let Some(p) = files::recent_menu(ui, &self.shell.recent) {
            if is_scene(&p) {
                self.open_scene(&p);
            } else {
                self.add_object(&p);
            }
        }
        ui.separator();
        if ui.button("Save scene  Ctrl+S").clicked() {
            self.save_scene();
        }
        if ui.button("Save scene as…  Ctrl+Shift+S").clicked() {
            self.ask(Purpose::SaveScene);
        }
        ui.separator();
        if ui.button("Export movie…  Ctrl+E").clicked() {
            self.ask(Purpose::ExportMovie);
        }
        if ui.button("Export glTF…  Ctrl+Shift+E").clicked() {
            self.ask(Purpose::ExportGltf);
        }
        ui.separator();
        if ui.button("Quit").clicked() {
            ui.ctx().send_viewport_cmd(egui::ViewportCommand::Close);
        }
    }

    /// The Composer's Edit menu.
    pub(super) fn compose_edit_menu(&mut self, ui: &mut egui::Ui) {
        if ui.button("Undo  Ctrl+Z").clicked() {
            self.scene_undo(false);
        }
        if ui.button("Redo  Ctrl+Shift+Z").clicked() {
            self.scene_undo(true);
        }
        ui.separator();
        if ui.button("Delete key  Del").clicked() {
            self.delete_key();
        }
        if ui.button("Copy key to the playhead  Ctrl+D").clicked() {
            self.copy_key();
        }
        if ui.button("Copy key  Ctrl+C").clicked() {
            let ctx = ui.ctx().clone();
            self.copy_key_to_clipboard(&ctx);
        }
        if ui
            .button("Paste key  Ctrl+V")
            .on_hover_text("At the playhead, onto the selected object")
            .clicked()
        {
            self.paste_key();
        }
    }

    /// The Picker's File menu.
    pub(super) fn file_menu(&mut self, ui: &mut egui::Ui) {
        if self.composer.is_some() && ui.button("Back to the Composer").clicked() {
            self.back_to_composer();
        }
        if ui.button("New scene (Composer)").clicked() {
            self.new_scene();
        }
        if ui.button("Open scene…").clicked() {
            self.ask(Purpose::OpenScene);
        }
        ui.separator();
        if ui.button("Open mesh…  Ctrl+O").clicked() {
            self.ask(Purpose::OpenMesh);
        }
        let has = self.picker.model.is_some();
        if ui
            .add_enabled(has, egui::Button::new("Open control file…"))
            .clicked()
        {
            self.ask(Purpose::OpenControls);
        }
        if let Some(p) = files::recent_menu(ui, &self.shell.recent) {
            self.open_path(&p);
        }
        ui.separator();
        if ui
            .add_enabled(has, egui::Button::new("Save controls  Ctrl+S"))
            .clicked()
        {
            self.save();
        }
        if ui
            .add_enabled(has, egui::Button::new("Save controls as…  Ctrl+Shift+S"))
            .clicked()
        {
            self.ask(Purpose::SaveControls);
        }
        if ui
            .add_enabled(has, egui::Button::new("Export deformed mesh…"))
            .clicked()
        {
            self.ask(Purpose::ExportMesh);
        }
        if ui
            .add_enabled(has, egui::Button::new("Export fitted .csrbf…"))
            .clicked()
        {
            self.ask(Purpose::ExportFitted);
        }
        ui.separator();
        if ui.button("Quit").clicked() {
            ui.ctx().send_viewport_cmd(egui::ViewportCommand::Close);
        }
    }

    /// The Picker's Edit menu.
    pub(super) fn edit_menu(&mut self, ui: &mut egui::Ui) {
        if ui.button("Undo  Ctrl+Z").clicked() {
            self.picker.undo(false);
        }
        if ui.button("Redo  Ctrl+Shift+Z").clicked() {
            self.picker.undo(true);
        }
        ui.separator();
        if ui.button("Delete selected  Del").clicked() {
            self.picker.delete_selected();
        }
        if ui.button("Duplicate (stamp)  Ctrl+D").clicked() {
            self.picker.duplicate();
        }
        if ui.button("Select all in layer  Ctrl+A").clicked() {
            self.picker.select_all();
        }
        for (axis, name) in ["X  (M)", "Y", "Z"].into_iter().enumerate() {
            if ui.button(format!("Mirror across {name}")).clicked() {
                self.picker.mirror(axis);
            }
        }
    }
}

impl StudioApp {
    /// "csrbf studio: NAME" with a * while it has unsaved changes (the open
    /// scene in the Composer, the control file or mesh in the Picker).
    pub(super) fn set_title(&mut self, ctx: &egui::Context) {
        let name = |p: &Path| {
            p.file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default()
        };
        let (what, dirty) = match self.mode {
            Mode::Compose => match self.composer.as_ref() {
                Some(c) => (
                    c.doc.path.as_deref().map_or("new scene".into(), name),
                    c.doc.dirty,
                ),
                None => (String::new(), false),
            },
            Mode::Pick => match self.picker.model.as_ref() {
                Some(m) => (
                    m.controls_path
                        .as_deref()
                        .map_or_else(|| name(&m.doc.mesh_path), name),
                    m.doc.dirty,
                ),
                None => (String::new(), false),
            },
        };
        let title = if what.is_empty() {
            "csrbf studio".to_string()
        } else {
            format!("csrbf studio: {what}{}", if dirty { " *" } else { "" })
        };
        if title != self.shell.title {
            ctx.send_viewport_cmd(egui::ViewportCommand::Title(title.clone()));
            self.shell.title = title;
        }
    }
}

/// Ctrl+Z (Some(false): undo) or Ctrl+Shift+Z / Ctrl+Y (Some(true): redo),
/// consumed; the same keys in the Picker and the Composer.
pub(super) fn undo_keys(ctx: &egui::Context) -> Option<bool> {
    use egui::{Key, KeyboardShortcut, Modifiers};
    let shortcut =
        |m: Modifiers, k: Key| ctx.input_mut(|i| i.consume_shortcut(&KeyboardShortcut::new(m, k)));
    if shortcut(Modifiers::COMMAND | Modifiers::SHIFT, Key::Z)
        || shortcut(Modifiers::COMMAND, Key::Y)
    {
        Some(true)
    } else if shortcut(Modifiers::COMMAND, Key::Z) {
        Some(false)
    } else {
        None
    }
}

/// The answer to "Quit during the export?".
#[derive(Clone, Copy)]
enum ExportClose {
    Finish,
    Cancel,
    Stay,
}

/// The answer to "Unsaved changes".
enum Answer {
    Save,
    Discard,
    Cancel,
}

/// Asks what to do with the unsaved changes of the scene (`scene`) or the
/// control file; None while unanswered.
fn unsaved_question(ctx: &egui::Context, scene: bool) -> Option<Answer> {
    let mut answer = None;
    egui::Modal::new(egui::Id::unique("unsaved")).show(ctx, |ui| {
        ui.heading("Unsaved changes");
        ui.label(if scene {
            "The scene has changes that are not saved."
        } else {
            "The control file has changes that are not saved."
        });
        ui.horizontal(|ui| {
            if ui.button("Save").clicked() {
                answer = Some(Answer::Save);
            }
            if ui.button("Discard").clicked() {
                answer = Some(Answer::Discard);
            }
            if ui.button("Cancel").clicked() {
                answer = Some(Answer::Cancel);
            }
        });
    });
    answer
}

/// Asks whether to restore what a recovery file kept: Some(true) to
/// restore, Some(false) to discard, None while unanswered.
fn restore_question(ctx: &egui::Context, heading: &str, text: &str) -> Option<bool> {
    let mut answer = None;
    egui::Modal::new(egui::Id::unique(heading)).show(ctx, |ui| {
        ui.heading(heading);
        ui.label(text);
        ui.horizontal(|ui| {
            if ui.button("Restore").clicked() {
                answer = Some(true);
            }
            if ui.button("Discard").clicked() {
                answer = Some(false);
            }
        });
    });
    answer
}

/// `movie.EXT` beside a scene file: `face.scene.json` gives `face.EXT`.
pub(super) fn movie_name(scene: &Path, ext: &str) -> PathBuf {
    let name = scene
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let stem = name
        .strip_suffix(".scene.json")
        .or_else(|| name.strip_suffix(".json"))
        .unwrap_or("scene");
    scene.with_file_name(format!("{stem}.{ext}"))
}

/// Whether a path names a scene file (`*.scene.json`).
pub(super) fn is_scene(path: &Path) -> bool {
    path.file_name()
        .and_then(|n| n.to_str())
        .is_some_and(|n| n.to_ascii_lowercase().ends_with(".scene.json"))
}

/// A side, top or bottom panel's frame without its fill: the window is
/// cleared to the panel colour instead ([`StudioApp::clear_color`]), which
/// costs nothing, where egui's own fill is shaded pixel by pixel. On a
/// software rasteriser (lavapipe, 2 cores) a fill of a whole 1280x800
/// window took 30 ms a frame; the panels' fills were half of what kept the
/// Composer's playback under 30 fps.
fn bare_panel(ui: &egui::Ui) -> egui::Frame {
    egui::Frame::side_top_panel(ui.style()).fill(egui::Color32::TRANSPARENT)
}

/// The side panel on the right (the Picker's parameters, the Composer's
/// scene), resizable.
fn side_panel(id: &'static str, ui: &egui::Ui) -> egui::Panel {
    egui::Panel::right(id)
        .frame(bare_panel(ui))
        .resizable(true)
        .default_size(360.0)
        .size_range(280.0..=560.0)
}

impl StudioApp {
    pub(super) fn status_bar(&mut self, ui: &mut egui::Ui) {
        let frame = self.screen.frame_text();
        let rate = self.playback_rate();
        ui.horizontal(|ui| {
            if self.mode == Mode::Compose
                && let Some(c) = self.composer.as_ref()
            {
                timeline::compose_status(ui, c, rate, &frame);
            } else if let Some(m) = self.picker.model.as_ref() {
                panel::pick_status(ui, m, &frame);
            }
            if let Some(e) = self.screen.gpu.as_ref().and_then(gpu::last_error) {
                ui.colored_label(egui::Color32::LIGHT_RED, format!("GPU: {e}"));
            }
            // A long message is cut at the window's edge with an ellipsis
            // and shown whole on hover, never lost.
            let status = self.status().to_owned();
            ui.add(egui::Label::new(status.as_str()).truncate())
                .on_hover_text(status);
        });
    }

    /// The window's close button: while an export runs, ask what to do with
    /// it; with unsaved changes, ask about them; else close.
    fn close_requested(&mut self, ctx: &egui::Context) {
        if self.shell.quit_after_export && !self.exporting() {
            self.shell.quit_after_export = false;
            ctx.send_viewport_cmd(egui::ViewportCommand::Close);
        }
        if !ctx.input(|i| i.viewport().close_requested()) || self.shell.allow_close {
            return;
        }
        let dirty = self.picker.model.as_ref().is_some_and(|m| m.doc.dirty)
            || self.composer.as_ref().is_some_and(|c| c.doc.dirty);
        if self.exporting() {
            ctx.send_viewport_cmd(egui::ViewportCommand::CancelClose);
            self.shell.close_during_export = true;
        } else if dirty {
            ctx.send_viewport_cmd(egui::ViewportCommand::CancelClose);
            self.shell.pending = Some(Pending::Close);
        }
    }

    /// "Quit during the export?": finish it then quit, cancel it and quit
    /// (its temporary file removed), or keep working.
    pub(super) fn close_during_export_modal(&mut self, ctx: &egui::Context) {
        if !self.shell.close_during_export {
            return;
        }
        let Some(job) = self.composer.as_ref().and_then(|c| c.export.as_ref()) else {
            self.shell.close_during_export = false;
            return;
        };
        let text = format!(
            "The {} is being written to {}.",
            job.what.to_lowercase(),
            job.path.display()
        );
        let mut answer = None;
        egui::Modal::new(egui::Id::unique("close during export")).show(ctx, |ui| {
            ui.heading("Quit during the export?");
            ui.label(text);
            ui.horizontal(|ui| {
                for (label, a) in [
                    ("Finish, then quit", ExportClose::Finish),
                    ("Cancel it and quit", ExportClose::Cancel),
                    ("Keep working", ExportClose::Stay),
                ] {
                    if ui.button(label).clicked() {
                        answer = Some(a);
                    }
                }
            });
        });
        let Some(answer) = answer else {
            return;
        };
        self.shell.close_during_export = false;
        match answer {
            ExportClose::Finish => self.shell.quit_after_export = true,
            ExportClose::Cancel => {
                job.cancel.store(true, std::sync::atomic::Ordering::Relaxed);
                self.finish_export(Duration::from_secs(30));
                ctx.send_viewport_cmd(egui::ViewportCommand::Close);
            }
            ExportClose::Stay => {}
        }
    }

    /// Files dropped on the window: each opened by what it is and the mode.
    pub(super) fn dropped_files(&mut self, ctx: &egui::Context) {
        let dropped: Vec<PathBuf> = ctx.input(|i| {
            i.raw
                .dropped_files
                .iter()
                .map(|f| f.path().to_path_buf())
                .filter(|p| !p.as_os_str().is_empty())
                .collect()
        });
        for p in dropped {
            let ext = p
                .extension()
                .and_then(|e| e.to_str())
                .map(str::to_ascii_lowercase)
                .unwrap_or_default();
            let compose = self.mode == Mode::Compose;
            if is_scene(&p) {
                self.open_scene(&p);
            } else if MESH_ENDINGS.contains(&ext.as_str()) && compose {
                self.add_object(&p);
            } else if VOLUME_ENDINGS.contains(&ext.as_str()) && compose {
                self.show_error(
                    "Cannot add the dropped file",
                    format!(
                        "{}: a scene's objects are surface meshes ({}); open a volume mesh in the Picker",
                        p.display(),
                        MESH_ENDINGS.join(", ")
                    ),
                );
            } else if MESH_ENDINGS.contains(&ext.as_str()) || VOLUME_ENDINGS.contains(&ext.as_str())
            {
                self.open_mesh(ctx, &p);
            } else if ext == "json" && compose {
                self.with_composer(|c| c.add_deformation(&p));
            } else if ext == "json" {
                self.open_controls(&p);
            } else {
                self.show_error(
                    "Cannot open the dropped file",
                    format!(
                        "{}: the studio reads meshes ({}), volume meshes ({}), control files (.json) and scenes (.scene.json)",
                        p.display(),
                        MESH_ENDINGS.join(", "),
                        VOLUME_ENDINGS.join(", ")
                    ),
                );
            }
        }
    }

    /// The Composer's frame: the timeline, the scene panel, the viewport,
    /// dialogs, export progress and the recovery file.
    pub(super) fn compose_frame(&mut self, ui: &mut egui::Ui) {
        let ctx = ui.ctx().clone();
        egui::Panel::bottom("timeline")
            .frame(bare_panel(ui))
            .resizable(true)
            .default_size(230.0)
            .size_range(120.0..=600.0)
            .show(ui, |ui| match self.composer.as_mut() {
                Some(c) => c.timeline_ui(ui),
                None => {
                    ui.label("No scene");
                }
            });
        self.serve();
        side_panel("scene", ui).show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| match self.composer.as_mut() {
                Some(c) => c.scene_panel(ui),
                None => {
                    ui.label("No scene: File > New scene or Open scene");
                }
            });
        });
        egui::CentralPanel::default()
            .frame(egui::Frame::NONE)
            .show(ui, |ui| {
                if let Some(c) = self.composer.as_mut() {
                    let axis = self.picker.axis_vector();
                    c.viewport_ui(ui, &mut self.screen, axis, &self.picker.view);
                }
            });
        self.serve();
        self.dialogs(&ctx);
        self.export_ui(&ctx);
        self.close_during_export_modal(&ctx);
        self.scene_recovery(&ctx);
    }

    /// The Picker's frame: the side panel, the viewport, dialogs and the
    /// recovery file.
    pub(super) fn pick_frame(&mut self, ui: &mut egui::Ui) {
        let ctx = ui.ctx().clone();
        side_panel("parameters", ui).show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| self.picker.side_panel(ui));
        });
        egui::CentralPanel::default()
            .frame(egui::Frame::NONE)
            .show(ui, |ui| self.picker.viewport_ui(ui, &mut self.screen));
        self.dialogs(&ctx);
        self.write_recovery();
        if self.picker.model.as_ref().is_some_and(|m| m.doc.dirty) {
            // Come back to write the recovery file even if nothing moves.
            ctx.request_repaint_after(Duration::from_secs(1));
        }
        if self
            .picker
            .model
            .as_ref()
            .is_some_and(|m| !m.preview.is_settled())
        {
            ctx.request_repaint_after(Duration::from_millis(30));
        }
    }
}

impl eframe::App for StudioApp {
    /// The panels' colour: they are drawn without a fill of their own, which a
    /// software rasteriser would shade pixel by pixel.
    fn clear_color(&self, visuals: &egui::Visuals) -> [f32; 4] {
        visuals.panel_fill.to_normalized_gamma_f32()
    }

    fn ui(&mut self, ui: &mut egui::Ui, frame: &mut eframe::Frame) {
        let started = Instant::now();
        self.screen.frame_begins(started);
        let ctx = ui.ctx().clone();
        self.set_title(&ctx);
        if let Some(m) = self.picker.model.as_mut() {
            m.take_frame();
        }
        self.dropped_files(&ctx);
        self.close_requested(&ctx);
        let exporting = self.exporting();
        if self.shell.dialog.is_none()
            && self.shell.message.is_none()
            && self.shell.pending.is_none()
            && !exporting
            // An open menu takes the keys (Esc closes it).
            && !egui::Popup::is_any_open(&ctx)
        {
            if !ctx.egui_wants_keyboard_input() && help::toggled(&ctx) {
                self.shell.help = !self.shell.help;
            }
            // Esc closes the help window first (before the room's Esc).
            if self.shell.help
                && ctx.input_mut(|i| i.consume_key(egui::Modifiers::NONE, egui::Key::Escape))
            {
                self.shell.help = false;
            }
            if self.mode == Mode::Compose {
                self.compose_keys(&ctx);
            } else {
                self.handle_keys(&ctx);
            }
        }
        if self.mode == Mode::Compose {
            self.tick(&ctx, frame.info().cpu_usage);
            if !ctx.input(|i| i.pointer.any_down())
                && let Some(c) = self.composer.as_mut()
            {
                c.history.end_merge();
            }
        }
        egui::Panel::top("menu")
            .frame(bare_panel(ui))
            .show(ui, |ui| self.menu(ui));
        egui::Panel::bottom("status")
            .frame(bare_panel(ui))
            .show(ui, |ui| self.status_bar(ui));
        if self.mode == Mode::Compose {
            self.compose_frame(ui);
        } else {
            self.pick_frame(ui);
        }
        let room = match self.mode {
            Mode::Pick => help::Room::Picker,
            Mode::Compose => help::Room::Composer,
        };
        help::window(&ctx, room, &mut self.shell.help);
        self.screen.frame_time = started.elapsed();
        let worker = match self.mode {
            Mode::Pick => self.picker.model.as_ref(),
            Mode::Compose => None,
        }
        .and_then(|m| m.preview.latest())
        .map(|f| f.took);
        self.screen.trace(worker);
        self.screen.waited = Duration::ZERO;
    }

    fn on_exit(&mut self) {
        // Never leave an export's temporary file: the export is cancelled
        // and its thread removes what it wrote.
        if self.exporting() {
            if let Some(job) = self.composer.as_ref().and_then(|c| c.export.as_ref()) {
                job.cancel.store(true, std::sync::atomic::Ordering::Relaxed);
            }
            self.finish_export(Duration::from_secs(30));
        }
        if self.picker.model.as_ref().is_some_and(|m| !m.doc.dirty) {
            Recovery::clear(self.shell.state.as_deref());
        }
        if self.composer.as_ref().is_some_and(|c| !c.doc.dirty) {
            SceneRecovery::clear(self.shell.state.as_deref());
        }
    }
}
