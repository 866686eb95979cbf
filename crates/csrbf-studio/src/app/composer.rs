//! The Composer: the scene around the Picker's deformations. One scene
//! document ([`SceneDoc`], edited only through [`SceneEdit`]s with undo),
//! the loaded [`Scene`] it describes (key edits retime it in microseconds;
//! other edits load it again from cached meshes), the frame at the
//! playhead, playback in real time, and export through the same library
//! calls as `csrbf animate` and `csrbf export`.
//!
//! The timeline and the side panel are in `timeline.rs` and `scene_panel.rs`;
//! this file keeps the state, the viewport and the files.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicUsize};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use csrbf::glam::{DVec3, Vec3};
use csrbf_anim::{AnimError, Camera, Scene, SceneFile};
use eframe::egui;

use super::gpu;
use super::key_drag::KeyDrag;
use super::request::{Outbox, reason};
use crate::Orbit;
use crate::compose::{
    KeyValue, Loaded, Playback, SceneDoc, SceneEdit, SceneHistory, Track, key_value, scene_bounds,
};

/// Which program the window is.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Mode {
    /// The Picker: control vectors on one mesh.
    #[default]
    Pick,
    /// The Composer: a scene of objects, keys and timing.
    Compose,
}

pub use crate::compose::KeyRef;

/// A key copied (Ctrl+C), to paste at the playhead (Ctrl+V).
#[derive(Clone, Copy, Debug)]
pub(super) struct CopiedKey {
    /// Where it came from.
    pub object: usize,
    pub track: Track,
    pub value: KeyValue,
    /// Tension, continuity and bias of a position key.
    pub tcb: Option<[f64; 3]>,
}

/// Why an export on a thread ended without its file.
#[derive(Debug, thiserror::Error)]
pub(super) enum ExportError {
    /// The movie could not be drawn or written (or was cancelled there).
    #[error(transparent)]
    Render(#[from] csrbf_render::RenderError),
    /// The glTF file could not be written.
    #[error(transparent)]
    Write(#[from] csrbf_mesh::MeshError),
    /// Cancelled before the file was written.
    #[error("cancelled")]
    Cancelled,
}

/// An export running on a thread.
pub(super) struct ExportJob {
    pub what: String,
    pub path: PathBuf,
    pub done: Arc<AtomicUsize>,
    pub total: Arc<AtomicUsize>,
    pub cancel: Arc<AtomicBool>,
    pub result: Arc<Mutex<Option<Result<String, ExportError>>>>,
    pub started: Instant,
}

/// The Composer's state.
pub(super) struct Composer {
    pub doc: SceneDoc,
    pub history: SceneHistory,
    /// The scene the document describes, loaded, with its mesh cache,
    /// stand-ins and the frame at the playhead.
    pub loaded: Loaded,
    pub samples: u32,
    pub orbit: Orbit,
    pub framed: bool,
    /// Look through the scene's camera (its gate: the scene's aspect).
    pub through_camera: bool,
    /// The scene camera as a drag of its eye or target has it (drawn; the
    /// document takes it when the drag ends).
    pub camera_preview: Option<csrbf_anim::CameraFile>,
    /// The key Ctrl+C copied.
    pub copied: Option<CopiedKey>,
    /// The next framing takes in the scene camera too (F).
    pub frame_camera: bool,
    pub playback: Playback,
    /// Draw every frame instead of keeping real time (slower, by choice).
    pub every_frame: bool,
    last_tick: Option<Instant>,
    /// Frames drawn while playing, over the last second: the rate shown.
    pub drawn: Vec<Instant>,
    /// The play under way: when it began, frames drawn, and the seconds of
    /// CPU eframe reported for them (update, tessellation and submission;
    /// the rest of a frame is the rasteriser and the display).
    played: Option<(Instant, u64, f64)>,
    pub selected: Option<usize>,
    pub key: Option<KeyRef>,
    pub hidden: Vec<bool>,
    pub drag: Option<KeyDrag>,
    /// A key being dragged along the timeline, and the time it is at.
    pub time_drag: Option<(KeyRef, f64)>,
    pub export: Option<ExportJob>,
    pub recovery_at: Option<Instant>,
    pub recovered_text: String,
    /// A rename being typed: the object and its text.
    pub renaming: Option<(usize, String)>,
    /// The part a texture or control file being chosen is for.
    pub part_target: Option<(usize, usize)>,
    /// Where the timeline's ruler was drawn (time 0 at its left edge,
    /// the duration at its right).
    pub ruler: egui::Rect,
    /// Where each track's row was drawn (same time scale as the ruler).
    pub rows: Vec<((usize, Track), egui::Rect)>,
    /// The status line while the Composer is shown.
    pub status: String,
    /// What the Composer asks of the shell.
    pub outbox: Outbox,
}

impl Composer {
    pub(super) fn new(mut doc: SceneDoc, samples: u32) -> Composer {
        // A scene opened (or new) is the saved state; a restored one is not.
        let mut history = SceneHistory::default();
        if !doc.dirty {
            history.mark_saved(&mut doc);
        }
        Composer {
            doc,
            history,
            loaded: Loaded::new(),
            samples,
            orbit: Orbit::new(Vec3::Y, Vec3::splat(-1.0), Vec3::splat(1.0), 1.6),
            framed: false,
            through_camera: false,
            camera_preview: None,
            copied: None,
            frame_camera: false,
            playback: Playback::default(),
            every_frame: false,
            last_tick: None,
            drawn: Vec::new(),
            played: None,
            selected: None,
            key: None,
            hidden: Vec::new(),
            drag: None,
            time_drag: None,
            export: None,
            recovery_at: None,
            recovered_text: String::new(),
            renaming: None,
            part_target: None,
            ruler: egui::Rect::NOTHING,
            rows: Vec::new(),
            status: String::new(),
            outbox: Outbox::default(),
        }
    }

    /// The scene `file` describes (see [`Loaded::prepare`]); the current
    /// scene is not changed.
    pub(super) fn prepare(
        &mut self,
        file: &SceneFile,
        force: bool,
    ) -> Result<Option<Scene>, AnimError> {
        self.loaded.prepare(&self.doc, file, force)
    }

    /// Installs a prepared scene; `structural`: the GPU prepares it again.
    /// A selection the scene no longer has is dropped.
    pub(super) fn install(&mut self, scene: Option<Scene>, structural: bool) {
        gpu::with_mesh_ids(|ids| self.loaded.install(scene, structural, ids));
        self.hidden.resize(self.doc.file.objects.len(), false);
        if self
            .selected
            .is_some_and(|s| s >= self.doc.file.objects.len())
        {
            self.selected = None;
        }
        if let Some((o, t, i)) = self.key
            && self.doc.key_times(o, t).len() <= i
        {
            self.key = None;
        }
    }

    /// The frame at the playhead (computed when the scene or time changed).
    pub fn frame_now(&mut self) {
        self.loaded.frame_at(self.doc.playhead);
    }

    /// The scene's camera.
    pub fn scene_camera(&self) -> Camera {
        let c = self
            .camera_preview
            .as_ref()
            .unwrap_or(&self.doc.file.camera);
        let v = |a: [f64; 3]| DVec3::from_array(a).as_vec3();
        Camera::perspective(v(c.eye), v(c.target), v(c.up), c.fov as f32)
    }

    /// Frames the objects over the whole scene and the scene camera's eye
    /// and target at the next draw (F). Opening a scene frames the objects
    /// alone.
    pub fn frame_everything(&mut self) {
        self.framed = false;
        self.frame_camera = true;
    }

    /// The world box of every object over the whole scene (sampled), and of
    /// the scene camera's eye and target when `frame_camera` says so.
    pub(super) fn bounds(&self) -> Option<(Vec3, Vec3)> {
        let camera = self.frame_camera.then_some(&self.doc.file.camera);
        scene_bounds(self.loaded.scene.as_ref()?, self.doc.file.duration, camera)
    }

    /// The value a new key of `track` gets at the playhead: what the scene
    /// shows there now.
    pub fn value_now(&self, object: usize, track: Track) -> Option<KeyValue> {
        self.loaded.value_now(&self.doc, object, track)
    }
}

/// The Composer's viewport input: what the pointer does to its camera and,
/// through [`key_drag`], to its keys.
/// The Composer's edits, playback and keys.
impl Composer {
    /// Applies a scene edit: the scene it makes must load (a mesh that
    /// cannot be read, a texture missing...), else nothing changes and the
    /// reason is shown. One undo step.
    pub(super) fn edit(&mut self, edit: SceneEdit) -> bool {
        self.edit_merging(edit, None)
    }

    /// [`Composer::edit`], merged into the last step when it has the
    /// same `tag` (the steps of one slider drag).
    pub(super) fn edit_merging(&mut self, edit: SceneEdit, tag: Option<&'static str>) -> bool {
        let mut trial = self.doc.clone();
        if let Err(e) = edit.apply(&mut trial) {
            self.status = format!("Not done: {e}");
            return false;
        }
        let structural = matches!(
            edit,
            SceneEdit::AddObject(_) | SceneEdit::RemoveObject(_) | SceneEdit::ReplaceObject(..)
        );
        match self.prepare(&trial.file, structural) {
            Ok(scene) => {
                let applied = match tag {
                    Some(tag) => self.history.apply_merging(&mut self.doc, &edit, tag),
                    None => self.history.apply(&mut self.doc, &edit),
                };
                if let Err(e) = applied {
                    self.status = format!("Not done: {e}");
                    return false;
                }
                self.install(scene, structural);
                // A refusal of an earlier value no longer holds.
                if self.status.starts_with("Not done") {
                    self.status.clear();
                }
                true
            }
            Err(e) => {
                self.outbox.error("Not done", reason(&e));
                false
            }
        }
    }

    pub(super) fn undo(&mut self, redo: bool) {
        let before = self.doc.clone();
        let r = if redo {
            self.history.redo(&mut self.doc)
        } else {
            self.history.undo(&mut self.doc)
        };
        if let Err(e) = r {
            self.status = e.to_string();
            return;
        }
        let file = self.doc.file.clone();
        match self.prepare(&file, false) {
            Ok(scene) => {
                self.install(scene, false);
                self.status = if redo { "Redone" } else { "Undone" }.into();
            }
            Err(e) => {
                // A file changed on disk since: keep the document as it was.
                self.doc = before;
                self.outbox.error("Cannot undo", reason(&e));
            }
        }
    }

    /// Loads the scene again from the disk (after the Picker saved one of
    /// its control files).
    pub(super) fn reload(&mut self) {
        self.loaded.forget_meshes();
        let file = self.doc.file.clone();
        match self.prepare(&file, true) {
            Ok(scene) => self.install(scene, true),
            Err(e) => {
                self.loaded.problem = Some(reason(&e));
                self.outbox.error("The scene no longer loads", reason(&e));
            }
        }
    }

    /// Plays: advances the playhead by the wall clock (or one frame a draw,
    /// when every frame is asked for).
    pub(super) fn tick(&mut self, ctx: &egui::Context, cpu: Option<f32>) {
        let now = Instant::now();
        if !self.playback.playing {
            self.last_tick = None;
            self.drawn.clear();
            // A play ended (paused, or at the end): say how it went, for
            // whoever reads the log (the figures of issue 9 come from it).
            if let Some((from, frames, cpu)) = self.played.take() {
                let secs = (now - from).as_secs_f64();
                eprintln!(
                    "csrbf-studio: played {frames} frames in {secs:.2} s = {:.1} fps ({} frames dropped; the scene runs at {} fps; {:.1} ms of CPU a frame in the app)",
                    frames as f64 / secs.max(1e-9),
                    self.playback.dropped,
                    self.doc.file.fps,
                    1e3 * cpu / frames.max(1) as f64
                );
            }
            return;
        }
        let played = self.played.get_or_insert((now, 0, 0.0));
        played.1 += 1;
        played.2 += f64::from(cpu.unwrap_or(0.0));
        let elapsed = self.last_tick.map_or(0.0, |t| (now - t).as_secs_f64());
        self.last_tick = Some(now);
        if self.every_frame {
            let before = self.doc.playhead;
            let frame = 1.0 / self.doc.file.fps;
            self.playback.advance(&mut self.doc, frame);
            if self.doc.playhead == before && !self.playback.playing {
                self.last_tick = None;
            }
        } else {
            self.playback.advance(&mut self.doc, elapsed);
        }
        self.drawn.push(now);
        self.drawn.retain(|t| now - *t < Duration::from_secs(1));
        ctx.request_repaint();
    }

    /// The rate frames were drawn at while playing, over the last second.
    pub(super) fn playback_rate(&self) -> f64 {
        match (self.drawn.first(), self.drawn.last()) {
            (Some(a), Some(b)) if self.drawn.len() > 1 && b > a => {
                (self.drawn.len() - 1) as f64 / (*b - *a).as_secs_f64()
            }
            _ => 0.0,
        }
    }

    /// Starts or stops playing.
    pub(super) fn toggle_play(&mut self) {
        if self.playback.playing {
            self.playback.pause();
        } else {
            self.playback.dropped = 0;
            self.playback.play(&mut self.doc);
        }
    }

    /// Plays (tests: `advance` then moves by the wall clock from now).
    pub(super) fn play(&mut self) {
        if !self.playback.playing {
            self.playback.dropped = 0;
            self.playback.play(&mut self.doc);
        }
    }

    /// Moves the playhead (snapped to the scene's frames) and stops playing.
    pub(super) fn set_playhead(&mut self, time: f64) {
        let fps = self.doc.file.fps;
        self.doc.playhead = ((time * fps).round() / fps).clamp(0.0, self.doc.file.duration);
        self.playback.pause();
    }

    /// Adds a key on `track` of `object` at the playhead with the value the
    /// scene has there now (then edited in the panel or the viewport).
    pub(super) fn add_key(&mut self, object: usize, track: Track) {
        let value = match self.value_now(object, track) {
            Some(v) => v,
            None => match track {
                Track::Position => KeyValue::Position([0.0; 3]),
                Track::Orientation => KeyValue::Orientation([0.0, 0.0, 0.0, 1.0]),
                Track::Phase { .. } => KeyValue::Phase(1.0),
            },
        };
        let t = self.doc.playhead;
        if self.edit(SceneEdit::AddKey {
            object,
            track,
            value,
        }) {
            let index = self
                .doc
                .key_times(object, track)
                .iter()
                .position(|&k| k == t);
            self.key = index.map(|i| (object, track, i));
            self.selected = Some(object);
            self.status = format!("Key at {t:.3} s");
        }
    }

    /// Deletes the selected key.
    pub(super) fn delete_key(&mut self) {
        let Some((object, track, index)) = self.key else {
            return;
        };
        if self.edit(SceneEdit::DeleteKey {
            object,
            track,
            index,
        }) {
            self.key = None;
        }
    }

    /// Copies the selected key to the playhead.
    pub(super) fn copy_key(&mut self) {
        let Some((object, track, index)) = self.key else {
            return;
        };
        self.edit(SceneEdit::CopyKey {
            object,
            track,
            index,
        });
    }

    /// Copies the selected key (Ctrl+C): its value and, for a position key,
    /// its tension, continuity and bias. The key is also put on the system
    /// clipboard as JSON (as the scene file writes it), which is also what
    /// lets a window's Ctrl+V reach the app.
    pub(super) fn copy_key_to_clipboard(&mut self, ctx: &egui::Context) {
        let Some((object, track, index)) = self.key else {
            self.status =
                "Nothing copied: select a key first (on the timeline or in the viewport)".into();
            return;
        };
        let Some(of) = self.doc.file.objects.get(object) else {
            return;
        };
        let Some(value) = key_value(of, track, index) else {
            return;
        };
        let (tcb, json, kind) = match track {
            Track::Position => {
                let k = of.trajectory.get(index);
                (
                    k.map(|k| [k.tension, k.continuity, k.bias]),
                    k.and_then(|k| serde_json::to_string(k).ok()),
                    "position",
                )
            }
            Track::Orientation => (
                None,
                of.orientation
                    .get(index)
                    .and_then(|k| serde_json::to_string(k).ok()),
                "orientation",
            ),
            Track::Phase { part, deformation } => (
                None,
                of.parts
                    .get(part)
                    .and_then(|p| p.deformations.get(deformation))
                    .and_then(|d| d.phase.get(index))
                    .and_then(|k| serde_json::to_string(k).ok()),
                "phase",
            ),
        };
        if let Some(json) = json {
            ctx.copy_text(json);
        }
        self.copied = Some(CopiedKey {
            object,
            track,
            value,
            tcb,
        });
        let time = self.doc.key_times(object, track)[index];
        self.status = format!(
            "Copied the {kind} key at {time:.2} s of {:?}: Ctrl+V puts it at the playhead of the selected object",
            of.name
        );
    }

    /// Pastes the copied key at the playhead (Ctrl+V): onto the selected
    /// object (else the one it came from), on its track of the same kind.
    /// A phase key goes to the selected phase track of that object, else
    /// the same part and deformation, else its first deformation.
    pub(super) fn paste_key(&mut self) {
        let Some(copied) = self.copied else {
            self.status = "Nothing to paste: select a key and copy it with Ctrl+C".into();
            return;
        };
        let object = self.selected.unwrap_or(copied.object);
        let Some(of) = self.doc.file.objects.get(object) else {
            self.status = "Nothing pasted: the object the key came from is gone".into();
            return;
        };
        let track = match copied.track {
            Track::Phase { .. } => {
                let phases: Vec<Track> = of
                    .parts
                    .iter()
                    .enumerate()
                    .flat_map(|(part, p)| {
                        (0..p.deformations.len())
                            .map(move |deformation| Track::Phase { part, deformation })
                    })
                    .collect();
                let chosen = self
                    .key
                    .filter(|k| k.0 == object && matches!(k.1, Track::Phase { .. }))
                    .map(|k| k.1);
                match chosen
                    .or_else(|| phases.contains(&copied.track).then_some(copied.track))
                    .or_else(|| phases.first().copied())
                {
                    Some(t) => t,
                    None => {
                        self.status = format!(
                            "Nothing pasted: {:?} has no deformation to take a phase key",
                            of.name
                        );
                        return;
                    }
                }
            }
            other => other,
        };
        let (time, name) = (self.doc.playhead, of.name.clone());
        if self.edit(SceneEdit::PasteKey {
            object,
            track,
            value: copied.value,
            tcb: copied.tcb,
        }) {
            let index = self
                .doc
                .key_times(object, track)
                .iter()
                .position(|&t| t == time);
            self.selected = Some(object);
            self.key = index.map(|i| (object, track, i));
            self.status = format!("Pasted the key at {time:.2} s of {name:?}");
        }
    }
}
