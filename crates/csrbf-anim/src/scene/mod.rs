//! A loaded scene: meshes read, parts selected, deformations fitted and
//! bound once, tracks built. [`Scene::frame`] gives every object's world
//! vertices at a time. Split by operation: `load` (files to objects),
//! `frame` (a time to positions), `contact` (the deformation rebuilt every
//! frame) and `texture` (images).

mod contact;
mod frame;
mod load;
mod texture;

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use csrbf::{Binding, Combine, Deformation, Kernel};
use csrbf_edit::controls::ControlFile;
use csrbf_mesh::Mesh;
use glam::{DQuat, DVec3, Vec3};

use crate::file::{ObjectFile, SceneFile};
use crate::rotation::Orientation;
use crate::spline::Trajectory;
use crate::track::PhaseTrack;
use crate::{AnimError, Result};

use load::{check_scene, load_object, resolve_contacts};
pub use texture::{TextureError, decode_texture, load_texture};

/// A decoded texture image.
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    /// Where it came from.
    pub path: PathBuf,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// RGBA8 pixels, row by row from the top.
    pub rgba: Vec<u8>,
    /// The file's bytes as encoded, for embedding in exports.
    pub encoded: Vec<u8>,
    /// `image/png` or `image/jpeg`.
    pub mime: String,
}

/// A part of an object: faces with one look.
#[derive(Clone, Debug)]
pub struct Part {
    /// Its name.
    pub name: String,
    /// Face indices of the object's mesh.
    pub faces: Vec<u32>,
    /// The vertices of those faces, ascending.
    pub vertices: Vec<u32>,
    /// Base colour, linear RGBA.
    pub color: [f32; 4],
    /// Texture over the mesh's UVs.
    pub texture: Option<Texture>,
    /// Whether its edges are drawn.
    pub wireframe: bool,
}

/// One fitted deformation stage, bound to its vertices.
#[derive(Clone, Debug)]
pub struct BoundStage {
    /// The deformation (starts, coefficients, kernel, R).
    pub deformation: Deformation,
    /// Destinations of its control vectors, for the overlay.
    pub targets: Vec<DVec3>,
    /// The vertices it moves (those of its region with a displacement).
    pub vertices: Vec<u32>,
    /// Every vertex of its region, bound to its starts.
    pub binding: Binding,
    /// Full displacement of each of `vertices` (times the stage's phase in
    /// its file), computed once at rest. Empty for a chained stage after the
    /// first, which is evaluated every frame at the points the stages before
    /// it moved.
    pub displacement: Vec<Vec3>,
    /// Phase of the stage within its control file.
    pub phase: f32,
    /// Every vertex of its region (in the part).
    pub region: Vec<u32>,
    /// The weight of each of `region` (1, or less in a falloff).
    pub weights: Vec<f32>,
    /// The deformation's `name` in its control file, if it has one.
    pub name: Option<String>,
    /// Which step of a fold-free sweep this stage is (None: a plain
    /// deformation). A sweep's step moves by
    /// [`csrbf::step_phase`]`(phase t, index, count)` at track phase t, and
    /// its `displacement` (step 0's) is kept without the phase.
    pub sweep: Option<csrbf::SweepStep>,
}

impl BoundStage {
    /// How far this stage moves at track phase `t`: its phase in the file
    /// times t, or a sweep's step's share of it.
    pub fn phase_at(&self, t: f32) -> f32 {
        let p = self.phase * t;
        match self.sweep {
            None => p,
            Some(s) => csrbf::step_phase(p as f64, s.index as usize, s.count as usize) as f32,
        }
    }

    /// The factor of the kept `displacement` at track phase `t` (the phase
    /// in the file is in it already, except for a sweep's step).
    pub fn displacement_factor(&self, t: f32) -> f32 {
        match self.sweep {
            None => t,
            Some(_) => self.phase_at(t),
        }
    }
}

/// A deformation of a part with its phase track.
#[derive(Clone, Debug)]
pub struct Animated {
    /// The part it belongs to.
    pub part: usize,
    /// The control file, as named in the scene.
    pub controls: String,
    /// Its stages (a control file may hold several).
    pub stages: Vec<BoundStage>,
    /// How they act together (the control file's `combine`).
    pub combine: Combine,
    /// Phase over time.
    pub track: PhaseTrack,
}

/// Contact deformation, rebuilt every frame.
#[derive(Clone, Debug)]
pub struct Contact {
    /// Index of the pushing object.
    pub with: usize,
    /// Kernel.
    pub kernel: Kernel,
    /// Reach factor for the radius of support.
    pub reach: f64,
    /// The longest edge of the pushed mesh, for the margin that keeps the
    /// pusher behind its faces.
    pub spacing: f64,
}

/// An animation object.
#[derive(Clone, Debug)]
pub struct Object {
    /// Its name.
    pub name: String,
    /// The rest mesh in the object's local frame (scaled).
    pub mesh: Mesh,
    /// Centre of gravity of the rest mesh (area-weighted), the centre of turning.
    pub center: DVec3,
    /// Radius of the bounding sphere about the centre.
    pub radius: f64,
    /// Parts.
    pub parts: Vec<Part>,
    /// Position of the frame over time.
    pub trajectory: Trajectory,
    /// Orientation over time.
    pub orientation: Orientation,
    /// Deformations with phase tracks.
    pub deformations: Vec<Animated>,
    /// Contact deformation.
    pub contact: Option<Contact>,
    /// The mesh's faces as triangles, for the normals of every frame.
    pub triangles: Vec<[u32; 3]>,
    /// The triangles, prepared once for the normals' passes of every frame
    /// (the plain function's values, faster).
    pub normals: csrbf_mesh::VertexNormals,
    /// The rest mesh and the stages' displacements as x y z w, prepared
    /// once from `mesh` and `deformations` (rebuild it with
    /// [`RestLanes::new`] if they change): a frame builds its points in the
    /// normals' lanes from them (the same values).
    pub lanes: RestLanes,
}

/// An object's rest points as x y z 0 and, for each of its stages that
/// moves many vertices, its displacement over all of them: what a frame
/// adds in the lanes its normals read ([`RestLanes::new`]).
#[derive(Clone, Debug, Default)]
pub struct RestLanes {
    /// Rest positions as x y z 0 ([`csrbf_mesh::POINT_FLOATS`] floats a
    /// vertex, as the normals take them).
    rest: csrbf_mesh::CacheAligned,
    /// Per stage of every deformation, in order: its displacement at every
    /// vertex as x y z -0, or None where it is scattered to its vertices.
    dense: Vec<Option<csrbf_mesh::CacheAligned>>,
}

impl Object {
    /// The rigid transform at `time`: local point to world point.
    pub fn transform(&self, time: f64) -> (DQuat, DVec3) {
        let rot = self.orientation.rotation(time);
        let pos = self.trajectory.position(time);
        // world = pos + center + rot (p - center)
        (rot, pos + self.center - rot * self.center)
    }
}

/// Meshes and control files given as values instead of files: the studio's
/// open documents. A scene looks each path up here (as it resolves it:
/// relative to the scene's folder) before reading the disk.
#[derive(Clone, Debug, Default)]
pub struct Assets {
    meshes: HashMap<PathBuf, Mesh>,
    controls: HashMap<PathBuf, ControlFile>,
}

impl Assets {
    /// No values: every path is read from the disk.
    pub fn new() -> Assets {
        Assets::default()
    }

    /// Uses `mesh` wherever a scene names `path`.
    pub fn set_mesh(&mut self, path: impl Into<PathBuf>, mesh: Mesh) {
        self.meshes.insert(path.into(), mesh);
    }

    /// Uses `controls` wherever a scene names `path`.
    pub fn set_controls(&mut self, path: impl Into<PathBuf>, controls: ControlFile) {
        self.controls.insert(path.into(), controls);
    }

    /// The mesh at `path`: the value given, else read from the file.
    fn mesh(&self, path: &Path) -> std::result::Result<Mesh, AssetError> {
        match self.meshes.get(path) {
            Some(m) => Ok(m.clone()),
            None => csrbf_mesh::read(path).map_err(AssetError::Mesh),
        }
    }

    /// The control file at `path`: the value given, else read and parsed.
    fn controls(&self, path: &Path) -> std::result::Result<ControlFile, AssetError> {
        if let Some(c) = self.controls.get(path) {
            return Ok(c.clone());
        }
        let text = std::fs::read_to_string(path).map_err(|e| AssetError::Read {
            path: path.to_path_buf(),
            source: e,
        })?;
        ControlFile::parse(&text).map_err(|e| AssetError::Controls {
            path: path.to_path_buf(),
            source: e,
        })
    }
}

/// Why a mesh or a control file a scene names could not be had (the
/// message a scene error carries at the object's `mesh` or `controls`).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum AssetError {
    /// The mesh could not be read (the mesh crate's whole chain).
    #[error("{}", .0.full())]
    Mesh(csrbf_mesh::MeshError),
    /// The control file could not be read.
    #[error("{}: {source}", path.display())]
    Read {
        /// The control file.
        path: PathBuf,
        /// The system's error.
        source: std::io::Error,
    },
    /// The control file is not one the CLI accepts.
    #[error("{}: {source}", path.display())]
    Controls {
        /// The control file.
        path: PathBuf,
        /// What is wrong, where.
        source: csrbf_edit::controls::ControlError,
    },
}

/// The colour of a part that names none: light grey.
pub const DEFAULT_PART_COLOR: [f32; 4] = [0.8, 0.8, 0.8, 1.0];

/// Largest picture side, in pixels (scenes, stills, movies, the renderer).
pub const MAX_SIDE: u32 = 8192;
/// Highest frame rate of a scene or movie.
pub const MAX_FPS: f64 = 240.0;

/// Most frames a scene, a movie or an export may have (about 55 minutes at
/// 30 fps): beyond it a scene or a time range is refused before any work.
pub const MAX_FRAMES: usize = 100_000;

/// Frames of a stretch of `span` seconds at `fps`, both ends included: the
/// one formula for movies, playback and export.
pub fn frame_count(span: f64, fps: f64) -> usize {
    let n = (span * fps).round();
    if n.is_finite() && n >= 0.0 {
        (n as usize).saturating_add(1)
    } else {
        1
    }
}

/// A loaded scene.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The file as written.
    pub file: SceneFile,
    /// The folder the file's relative paths start from.
    pub dir: PathBuf,
    /// The objects.
    pub objects: Vec<Object>,
    /// What was odd but accepted (a non-unit quaternion normalised, ...).
    pub warnings: Vec<String>,
}

/// One object at one time.
#[derive(Clone, Debug, Default)]
pub struct FrameObject {
    /// World-space positions.
    pub positions: Vec<Vec3>,
    /// World-space vertex normals.
    pub normals: Vec<Vec3>,
    /// Control vectors in world space: start, where it is at this phase, destination, R.
    pub controls: Vec<(Vec3, Vec3, Vec3, f32)>,
    /// The normals' buffers, kept between frames.
    scratch: csrbf_mesh::NormalsScratch,
    /// A chained control file's buffers, kept between frames.
    chain: ChainScratch,
    /// Each deformation's phase at this frame's time.
    phases: Vec<f32>,
}

/// Buffers of a chained control file's frame: the points as its stages
/// move them (then its displacement), one stage's points and displacements.
#[derive(Clone, Debug, Default)]
struct ChainScratch {
    x: Vec<Vec3>,
    pts: Vec<Vec3>,
    d: Vec<Vec3>,
}

/// Every object at one time.
#[derive(Clone, Debug, Default)]
pub struct Frame {
    /// The time.
    pub time: f64,
    /// One per scene object.
    pub objects: Vec<FrameObject>,
}

impl SceneFile {
    /// The checks of the scene as a whole that need no file (timing, size,
    /// camera, lights...), as `csrbf animate` makes them before reading
    /// meshes: for editors that must not produce a scene the CLI refuses.
    pub fn check(&self) -> std::result::Result<(), crate::file::ParseError> {
        check_scene(self).map_err(|(at, message)| crate::file::ParseError { at, message })
    }
}

impl Scene {
    /// Reads, checks and prepares a scene file.
    pub fn load(path: &Path) -> Result<Scene> {
        let text = std::fs::read_to_string(path).map_err(|e| AnimError::Io {
            path: path.to_owned(),
            message: e.to_string(),
        })?;
        let file = SceneFile::parse(&text).map_err(|crate::file::ParseError { at, message }| {
            AnimError::Scene {
                path: path.to_owned(),
                at,
                message,
            }
        })?;
        let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        Scene::from_file(file, &dir, path)
    }

    /// Prepares a scene from its description; relative paths start at `dir`;
    /// `name` names the scene in errors.
    pub fn from_file(file: SceneFile, dir: &Path, name: &Path) -> Result<Scene> {
        Scene::from_file_with(file, dir, name, &Assets::default())
    }

    /// [`Scene::from_file`], taking meshes and control files from `assets`
    /// where it has them (values, not files).
    pub fn from_file_with(
        file: SceneFile,
        dir: &Path,
        name: &Path,
        assets: &Assets,
    ) -> Result<Scene> {
        let err = |at: String, message: String| AnimError::Scene {
            path: name.to_owned(),
            at,
            message,
        };
        check_scene(&file).map_err(|(a, m)| err(a, m))?;
        let mut warnings = Vec::new();
        let mut objects = Vec::with_capacity(file.objects.len());
        for (oi, of) in file.objects.iter().enumerate() {
            let at = |k: &str| format!("objects[{oi}].{k}");
            if file.objects[..oi].iter().any(|o| o.name == of.name) {
                return Err(err(
                    at("name"),
                    format!(
                        "{:?} is used by an earlier object; names must be unique",
                        of.name
                    ),
                ));
            }
            objects.push(load_object(of, dir, assets, &at, &mut warnings).map_err(
                |e| match e {
                    AnimError::Scene { at, message, .. } => err(at, message),
                    other => other,
                },
            )?);
        }
        resolve_contacts(&file, &mut objects).map_err(|(a, m)| err(a, m))?;
        Ok(Scene {
            file,
            dir: dir.to_owned(),
            objects,
            warnings,
        })
    }

    /// Number of frames at the file's rate over its duration (both ends included).
    pub fn frame_count(&self) -> usize {
        frame_count(self.file.duration, self.file.fps)
    }

    /// Takes `file` as the scene's description when it differs from the one
    /// loaded only in what needs no mesh, fit or texture: key tracks
    /// (trajectory, orientation, interpolation, phase keys and easing),
    /// timing, size, background, camera and lights. Tracks are rebuilt and
    /// checked as [`Scene::load`] checks them, in microseconds: what the
    /// Composer does on every key edit and every step of a key drag.
    /// Returns `Ok(false)`, changing nothing, when `file` differs in
    /// anything else (objects, meshes, parts, control files, contact): the
    /// caller loads it instead. On error the scene is left as it was.
    pub fn retime(&mut self, file: SceneFile) -> Result<bool> {
        fn shape(o: &ObjectFile) -> ObjectFile {
            let mut o = o.clone();
            o.trajectory.clear();
            o.orientation.clear();
            o.interpolation = Default::default();
            for d in o.parts.iter_mut().flat_map(|p| &mut p.deformations) {
                d.phase.clear();
                d.easing = Default::default();
            }
            o
        }
        if file.objects.len() != self.file.objects.len()
            || file
                .objects
                .iter()
                .zip(&self.file.objects)
                .any(|(a, b)| shape(a) != shape(b))
        {
            return Ok(false);
        }
        let name = PathBuf::from("(scene)");
        let err = |at: String, message: String| AnimError::Scene {
            path: name.clone(),
            at,
            message,
        };
        check_scene(&file).map_err(|(a, m)| err(a, m))?;
        let mut warnings = Vec::new();
        let mut tracks = Vec::with_capacity(file.objects.len());
        for (oi, of) in file.objects.iter().enumerate() {
            let at = |k: &str| format!("objects[{oi}].{k}");
            let (trajectory, orientation) =
                load::object_tracks(of, &at, &mut warnings).map_err(|e| match e {
                    AnimError::Scene { at, message, .. } => err(at, message),
                    other => other,
                })?;
            let mut phases = Vec::new();
            for (pi, pf) in of.parts.iter().enumerate() {
                for (di, df) in pf.deformations.iter().enumerate() {
                    let here = |k: &str| at(&format!("parts[{pi}].deformations[{di}].{k}"));
                    phases.push(load::phase_track(df, &here).map_err(|e| match e {
                        AnimError::Scene { at, message, .. } => err(at, message),
                        other => other,
                    })?);
                }
            }
            tracks.push((trajectory, orientation, phases));
        }
        for (obj, (trajectory, orientation, phases)) in self.objects.iter_mut().zip(tracks) {
            obj.trajectory = trajectory;
            obj.orientation = orientation;
            for (anim, track) in obj.deformations.iter_mut().zip(phases) {
                anim.track = track;
            }
        }
        self.file = file;
        Ok(true)
    }

    /// Replaces object `index` by `object` and prepares only it again (its
    /// mesh, parts, deformations), taking meshes and control files from
    /// `assets` where it has them: what the Composer does when one object is
    /// edited. On error the scene is left as it was.
    pub fn update_object(
        &mut self,
        index: usize,
        object: ObjectFile,
        assets: &Assets,
    ) -> Result<()> {
        let name = PathBuf::from("(scene)");
        let err = |at: String, message: String| AnimError::Scene {
            path: name.clone(),
            at,
            message,
        };
        if index >= self.objects.len() {
            return Err(err(
                format!("objects[{index}]"),
                format!("there are only {} objects", self.objects.len()),
            ));
        }
        let mut file = self.file.clone();
        file.objects[index] = object;
        check_scene(&file).map_err(|(a, m)| err(a, m))?;
        if file
            .objects
            .iter()
            .enumerate()
            .any(|(k, o)| k != index && o.name == file.objects[index].name)
        {
            return Err(err(
                format!("objects[{index}].name"),
                format!(
                    "{:?} is used by another object; names must be unique",
                    file.objects[index].name
                ),
            ));
        }
        let mut warnings = Vec::new();
        let at = |k: &str| format!("objects[{index}].{k}");
        let fresh = load_object(&file.objects[index], &self.dir, assets, &at, &mut warnings)
            .map_err(|e| match e {
                AnimError::Scene { at, message, .. } => err(at, message),
                other => other,
            })?;
        let mut objects = self.objects.clone();
        objects[index] = fresh;
        for o in &mut objects {
            o.contact = None;
        }
        resolve_contacts(&file, &mut objects).map_err(|(a, m)| err(a, m))?;
        self.file = file;
        self.objects = objects;
        self.warnings.extend(warnings);
        Ok(())
    }
}
