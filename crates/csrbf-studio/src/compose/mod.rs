//! The Composer's editor core: a scene file as a
//! document, every edit a value checked before it lands, undo and redo.
//! The window over it is `app` (Compose mode); `csrbf animate` reads what
//! [`SceneDoc::to_text`] writes.
//!
//! Keys stay in time order: a key added at the playhead goes where its time
//! puts it, and a key dragged past another one in time is reordered. Two keys
//! of a track at the same time are refused (the CLI refuses them too), as is
//! a time outside `[0, duration]`.

use std::path::{Path, PathBuf};

use csrbf_anim::{
    CameraFile, LightFile, ObjectFile, OrientationKeyFile, PhaseKeyFile, PositionKeyFile, SceneFile,
};

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
    /// Sets the value of an existing key (its time and TCB kept): a key
    /// dragged in the viewport or typed in the panel.
    SetKey {
        /// The object.
        object: usize,
        /// The track.
        track: Track,
        /// The key's index.
        index: usize,
        /// Its new value.
        value: KeyValue,
    },
    /// Copies a key (value and TCB) to the playhead.
    CopyKey {
        /// The object.
        object: usize,
        /// The track.
        track: Track,
        /// The key copied.
        index: usize,
    },
    /// Puts a key at the playhead with `value` and, for a position key,
    /// `tcb` (tension, continuity, bias): a key pasted from a copy, onto
    /// any object's track of the same kind. A key already there takes them.
    PasteKey {
        /// The object.
        object: usize,
        /// The track (of the value's kind).
        track: Track,
        /// The value.
        value: KeyValue,
        /// Tension, continuity and bias of a position key.
        tcb: Option<[f64; 3]>,
    },
    /// Replaces an object's description (its scale, parts, colours,
    /// textures, deformations, contact): what the panel edits.
    ReplaceObject(usize, Box<ObjectFile>),
    /// Sets the scene's camera.
    SetCamera(CameraFile),
    /// Sets the scene's directional lights (none: the renderer's default
    /// key and fill lights, placed from the camera).
    SetLights(Vec<LightFile>),
    /// Sets the picture size and background colour.
    SetLook {
        /// Width and height in pixels.
        size: [u32; 2],
        /// Background, linear RGB.
        background: [f32; 3],
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

    /// A new, empty scene: 4 s at 30 fps, 1280 x 720, a camera on +Z.
    pub fn empty() -> SceneDoc {
        SceneDoc::new(
            SceneFile {
                duration: 4.0,
                fps: 30.0,
                size: [1280, 720],
                background: [0.035, 0.04, 0.05],
                camera: CameraFile {
                    eye: [0.0, 0.0, 10.0],
                    target: [0.0, 0.0, 0.0],
                    up: [0.0, 1.0, 0.0],
                    fov: 35.0,
                },
                lights: Vec::new(),
                objects: Vec::new(),
            },
            None,
        )
    }

    /// The scene file's text, as saved.
    pub fn to_text(&self) -> String {
        self.file.to_json()
    }

    /// The folder the file's relative paths start from: the scene file's,
    /// or the working folder for a scene never saved (whose paths the
    /// studio writes absolute until it is).
    pub fn dir(&self) -> PathBuf {
        match self.path.as_deref().and_then(Path::parent) {
            Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
            _ => std::env::current_dir().unwrap_or_default(),
        }
    }

    /// A path the scene names (mesh, texture, control file), resolved.
    pub fn resolve(&self, named: &str) -> PathBuf {
        self.dir().join(named)
    }

    /// How the scene names `path`: relative to its folder once it has one,
    /// with `/` between parts (as the CLI writes them on every system).
    pub fn name_of(&self, path: &Path) -> String {
        match &self.path {
            Some(_) => relative_path(&self.dir(), path),
            None => std::path::absolute(path)
                .unwrap_or_else(|_| path.to_path_buf())
                .to_string_lossy()
                .into_owned(),
        }
    }

    /// Why the scene cannot be saved as it stands (the CLI refuses a scene
    /// with no object), if it cannot.
    pub fn saveable(&self) -> Result<(), String> {
        self.file
            .check()
            .map_err(|e| format!("{}: {}", e.at, e.message))
    }

    /// The text to write at `path`: every path the scene names made
    /// relative to `path`'s folder, so the scene still finds its meshes,
    /// textures and control files from there (`csrbf animate` reads them
    /// relative to the scene file).
    pub fn text_for(&self, path: &Path) -> String {
        self.rebased(path).to_json()
    }

    /// The scene with its paths made relative to `path`'s folder.
    pub fn rebased(&self, path: &Path) -> SceneFile {
        let to = match path.parent() {
            Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let mut file = self.file.clone();
        let moved = |named: &mut String| {
            let resolved = self.resolve(named);
            *named = relative_path(&to, &resolved);
        };
        for o in &mut file.objects {
            moved(&mut o.mesh);
            for p in &mut o.parts {
                if let Some(t) = &mut p.texture {
                    moved(t);
                }
                for d in &mut p.deformations {
                    moved(&mut d.controls);
                }
            }
        }
        file
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

/// A part of the whole mesh, light grey, with no deformation: what a new
/// object starts with.
pub fn whole_part() -> csrbf_anim::PartFile {
    csrbf_anim::PartFile {
        name: "all".into(),
        select: "all".into(),
        color: None,
        texture: None,
        wireframe: false,
        deformations: Vec::new(),
    }
}

/// `path` relative to the folder `from`, with `/` between parts: `..` up to
/// the parts they share, then down. Paths on different drives or roots stay
/// absolute.
pub fn relative_path(from: &Path, path: &Path) -> String {
    use std::path::Component;
    let abs = |p: &Path| {
        let p = std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
        // Lexically drop `.` and fold `..` (no symlinks are followed).
        let mut out: Vec<Component> = Vec::new();
        for c in p.components() {
            match c {
                Component::CurDir => {}
                Component::ParentDir if matches!(out.last(), Some(Component::Normal(_))) => {
                    out.pop();
                }
                c => out.push(c),
            }
        }
        out.into_iter()
            .map(|c| c.as_os_str().to_os_string())
            .collect::<Vec<_>>()
    };
    let (a, b) = (abs(from), abs(path));
    if a.first() != b.first() {
        return b.iter().collect::<PathBuf>().to_string_lossy().into_owned();
    }
    let common = a.iter().zip(&b).take_while(|(x, y)| x == y).count();
    let mut parts: Vec<String> = vec!["..".to_string(); a.len() - common];
    parts.extend(b[common..].iter().map(|c| c.to_string_lossy().into_owned()));
    parts.join("/")
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
                put_key(object_mut(&mut file, *object)?, *track, t, *value, None)?;
            }
            SceneEdit::SetKey {
                object,
                track,
                index,
                value,
            } => {
                let o = object_mut(&mut file, *object)?;
                let t = key_time(o, *track, *index)?;
                put_key(o, *track, t, *value, None)?;
            }
            SceneEdit::CopyKey {
                object,
                track,
                index,
            } => {
                let t = doc.playhead;
                in_time(t)?;
                let o = object_mut(&mut file, *object)?;
                let value = key_value(o, *track, *index)
                    .ok_or_else(|| EditError::Invalid(format!("no key {index} in this track")))?;
                let tcb = match track {
                    Track::Position => o
                        .trajectory
                        .get(*index)
                        .map(|k| [k.tension, k.continuity, k.bias]),
                    _ => None,
                };
                put_key(o, *track, t, value, tcb)?;
            }
            SceneEdit::PasteKey {
                object,
                track,
                value,
                tcb,
            } => {
                let t = doc.playhead;
                in_time(t)?;
                put_key(object_mut(&mut file, *object)?, *track, t, *value, *tcb)?;
            }
            SceneEdit::ReplaceObject(i, object) => {
                if object.name.trim().is_empty() {
                    return Err(EditError::Invalid("a name cannot be empty".into()));
                }
                if file
                    .objects
                    .iter()
                    .enumerate()
                    .any(|(k, x)| k != *i && x.name == object.name)
                {
                    return Err(EditError::Invalid(format!(
                        "an object is already named {:?}",
                        object.name
                    )));
                }
                *object_mut(&mut file, *i)? = (**object).clone();
            }
            SceneEdit::SetCamera(camera) => file.camera = camera.clone(),
            SceneEdit::SetLights(lights) => {
                for (i, l) in lights.iter().enumerate() {
                    let d = l.direction;
                    if d.iter().any(|c| !c.is_finite()) || d.iter().all(|c| *c == 0.0) {
                        return Err(EditError::Invalid(format!(
                            "light {i}: its direction must be finite and not zero, got {d:?}"
                        )));
                    }
                    if l.color.iter().any(|c| !c.is_finite() || *c < 0.0)
                        || !l.intensity.is_finite()
                        || l.intensity < 0.0
                    {
                        return Err(EditError::Invalid(format!(
                            "light {i}: colour and intensity must be finite and >= 0, got {:?} and {}",
                            l.color, l.intensity
                        )));
                    }
                }
                file.lights = lights.clone();
            }
            SceneEdit::SetLook { size, background } => {
                if background.iter().any(|c| !(0.0..=1.0).contains(c)) {
                    return Err(EditError::Invalid(format!(
                        "background colour must be within [0, 1], got {background:?}"
                    )));
                }
                file.size = *size;
                file.background = *background;
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
        check(&file)?;
        doc.file = file;
        doc.playhead = doc.playhead.clamp(0.0, doc.file.duration);
        doc.dirty = true;
        Ok(())
    }
}

/// The CLI's whole-scene checks, but for "no object": a scene being built
/// may have none yet (saving one is refused, see [`SceneDoc::saveable`]).
fn check(file: &SceneFile) -> Result<(), EditError> {
    match file.check() {
        Ok(()) => Ok(()),
        // The object count is checked last: everything else passed.
        Err(e) if e.at == "objects" && file.objects.is_empty() => Ok(()),
        Err(e) => Err(EditError::Invalid(format!("{}: {}", e.at, e.message))),
    }
}

/// Puts a key of `value` at time `t` (replacing the value of a key already
/// there, keeping its TCB unless `tcb` is given).
fn put_key(
    o: &mut ObjectFile,
    track: Track,
    t: f64,
    value: KeyValue,
    tcb: Option<[f64; 3]>,
) -> Result<usize, EditError> {
    match (track, value) {
        (Track::Position, KeyValue::Position(p)) if p.iter().all(|x| x.is_finite()) => {
            let old = o.trajectory.iter().find(|k| k.time == t).copied();
            let [tension, continuity, bias] =
                tcb.unwrap_or(old.map_or([0.0; 3], |k| [k.tension, k.continuity, k.bias]));
            let key = PositionKeyFile {
                time: t,
                position: p,
                tension,
                continuity,
                bias,
            };
            insert_sorted(&mut o.trajectory, key, true)
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
            insert_sorted(&mut o.orientation, key, true)
        }
        (Track::Phase { part, deformation }, KeyValue::Phase(p)) if (0.0..=1.0).contains(&p) => {
            let d = phase_track(o, part, deformation)?;
            insert_sorted(d, PhaseKeyFile { time: t, phase: p }, true)
        }
        _ => Err(EditError::Invalid(format!(
            "{value:?} is not a valid key for the {track:?} track"
        ))),
    }
}

/// The time of key `index` of a track.
fn key_time(o: &mut ObjectFile, track: Track, index: usize) -> Result<f64, EditError> {
    let t = match track {
        Track::Position => o.trajectory.get(index).map(|k| k.time),
        Track::Orientation => o.orientation.get(index).map(|k| k.time),
        Track::Phase { part, deformation } => phase_track(o, part, deformation)?
            .get(index)
            .map(|k| k.time),
    };
    t.ok_or_else(|| EditError::Invalid(format!("no key {index} in this track")))
}

/// The value of key `index` of a track (an orientation written as an axis
/// and angle or Euler angles is given as its quaternion).
pub fn key_value(o: &ObjectFile, track: Track, index: usize) -> Option<KeyValue> {
    match track {
        Track::Position => o
            .trajectory
            .get(index)
            .map(|k| KeyValue::Position(k.position)),
        Track::Orientation => o
            .orientation
            .get(index)
            .and_then(orientation_quaternion)
            .map(KeyValue::Orientation),
        Track::Phase { part, deformation } => o
            .parts
            .get(part)?
            .deformations
            .get(deformation)?
            .phase
            .get(index)
            .map(|k| KeyValue::Phase(k.phase)),
    }
}

/// An orientation key's rotation as a unit quaternion `[x, y, z, w]`,
/// however the file wrote it (None for a key the CLI would refuse).
pub fn orientation_quaternion(k: &OrientationKeyFile) -> Option<[f64; 4]> {
    use csrbf::glam::{DQuat, DVec3};
    let q = match (k.quaternion, k.axis, k.angle, k.euler) {
        (Some(q), None, None, None) => DQuat::from_array(q),
        (None, Some(a), Some(angle), None) => {
            csrbf_anim::OrientationKey::from_axis_angle(0.0, DVec3::from_array(a), angle).rotation
        }
        (None, None, None, Some(e)) => {
            csrbf_anim::OrientationKey::from_euler_degrees(0.0, DVec3::from_array(e)).rotation
        }
        _ => return None,
    };
    let n = q.length();
    (n > 1e-9 && n.is_finite()).then(|| (q / n).to_array())
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
    /// The tag of the last edit, when it may take the next one in.
    merging: Option<&'static str>,
}

impl SceneHistory {
    /// Applies an edit and records it; clears what could be redone.
    pub fn apply(&mut self, doc: &mut SceneDoc, edit: &SceneEdit) -> Result<(), EditError> {
        let before = doc.file.clone();
        edit.apply(doc)?;
        self.done.push(before);
        self.undone.clear();
        self.merging = None;
        Ok(())
    }

    /// [`SceneHistory::apply`], but one undo step with the edits before it
    /// of the same `tag` (the steps of a slider drag or of typing a value),
    /// until [`SceneHistory::end_merge`].
    pub fn apply_merging(
        &mut self,
        doc: &mut SceneDoc,
        edit: &SceneEdit,
        tag: &'static str,
    ) -> Result<(), EditError> {
        if self.merging == Some(tag) && !self.done.is_empty() {
            edit.apply(doc)?;
            self.undone.clear();
            return Ok(());
        }
        self.apply(doc, edit)?;
        self.merging = Some(tag);
        Ok(())
    }

    /// Ends a merged run: the next edit is a step of its own.
    pub fn end_merge(&mut self) {
        self.merging = None;
    }

    /// Steps that can be undone.
    pub fn undo_steps(&self) -> usize {
        self.done.len()
    }

    /// Undoes the last edit.
    pub fn undo(&mut self, doc: &mut SceneDoc) -> Result<(), EditError> {
        let before = self.done.pop().ok_or(EditError::Nothing("undo"))?;
        self.merging = None;
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
    fn keys_are_set_copied_and_objects_replaced_in_one_step_each() {
        let mut d = doc();
        let mut h = SceneHistory::default();
        for t in [0.0, 2.0] {
            d.playhead = t;
            h.apply(
                &mut d,
                &SceneEdit::AddKey {
                    object: 0,
                    track: Track::Position,
                    value: KeyValue::Position([t, 0.0, 0.0]),
                },
            )
            .expect("add");
        }
        h.apply(
            &mut d,
            &SceneEdit::SetTcb {
                object: 0,
                index: 1,
                tcb: [0.3, 0.0, -0.4],
            },
        )
        .expect("tcb");
        // Setting a key's value keeps its time and TCB.
        h.apply(
            &mut d,
            &SceneEdit::SetKey {
                object: 0,
                track: Track::Position,
                index: 1,
                value: KeyValue::Position([5.0, 1.0, 0.0]),
            },
        )
        .expect("set");
        let k = d.file.objects[0].trajectory[1];
        assert_eq!((k.time, k.position, k.tension), (2.0, [5.0, 1.0, 0.0], 0.3));
        // A copy lands at the playhead with value and TCB.
        d.playhead = 3.0;
        h.apply(
            &mut d,
            &SceneEdit::CopyKey {
                object: 0,
                track: Track::Position,
                index: 1,
            },
        )
        .expect("copy");
        let c = d.file.objects[0].trajectory[2];
        assert_eq!((c.time, c.position, c.bias), (3.0, [5.0, 1.0, 0.0], -0.4));
        // An orientation written as axis and angle reads as its quaternion.
        let q = orientation_quaternion(&OrientationKeyFile {
            time: 0.0,
            quaternion: None,
            axis: Some([0.0, 0.0, 1.0]),
            angle: Some(90.0),
            euler: None,
        })
        .expect("rotation");
        assert!((q[2] - 0.5f64.sqrt()).abs() < 1e-12 && (q[3] - 0.5f64.sqrt()).abs() < 1e-12);
        // The panel's edits replace the object whole; names stay unique.
        let mut o = d.file.objects[0].clone();
        o.scale = 2.0;
        h.apply(&mut d, &SceneEdit::ReplaceObject(0, Box::new(o)))
            .expect("replace");
        assert_eq!(d.file.objects[0].scale, 2.0);
        // The last object can go (a scene being built), but is not saveable.
        h.apply(&mut d, &SceneEdit::RemoveObject(0))
            .expect("remove");
        assert!(d.saveable().is_err());
        h.undo(&mut d).expect("undo");
        assert!(d.saveable().is_ok());
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
        let light = LightFile {
            direction: [0.0, -1.0, -0.5],
            color: [1.0, 0.9, 0.8],
            intensity: 0.7,
        };
        h.apply(&mut d, &SceneEdit::SetLights(vec![light.clone()]))
            .expect("lights");
        for bad in [
            LightFile {
                direction: [0.0; 3],
                ..light.clone()
            },
            LightFile {
                color: [1.0, -0.1, 0.0],
                ..light.clone()
            },
            LightFile {
                intensity: f32::NAN,
                ..light.clone()
            },
        ] {
            let e = h
                .apply(&mut d, &SceneEdit::SetLights(vec![light.clone(), bad]))
                .expect_err("refused");
            assert!(e.to_string().contains("light 1"), "{e}");
        }
        assert_eq!(d.file.lights, vec![light], "a refused edit changes nothing");
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
mod path_tests {
    use super::*;

    #[test]
    fn paths_are_rebased_relative_to_where_the_scene_is_saved() {
        assert_eq!(
            relative_path(Path::new("/a/b/scenes"), Path::new("/a/b/models/head.off")),
            "../models/head.off"
        );
        assert_eq!(
            relative_path(Path::new("/a/b"), Path::new("/a/b/./x/../head.off")),
            "head.off"
        );
        let file = SceneFile::parse(
            r#"{"duration": 1, "camera": {"eye": [0, 0, 5], "target": [0, 0, 0]},
                "objects": [{"name": "head", "mesh": "models/head.off",
                  "parts": [{"name": "skin", "texture": "tex/skin.png",
                    "deformations": [{"controls": "smile.json"}]}]}]}"#,
        )
        .expect("scene");
        let doc = SceneDoc::new(file, Some(PathBuf::from("/w/s.scene.json")));
        let moved = doc.rebased(Path::new("/w/out/deep/s.scene.json"));
        let o = &moved.objects[0];
        assert_eq!(o.mesh, "../../models/head.off");
        assert_eq!(o.parts[0].texture.as_deref(), Some("../../tex/skin.png"));
        assert_eq!(o.parts[0].deformations[0].controls, "../../smile.json");
        // A scene never saved names files by absolute paths until it is.
        let fresh = SceneDoc::empty();
        let named = fresh.name_of(Path::new("rel/head.off"));
        assert!(Path::new(&named).is_absolute(), "{named}");
        assert!(fresh.saveable().is_err(), "no object yet");
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
