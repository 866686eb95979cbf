//! What the shell does with scenes: new, open, restore, save, objects
//! added, the way to the Picker and back, exports on a thread, the
//! Composer's keys and its recovery file; and the Composer's state as tests
//! and tools read it.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use csrbf::glam::Vec3;
use csrbf_anim::{Camera, Frame, ObjectFile, Scene, SceneFile};
use eframe::egui;

use super::composer::{Composer, ExportError, ExportJob, KeyRef, Mode};
use super::files::{Purpose, SceneRecovery};
use super::request::reason;
use super::studio::{Pending, StudioApp};
use crate::compose::{Playback, SceneDoc, SceneEdit, Track, world_centre};
use crate::gizmo::{RING_PIXELS, axis_rings};

impl StudioApp {
    /// The rectangle the scene's camera sees inside `rect` (its aspect), or
    /// `rect` when not looking through it.
    pub fn scene_gate(&self, rect: egui::Rect) -> egui::Rect {
        self.composer.as_ref().map_or(rect, |c| c.gate(rect))
    }

    /// The camera the Composer's viewport draws with, its size in physical
    /// pixels and its rectangle on screen.
    pub fn compose_camera(&self) -> Option<(Camera, [u32; 2], egui::Rect)> {
        Some(self.composer.as_ref()?.camera(self.screen.viewport))
    }
    /// Applies a scene edit (see `Composer::edit`); false if it was
    /// refused, with the reason shown.
    pub fn scene_edit(&mut self, edit: SceneEdit) -> bool {
        self.scene_edit_merging(edit, None)
    }

    pub(super) fn scene_edit_merging(
        &mut self,
        edit: SceneEdit,
        tag: Option<&'static str>,
    ) -> bool {
        let done = self
            .composer
            .as_mut()
            .is_some_and(|c| c.edit_merging(edit, tag));
        self.serve();
        done
    }

    /// Runs `f` on the Composer, if a scene is open, then does what it asked.
    pub(super) fn with_composer(&mut self, f: impl FnOnce(&mut Composer)) {
        if let Some(c) = self.composer.as_mut() {
            f(c);
        }
        self.serve();
    }

    /// The rate frames were drawn at while playing, over the last second.
    pub fn playback_rate(&self) -> f64 {
        self.composer.as_ref().map_or(0.0, Composer::playback_rate)
    }

    /// Starts or stops playing.
    pub fn toggle_play(&mut self) {
        self.with_composer(Composer::toggle_play);
    }

    /// Plays (tests: `advance` then moves by the wall clock from now).
    pub fn play(&mut self) {
        self.with_composer(Composer::play);
    }

    /// Moves the playhead (snapped to the scene's frames) and stops playing.
    pub fn set_playhead(&mut self, time: f64) {
        self.with_composer(|c| c.set_playhead(time));
    }

    /// Adds a key on `track` of `object` at the playhead with the value the
    /// scene has there now.
    pub fn add_key(&mut self, object: usize, track: Track) {
        self.with_composer(|c| c.add_key(object, track));
    }

    /// Deletes the selected key.
    pub fn delete_key(&mut self) {
        self.with_composer(Composer::delete_key);
    }

    /// Copies the selected key to the playhead.
    pub fn copy_key(&mut self) {
        self.with_composer(Composer::copy_key);
    }

    /// Copies the selected key (Ctrl+C), to the system clipboard too.
    pub fn copy_key_to_clipboard(&mut self, ctx: &egui::Context) {
        self.with_composer(|c| c.copy_key_to_clipboard(ctx));
    }

    /// Pastes the copied key at the playhead (Ctrl+V).
    pub fn paste_key(&mut self) {
        self.with_composer(Composer::paste_key);
    }

    pub(super) fn scene_undo(&mut self, redo: bool) {
        self.with_composer(|c| c.undo(redo));
    }

    pub(super) fn reload_scene(&mut self) {
        self.with_composer(Composer::reload);
    }

    pub(super) fn tick(&mut self, ctx: &egui::Context, cpu: Option<f32>) {
        self.with_composer(|c| c.tick(ctx, cpu));
    }
    /// The Composer's scene document, if one is open (for tests and tools).
    pub fn scene_doc(&self) -> Option<&SceneDoc> {
        self.composer.as_ref().map(|c| &c.doc)
    }

    /// The loaded scene the Composer shows.
    pub fn loaded_scene(&self) -> Option<&Scene> {
        self.composer.as_ref()?.loaded.scene.as_deref()
    }

    /// The frame shown (the scene at the playhead).
    pub fn shown_frame(&self) -> Option<&Frame> {
        self.composer.as_ref().map(|c| &*c.loaded.frame)
    }

    /// Which program the window is.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// The playback state.
    pub fn playback(&self) -> Option<&Playback> {
        self.composer.as_ref().map(|c| &c.playback)
    }

    /// The selected key.
    pub fn selected_key(&self) -> Option<KeyRef> {
        self.composer.as_ref()?.key
    }

    /// Where the timeline's ruler is on screen (time 0 at its left edge,
    /// the scene's duration at its right): what a test clicks to scrub.
    pub fn timeline_ruler(&self) -> Option<egui::Rect> {
        self.composer
            .as_ref()
            .map(|c| c.ruler)
            .filter(|r| r.is_positive())
    }

    /// Selects a key (as a click on it in the timeline does).
    pub fn select_key(&mut self, key: KeyRef) {
        if let Some(c) = self.composer.as_mut()
            && c.doc.key_times(key.0, key.1).len() > key.2
        {
            c.key = Some(key);
            c.selected = Some(key.0);
        }
    }

    /// The selected orientation key's gizmo as drawn: for X, Y and Z, the
    /// axis and its ring's points on screen (what a test or a tool aims at).
    pub fn gizmo_rings(&self) -> Vec<(Vec3, Vec<egui::Pos2>)> {
        let Some(c) = self.composer.as_ref() else {
            return Vec::new();
        };
        let (Some((cam, size, gate)), Some(scene)) =
            (self.compose_camera(), c.loaded.scene.as_ref())
        else {
            return Vec::new();
        };
        let Some((o, Track::Orientation, i)) = c.key else {
            return Vec::new();
        };
        let Some(centre) = c
            .doc
            .key_times(o, Track::Orientation)
            .get(i)
            .and_then(|&t| world_centre(scene, o, t))
        else {
            return Vec::new();
        };
        let ppp = size[0] as f32 / gate.width();
        axis_rings(centre, &cam, size, RING_PIXELS * ppp)
            .into_iter()
            .map(|(axis, pts, _)| {
                let screen = pts
                    .iter()
                    .filter_map(|p| cam.project(*p, size))
                    .map(|(q, _)| egui::pos2(gate.min.x + q.x / ppp, gate.min.y + q.y / ppp))
                    .collect();
                (axis, screen)
            })
            .collect()
    }

    /// Where the timeline row of `track` of `object` is on screen.
    pub fn timeline_row(&self, object: usize, track: Track) -> Option<egui::Rect> {
        self.composer
            .as_ref()?
            .rows
            .iter()
            .find(|(k, _)| *k == (object, track))
            .map(|(_, r)| *r)
    }

    /// Scene edits that can be undone.
    pub fn scene_undo_steps(&self) -> usize {
        self.composer.as_ref().map_or(0, |c| c.history.undo_steps())
    }

    /// Whether an export is running.
    pub fn exporting(&self) -> bool {
        self.composer.as_ref().is_some_and(|c| c.export.is_some())
    }

    pub(super) fn composer_samples(&self) -> u32 {
        if self.screen.software { 1 } else { 4 }
    }

    /// Switches to the Composer with a new, empty scene (after asking about
    /// unsaved changes to the scene open).
    pub fn new_scene(&mut self) {
        if self.composer.as_ref().is_some_and(|c| c.doc.dirty) {
            self.shell.pending = Some(Pending::NewScene);
            return;
        }
        self.composer = Some(Composer::new(SceneDoc::empty(), self.composer_samples()));
        self.mode = Mode::Compose;
        *self.status_mut() = "New scene: add a mesh (Scene > Add object, or drop one here)".into();
    }

    /// Opens a scene file in the Composer. A file the CLI would refuse (or
    /// whose meshes, control files or textures cannot be read) leaves the
    /// open scene as it was and says why, in the CLI's words.
    pub fn open_scene(&mut self, path: &Path) {
        if self.composer.as_ref().is_some_and(|c| c.doc.dirty) {
            self.shell.pending = Some(Pending::OpenScene(path.to_path_buf()));
            return;
        }
        self.open_scene_now(path);
    }

    pub(super) fn open_scene_now(&mut self, path: &Path) {
        let started = Instant::now();
        let doc = match SceneDoc::open(path) {
            Ok(d) => d,
            Err(e) => return self.show_error("Cannot open the scene", reason(&e)),
        };
        self.adopt_scene(doc, started, &format!("Opened {}", path.display()));
        if self.composer.as_ref().is_some_and(|c| c.doc.path.is_some()) {
            super::files::remember(self.shell.state.as_deref(), path);
            self.shell.recent = super::files::recent_files(self.shell.state.as_deref());
        }
    }

    /// Makes `doc` the Composer's document if its scene loads.
    pub(super) fn adopt_scene(&mut self, doc: SceneDoc, started: Instant, note: &str) {
        let mut c = Composer::new(doc, self.composer_samples());
        let file = c.doc.file.clone();
        let scene = match c.prepare(&file, true) {
            Ok(s) => s,
            Err(e) => return self.show_error("Cannot open the scene", reason(&e)),
        };
        c.install(scene, true);
        let warnings = c
            .loaded
            .scene
            .as_ref()
            .map(|s| s.warnings.join("; "))
            .unwrap_or_default();
        self.composer = Some(c);
        self.mode = Mode::Compose;
        self.picker.gesture = super::picker::Gesture::None;
        *self.status_mut() = format!(
            "{note} in {:.0} ms{}",
            started.elapsed().as_secs_f64() * 1e3,
            if warnings.is_empty() {
                String::new()
            } else {
                format!(" ({warnings})")
            }
        );
        eprintln!("csrbf-studio: {}", self.status());
    }

    /// Reopens the scene kept in the recovery file.
    pub fn restore_scene(&mut self, r: &SceneRecovery) {
        let file = match SceneFile::parse(&r.scene) {
            Ok(f) => f,
            Err(e) => return self.show_error("Cannot restore the scene", reason(&e)),
        };
        let mut doc = SceneDoc::new(file, r.path.clone());
        doc.dirty = true;
        self.adopt_scene(doc, Instant::now(), "Restored the unsaved scene");
        if let Some(c) = self.composer.as_mut() {
            c.doc.dirty = true;
        }
    }

    /// Saves the scene where it came from, else asks where.
    pub fn save_scene(&mut self) {
        match self.composer.as_ref().and_then(|c| c.doc.path.clone()) {
            Some(p) => self.save_scene_to(&p),
            None => self.ask(Purpose::SaveScene),
        }
    }

    /// Saves the scene at `path` in the CLI's format, its paths relative to
    /// that folder; whole or not at all. A scene the CLI would refuse is
    /// not written.
    pub fn save_scene_to(&mut self, path: &Path) {
        let Some(c) = self.composer.as_mut() else {
            return;
        };
        if let Err(e) = c.doc.saveable() {
            return self.show_error("Cannot save the scene", reason(&e));
        }
        let rebased = c.doc.rebased(path);
        match csrbf_mesh::write_atomic(path, rebased.to_json().as_bytes()) {
            Ok(()) => {
                c.doc.file = rebased;
                c.doc.path = Some(path.to_path_buf());
                c.history.mark_saved(&mut c.doc);
                // Paths changed form, not meaning: the cache keys stay valid.
                if let Some(s) = c.loaded.scene.as_mut() {
                    let s = Arc::make_mut(s);
                    s.file = c.doc.file.clone();
                    s.dir = c.doc.dir();
                }
                SceneRecovery::clear(self.shell.state.as_deref());
                *self.status_mut() = format!("Saved {}", path.display());
                super::files::remember(self.shell.state.as_deref(), path);
                self.shell.recent = super::files::recent_files(self.shell.state.as_deref());
            }
            Err(e) => self.show_error("Cannot save the scene", reason(&e)),
        }
    }

    /// Adds a mesh as a new object (one part, light grey), at the origin.
    pub fn add_object(&mut self, path: &Path) {
        if self.composer.is_none() {
            self.new_scene();
        }
        let Some(c) = self.composer.as_ref() else {
            return;
        };
        let stem = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "object".into());
        let mut name = stem.clone();
        let mut k = 2;
        while c.doc.file.objects.iter().any(|o| o.name == name) {
            name = format!("{stem} {k}");
            k += 1;
        }
        let object = ObjectFile {
            name: name.clone(),
            mesh: c.doc.name_of(path),
            scale: 1.0,
            rotation: None,
            parts: vec![crate::compose::whole_part()],
            trajectory: Vec::new(),
            orientation: Vec::new(),
            interpolation: Default::default(),
            contact: None,
        };
        let first = c.doc.file.objects.is_empty();
        if self.scene_edit(SceneEdit::AddObject(Box::new(object))) {
            let Some(c) = self.composer.as_mut() else {
                return;
            };
            c.selected = Some(c.doc.file.objects.len() - 1);
            if first {
                // The scene's camera starts framing its first object.
                if let Some((lo, hi)) = c.bounds() {
                    let [w, h] = c.doc.file.size;
                    let cam = Camera::framing(
                        -Camera::preset_direction(csrbf_anim::ViewPreset::Front, Vec3::Y),
                        Vec3::Y,
                        lo,
                        hi,
                        35.0,
                        w as f32 / h as f32,
                        1.0,
                    );
                    let f = |v: Vec3| v.as_dvec3().to_array();
                    let mut camera = c.doc.file.camera.clone();
                    camera.eye = f(cam.eye);
                    camera.target = f(cam.target);
                    camera.up = [0.0, 1.0, 0.0];
                    camera.fov = 35.0;
                    self.scene_edit_merging(SceneEdit::SetCamera(camera), Some("add object"));
                }
                if let Some(c) = self.composer.as_mut() {
                    c.framed = false;
                }
            }
            *self.status_mut() = format!("Added {} as {name:?}", path.display());
        }
    }

    /// Opens deformation `deformation` of part `part` of `object` in the
    /// Picker: its mesh and its control file. File > Back to the Composer
    /// returns (reloading the scene when the control file was saved).
    pub fn edit_in_picker(&mut self, object: usize, part: usize, deformation: usize) {
        let Some(c) = self.composer.as_ref() else {
            return;
        };
        let Some(o) = c.doc.file.objects.get(object) else {
            return;
        };
        let Some(d) = o
            .parts
            .get(part)
            .and_then(|p| p.deformations.get(deformation))
        else {
            return;
        };
        let mesh = c.doc.resolve(&o.mesh);
        let controls = c.doc.resolve(&d.controls);
        let scaled = (o.scale != 1.0 || o.rotation.is_some()).then(|| {
            format!(
                "The Picker shows {} at its own size and axes (the scene scales it by {} and turns it by its base rotation); control files are in the mesh's own units and axes",
                o.name, o.scale
            )
        });
        let ctx = self.screen.ctx.clone();
        if self.picker.model.as_ref().is_some_and(|m| m.doc.dirty) {
            self.shell.pending = Some(Pending::EditInPicker(object, part, deformation));
            return;
        }
        self.open_mesh_now(&ctx, &mesh);
        if self.picker.model.is_some() {
            self.open_controls(&controls);
            self.mode = Mode::Pick;
            if let Some(note) = scaled {
                self.picker.status = note;
            }
        }
    }

    /// Back from the Picker to the Composer: the scene is loaded again so a
    /// saved control file shows. Unsaved Picker changes are asked about.
    pub fn back_to_composer(&mut self) {
        if self.picker.model.as_ref().is_some_and(|m| m.doc.dirty) {
            self.shell.pending = Some(Pending::BackToComposer);
            return;
        }
        if self.composer.is_some() {
            self.mode = Mode::Compose;
            self.reload_scene();
        }
    }

    /// Starts writing a movie of the scene (MP4, GIF, or a folder of PNG
    /// frames) on a thread through `csrbf_render::render_movie`, the loop
    /// of `csrbf animate`; a progress bar with Cancel shows meanwhile.
    pub fn export_movie(&mut self, path: &Path) {
        let Some(scene) = self.export_scene("movie") else {
            return;
        };
        let format = match csrbf_render::movie::MovieFormat::of(path) {
            Ok(f) => f,
            Err(e) => return self.show_error("Cannot export the movie", reason(&e)),
        };
        let path = path.to_path_buf();
        self.spawn_export("Movie", path.clone(), move |progress| {
            let options = csrbf_render::movie::MovieOptions::of(&scene);
            let written = csrbf_render::movie::render_movie(&scene, &path, options, progress)?;
            Ok(format!(
                "Wrote {} ({} frames{})",
                written.path.display(),
                written.frames,
                if format == csrbf_render::movie::MovieFormat::Frames {
                    ", PNG"
                } else {
                    ""
                }
            ))
        });
    }

    /// Writes the scene as glTF (`.glb`, or `.gltf` with the buffer
    /// embedded) through `csrbf_anim::export_gltf`, as `csrbf export`.
    pub fn export_gltf(&mut self, path: &Path) {
        let Some(scene) = self.export_scene("glTF") else {
            return;
        };
        let glb = !path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("gltf"));
        let path = path.to_path_buf();
        self.spawn_export("glTF", path.clone(), move |progress| {
            progress(0, 1);
            let bytes = csrbf_anim::export_gltf(&scene, glb);
            if !progress(1, 1) {
                return Err(ExportError::Cancelled);
            }
            csrbf_mesh::write_atomic(&path, &bytes)?;
            let notes = csrbf_anim::export_notes(&scene);
            Ok(format!(
                "Wrote {} ({} KB){}",
                path.display(),
                bytes.len() / 1024,
                if notes.is_empty() {
                    String::new()
                } else {
                    format!("; {}", notes.join("; "))
                }
            ))
        });
    }

    pub(super) fn export_scene(&mut self, what: &str) -> Option<Arc<Scene>> {
        let c = self.composer.as_ref()?;
        if c.export.is_some() {
            *self.status_mut() = "An export is running".into();
            return None;
        }
        match (&c.loaded.scene, c.doc.saveable()) {
            (Some(s), Ok(())) => Some(s.clone()),
            (_, Err(e)) => {
                self.show_error(&format!("Cannot export the {what}"), reason(&e));
                None
            }
            (None, Ok(())) => {
                let p = c
                    .loaded
                    .problem
                    .clone()
                    .unwrap_or_else(|| "the scene is empty".into());
                self.show_error(&format!("Cannot export the {what}"), p);
                None
            }
        }
    }

    pub(super) fn spawn_export(
        &mut self,
        what: &str,
        path: PathBuf,
        work: impl FnOnce(&mut dyn FnMut(usize, usize) -> bool) -> Result<String, ExportError>
        + Send
        + 'static,
    ) {
        let Some(c) = self.composer.as_mut() else {
            return;
        };
        let done = Arc::new(AtomicUsize::new(0));
        let total = Arc::new(AtomicUsize::new(1));
        let cancel = Arc::new(AtomicBool::new(false));
        let result = Arc::new(Mutex::new(None));
        let (d, t, k, r) = (done.clone(), total.clone(), cancel.clone(), result.clone());
        let wake = self.screen.ctx.clone();
        let spawned = std::thread::Builder::new()
            .name("csrbf-export".into())
            .spawn(move || {
                // No repaint per frame: on a software rasteriser a repaint of
                // the window costs as much as a frame of the movie (see
                // `export_ui` for how often the progress bar looks).
                let mut progress = |a: usize, b: usize| {
                    d.store(a, Ordering::Relaxed);
                    t.store(b.max(1), Ordering::Relaxed);
                    !k.load(Ordering::Relaxed)
                };
                let out = work(&mut progress);
                if let Ok(mut slot) = r.lock() {
                    *slot = Some(out);
                }
                wake.request_repaint();
            });
        if let Err(e) = spawned {
            return self.show_error("Cannot export", reason(&e));
        }
        c.export = Some(ExportJob {
            what: what.into(),
            path,
            done,
            total,
            cancel,
            result,
            started: Instant::now(),
        });
    }

    /// Waits for the running export to end (tests); false if it did not
    /// within `limit`.
    pub fn finish_export(&mut self, limit: Duration) -> bool {
        let until = Instant::now() + limit;
        while self.exporting() {
            self.poll_export();
            if Instant::now() > until {
                return false;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        true
    }

    pub(super) fn poll_export(&mut self) {
        let Some(job) = self.composer.as_ref().and_then(|c| c.export.as_ref()) else {
            return;
        };
        let out = job.result.lock().ok().and_then(|mut r| r.take());
        let Some(out) = out else {
            return;
        };
        let what = job.what.clone();
        let secs = job.started.elapsed().as_secs_f64();
        let cancelled = job.cancel.load(Ordering::Relaxed);
        let path = job.path.clone();
        if let Some(c) = self.composer.as_mut() {
            c.export = None;
        }
        match out {
            Ok(note) => {
                *self.status_mut() = format!("{note} in {secs:.2} s");
                // In the log too: the export figures of issue 9 come from it.
                eprintln!("csrbf-studio: {}", self.status());
            }
            Err(_) if cancelled => {
                *self.status_mut() = format!(
                    "{what} export cancelled; nothing was left at {}",
                    path.display()
                )
            }
            Err(e) => self.show_error(&format!("Cannot export the {what}"), reason(&e)),
        }
    }

    /// The export's progress bar and Cancel button.
    pub(super) fn export_ui(&mut self, ctx: &egui::Context) {
        self.poll_export();
        let Some(job) = self.composer.as_ref().and_then(|c| c.export.as_ref()) else {
            return;
        };
        let done = job.done.load(Ordering::Relaxed);
        let total = job.total.load(Ordering::Relaxed).max(1);
        let mut cancel = false;
        egui::Modal::new(egui::Id::unique("export progress")).show(ctx, |ui| {
            ui.set_min_width(360.0);
            ui.heading(format!("Exporting the {}", job.what));
            ui.label(job.path.display().to_string());
            ui.add(
                egui::ProgressBar::new(done as f32 / total as f32)
                    .text(format!("frame {done} of {total}")),
            );
            // How long it will take, from the frames done: a long export
            // (90,001 frames at 3 a second) says so while it can be stopped.
            if let Some(left) = time_left(done, total, job.started.elapsed()) {
                ui.label(left);
            }
            if job.cancel.load(Ordering::Relaxed) {
                ui.label("Cancelling…");
            } else if ui.button("Cancel").clicked() {
                cancel = true;
            }
        });
        if cancel {
            job.cancel.store(true, Ordering::Relaxed);
        }
        // A repaint of the whole window on a software rasteriser costs
        // about 18 ms of both cores at 1280x800 (45 ms while egui filled
        // the panels): every 2 s keeps the export within a few % of
        // `csrbf animate`; every second cost 3-8 %.
        ctx.request_repaint_after(if self.screen.software {
            Duration::from_secs(2)
        } else {
            Duration::from_millis(250)
        });
    }

    /// The Composer's keys.
    pub(super) fn compose_keys(&mut self, ctx: &egui::Context) {
        // Keys typed into a field (a name, a number) are the field's.
        if ctx.egui_wants_keyboard_input() {
            return;
        }
        use egui::{Key, KeyboardShortcut, Modifiers};
        let shortcut = |m: Modifiers, k: Key| {
            ctx.input_mut(|i| i.consume_shortcut(&KeyboardShortcut::new(m, k)))
        };
        if let Some(redo) = super::studio::undo_keys(ctx) {
            self.scene_undo(redo);
        }
        if shortcut(Modifiers::COMMAND | Modifiers::SHIFT, Key::S) {
            self.ask(Purpose::SaveScene);
        }
        if shortcut(Modifiers::COMMAND, Key::S) {
            self.save_scene();
        }
        if shortcut(Modifiers::COMMAND, Key::O) {
            self.ask(Purpose::OpenScene);
        }
        if shortcut(Modifiers::COMMAND | Modifiers::SHIFT, Key::E) {
            self.ask(Purpose::ExportGltf);
        }
        if shortcut(Modifiers::COMMAND, Key::E) {
            self.ask(Purpose::ExportMovie);
        }
        if shortcut(Modifiers::COMMAND, Key::D) {
            self.copy_key();
        }
        // A window sends Ctrl+C and Ctrl+V as Copy and Paste events (Paste
        // only when the clipboard holds text: copying puts the key there).
        let (copy, paste) = ctx.input(|i| {
            (
                i.events.iter().any(|e| matches!(e, egui::Event::Copy)),
                i.events.iter().any(|e| matches!(e, egui::Event::Paste(_))),
            )
        });
        if copy || shortcut(Modifiers::COMMAND, Key::C) {
            self.copy_key_to_clipboard(ctx);
        }
        if paste || shortcut(Modifiers::COMMAND, Key::V) {
            self.paste_key();
        }
        self.compose_plain_keys(ctx);
    }

    /// The Composer's keys without modifiers: playback, keys, the view.
    pub(super) fn compose_plain_keys(&mut self, ctx: &egui::Context) {
        use egui::{Key, Modifiers};
        let plain = |k: Key| ctx.input_mut(|i| i.consume_key(Modifiers::NONE, k));
        if plain(Key::Space) {
            self.toggle_play();
        }
        let step = |app: &mut StudioApp, n: i64| {
            if let Some(c) = app.composer.as_mut() {
                c.playback.pause();
                c.playback.step(&mut c.doc, n);
            }
        };
        if plain(Key::ArrowRight) {
            step(self, 1);
        }
        if plain(Key::ArrowLeft) {
            step(self, -1);
        }
        if plain(Key::Home) {
            self.set_playhead(0.0);
        }
        if plain(Key::End) {
            let d = self.scene_doc().map_or(0.0, |d| d.file.duration);
            self.set_playhead(d);
        }
        if plain(Key::Delete) || plain(Key::Backspace) {
            self.delete_key();
        }
        if plain(Key::K)
            && let Some(o) = self.composer.as_ref().and_then(|c| c.selected)
        {
            self.add_key(o, Track::Position);
        }
        if plain(Key::C)
            && let Some(c) = self.composer.as_mut()
        {
            c.through_camera = !c.through_camera;
        }
        for (k, axis) in [(Key::X, 0), (Key::Y, 1), (Key::Z, 2)] {
            if plain(k) {
                self.picker.axis = if self.picker.axis == Some(axis) {
                    None
                } else {
                    Some(axis)
                };
            }
        }
        if plain(Key::F)
            && let Some(c) = self.composer.as_mut()
        {
            c.frame_everything();
        }
    }

    /// Writes the recovery file while the scene has unsaved changes.
    pub(super) fn scene_recovery(&mut self, ctx: &egui::Context) {
        let Some(c) = self.composer.as_mut() else {
            return;
        };
        if !c.doc.dirty {
            return;
        }
        if c.recovery_at
            .is_none_or(|t| t.elapsed() > Duration::from_secs(1))
        {
            c.recovery_at = Some(Instant::now());
            let text = c.doc.to_text();
            if c.recovered_text != text {
                SceneRecovery {
                    path: c.doc.path.clone(),
                    scene: text.clone(),
                }
                .store(self.shell.state.as_deref());
                c.recovered_text = text;
            }
        }
        ctx.request_repaint_after(Duration::from_secs(1));
    }
}

/// "about 8 h 20 min left (3.0 frames a second)" once a frame is done and
/// a second has passed, else None.
pub(super) fn time_left(done: usize, total: usize, elapsed: Duration) -> Option<String> {
    let secs = elapsed.as_secs_f64();
    if done == 0 || secs < 1.0 || done >= total {
        return None;
    }
    let rate = done as f64 / secs;
    let left = (total - done) as f64 / rate;
    let (h, m, s) = (
        (left / 3600.0).floor(),
        ((left % 3600.0) / 60.0).floor(),
        (left % 60.0).round(),
    );
    let when = if h >= 1.0 {
        format!("{h:.0} h {m:.0} min")
    } else if m >= 1.0 {
        format!("{m:.0} min {s:.0} s")
    } else {
        format!("{s:.0} s")
    };
    Some(format!("about {when} left ({rate:.1} frames a second)"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_time_left_is_said_in_hours_minutes_or_seconds() {
        // Issue 42: 90,001 frames at 3 a second.
        let t = time_left(30, 90_001, Duration::from_secs(10)).expect("an estimate");
        assert_eq!(t, "about 8 h 19 min left (3.0 frames a second)");
        assert_eq!(
            time_left(10, 130, Duration::from_secs(2)).as_deref(),
            Some("about 24 s left (5.0 frames a second)")
        );
        assert_eq!(
            time_left(1, 200, Duration::from_secs(1)).as_deref(),
            Some("about 3 min 19 s left (1.0 frames a second)")
        );
        assert_eq!(time_left(0, 10, Duration::from_secs(5)), None);
        assert_eq!(time_left(5, 10, Duration::from_millis(500)), None);
        assert_eq!(time_left(10, 10, Duration::from_secs(5)), None);
    }
}
