//! The papers' four examples as scene files with their models and control
//! files: `face` (an expression comes and goes, figure 1), `fish` (a duck
//! swims along a Kochanek-Bartels path, turning, beak, tail and wings
//! moving; figure 8), `ball` (a ball bounces in a box of 386 vertices whose
//! walls bulge where it hits, the system rebuilt and solved every frame;
//! figure 9) and `brick` (the same control vectors with three radii; figure 2).

use csrbf::{Combine, FitOptions, Kernel, Polynomial};
use csrbf_edit::controls::{ControlFile, ControlSpec};
use csrbf_mesh::shapes::{subdivided_box, uv_sphere};
use csrbf_mesh::{Format, Mesh};
use glam::{DVec3, Vec3};

use crate::file::*;
use crate::spline::{PositionKey, Trajectory};

/// The bundled head (CGAL, CC0) and its smile.
const HEAD: &[u8] = include_bytes!("../../../assets/models/cgal_head.off");
const SMILE: &[u8] = include_bytes!("../../../assets/controls/head_smile.json");
/// The bundled duck (pybullet, zlib).
const DUCK: &[u8] = include_bytes!("../../../assets/models/pybullet_duck.obj");

/// A demo: its scene, the files the scene refers to, and the time of its poster.
#[derive(Clone, Debug)]
pub struct Demo {
    /// The scene, with paths relative to the demo's folder.
    pub scene: SceneFile,
    /// Files to write beside the scene: relative path and bytes.
    pub files: Vec<(String, Vec<u8>)>,
    /// The time of the poster picture.
    pub poster: f64,
}

impl Demo {
    /// Writes the demo's files and its scene file (`NAME.scene.json`) into
    /// `dir`, each whole or not at all; returns the scene file's path.
    pub fn write(
        &self,
        dir: &std::path::Path,
        name: &str,
    ) -> csrbf_mesh::Result<std::path::PathBuf> {
        for (rel, bytes) in &self.files {
            let path = dir.join(rel);
            if let Some(parent) = path.parent() {
                std::fs::create_dir_all(parent).map_err(|source| csrbf_mesh::MeshError::Io {
                    path: parent.to_owned(),
                    source,
                })?;
            }
            csrbf_mesh::write_atomic(&path, bytes)?;
        }
        let scene = dir.join(format!("{name}.scene.json"));
        csrbf_mesh::write_atomic(&scene, self.scene.to_json().as_bytes())?;
        Ok(scene)
    }
}

/// The demos' names.
pub const DEMOS: [&str; 4] = ["face", "fish", "ball", "brick"];

/// The demo called `name`.
pub fn demo(name: &str) -> Option<Demo> {
    match name {
        "face" => Some(face()),
        "fish" => Some(fish()),
        "ball" => Some(ball()),
        "brick" => Some(brick()),
        _ => None,
    }
}

fn camera(eye: [f64; 3], target: [f64; 3], fov: f64) -> CameraFile {
    CameraFile {
        eye,
        target,
        up: [0.0, 1.0, 0.0],
        fov,
    }
}

fn object(name: &str, mesh: &str, parts: Vec<PartFile>) -> ObjectFile {
    ObjectFile {
        name: name.into(),
        mesh: mesh.into(),
        scale: 1.0,
        rotation: None,
        parts,
        trajectory: vec![],
        orientation: vec![],
        interpolation: Interpolation::Squad,
        contact: None,
    }
}

fn part(name: &str, color: [f32; 4], deformations: Vec<DeformationFile>) -> PartFile {
    PartFile {
        name: name.into(),
        select: "all".into(),
        color: Some(Color(color)),
        texture: None,
        wireframe: false,
        deformations,
    }
}

fn track(controls: &str, keys: &[(f64, f64)]) -> DeformationFile {
    DeformationFile {
        controls: controls.into(),
        phase: keys
            .iter()
            .map(|&(time, phase)| PhaseKeyFile { time, phase })
            .collect(),
        easing: Easing::Smooth,
    }
}

fn scene(duration: f64, cam: CameraFile, objects: Vec<ObjectFile>) -> SceneFile {
    SceneFile {
        duration,
        fps: 30.0,
        size: [1024, 768],
        background: [0.035, 0.04, 0.05],
        camera: cam,
        lights: vec![],
        objects,
    }
}

fn mesh_bytes(m: &Mesh, f: Format) -> Vec<u8> {
    m.to_bytes(f).unwrap_or_default()
}

/// A control file (the engine's writer): kernel, R, no polynomial, and
/// (start, destination) pairs.
fn controls(kernel: Kernel, radius: f64, pairs: &[(DVec3, DVec3)]) -> Vec<u8> {
    let spec = ControlSpec::new(
        pairs.iter().map(|p| p.0).collect(),
        pairs.iter().map(|p| p.1).collect(),
        FitOptions::new(radius)
            .with_kernel(kernel)
            .with_polynomial(Polynomial::None),
    );
    ControlFile::new(vec![spec], Combine::Chain)
        .to_text()
        .into_bytes()
}

fn face() -> Demo {
    let mut head = object(
        "head",
        "models/cgal_head.off",
        vec![part(
            "skin",
            [0.8, 0.48, 0.36, 1.0],
            vec![track(
                "controls/smile.json",
                &[(0.0, 0.0), (1.2, 1.0), (2.6, 1.0), (3.8, 0.0)],
            )],
        )],
    );
    head.orientation = vec![
        OrientationKeyFile {
            time: 0.0,
            quaternion: None,
            axis: Some([0.0, 1.0, 0.0]),
            angle: Some(-10.0),
            euler: None,
        },
        OrientationKeyFile {
            time: 2.0,
            quaternion: None,
            axis: Some([0.0, 1.0, 0.0]),
            angle: Some(12.0),
            euler: None,
        },
        OrientationKeyFile {
            time: 4.0,
            quaternion: None,
            axis: Some([0.0, 1.0, 0.0]),
            angle: Some(-10.0),
            euler: None,
        },
    ];
    Demo {
        scene: scene(
            4.0,
            camera([-30.0, 12.0, 12.0], [0.0, 9.0, 0.0], 38.0),
            vec![head],
        ),
        files: vec![
            ("models/cgal_head.off".into(), HEAD.to_vec()),
            ("controls/smile.json".into(), SMILE.to_vec()),
        ],
        poster: 1.9,
    }
}

/// The mesh vertex nearest to `p`.
fn snap(m: &Mesh, p: DVec3) -> DVec3 {
    m.positions
        .iter()
        .map(|v| v.as_dvec3())
        .min_by(|a, b| a.distance_squared(p).total_cmp(&b.distance_squared(p)))
        .unwrap_or(p)
}

/// Zero-length controls on vertices spread over the mesh, away from `moving`:
/// they pin the rest of the body so the motion stays where it belongs.
fn anchors(m: &Mesh, moving: &[DVec3], count: usize, keep_away: f64) -> Vec<(DVec3, DVec3)> {
    let n = m.positions.len();
    let mut out: Vec<(DVec3, DVec3)> = Vec::new();
    for k in 0..n {
        if out.len() >= count {
            break;
        }
        // A stride coprime with n walks the whole mesh evenly.
        let v = m.positions[(k * 7919) % n].as_dvec3();
        let far = moving.iter().all(|p| p.distance(v) > keep_away)
            && out.iter().all(|(a, _)| a.distance(v) > keep_away * 0.45);
        if far {
            out.push((v, v));
        }
    }
    out
}

fn moving(m: &Mesh, list: &[([f64; 3], [f64; 3])]) -> Vec<(DVec3, DVec3)> {
    let mut out: Vec<(DVec3, DVec3)> = Vec::new();
    for (p, d) in list {
        let s = snap(m, DVec3::from_array(*p));
        if out.iter().all(|(a, _)| a.distance(s) > 1e-6) {
            out.push((s, s + DVec3::from_array(*d)));
        }
    }
    out
}

fn fish() -> Demo {
    let duck = Mesh::from_bytes(DUCK, Format::Obj, "duck.obj".as_ref()).unwrap_or_default();
    // The duck looks along -x, y up; beak at x -0.95, tail at x +0.65.
    let beak = moving(
        &duck,
        &[
            ([-0.98, 1.27, 0.18], [0.0, 0.1, 0.0]),
            ([-0.95, 1.3, 0.05], [0.0, 0.08, 0.0]),
            ([-0.95, 1.3, 0.3], [0.0, 0.08, 0.0]),
            ([-0.9, 1.08, 0.18], [0.0, -0.1, 0.0]),
            ([-0.88, 1.1, 0.05], [0.0, -0.08, 0.0]),
            ([-0.88, 1.1, 0.3], [0.0, -0.08, 0.0]),
        ],
    );
    let tail = moving(
        &duck,
        &[
            ([0.69, 0.55, 0.0], [0.0, 0.05, 0.16]),
            ([0.66, 0.7, 0.0], [0.0, 0.05, 0.14]),
            ([0.62, 0.85, 0.0], [0.0, 0.04, 0.12]),
            ([0.62, 0.4, 0.0], [0.0, 0.0, 0.1]),
            ([0.6, 0.6, 0.3], [0.0, 0.03, 0.12]),
            ([0.6, 0.6, -0.25], [0.0, 0.03, 0.12]),
        ],
    );
    let wings = moving(
        &duck,
        &[
            ([0.0, 0.65, 0.6], [0.0, 0.12, 0.1]),
            ([0.2, 0.7, 0.57], [0.0, 0.14, 0.1]),
            ([-0.2, 0.6, 0.57], [0.0, 0.08, 0.08]),
            ([0.0, 0.65, -0.54], [0.0, 0.12, -0.1]),
            ([0.2, 0.7, -0.5], [0.0, 0.14, -0.1]),
            ([-0.2, 0.6, -0.52], [0.0, 0.08, -0.08]),
        ],
    );
    let all: Vec<DVec3> = beak
        .iter()
        .chain(&tail)
        .chain(&wings)
        .map(|c| c.0)
        .collect();
    let pins = anchors(&duck, &all, 25, 0.3);
    let with =
        |m: &[(DVec3, DVec3)]| -> Vec<(DVec3, DVec3)> { m.iter().chain(&pins).copied().collect() };
    let (b, t, w) = (with(&beak), with(&tail), with(&wings));
    let duration = 8.0;
    let osc = |period: f64, phase0: f64| -> Vec<(f64, f64)> {
        let mut keys = vec![];
        let mut time = 0.0;
        let mut up = phase0 > 0.5;
        while time <= duration + 1e-9 {
            keys.push((time, if up { 1.0 } else { 0.0 }));
            up = !up;
            time += period / 2.0;
        }
        keys
    };
    // A closed path on the water, with timing marks; the duck turns to follow it.
    let path = [
        (0.0, [0.0, 0.0, 0.0]),
        (2.0, [1.6, 0.0, -1.2]),
        (4.0, [3.2, 0.0, 0.0]),
        (6.0, [1.6, 0.0, 1.3]),
        (8.0, [0.0, 0.0, 0.0]),
    ];
    let keys: Vec<PositionKeyFile> = path
        .iter()
        .map(|&(time, position)| PositionKeyFile {
            time,
            position,
            tension: 0.0,
            continuity: 0.0,
            bias: 0.0,
        })
        .collect();
    let tr = Trajectory::new(
        keys.iter()
            .map(|k| PositionKey::new(k.time, DVec3::from_array(k.position)))
            .collect(),
    );
    let mut orientation = Vec::new();
    for k in 0..=16 {
        let time = k as f64 * duration / 16.0;
        let v = tr.velocity((time).clamp(0.01, duration - 0.01));
        let yaw = v.z.atan2(-v.x).to_degrees();
        orientation.push(OrientationKeyFile {
            time,
            quaternion: None,
            axis: Some([0.0, 1.0, 0.0]),
            angle: Some(yaw),
            euler: None,
        });
    }
    // Unwrap the yaw so consecutive keys differ by less than half a turn.
    for i in 1..orientation.len() {
        let (prev, cur) = (
            orientation[i - 1].angle.unwrap_or(0.0),
            orientation[i].angle.unwrap_or(0.0),
        );
        let mut a = cur;
        while a - prev > 180.0 {
            a -= 360.0;
        }
        while a - prev < -180.0 {
            a += 360.0;
        }
        orientation[i].angle = Some(a);
    }
    let mut obj = object(
        "duck",
        "models/pybullet_duck.obj",
        vec![part(
            "body",
            [0.95, 0.75, 0.15, 1.0],
            vec![
                track("controls/beak.json", &osc(0.9, 0.0)),
                track("controls/tail.json", &osc(0.7, 1.0)),
                track("controls/wings.json", &osc(1.3, 0.0)),
            ],
        )],
    );
    obj.trajectory = keys;
    obj.orientation = orientation;
    obj.interpolation = Interpolation::Squad;
    Demo {
        scene: scene(
            duration,
            camera([1.6, 3.4, 5.6], [1.6, 0.5, 0.0], 40.0),
            vec![obj],
        ),
        files: vec![
            ("models/pybullet_duck.obj".into(), DUCK.to_vec()),
            ("controls/beak.json".into(), controls(Kernel::C0, 0.3, &b)),
            ("controls/tail.json".into(), controls(Kernel::C0, 0.45, &t)),
            ("controls/wings.json".into(), controls(Kernel::C0, 0.4, &w)),
        ],
        poster: 2.4,
    }
}

fn ball() -> Demo {
    let boxm = subdivided_box(Vec3::splat(2.0), [8, 8, 8]);
    let sphere = uv_sphere(0.45, 12, 24);
    // The ball dips 0.2 into a wall at each impact key (tension 1: it slows
    // into the wall and leaves it), then flies to the next wall.
    let hits: [(f64, [f64; 3]); 7] = [
        (0.0, [0.0, 0.0, 0.0]),
        (0.8, [0.75, 0.2, 0.1]),
        (1.6, [-0.1, -0.75, 0.3]),
        (2.4, [-0.75, 0.1, -0.2]),
        (3.2, [0.2, 0.75, -0.1]),
        (4.0, [0.3, -0.1, 0.75]),
        (4.8, [0.0, 0.0, 0.0]),
    ];
    let trajectory = hits
        .iter()
        .enumerate()
        .map(|(i, &(time, position))| PositionKeyFile {
            time,
            position,
            tension: if i == 0 || i == hits.len() - 1 {
                0.0
            } else {
                1.0
            },
            continuity: 0.0,
            bias: 0.0,
        })
        .collect();
    let mut ball = object(
        "ball",
        "models/ball.obj",
        vec![part("ball", [0.85, 0.15, 0.1, 1.0], vec![])],
    );
    ball.trajectory = trajectory;
    let mut walls_part = part("walls", [0.55, 0.75, 1.0, 0.3], vec![]);
    walls_part.wireframe = true;
    let mut walls = object("box", "models/box.obj", vec![walls_part]);
    walls.contact = Some(ContactFile {
        with: "ball".into(),
        kernel: Kernel::C2,
        reach: 1.5,
    });
    Demo {
        scene: scene(
            4.8,
            camera([2.6, 2.2, 4.6], [0.0, 0.0, 0.0], 40.0),
            vec![ball, walls],
        ),
        files: vec![
            ("models/box.obj".into(), mesh_bytes(&boxm, Format::Obj)),
            ("models/ball.obj".into(), mesh_bytes(&sphere, Format::Obj)),
        ],
        poster: 0.8,
    }
}

fn brick() -> Demo {
    let brick = subdivided_box(Vec3::new(2.0, 0.6, 1.0), [20, 6, 10]);
    // The same control vectors: two dents in the top, one corner pulled out.
    let pairs = [
        (DVec3::new(-0.4, 0.3, 0.0), DVec3::new(-0.4, 0.05, 0.0)),
        (DVec3::new(0.5, 0.3, 0.2), DVec3::new(0.5, 0.12, 0.2)),
        (DVec3::new(1.0, -0.3, 0.5), DVec3::new(1.25, -0.35, 0.7)),
    ];
    let mut objects = Vec::new();
    let mut files = vec![("models/brick.obj".into(), mesh_bytes(&brick, Format::Obj))];
    for (i, r) in [0.3, 0.6, 1.2].into_iter().enumerate() {
        let name = format!("controls/brick_r{r}.json");
        files.push((name.clone(), controls(Kernel::C2, r, &pairs)));
        let mut o = object(
            &format!("brick R {r}"),
            "models/brick.obj",
            vec![part(
                "brick",
                [0.7, 0.3, 0.2, 1.0],
                vec![track(
                    &name,
                    &[(0.0, 0.0), (1.2, 1.0), (2.8, 1.0), (4.0, 0.0)],
                )],
            )],
        );
        o.trajectory = vec![PositionKeyFile {
            time: 0.0,
            position: [0.0, 1.0 - 1.0 * i as f64, 0.0],
            tension: 0.0,
            continuity: 0.0,
            bias: 0.0,
        }];
        objects.push(o);
    }
    Demo {
        scene: scene(4.0, camera([1.6, 1.4, 4.6], [0.0, 0.0, 0.0], 42.0), objects),
        files,
        poster: 2.0,
    }
}
