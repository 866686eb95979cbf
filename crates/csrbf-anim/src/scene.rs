//! A loaded scene: meshes read, parts selected, deformations fitted and
//! bound once, tracks built. [`Scene::frame`] gives every object's world
//! vertices at a time.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use csrbf::controls::ControlFile;
use csrbf::{Binding, Combine, Deformation, FitOptions, Kernel, Polynomial, Region, System};
use csrbf_mesh::Mesh;
use glam::{DQuat, DVec3, Vec3};

use crate::file::{ObjectFile, PartFile, SceneFile};
use crate::rotation::{Orientation, OrientationKey};
use crate::spline::{PositionKey, Trajectory};
use crate::track::PhaseTrack;
use crate::{AnimError, Result};

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
    /// Kernel weights of every vertex of its region.
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
    fn mesh(&self, path: &Path) -> std::result::Result<Mesh, String> {
        match self.meshes.get(path) {
            Some(m) => Ok(m.clone()),
            None => csrbf_mesh::read(path).map_err(|e| e.to_string()),
        }
    }

    /// The control file at `path`: the value given, else read and parsed.
    fn controls(&self, path: &Path) -> std::result::Result<ControlFile, String> {
        if let Some(c) = self.controls.get(path) {
            return Ok(c.clone());
        }
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
        ControlFile::parse(&text).map_err(|e| format!("{}: {e}", path.display()))
    }
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
}

/// Every object at one time.
#[derive(Clone, Debug, Default)]
pub struct Frame {
    /// The time.
    pub time: f64,
    /// One per scene object.
    pub objects: Vec<FrameObject>,
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

    /// Every object's world vertices, normals and control vectors at `time`.
    pub fn frame(&self, time: f64) -> Frame {
        let mut f = Frame::default();
        self.frame_into(time, &mut f);
        f
    }

    /// [`Scene::frame`] into an existing frame, reusing its buffers: for
    /// playback, where a frame a tick should allocate nothing.
    pub fn frame_into(&self, time: f64, frame: &mut Frame) {
        frame.time = time;
        frame
            .objects
            .resize_with(self.objects.len(), FrameObject::default);
        for (oi, (obj, out)) in self
            .objects
            .iter()
            .zip(frame.objects.iter_mut())
            .enumerate()
        {
            let local = &mut out.positions;
            local.clear();
            local.extend_from_slice(&obj.mesh.positions);
            let controls = &mut out.controls;
            controls.clear();
            for anim in &obj.deformations {
                let t = anim.track.phase(time) as f32;
                if anim.combine == Combine::Chain && anim.stages.len() > 1 {
                    Self::chain_frame(&obj.mesh.positions, anim, t, local);
                }
                for st in &anim.stages {
                    if anim.combine == Combine::Add || anim.stages.len() == 1 {
                        for (&v, d) in st.vertices.iter().zip(&st.displacement) {
                            local[v as usize] += *d * t;
                        }
                    }
                    for (s, g) in st.deformation.starts().iter().zip(&st.targets) {
                        let (s, g) = (s.as_vec3(), g.as_vec3());
                        controls.push((s, s + (g - s) * t, g, st.deformation.radius() as f32));
                    }
                }
            }
            if let Some(c) = &obj.contact {
                self.contact(oi, c, time, local, controls);
            }
            let (rot, shift) = obj.transform(time);
            let (rot32, shift32) = (rot.as_quat(), shift.as_vec3());
            csrbf_mesh::triangle_vertex_normals_into(local, &obj.triangles, &mut out.normals);
            for (p, n) in local.iter_mut().zip(out.normals.iter_mut()) {
                *p = rot32 * *p + shift32;
                *n = rot32 * *n;
            }
            for (s, p, g, _) in controls.iter_mut() {
                *s = rot32 * *s + shift32;
                *p = rot32 * *p + shift32;
                *g = rot32 * *g + shift32;
            }
        }
    }

    /// Adds what a chained control file does at track phase `t`: each stage after
    /// the first is evaluated at the points this file's stages before it moved
    /// (other files of the part add, as blend shapes do).
    fn chain_frame(rest: &[Vec3], anim: &Animated, t: f32, local: &mut [Vec3]) {
        for (l, d) in local.iter_mut().zip(Self::chain_at(rest, anim, t)) {
            *l += d;
        }
    }

    /// The displacement of every vertex by a chained control file at full
    /// track phase (each stage at its own phase in the file).
    pub fn chained_displacement(rest: &[Vec3], anim: &Animated) -> Vec<Vec3> {
        Self::chain_at(rest, anim, 1.0)
    }

    fn chain_at(rest: &[Vec3], anim: &Animated, t: f32) -> Vec<Vec3> {
        let mut x = rest.to_vec();
        for (si, st) in anim.stages.iter().enumerate() {
            if si == 0 {
                for (&v, d) in st.vertices.iter().zip(&st.displacement) {
                    x[v as usize] += *d * t;
                }
            } else {
                let pts: Vec<Vec3> = st.region.iter().map(|&v| x[v as usize]).collect();
                let d = st.deformation.displacements_f32(&pts);
                for ((&v, d), w) in st.region.iter().zip(d).zip(&st.weights) {
                    x[v as usize] += d * (st.phase * t * w);
                }
            }
        }
        for (x, r) in x.iter_mut().zip(rest) {
            *x -= *r;
        }
        x
    }

    /// Pushes the vertices of object `oi` inside the pusher's bounding sphere
    /// out to its surface: control vectors from the collision, system built
    /// and solved for this frame only.
    fn contact(
        &self,
        oi: usize,
        c: &Contact,
        time: f64,
        local: &mut [Vec3],
        controls: &mut Vec<(Vec3, Vec3, Vec3, f32)>,
    ) {
        let obj = &self.objects[oi];
        let pusher = &self.objects[c.with];
        let (prot, pshift) = pusher.transform(time);
        let centre_world = prot * pusher.center + pshift;
        let (rot, shift) = obj.transform(time);
        let centre = rot.inverse() * (centre_world - shift);
        // Vertices are pushed a little past the sphere: the faces between
        // them are chords that sag inside it by about h^2 / (8 r) for
        // vertices h apart, and near the rim a chord from a pushed vertex to
        // one left on the wall dips deeper. Four times the sag, h^2 / (2 r),
        // keeps the ball behind the wall (the demo's test checks every frame).
        let margin = c.spacing * c.spacing / (2.0 * pusher.radius);
        let r = pusher.radius + margin;
        let mut starts = Vec::new();
        let mut targets = Vec::new();
        let mut depth: f64 = 0.0;
        for p in local.iter() {
            let d = p.as_dvec3() - centre;
            let dist = d.length();
            if dist < r && dist > 1e-12 {
                starts.push(p.as_dvec3());
                targets.push(centre + d / dist * r);
                depth = depth.max(r - dist);
            }
        }
        if starts.is_empty() {
            return;
        }
        let radius = c.reach * (0.5 * r + depth);
        let opts = FitOptions::default()
            .with_kernel(c.kernel)
            .with_polynomial(Polynomial::None)
            .with_radius(radius);
        let Ok(def) = System::new(&starts, opts).and_then(|s| s.solve(&targets)) else {
            return;
        };
        let disp = def.displacements_f32(local);
        for (p, d) in local.iter_mut().zip(disp) {
            *p += d;
        }
        for (s, g) in starts.iter().zip(&targets) {
            controls.push((s.as_vec3(), g.as_vec3(), g.as_vec3(), radius as f32));
        }
    }
}

fn check_scene(f: &SceneFile) -> std::result::Result<(), (String, String)> {
    let bad = |at: &str, m: String| Err((at.to_owned(), m));
    if !(f.duration > 0.0 && f.duration.is_finite()) {
        return bad(
            "duration",
            format!("must be a number of seconds > 0, got {}", f.duration),
        );
    }
    if !(f.fps > 0.0 && f.fps <= MAX_FPS) {
        return bad(
            "fps",
            format!("must be within (0, {MAX_FPS}], got {}", f.fps),
        );
    }
    let frames = frame_count(f.duration, f.fps);
    if frames > MAX_FRAMES {
        return bad(
            "duration",
            format!(
                "{} s at {} fps is {frames} frames, more than the limit of {MAX_FRAMES} (movies and glTF export sample every frame): shorten it or lower fps",
                f.duration, f.fps
            ),
        );
    }
    if f.size.iter().any(|&s| s == 0 || s > MAX_SIDE) {
        return bad(
            "size",
            format!(
                "each side must be within 1..{MAX_SIDE} pixels, got {:?}",
                f.size
            ),
        );
    }
    let eye = DVec3::from_array(f.camera.eye);
    let target = DVec3::from_array(f.camera.target);
    if !eye.is_finite() || !target.is_finite() || eye.distance(target) == 0.0 {
        return bad(
            "camera",
            "eye and target must be finite and distinct".into(),
        );
    }
    if !(f.camera.fov > 1.0 && f.camera.fov < 179.0) {
        return bad(
            "camera.fov",
            format!("must be within (1, 179) degrees, got {}", f.camera.fov),
        );
    }
    if f.objects.is_empty() {
        return bad("objects", "the scene has no object".into());
    }
    Ok(())
}

/// Checks that key times increase strictly.
fn check_times(times: impl Iterator<Item = f64>, at: &dyn Fn(usize) -> String) -> Result<()> {
    let mut prev: Option<f64> = None;
    for (i, t) in times.enumerate() {
        if !t.is_finite() {
            return Err(scene_err(at(i), format!("time {t} is not a number")));
        }
        if let Some(p) = prev
            && t <= p
        {
            return Err(scene_err(
                at(i),
                format!("time {t} is not after the previous key's {p}: keys must be in time order"),
            ));
        }
        prev = Some(t);
    }
    Ok(())
}

/// Finds the object each contact deformation names and checks its numbers.
fn resolve_contacts(
    file: &SceneFile,
    objects: &mut [Object],
) -> std::result::Result<(), (String, String)> {
    for (oi, of) in file.objects.iter().enumerate() {
        if let Some(c) = &of.contact {
            let with = file
                .objects
                .iter()
                .position(|o| o.name == c.with)
                .filter(|&w| w != oi)
                .ok_or_else(|| {
                    (
                        format!("objects[{oi}].contact.with"),
                        format!("no other object is called {:?}", c.with),
                    )
                })?;
            let kernel = c.kernel;
            if !(c.reach > 0.0 && c.reach.is_finite()) {
                return Err((
                    format!("objects[{oi}].contact.reach"),
                    format!("must be > 0, got {}", c.reach),
                ));
            }
            let o = &objects[oi];
            let spacing = o
                .triangles
                .iter()
                .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
                .map(|(a, b)| o.mesh.positions[a as usize].distance(o.mesh.positions[b as usize]))
                .fold(0.0f32, f32::max) as f64;
            objects[oi].contact = Some(Contact {
                with,
                kernel,
                reach: c.reach,
                spacing,
            });
        }
    }
    Ok(())
}

fn scene_err(at: String, message: String) -> AnimError {
    AnimError::Scene {
        path: PathBuf::new(),
        at,
        message,
    }
}

fn load_object(
    of: &ObjectFile,
    dir: &Path,
    assets: &Assets,
    at: &dyn Fn(&str) -> String,
    warnings: &mut Vec<String>,
) -> Result<Object> {
    let mesh_path = dir.join(&of.mesh);
    let mut mesh = assets
        .mesh(&mesh_path)
        .map_err(|e| scene_err(at("mesh"), e))?;
    if !(of.scale > 0.0 && of.scale.is_finite()) {
        return Err(scene_err(
            at("scale"),
            format!("must be > 0, got {}", of.scale),
        ));
    }
    if of.scale != 1.0 {
        for p in &mut mesh.positions {
            *p *= of.scale as f32;
        }
    }
    let (center, radius) = center_of_gravity(&mesh);
    let parts = if of.parts.is_empty() {
        vec![make_part(
            &mesh,
            &PartFile {
                name: "all".into(),
                select: "all".into(),
                color: None,
                texture: None,
                wireframe: false,
                deformations: vec![],
            },
            dir,
            &|k| at(&format!("parts.{k}")),
        )?]
    } else {
        of.parts
            .iter()
            .enumerate()
            .map(|(pi, pf)| make_part(&mesh, pf, dir, &|k| at(&format!("parts[{pi}].{k}"))))
            .collect::<Result<Vec<_>>>()?
    };
    let mut deformations = Vec::new();
    for (pi, pf) in of.parts.iter().enumerate() {
        for (di, df) in pf.deformations.iter().enumerate() {
            let here = |k: &str| at(&format!("parts[{pi}].deformations[{di}].{k}"));
            deformations.push(load_deformation(
                &mesh, &parts[pi], pi, df, dir, assets, &here,
            )?);
        }
    }
    check_times(of.trajectory.iter().map(|k| k.time), &|i| {
        at(&format!("trajectory[{i}].time"))
    })?;
    for (i, k) in of.trajectory.iter().enumerate() {
        for (name, v) in [
            ("tension", k.tension),
            ("continuity", k.continuity),
            ("bias", k.bias),
        ] {
            if !(-1.0..=1.0).contains(&v) {
                return Err(scene_err(
                    at(&format!("trajectory[{i}].{name}")),
                    format!("must be within [-1, 1], got {v}"),
                ));
            }
        }
    }
    let trajectory = Trajectory::new(
        of.trajectory
            .iter()
            .map(|k| PositionKey {
                time: k.time,
                position: DVec3::from_array(k.position),
                tension: k.tension,
                continuity: k.continuity,
                bias: k.bias,
            })
            .collect(),
    );
    check_times(of.orientation.iter().map(|k| k.time), &|i| {
        at(&format!("orientation[{i}].time"))
    })?;
    let mut keys = Vec::new();
    for (i, k) in of.orientation.iter().enumerate() {
        let here = at(&format!("orientation[{i}]"));
        let key = match (k.quaternion, k.axis, k.angle, k.euler) {
            (Some(q), None, None, None) => {
                let q = DQuat::from_array(q);
                let len = q.length();
                if !(len > 1e-9) || !len.is_finite() {
                    return Err(scene_err(
                        format!("{here}.quaternion"),
                        "a zero quaternion is no rotation".into(),
                    ));
                }
                if (len - 1.0).abs() > 1e-6 {
                    warnings.push(format!(
                        "{here}.quaternion: length {len}, not 1: normalised"
                    ));
                }
                OrientationKey {
                    time: k.time,
                    rotation: q / len,
                }
            }
            (None, Some(axis), Some(angle), None) => {
                if DVec3::from_array(axis).length() == 0.0 {
                    return Err(scene_err(
                        format!("{here}.axis"),
                        "the axis has zero length".into(),
                    ));
                }
                OrientationKey::from_axis_angle(k.time, DVec3::from_array(axis), angle)
            }
            (None, None, None, Some(e)) => {
                OrientationKey::from_euler_degrees(k.time, DVec3::from_array(e))
            }
            _ => {
                return Err(scene_err(
                    here,
                    "give exactly one of \"quaternion\", \"axis\" with \"angle\", or \"euler\""
                        .into(),
                ));
            }
        };
        keys.push(key);
    }
    let interpolation = of.interpolation;
    Ok(Object {
        name: of.name.clone(),
        center,
        radius,
        parts,
        trajectory,
        orientation: Orientation::new(keys, interpolation),
        deformations,
        contact: None,
        triangles: mesh.faces.triangles(),
        mesh,
    })
}

/// Area-weighted centroid of the surface (vertex mean when there is no
/// face), and the largest distance of a vertex from it.
fn center_of_gravity(mesh: &Mesh) -> (DVec3, f64) {
    let mut sum = DVec3::ZERO;
    let mut area = 0.0;
    for f in mesh.faces.iter() {
        for [p0, a, b] in csrbf_mesh::fan(f) {
            let p = |i: u32| mesh.positions[i as usize].as_dvec3();
            let (p0, a, b) = (p(p0), p(a), p(b));
            let w = (a - p0).cross(b - p0).length() * 0.5;
            sum += (p0 + a + b) / 3.0 * w;
            area += w;
        }
    }
    let c = if area > 0.0 {
        sum / area
    } else {
        mesh.positions.iter().map(|p| p.as_dvec3()).sum::<DVec3>()
            / mesh.positions.len().max(1) as f64
    };
    let r = mesh
        .positions
        .iter()
        .map(|p| p.as_dvec3().distance(c))
        .fold(0.0, f64::max);
    (c, r)
}

fn make_part(mesh: &Mesh, pf: &PartFile, dir: &Path, at: &dyn Fn(&str) -> String) -> Result<Part> {
    let nf = mesh.faces.len() as u32;
    let faces: Vec<u32> = match &pf.select {
        serde_json::Value::String(s) if s == "all" => (0..nf).collect(),
        serde_json::Value::Object(o) if o.contains_key("group") => {
            let name = o["group"]
                .as_str()
                .ok_or_else(|| scene_err(at("select.group"), "expected a part name".into()))?;
            let mut f: Vec<u32> = mesh
                .parts
                .iter()
                .filter(|p| p.name == name)
                .flat_map(|p| p.faces.iter().copied())
                .collect();
            if f.is_empty() {
                let names: Vec<&str> = mesh.parts.iter().map(|p| p.name.as_str()).collect();
                return Err(scene_err(
                    at("select.group"),
                    format!("the mesh has no part {name:?} (it has {names:?})"),
                ));
            }
            f.sort_unstable();
            f.dedup();
            f
        }
        other => {
            // A region: faces whose every corner lies in it.
            let region = csrbf::controls::parse_region(other, &at("select")).map_err(|e| {
                scene_err(
                    at("select"),
                    format!(
                        "expected \"all\", {{\"group\": name}}, or a region: {}",
                        e.message
                    ),
                )
            })?;
            let inside = region
                .select(&mesh.positions, &|n| mesh.part_vertices(n))
                .map_err(|e| scene_err(at("select"), e.to_string()))?;
            let mut mark = vec![false; mesh.positions.len()];
            for v in inside {
                mark[v as usize] = true;
            }
            (0..nf)
                .filter(|&f| {
                    mesh.faces
                        .face(f as usize)
                        .iter()
                        .all(|&v| mark[v as usize])
                })
                .collect()
        }
    };
    let mut mark = vec![false; mesh.positions.len()];
    for &f in &faces {
        for &v in mesh.faces.face(f as usize) {
            mark[v as usize] = true;
        }
    }
    let vertices = (0..mark.len() as u32)
        .filter(|&v| mark[v as usize])
        .collect();
    let color = pf.color.map_or(DEFAULT_PART_COLOR, |c| c.0);
    let texture = match &pf.texture {
        // A part selected by a material of the mesh takes that material's
        // embedded image (glTF) when the scene names none.
        None => embedded_texture(mesh, &pf.select),
        Some(t) => {
            Some(load_texture(&dir.join(t)).map_err(|e| scene_err(at("texture"), e.to_string()))?)
        }
    };
    Ok(Part {
        name: pf.name.clone(),
        faces,
        vertices,
        color,
        texture,
        wireframe: pf.wireframe,
    })
}

/// The embedded texture of the material a part is selected by, or for a
/// part of the whole mesh the only textured material's, if any.
fn embedded_texture(mesh: &Mesh, select: &serde_json::Value) -> Option<Texture> {
    let textured: Vec<_> = mesh
        .materials
        .iter()
        .filter(|m| m.texture.is_some())
        .collect();
    let mat = match select.get("group").and_then(|g| g.as_str()) {
        Some(name) => mesh.materials.iter().find(|m| m.name == name)?,
        None if select.as_str() == Some("all") && textured.len() == 1 => textured[0],
        None => return None,
    };
    let (_, bytes) = mat.texture.as_ref()?;
    decode_texture(bytes.clone(), Path::new(&format!("material {}", mat.name))).ok()
}

/// A texture that cannot be used.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{}: {reason}", path.display())]
pub struct TextureError {
    /// The image file (or the material that embeds it).
    pub path: PathBuf,
    /// Why.
    pub reason: String,
}

/// Decodes a PNG or JPEG texture.
pub fn load_texture(path: &Path) -> std::result::Result<Texture, TextureError> {
    let encoded = std::fs::read(path).map_err(|e| TextureError {
        path: path.to_owned(),
        reason: e.to_string(),
    })?;
    decode_texture(encoded, path)
}

/// Decodes PNG or JPEG bytes; `path` names them in errors.
pub fn decode_texture(encoded: Vec<u8>, path: &Path) -> std::result::Result<Texture, TextureError> {
    let bad = |reason: String| TextureError {
        path: path.to_owned(),
        reason,
    };
    let format = image::guess_format(&encoded).map_err(|e| bad(format!("not an image: {e}")))?;
    let mime = match format {
        image::ImageFormat::Png => "image/png",
        image::ImageFormat::Jpeg => "image/jpeg",
        other => {
            return Err(bad(format!(
                "{other:?} images are not supported; use PNG or JPEG"
            )));
        }
    };
    let img = image::load_from_memory_with_format(&encoded, format)
        .map_err(|e| bad(format!("cannot decode the image: {e}")))?
        .to_rgba8();
    Ok(Texture {
        path: path.to_owned(),
        width: img.width(),
        height: img.height(),
        rgba: img.into_raw(),
        encoded,
        mime: mime.into(),
    })
}

fn load_deformation(
    mesh: &Mesh,
    part: &Part,
    pi: usize,
    df: &crate::file::DeformationFile,
    dir: &Path,
    assets: &Assets,
    at: &dyn Fn(&str) -> String,
) -> Result<Animated> {
    let path = dir.join(&df.controls);
    let cf = assets
        .controls(&path)
        .map_err(|e| scene_err(at("controls"), e))?;
    let mut stages = Vec::new();
    let lookup = |n: &str| mesh.part_vertices(n);
    for (si, spec) in cf.deformations.iter().enumerate() {
        // Handles become control vectors on the rest mesh.
        let spec = spec
            .resolve(&mesh.positions, &lookup)
            .map_err(|e| scene_err(at("controls"), format!("{}: {e}", path.display())))?;
        let sys = System::new(&spec.starts, spec.options)
            .map_err(|e| scene_err(at("controls"), format!("{}: {e}", path.display())))?;
        let deformation = sys
            .solve(&spec.targets)
            .map_err(|e| scene_err(at("controls"), format!("{}: {e}", path.display())))?;
        // The stage acts on the part's vertices that are also in its region,
        // each by its weight there (less than 1 in a falloff).
        let (region, weights): (Vec<u32>, Vec<f32>) = if spec.region == Region::All {
            (part.vertices.clone(), vec![1.0; part.vertices.len()])
        } else {
            let (sel, w) = spec
                .region
                .weights(&mesh.positions, &|n| mesh.part_vertices(n))
                .map_err(|e| scene_err(at("controls"), format!("{}: {e}", path.display())))?;
            let mut weight = vec![0.0f32; mesh.positions.len()];
            for (v, w) in sel.into_iter().zip(w) {
                weight[v as usize] = w;
            }
            part.vertices
                .iter()
                .copied()
                .filter(|&v| weight[v as usize] > 0.0)
                .map(|v| (v, weight[v as usize]))
                .unzip()
        };
        let pts: Vec<Vec3> = region.iter().map(|&v| mesh.positions[v as usize]).collect();
        let binding = Binding::new(&deformation, &pts);
        let per_frame = cf.combine == Combine::Chain && si > 0;
        let (vertices, displacement) = if per_frame {
            (region.clone(), Vec::new())
        } else {
            let displacement = binding
                .displacements(&deformation)
                .map_err(|e| scene_err(at("controls"), e.to_string()))?;
            // Keep only the vertices that move: a frame then touches nothing else.
            region
                .iter()
                .zip(displacement)
                .zip(&weights)
                .filter(|((_, d), _)| *d != Vec3::ZERO)
                .map(|((&v, d), w)| (v, d * (spec.phase as f32 * w)))
                .unzip()
        };
        stages.push(BoundStage {
            deformation,
            targets: spec.targets,
            vertices,
            binding,
            displacement,
            phase: spec.phase as f32,
            region,
            weights,
        });
    }
    check_times(df.phase.iter().map(|k| k.time), &|i| {
        at(&format!("phase[{i}].time"))
    })?;
    if let Some((i, k)) = df
        .phase
        .iter()
        .enumerate()
        .find(|(_, k)| !(0.0..=1.0).contains(&k.phase))
    {
        return Err(scene_err(
            at(&format!("phase[{i}].phase")),
            format!("must be within [0, 1], got {}", k.phase),
        ));
    }
    let easing = df.easing;
    let track = if df.phase.is_empty() {
        PhaseTrack::constant(1.0)
    } else {
        PhaseTrack::new(df.phase.iter().map(|k| (k.time, k.phase)).collect(), easing)
    };
    Ok(Animated {
        part: pi,
        controls: df.controls.clone(),
        stages,
        combine: cf.combine,
        track,
    })
}
