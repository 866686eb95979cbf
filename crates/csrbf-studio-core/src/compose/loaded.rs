//! The scene a [`SceneDoc`] describes, loaded, and what loading it again
//! needs: an edit is applied to a copy of the document and the scene it
//! describes prepared first ([`Loaded::prepare`]: the loaded scene retimed
//! when only keys, timing or the camera changed, else loaded again with the
//! meshes read once); only when that succeeds does the edit land and the
//! scene get installed ([`Loaded::install`]: new stand-ins for big meshes
//! when the objects' shapes changed). The frame at the playhead is kept.

use std::collections::HashSet;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use csrbf::glam::{DVec3, Vec3};
use csrbf_anim::{AnimError, Assets, Frame, Scene, SceneFile};
use csrbf_mesh::StandIn;

use super::{KeyValue, SceneDoc, Track};
use crate::preview::BIG_MESH_TRIANGLES;

/// A loaded scene, its mesh cache, its stand-ins and its current frame.
#[derive(Default)]
pub struct Loaded {
    /// The loaded scene (None while it has no object or cannot load).
    pub scene: Option<Arc<Scene>>,
    /// Why the scene cannot load as it stands, if it cannot.
    pub problem: Option<String>,
    /// Identifies the GPU preparation of `scene` (changes when objects,
    /// parts or looks do).
    pub gpu_id: u64,
    /// The frame at the time of the last [`Loaded::frame_at`].
    pub frame: Arc<Frame>,
    /// The last time the scene was loaded whole, in ms.
    pub load_ms: f64,
    /// Lighter copies of the objects over [`BIG_MESH_TRIANGLES`], drawn
    /// while the scene plays or a key is dragged.
    pub stand_ins: Vec<Option<Arc<StandIn>>>,
    /// Meshes read once, by resolved path.
    assets: Assets,
    read: HashSet<PathBuf>,
    /// Which scene and time `frame` is of.
    frame_of: Option<(u64, f64)>,
    /// Bumped whenever `scene` changes.
    generation: u64,
}

impl Loaded {
    /// Nothing loaded.
    pub fn new() -> Loaded {
        Loaded::default()
    }

    /// Forgets the meshes read (the next load reads them again: after the
    /// Picker saved one of the files).
    pub fn forget_meshes(&mut self) {
        self.read.clear();
        self.assets = Assets::new();
    }

    /// Bumped whenever the scene changes (what is drawn follows it).
    pub fn generation(&self) -> u64 {
        self.generation
    }

    /// The scene `file` describes (`doc` gives its folder and name): the
    /// loaded one retimed when only keys, timing or the camera differ (no
    /// mesh read, no fit; unless `force`), else loaded again with meshes
    /// from the cache. What is installed is not changed.
    pub fn prepare(
        &mut self,
        doc: &SceneDoc,
        file: &SceneFile,
        force: bool,
    ) -> Result<Option<Scene>, AnimError> {
        if file.objects.is_empty() {
            return Ok(None);
        }
        if !force && let Some(s) = &self.scene {
            let mut s = (**s).clone();
            if s.retime(file.clone())? {
                return Ok(Some(s));
            }
        }
        let dir = doc.dir();
        for o in &file.objects {
            let p = csrbf_anim::path::resolve(&dir, &o.mesh);
            if !self.read.contains(&p)
                && let Ok(m) = csrbf_mesh::read(&p)
            {
                self.assets.set_mesh(p.clone(), m);
                self.read.insert(p);
            }
        }
        let name = doc
            .path
            .clone()
            .unwrap_or_else(|| PathBuf::from("(new scene)"));
        let started = Instant::now();
        let scene = Scene::from_file_with(file.clone(), &dir, &name, &self.assets)?;
        self.load_ms = started.elapsed().as_secs_f64() * 1e3;
        Ok(Some(scene))
    }

    /// Installs a prepared scene. Unless only keys or looks changed (and
    /// not `structural`), it gets a new GPU id from `next_id` and new
    /// stand-ins.
    pub fn install(&mut self, scene: Option<Scene>, structural: bool, next_id: &mut u64) {
        let same_shape = match (&self.scene, &scene) {
            (Some(a), Some(b)) => {
                !structural
                    && a.objects.len() == b.objects.len()
                    && a.file.objects.iter().zip(&b.file.objects).all(|(x, y)| {
                        x.mesh == y.mesh
                            && x.parts == y.parts
                            && x.scale == y.scale
                            && x.rotation == y.rotation
                    })
            }
            _ => false,
        };
        if !same_shape {
            self.gpu_id = *next_id;
            *next_id += 1;
            self.stand_ins = scene
                .iter()
                .flat_map(|s| &s.objects)
                .map(|o| {
                    (o.triangles.len() > BIG_MESH_TRIANGLES)
                        .then(|| Arc::new(StandIn::new(&o.mesh.positions, &o.triangles)))
                })
                .collect();
        }
        self.scene = scene.map(Arc::new);
        self.generation += 1;
        self.problem = None;
    }

    /// Makes [`Loaded::frame`] the scene at time `t` (computed only when the
    /// scene or the time changed).
    pub fn frame_at(&mut self, t: f64) {
        let Some(scene) = &self.scene else {
            return;
        };
        let at = (self.generation, t);
        if self.frame_of != Some(at) {
            scene.frame_into(t, Arc::make_mut(&mut self.frame));
            self.frame_of = Some(at);
        }
    }

    /// Retimes the loaded scene in place to `file` (a drag step: no undo
    /// step, the document unchanged until the drag ends).
    pub fn preview(&mut self, file: SceneFile) {
        if let Some(s) = self.scene.as_mut()
            && Arc::make_mut(s).retime(file).unwrap_or(false)
        {
            self.generation += 1;
        }
    }

    /// The value a new key of `track` of `object` gets at the playhead of
    /// `doc`: what the scene shows there now.
    pub fn value_now(&self, doc: &SceneDoc, object: usize, track: Track) -> Option<KeyValue> {
        let t = doc.playhead;
        let o = self.scene.as_ref()?.objects.get(object)?;
        Some(match track {
            Track::Position => KeyValue::Position(o.trajectory.position(t).to_array()),
            Track::Orientation => KeyValue::Orientation(o.orientation.rotation(t).to_array()),
            Track::Phase { part, deformation } => {
                // Deformations are listed part by part, in file order.
                let of = doc.file.objects.get(object)?;
                let flat = of
                    .parts
                    .get(..part)?
                    .iter()
                    .map(|p| p.deformations.len())
                    .sum::<usize>()
                    + deformation;
                KeyValue::Phase(o.deformations.get(flat)?.track.phase(t).clamp(0.0, 1.0))
            }
        })
    }

    /// Where object `object`'s frame is at `time`: its centre of gravity in
    /// the world.
    pub fn world_centre(&self, object: usize, time: f64) -> Option<Vec3> {
        world_centre(self.scene.as_deref()?, object, time)
    }
}

/// Where an object's frame is at `time`: its centre of gravity in the world.
pub fn world_centre(scene: &Scene, object: usize, time: f64) -> Option<Vec3> {
    let o = scene.objects.get(object)?;
    let (rot, shift) = o.transform(time);
    Some((rot * o.center + shift).as_vec3())
}

/// The world box of every object of `scene` over `duration` seconds
/// (sampled 17 times), and of the camera's eye and target when given.
pub fn scene_bounds(
    scene: &Scene,
    duration: f64,
    camera: Option<&csrbf_anim::CameraFile>,
) -> Option<(Vec3, Vec3)> {
    let mut lo = Vec3::INFINITY;
    let mut hi = Vec3::NEG_INFINITY;
    for (k, o) in scene.objects.iter().enumerate() {
        for j in 0..=16 {
            let c = world_centre(scene, k, duration * j as f64 / 16.0).unwrap_or_default();
            let r = o.radius as f32;
            lo = lo.min(c - Vec3::splat(r));
            hi = hi.max(c + Vec3::splat(r));
        }
    }
    if let Some(f) = camera
        && lo.is_finite()
    {
        for p in [f.eye, f.target] {
            let p = DVec3::from_array(p).as_vec3();
            lo = lo.min(p);
            hi = hi.max(p);
        }
    }
    lo.is_finite().then_some((lo, hi))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compose::SceneEdit;
    use std::path::Path;

    fn face() -> SceneDoc {
        let path =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/scenes/face.scene.json");
        SceneDoc::open(&path).expect("the face scene")
    }

    #[test]
    fn a_key_edit_retimes_and_a_new_object_loads_again_with_the_cache() {
        let mut doc = face();
        let mut loaded = Loaded::new();
        let mut next_id = 1;
        let scene = loaded.prepare(&doc, &doc.file, false).expect("loads");
        loaded.install(scene, false, &mut next_id);
        assert_eq!((loaded.gpu_id, next_id), (1, 2));
        assert!(
            loaded.stand_ins.len() == 1 && loaded.stand_ins[0].is_none(),
            "a small mesh draws itself"
        );
        let (reads, generation) = (loaded.read.len(), loaded.generation());
        // A position key at 3 s: retimed, the same GPU preparation (a phase
        // key is in the parts, whose change prepares the GPU again).
        doc.playhead = 3.0;
        let track = Track::Position;
        let value = loaded.value_now(&doc, 0, track).expect("a position");
        let mut edited = doc.clone();
        SceneEdit::AddKey {
            object: 0,
            track,
            value,
        }
        .apply(&mut edited)
        .expect("a key");
        let scene = loaded.prepare(&doc, &edited.file, false).expect("retimes");
        loaded.install(scene, false, &mut next_id);
        assert_eq!((loaded.gpu_id, loaded.generation()), (1, generation + 1));
        // A second object of the same mesh: loaded again, its mesh not read
        // again, a new GPU preparation.
        let mut twice = edited.file.clone();
        let mut copy = twice.objects[0].clone();
        copy.name = "again".into();
        twice.objects.push(copy);
        let scene = loaded.prepare(&edited, &twice, false).expect("loads");
        loaded.install(scene, false, &mut next_id);
        assert_eq!(loaded.gpu_id, 2);
        assert_eq!(loaded.read.len(), reads);
        assert_eq!(loaded.scene.as_ref().map(|s| s.objects.len()), Some(2));
    }

    #[test]
    fn the_value_now_is_what_the_frame_shows_and_the_frame_follows_the_time() {
        let doc = face();
        let mut loaded = Loaded::new();
        let scene = loaded.prepare(&doc, &doc.file, false).expect("loads");
        loaded.install(scene, false, &mut 1);
        let mut doc = doc;
        doc.playhead = 1.0;
        let Some(KeyValue::Orientation(q)) = loaded.value_now(&doc, 0, Track::Orientation) else {
            panic!("an orientation");
        };
        let scene = loaded.scene.clone().expect("loaded");
        let want = scene.objects[0].orientation.rotation(1.0).to_array();
        assert_eq!(q, want);
        loaded.frame_at(1.0);
        let at_one = loaded.frame.objects[0].positions.clone();
        loaded.frame_at(2.0);
        assert_ne!(loaded.frame.objects[0].positions, at_one);
        assert_eq!(
            loaded.frame.objects[0].positions,
            scene.frame(2.0).objects[0].positions
        );
        // A phase between keys is the track's, clamped to [0, 1].
        let Some(KeyValue::Phase(p)) = loaded.value_now(
            &doc,
            0,
            Track::Phase {
                part: 0,
                deformation: 0,
            },
        ) else {
            panic!("a phase");
        };
        assert!(p > 0.0 && p < 1.0, "{p}");
        assert!(loaded.value_now(&doc, 5, Track::Position).is_none());
    }

    #[test]
    fn the_bounds_hold_every_object_over_the_scene_and_the_camera_when_asked() {
        let doc = face();
        let mut loaded = Loaded::new();
        let scene = loaded.prepare(&doc, &doc.file, false).expect("loads");
        loaded.install(scene, false, &mut 1);
        let scene = loaded.scene.clone().expect("loaded");
        let (lo, hi) = scene_bounds(&scene, 4.0, None).expect("bounds");
        let c = loaded.world_centre(0, 0.0).expect("centre");
        assert!(c.cmpge(lo).all() && c.cmple(hi).all());
        let eye = Vec3::new(-30.0, 12.0, 12.0);
        assert!(!eye.cmpge(lo).all());
        let (lo, hi) = scene_bounds(&scene, 4.0, Some(&doc.file.camera)).expect("bounds");
        assert!(eye.cmpge(lo).all() && eye.cmple(hi).all());
    }
}
