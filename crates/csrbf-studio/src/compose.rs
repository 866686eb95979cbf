//! The Composer's editor core (the first part of issue 9): a scene file as a
//! document, every edit a value checked before it lands, undo and redo.
//! The window over it is still to come; `csrbf animate` reads what
//! [`SceneDoc::to_text`] writes.
//!
//! Keys stay in time order: a key added at the playhead goes where its time
//! puts it, and a key dragged past another one in time is reordered. Two keys
//! of a track at the same time are refused (the CLI refuses them too), as is
//! a time outside `[0, duration]`.

use std::path::{Path, PathBuf};

use csrbf_anim::{ObjectFile, OrientationKeyFile, PhaseKeyFile, PositionKeyFile, SceneFile};

use crate::EditError;

/// A scene being composed.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneDoc {
    /// The scene, as its file says it.
    pub file: SceneFile,
    /// Where it was opened from or last saved to.
    pub path: Option<PathBuf>,
    /// The time shown, seconds.
    pub playhead: f64,
    /// Changes since the last save.
    pub dirty: bool,
}

/// One key track of an object.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Track {
    /// The trajectory (position keys).
    Position,
    /// The orientation keys.
    Orientation,
    /// The phase keys of a part's deformation.
    Phase {
        /// The part.
        part: usize,
        /// The deformation of that part.
        deformation: usize,
    },
}

/// What a new key holds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum KeyValue {
    /// A position.
    Position([f64; 3]),
    /// An orientation as a unit quaternion `[x, y, z, w]`.
    Orientation([f64; 4]),
    /// A phase in [0, 1].
    Phase(f64),
}

/// One edit of a scene.
#[derive(Clone, Debug, PartialEq)]
pub enum SceneEdit {
    /// Adds an object at the end.
    AddObject(Box<ObjectFile>),
    /// Removes an object.
    RemoveObject(usize),
    /// Renames an object (names stay unique).
    RenameObject(usize, String),
    /// Adds a key at the playhead (replacing the value of a key already
    /// there).
    AddKey {
        /// The object.
        object: usize,
        /// The track.
        track: Track,
        /// The value.
        value: KeyValue,
    },
    /// Moves a key in time (reordering the track if it passes another key).
    MoveKey {
        /// The object.
        object: usize,
        /// The track.
        track: Track,
        /// The key's index in time order.
        index: usize,
        /// Its new time.
        time: f64,
    },
    /// Deletes a key.
    DeleteKey {
        /// The object.
        object: usize,
        /// The track.
        track: Track,
        /// The key's index.
        index: usize,
    },
    /// Sets a position key's tension, continuity and bias (each in [-1, 1]).
    SetTcb {
        /// The object.
        object: usize,
        /// The key's index.
        index: usize,
        /// Tension, continuity, bias.
        tcb: [f64; 3],
    },
    /// Sets the scene's frame rate and duration.
    SetTiming {
        /// Frames per second (> 0).
        fps: f64,
        /// Seconds (> 0).
        duration: f64,
    },
}

impl SceneDoc {
    /// A document of this scene.
    pub fn new(file: SceneFile, path: Option<PathBuf>) -> SceneDoc {
        SceneDoc {
            file,
            path,
            playhead: 0.0,
            dirty: false,
        }
    }

    /// Reads a scene file, refusing what the CLI refuses to parse (the
    /// message names the file and the JSON path).
    pub fn open(path: &Path) -> Result<SceneDoc, String> {
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
        let file = SceneFile::parse(&text)
            .map_err(|e| format!("{}: {}: {}", path.display(), e.at, e.message))?;
        Ok(SceneDoc::new(file, Some(path.to_path_buf())))
    }

    /// The scene file's text, as saved.
    pub fn to_text(&self) -> String {
        self.file.to_json()
    }

    /// The key times of a track, in order (empty for a track that does not
    /// exist).
    pub fn key_times(&self, object: usize, track: Track) -> Vec<f64> {
        let Some(o) = self.file.objects.get(object) else {
            return Vec::new();
        };
        match track {
            Track::Position => o.trajectory.iter().map(|k| k.time).collect(),
            Track::Orientation => o.orientation.iter().map(|k| k.time).collect(),
            Track::Phase { part, deformation } => o
                .parts
                .get(part)
                .and_then(|p| p.deformations.get(deformation))
                .map(|d| d.phase.iter().map(|k| k.time).collect())
                .unwrap_or_default(),
        }
    }
}

/// A track's keys, whatever their kind: time is all the ordering needs.
trait Timed: Clone {
    fn time(&self) -> f64;
    fn set_time(&mut self, t: f64);
}

macro_rules! timed {
    ($t:ty) => {
        impl Timed for $t {
            fn time(&self) -> f64 {
                self.time
            }
            fn set_time(&mut self, t: f64) {
                self.time = t;
            }
        }
    };
}
timed!(PositionKeyFile);
timed!(OrientationKeyFile);
timed!(PhaseKeyFile);

/// Puts `key` where its time belongs; a key at the same time is replaced
/// when `replace`, else refused.
fn insert_sorted<K: Timed>(keys: &mut Vec<K>, key: K, replace: bool) -> Result<usize, EditError> {
    let t = key.time();
    match keys.iter().position(|k| k.time() == t) {
        Some(i) if replace => {
            keys[i] = key;
            Ok(i)
        }
        Some(_) => Err(EditError::Invalid(format!(
            "a key is already at {t} s: two keys of a track cannot share a time"
        ))),
        None => {
            let i = keys.iter().position(|k| k.time() > t).unwrap_or(keys.len());
            keys.insert(i, key);
            Ok(i)
        }
    }
}

fn move_key<K: Timed>(keys: &mut Vec<K>, index: usize, time: f64) -> Result<(), EditError> {
    if index >= keys.len() {
        return Err(EditError::Invalid(format!("no key {index} in this track")));
    }
    let mut k = keys.remove(index);
    k.set_time(time);
    let old = keys.clone();
    insert_sorted(keys, k, false)
        .map(|_| ())
        .inspect_err(|_| *keys = old)
}

fn delete_key<K>(keys: &mut Vec<K>, index: usize) -> Result<(), EditError> {
    if index >= keys.len() {
        return Err(EditError::Invalid(format!("no key {index} in this track")));
    }
    keys.remove(index);
    Ok(())
}

impl SceneEdit {
    /// Applies the edit to `doc` (its playhead places new keys); on error
    /// the document is unchanged.
    pub fn apply(&self, doc: &mut SceneDoc) -> Result<(), EditError> {
        let mut file = doc.file.clone();
        let duration = file.duration;
        let in_time = |t: f64| {
            if t.is_finite() && (0.0..=duration).contains(&t) {
                Ok(())
            } else {
                Err(EditError::Invalid(format!(
                    "time {t} s is outside the scene (0 to {duration} s)"
                )))
            }
        };
        match self {
            SceneEdit::AddObject(o) => {
                if file.objects.iter().any(|x| x.name == o.name) {
                    return Err(EditError::Invalid(format!(
                        "an object is already named {:?}",
                        o.name
                    )));
                }
                file.objects.push((**o).clone());
            }
            SceneEdit::RemoveObject(i) => {
                if *i >= file.objects.len() {
                    return Err(EditError::Invalid(format!("no object {i}")));
                }
                file.objects.remove(*i);
            }
            SceneEdit::RenameObject(i, name) => {
                if name.trim().is_empty() {
                    return Err(EditError::Invalid("a name cannot be empty".into()));
                }
                if file
                    .objects
                    .iter()
                    .enumerate()
                    .any(|(k, x)| k != *i && x.name == *name)
                {
                    return Err(EditError::Invalid(format!(
                        "an object is already named {name:?}"
                    )));
                }
                let o = file
                    .objects
                    .get_mut(*i)
                    .ok_or_else(|| EditError::Invalid(format!("no object {i}")))?;
                o.name = name.clone();
            }
            SceneEdit::AddKey {
                object,
                track,
                value,
            } => {
                let t = doc.playhead;
                in_time(t)?;
                let o = object_mut(&mut file, *object)?;
                match (track, value) {
                    (Track::Position, KeyValue::Position(p)) if p.iter().all(|x| x.is_finite()) => {
                        let old = o.trajectory.iter().find(|k| k.time == t).copied();
                        let key = PositionKeyFile {
                            time: t,
                            position: *p,
                            tension: old.map_or(0.0, |k| k.tension),
                            continuity: old.map_or(0.0, |k| k.continuity),
                            bias: old.map_or(0.0, |k| k.bias),
                        };
                        insert_sorted(&mut o.trajectory, key, true)?;
                    }
                    (Track::Orientation, KeyValue::Orientation(q)) => {
                        let n = q.iter().map(|x| x * x).sum::<f64>().sqrt();
                        if !(n > 0.0 && n.is_finite()) {
                            return Err(EditError::Invalid(format!(
                                "quaternion {q:?} is not a rotation"
                            )));
                        }
                        let key = OrientationKeyFile {
                            time: t,
                            quaternion: Some(q.map(|x| x / n)),
                            axis: None,
                            angle: None,
                            euler: None,
                        };
                        insert_sorted(&mut o.orientation, key, true)?;
                    }
                    (Track::Phase { part, deformation }, KeyValue::Phase(p))
                        if (0.0..=1.0).contains(p) =>
                    {
                        let d = o
                            .parts
                            .get_mut(*part)
                            .and_then(|pt| pt.deformations.get_mut(*deformation))
                            .ok_or_else(|| {
                                EditError::Invalid(format!(
                                    "no deformation {deformation} in part {part}"
                                ))
                            })?;
                        insert_sorted(&mut d.phase, PhaseKeyFile { time: t, phase: *p }, true)?;
                    }
                    _ => {
                        return Err(EditError::Invalid(format!(
                            "{value:?} is not a valid key for the {track:?} track"
                        )));
                    }
                }
            }
            SceneEdit::MoveKey {
                object,
                track,
                index,
                time,
            } => {
                in_time(*time)?;
                let o = object_mut(&mut file, *object)?;
                match track {
                    Track::Position => move_key(&mut o.trajectory, *index, *time)?,
                    Track::Orientation => move_key(&mut o.orientation, *index, *time)?,
                    Track::Phase { part, deformation } => {
                        let d = phase_track(o, *part, *deformation)?;
                        move_key(d, *index, *time)?
                    }
                }
            }
            SceneEdit::DeleteKey {
                object,
                track,
                index,
            } => {
                let o = object_mut(&mut file, *object)?;
                match track {
                    Track::Position => delete_key(&mut o.trajectory, *index)?,
                    Track::Orientation => delete_key(&mut o.orientation, *index)?,
                    Track::Phase { part, deformation } => {
                        delete_key(phase_track(o, *part, *deformation)?, *index)?
                    }
                }
            }
            SceneEdit::SetTcb { object, index, tcb } => {
                if tcb.iter().any(|x| !(-1.0..=1.0).contains(x)) {
                    return Err(EditError::Invalid(format!(
                        "tension, continuity and bias must be within [-1, 1], got {tcb:?}"
                    )));
                }
                let o = object_mut(&mut file, *object)?;
                let k = o
                    .trajectory
                    .get_mut(*index)
                    .ok_or_else(|| EditError::Invalid(format!("no position key {index}")))?;
                [k.tension, k.continuity, k.bias] = *tcb;
            }
            SceneEdit::SetTiming { fps, duration } => {
                if !(*fps > 0.0 && fps.is_finite() && *duration > 0.0 && duration.is_finite()) {
                    return Err(EditError::Invalid(format!(
                        "fps and duration must be numbers > 0, got {fps} and {duration}"
                    )));
                }
                let last = file
                    .objects
                    .iter()
                    .flat_map(|o| {
                        o.trajectory
                            .iter()
                            .map(|k| k.time)
                            .chain(o.orientation.iter().map(|k| k.time))
                            .chain(
                                o.parts
                                    .iter()
                                    .flat_map(|p| &p.deformations)
                                    .flat_map(|d| d.phase.iter().map(|k| k.time)),
                            )
                    })
                    .fold(0.0, f64::max);
                if *duration < last {
                    return Err(EditError::Invalid(format!(
                        "a key is at {last} s: the scene cannot end before it"
                    )));
                }
                file.fps = *fps;
                file.duration = *duration;
            }
        }
        // What the CLI would refuse is refused here (frame limits, sizes).
        file.check()
            .map_err(|e| EditError::Invalid(format!("{}: {}", e.at, e.message)))?;
        doc.file = file;
        doc.playhead = doc.playhead.clamp(0.0, doc.file.duration);
        doc.dirty = true;
        Ok(())
    }
}

fn object_mut(file: &mut SceneFile, i: usize) -> Result<&mut ObjectFile, EditError> {
    file.objects
        .get_mut(i)
        .ok_or_else(|| EditError::Invalid(format!("no object {i}")))
}

fn phase_track(
    o: &mut ObjectFile,
    part: usize,
    deformation: usize,
) -> Result<&mut Vec<PhaseKeyFile>, EditError> {
    o.parts
        .get_mut(part)
        .and_then(|p| p.deformations.get_mut(deformation))
        .map(|d| &mut d.phase)
        .ok_or_else(|| EditError::Invalid(format!("no deformation {deformation} in part {part}")))
}

/// Undo and redo of scene edits: the scene before each one (scene files are
/// small; the meshes they name are not in them).
#[derive(Clone, Debug, Default)]
pub struct SceneHistory {
    done: Vec<SceneFile>,
    undone: Vec<SceneFile>,
}

impl SceneHistory {
    /// Applies an edit and records it; clears what could be redone.
    pub fn apply(&mut self, doc: &mut SceneDoc, edit: &SceneEdit) -> Result<(), EditError> {
        let before = doc.file.clone();
        edit.apply(doc)?;
        self.done.push(before);
        self.undone.clear();
        Ok(())
    }

    /// Undoes the last edit.
    pub fn undo(&mut self, doc: &mut SceneDoc) -> Result<(), EditError> {
        let before = self.done.pop().ok_or(EditError::Nothing("undo"))?;
        self.undone.push(std::mem::replace(&mut doc.file, before));
        doc.dirty = true;
        Ok(())
    }

    /// Redoes the last undone edit.
    pub fn redo(&mut self, doc: &mut SceneDoc) -> Result<(), EditError> {
        let after = self.undone.pop().ok_or(EditError::Nothing("redo"))?;
        self.done.push(std::mem::replace(&mut doc.file, after));
        doc.dirty = true;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn doc() -> SceneDoc {
        let file = SceneFile::parse(
            r#"{"duration": 4, "fps": 25,
                "camera": {"eye": [0, 0, 5], "target": [0, 0, 0]},
                "objects": [{"name": "head", "mesh": "head.off",
                  "parts": [{"name": "all", "select": "all",
                    "deformations": [{"controls": "smile.json", "phase": [{"time": 0, "phase": 0}]}]}]}]}"#,
        )
        .expect("a scene");
        SceneDoc::new(file, None)
    }

    #[test]
    fn keys_go_in_at_the_playhead_in_time_order_and_undo_restores() {
        let mut d = doc();
        let mut h = SceneHistory::default();
        let start = d.file.clone();
        for (t, x) in [(2.0, 1.0), (0.0, 0.0), (1.0, 0.5)] {
            d.playhead = t;
            h.apply(
                &mut d,
                &SceneEdit::AddKey {
                    object: 0,
                    track: Track::Position,
                    value: KeyValue::Position([x, 0.0, 0.0]),
                },
            )
            .expect("add");
        }
        assert_eq!(d.key_times(0, Track::Position), vec![0.0, 1.0, 2.0]);
        // A key added where one is replaces its value, keeping its TCB.
        h.apply(
            &mut d,
            &SceneEdit::SetTcb {
                object: 0,
                index: 1,
                tcb: [0.5, -0.2, 0.1],
            },
        )
        .expect("tcb");
        d.playhead = 1.0;
        h.apply(
            &mut d,
            &SceneEdit::AddKey {
                object: 0,
                track: Track::Position,
                value: KeyValue::Position([0.7, 0.0, 0.0]),
            },
        )
        .expect("replace");
        let k = d.file.objects[0].trajectory[1];
        assert_eq!((k.position[0], k.tension, k.bias), (0.7, 0.5, 0.1));
        // Moving a key past another reorders; onto another is refused.
        h.apply(
            &mut d,
            &SceneEdit::MoveKey {
                object: 0,
                track: Track::Position,
                index: 0,
                time: 1.5,
            },
        )
        .expect("move");
        assert_eq!(d.key_times(0, Track::Position), vec![1.0, 1.5, 2.0]);
        let before = d.clone();
        for bad in [
            SceneEdit::MoveKey {
                object: 0,
                track: Track::Position,
                index: 0,
                time: 2.0,
            },
            SceneEdit::MoveKey {
                object: 0,
                track: Track::Position,
                index: 0,
                time: 9.0,
            },
            SceneEdit::SetTcb {
                object: 0,
                index: 0,
                tcb: [2.0, 0.0, 0.0],
            },
            SceneEdit::SetTiming {
                fps: 25.0,
                duration: 1.0,
            },
            SceneEdit::RenameObject(0, String::new()),
            // More frames than movies and exports take (the CLI's limit).
            SceneEdit::SetTiming {
                fps: 1000.0,
                duration: 1.0e6,
            },
            SceneEdit::DeleteKey {
                object: 3,
                track: Track::Position,
                index: 0,
            },
        ] {
            assert!(h.apply(&mut d, &bad).is_err(), "{bad:?}");
            assert_eq!(d, before, "{bad:?} changed the scene");
        }
        // Phase keys on a part's deformation.
        d.playhead = 3.0;
        h.apply(
            &mut d,
            &SceneEdit::AddKey {
                object: 0,
                track: Track::Phase {
                    part: 0,
                    deformation: 0,
                },
                value: KeyValue::Phase(1.0),
            },
        )
        .expect("phase");
        assert_eq!(
            d.key_times(
                0,
                Track::Phase {
                    part: 0,
                    deformation: 0
                }
            ),
            vec![0.0, 3.0]
        );
        while h.undo(&mut d).is_ok() {}
        assert_eq!(d.file, start);
        h.redo(&mut d).expect("redo");
        assert_eq!(d.key_times(0, Track::Position), vec![2.0]);
    }

    #[test]
    fn a_saved_scene_reads_back_equal_and_the_cli_accepts_its_text() {
        let mut d = doc();
        let mut h = SceneHistory::default();
        d.playhead = 1.0;
        h.apply(
            &mut d,
            &SceneEdit::AddKey {
                object: 0,
                track: Track::Orientation,
                value: KeyValue::Orientation([0.0, 0.0, 2.0, 2.0]),
            },
        )
        .expect("orientation");
        let mut other = d.file.objects[0].clone();
        other.name = "ball".into();
        h.apply(&mut d, &SceneEdit::AddObject(Box::new(other.clone())))
            .expect("add");
        assert!(
            h.apply(&mut d, &SceneEdit::AddObject(Box::new(other)))
                .is_err(),
            "names stay unique"
        );
        h.apply(
            &mut d,
            &SceneEdit::SetTiming {
                fps: 30.0,
                duration: 2.0,
            },
        )
        .expect("timing");
        let back = SceneFile::parse(&d.to_text()).expect("the CLI's parser reads it");
        assert_eq!(back, d.file);
        let q = back.objects[0].orientation[0]
            .quaternion
            .expect("quaternion");
        assert!((q[2] - 0.5f64.sqrt()).abs() < 1e-12, "normalised: {q:?}");
    }
}

/// Playing a scene in real time: the playhead moves by whole frames of the
/// scene's fps as wall-clock time passes; when drawing is slower than the
/// scene, frames are skipped (and counted) so the scene keeps its speed.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Playback {
    /// Whether it plays.
    pub playing: bool,
    /// Start again at the end of the range instead of stopping.
    pub looping: bool,
    /// Play only between these times (the whole scene when None).
    pub range: Option<(f64, f64)>,
    /// Frames skipped because a frame took longer than the scene allows.
    pub dropped: u64,
    /// Wall-clock seconds not yet turned into frames.
    carry: f64,
}

impl Playback {
    /// The scene's frame at `time` (rounded down).
    pub fn frame_of(doc: &SceneDoc, time: f64) -> i64 {
        (time * doc.file.fps + 1e-9).floor() as i64
    }

    fn bounds(&self, doc: &SceneDoc) -> (f64, f64) {
        let d = doc.file.duration;
        match self.range {
            Some((a, b)) if a < b => (a.clamp(0.0, d), b.clamp(0.0, d)),
            _ => (0.0, d),
        }
    }

    /// Starts playing (from the range's start if the playhead is at its end).
    pub fn play(&mut self, doc: &mut SceneDoc) {
        let (a, b) = self.bounds(doc);
        if doc.playhead >= b || doc.playhead < a {
            doc.playhead = a;
        }
        self.playing = true;
        self.carry = 0.0;
    }

    /// Stops where it is.
    pub fn pause(&mut self) {
        self.playing = false;
    }

    /// Moves the playhead by `frames` whole frames (negative: back), within
    /// the range.
    pub fn step(&self, doc: &mut SceneDoc, frames: i64) {
        let (a, b) = self.bounds(doc);
        let f = Playback::frame_of(doc, doc.playhead) + frames;
        doc.playhead = (f as f64 / doc.file.fps).clamp(a, b);
    }

    /// Advances by `elapsed` seconds of wall-clock time: returns how many
    /// frames the playhead moved (more than one when frames were dropped).
    pub fn advance(&mut self, doc: &mut SceneDoc, elapsed: f64) -> i64 {
        if !self.playing || !(elapsed >= 0.0) {
            return 0;
        }
        let fps = doc.file.fps;
        self.carry += elapsed;
        let frames = (self.carry * fps + 1e-9).floor() as i64;
        if frames == 0 {
            return 0;
        }
        self.carry -= frames as f64 / fps;
        self.dropped += (frames - 1).max(0) as u64;
        let (a, b) = self.bounds(doc);
        let mut t = (Playback::frame_of(doc, doc.playhead) + frames) as f64 / fps;
        if t > b + 1e-9 {
            if self.looping && b > a {
                t = a + (t - b - 1.0 / fps).rem_euclid(b - a + 1.0 / fps);
            } else {
                t = b;
                self.playing = false;
            }
        }
        doc.playhead = t.clamp(a, b);
        frames
    }
}

#[cfg(test)]
mod playback_tests {
    use super::*;

    fn doc() -> SceneDoc {
        let file = SceneFile::parse(
            r#"{"duration": 2, "fps": 10, "camera": {"eye": [0, 0, 5], "target": [0, 0, 0]}, "objects": []}"#,
        )
        .expect("a scene");
        SceneDoc::new(file, None)
    }

    #[test]
    fn playing_moves_the_playhead_by_the_fps_and_counts_dropped_frames() {
        let mut d = doc();
        let mut p = Playback::default();
        p.play(&mut d);
        // Real time at the scene's rate: one frame per 0.1 s.
        for k in 1..=5 {
            assert_eq!(p.advance(&mut d, 0.1), 1);
            assert!((d.playhead - 0.1 * k as f64).abs() < 1e-9, "{}", d.playhead);
        }
        assert_eq!(p.dropped, 0);
        // Half-frames add up; a slow frame skips frames and says so.
        assert_eq!(p.advance(&mut d, 0.05), 0);
        assert_eq!(p.advance(&mut d, 0.05), 1);
        assert_eq!(p.advance(&mut d, 0.35), 3);
        assert_eq!(p.dropped, 2);
        assert!((d.playhead - 0.9).abs() < 1e-9, "{}", d.playhead);
        // The end stops it, or wraps when looping.
        assert!(p.advance(&mut d, 5.0) > 0);
        assert_eq!(d.playhead, 2.0);
        assert!(!p.playing);
        p.looping = true;
        p.range = Some((0.5, 1.0));
        p.play(&mut d);
        assert_eq!(d.playhead, 0.5);
        for _ in 0..6 {
            p.advance(&mut d, 0.1);
        }
        assert!((d.playhead - 0.5).abs() < 1e-9, "wrapped: {}", d.playhead);
        // Frame steps stay in the range; paused, time does nothing.
        p.pause();
        assert_eq!(p.advance(&mut d, 1.0), 0);
        p.step(&mut d, -3);
        assert_eq!(d.playhead, 0.5);
        p.step(&mut d, 2);
        assert!((d.playhead - 0.7).abs() < 1e-9);
    }
}
