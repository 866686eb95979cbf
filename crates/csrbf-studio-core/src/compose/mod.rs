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

use csrbf_anim::{CameraFile, LightFile, ObjectFile, SceneFile};

mod edit;
mod history;
mod keys;
mod loaded;
mod look;
mod objects;
mod pick;
mod playback;
#[cfg(test)]
mod tests;

pub use history::SceneHistory;
pub use keys::{key_value, orientation_quaternion};
pub use loaded::{Loaded, scene_bounds, world_centre};
#[cfg(any(test, feature = "fixtures"))]
pub use pick::fixture;
pub use pick::{KeyHit, pick_camera_end, pick_key, pick_object};
pub use playback::Playback;

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

/// Why a scene file cannot be opened or saved.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SceneDocError {
    /// The file could not be read.
    #[error("{}: {source}", path.display())]
    Read {
        /// The scene file.
        path: PathBuf,
        /// The system's error.
        source: std::io::Error,
    },
    /// The file is not a scene the CLI reads.
    #[error("{}: {at}: {message}", path.display())]
    Parse {
        /// The scene file.
        path: PathBuf,
        /// JSON path, or line and column.
        at: String,
        /// What is wrong.
        message: String,
    },
    /// The scene as it stands is one the CLI refuses (one with no object).
    #[error("{at}: {message}")]
    NotSaveable {
        /// JSON path.
        at: String,
        /// What is wrong.
        message: String,
    },
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

/// A key of the timeline: object, track, index.
pub type KeyRef = (usize, Track, usize);

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
    pub fn open(path: &Path) -> Result<SceneDoc, SceneDocError> {
        let text = std::fs::read_to_string(path).map_err(|e| SceneDocError::Read {
            path: path.to_path_buf(),
            source: e,
        })?;
        let file = SceneFile::parse(&text).map_err(|e| SceneDocError::Parse {
            path: path.to_path_buf(),
            at: e.at,
            message: e.message,
        })?;
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
        csrbf_anim::path::resolve(&self.dir(), named)
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
    pub fn saveable(&self) -> Result<(), SceneDocError> {
        self.file.check().map_err(|e| SceneDocError::NotSaveable {
            at: e.at,
            message: e.message,
        })
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
