//! Files to objects: checks, meshes, parts, deformations (fitted and bound
//! once), tracks, contacts.

use std::path::{Path, PathBuf};

use csrbf::{Binding, Combine, Region};
use csrbf_mesh::Mesh;
use glam::{DQuat, DVec3, Vec3};

use crate::file::{ObjectFile, PartFile, RotationFile, SceneFile};
use crate::rotation::{Orientation, OrientationKey};
use crate::spline::{PositionKey, Trajectory};
use crate::track::PhaseTrack;
use crate::{AnimError, Result};

use super::texture::embedded_texture;
use super::{
    Animated, Assets, BoundStage, Contact, DEFAULT_PART_COLOR, MAX_FPS, MAX_FRAMES, MAX_SIDE,
    Object, Part, frame_count, load_texture,
};

pub(super) fn check_scene(f: &SceneFile) -> std::result::Result<(), (String, String)> {
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
    for (i, l) in f.lights.iter().enumerate() {
        let d = DVec3::from_array(l.direction);
        if !d.is_finite() || d.length() == 0.0 {
            return bad(
                &format!("lights[{i}].direction"),
                format!(
                    "must be a finite, non-zero direction, got {:?}",
                    l.direction
                ),
            );
        }
        if l.color.iter().any(|c| !c.is_finite() || *c < 0.0) {
            return bad(
                &format!("lights[{i}].color"),
                format!("must be finite and >= 0, got {:?}", l.color),
            );
        }
        if !l.intensity.is_finite() || l.intensity < 0.0 {
            return bad(
                &format!("lights[{i}].intensity"),
                format!("must be finite and >= 0, got {}", l.intensity),
            );
        }
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
pub(super) fn resolve_contacts(
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

pub(super) fn load_object(
    of: &ObjectFile,
    dir: &Path,
    assets: &Assets,
    at: &dyn Fn(&str) -> String,
    warnings: &mut Vec<String>,
) -> Result<Object> {
    let mesh_path = crate::path::resolve(dir, &of.mesh);
    let mesh = assets
        .mesh(&mesh_path)
        .map_err(|e| scene_err(at("mesh"), e.to_string()))?;
    if !(of.scale > 0.0 && of.scale.is_finite()) {
        return Err(scene_err(
            at("scale"),
            format!("must be > 0, got {}", of.scale),
        ));
    }
    let rotation = match &of.rotation {
        Some(r) => rotation_of(r, &at("rotation"), warnings)?,
        None => DQuat::IDENTITY,
    };
    // Parts and control files are read against the mesh as its file has
    // it; the object's scale and base rotation then place the mesh and
    // every fitted map with it (`Deformation::placed`: the same map).
    let placement = Placement {
        scale: of.scale,
        rotation,
    };
    let placed_mesh = (!placement.is_identity()).then(|| {
        let m = (glam::DMat3::from_quat(rotation) * of.scale).as_mat3();
        let mut placed = mesh.clone();
        for p in &mut placed.positions {
            *p = m * *p;
        }
        placed
    });
    let placed = placed_mesh.as_ref().unwrap_or(&mesh);
    let (center, radius) = center_of_gravity(placed);
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
    let parts = own_faces(&mesh, parts);
    let mut deformations = Vec::new();
    for (pi, pf) in of.parts.iter().enumerate() {
        for (di, df) in pf.deformations.iter().enumerate() {
            let here = |k: &str| at(&format!("parts[{pi}].deformations[{di}].{k}"));
            deformations.push(load_deformation(
                &mesh, placed, placement, &parts[pi], pi, df, dir, assets, &here,
            )?);
        }
    }
    let (trajectory, orientation) = object_tracks(of, at, warnings)?;
    let mesh = placed_mesh.unwrap_or(mesh);
    let triangles = mesh.faces.triangles();
    let lanes = super::RestLanes::new(&mesh.positions, &deformations);
    Ok(Object {
        name: of.name.clone(),
        center,
        radius,
        parts,
        trajectory,
        orientation,
        deformations,
        contact: None,
        normals: csrbf_mesh::VertexNormals::new(&triangles, mesh.positions.len()),
        lanes,
        triangles,
        mesh,
    })
}

/// An object's trajectory and orientation from its keys, checked.
pub(super) fn object_tracks(
    of: &ObjectFile,
    at: &dyn Fn(&str) -> String,
    warnings: &mut Vec<String>,
) -> Result<(Trajectory, Orientation)> {
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
        let given = RotationFile {
            quaternion: k.quaternion,
            axis: k.axis,
            angle: k.angle,
            euler: k.euler,
        };
        let key = OrientationKey {
            time: k.time,
            rotation: rotation_of(&given, &here, warnings)?,
        };
        keys.push(key);
    }
    Ok((trajectory, Orientation::new(keys, of.interpolation)))
}

/// The rotation a [`RotationFile`] gives (an orientation key's or an
/// object's base rotation), checked; `here` is its place in the scene.
fn rotation_of(r: &RotationFile, here: &str, warnings: &mut Vec<String>) -> Result<DQuat> {
    Ok(match (r.quaternion, r.axis, r.angle, r.euler) {
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
            q / len
        }
        (None, Some(axis), Some(angle), None) => {
            let axis = DVec3::from_array(axis);
            if axis.length() == 0.0 || !axis.is_finite() {
                return Err(scene_err(
                    format!("{here}.axis"),
                    "the axis has zero length".into(),
                ));
            }
            if !angle.is_finite() {
                return Err(scene_err(
                    format!("{here}.angle"),
                    format!("must be a finite number of degrees, got {angle}"),
                ));
            }
            OrientationKey::from_axis_angle(0.0, axis, angle).rotation
        }
        (None, None, None, Some(e)) => {
            if !e.iter().all(|v| v.is_finite()) {
                return Err(scene_err(
                    format!("{here}.euler"),
                    format!("must be finite degrees, got {e:?}"),
                ));
            }
            OrientationKey::from_euler_degrees(0.0, DVec3::from_array(e)).rotation
        }
        _ => {
            return Err(scene_err(
                here.to_owned(),
                "give exactly one of \"quaternion\", \"axis\" with \"angle\", or \"euler\"".into(),
            ));
        }
    })
}

/// How an object's mesh is placed in the scene: `x -> scale * rotation * x`.
#[derive(Clone, Copy, Debug)]
pub(super) struct Placement {
    scale: f64,
    rotation: DQuat,
}

impl Placement {
    fn is_identity(&self) -> bool {
        self.scale == 1.0 && self.rotation == DQuat::IDENTITY
    }

    /// A point of the mesh's own frame, placed.
    fn point(&self, p: DVec3) -> DVec3 {
        self.rotation * p * self.scale
    }
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

/// Each face belongs to the last part that selects it: a whole-mesh part
/// first, then the pieces carved out of it (each drawn once, in its own
/// colour, and moved by its own deformations). A part's vertices are those
/// of the faces it keeps.
fn own_faces(mesh: &Mesh, mut parts: Vec<Part>) -> Vec<Part> {
    if parts.len() < 2 {
        return parts;
    }
    let mut owner = vec![usize::MAX; mesh.faces.len()];
    for (pi, p) in parts.iter().enumerate() {
        for &f in &p.faces {
            owner[f as usize] = pi;
        }
    }
    for (pi, p) in parts.iter_mut().enumerate() {
        p.faces.retain(|&f| owner[f as usize] == pi);
        p.vertices = face_vertices(mesh, &p.faces);
    }
    parts
}

/// The vertices of `faces`, ascending.
fn face_vertices(mesh: &Mesh, faces: &[u32]) -> Vec<u32> {
    let mut mark = vec![false; mesh.positions.len()];
    for &f in faces {
        for &v in mesh.faces.face(f as usize) {
            mark[v as usize] = true;
        }
    }
    (0..mark.len() as u32)
        .filter(|&v| mark[v as usize])
        .collect()
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
            let region = csrbf_edit::controls::parse_region(other, &at("select")).map_err(|e| {
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
    let vertices = face_vertices(mesh, &faces);
    let color = pf.color.map_or(DEFAULT_PART_COLOR, |c| c.0);
    let texture = match &pf.texture {
        // A part selected by a material of the mesh takes that material's
        // embedded image (glTF) when the scene names none.
        None => embedded_texture(mesh, &pf.select),
        Some(t) => Some(
            load_texture(&crate::path::resolve(dir, t))
                .map_err(|e| scene_err(at("texture"), e.to_string()))?,
        ),
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

/// A deformation's phase track from its keys, checked.
pub(super) fn phase_track(
    df: &crate::file::DeformationFile,
    at: &dyn Fn(&str) -> String,
) -> Result<PhaseTrack> {
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
    Ok(track)
}

#[allow(clippy::too_many_arguments)]
fn load_deformation(
    mesh: &Mesh,
    placed: &Mesh,
    placement: Placement,
    part: &Part,
    pi: usize,
    df: &crate::file::DeformationFile,
    dir: &Path,
    assets: &Assets,
    at: &dyn Fn(&str) -> String,
) -> Result<Animated> {
    let path = crate::path::resolve(dir, &df.controls);
    let cf = assets
        .controls(&path)
        .map_err(|e| scene_err(at("controls"), e.to_string()))?;
    // The edit layer's road: handles become control vectors on the rest
    // mesh, connected regions weights along it, regions are checked against
    // it, each deformation is fitted (single map or sweep) in one place.
    let source = path.display().to_string();
    let edit = csrbf_edit::fit(&cf, &source, Some(mesh), false, &mut |_| {})
        .map_err(|e| scene_err(at("controls"), csrbf_edit::error_chain(&e)))?;
    let mut stages = Vec::new();
    for ((spec, fitted), given) in edit.specs.iter().zip(edit.fitted).zip(&cf.deformations) {
        for step in fitted.stages {
            let si = stages.len();
            stages.push(
                bind_stage(
                    mesh,
                    placed,
                    placement,
                    part,
                    spec,
                    step,
                    given.name.clone(),
                    si > 0 && cf.combine == Combine::Chain,
                )
                .map_err(|e| scene_err(at("controls"), format!("{}: {e}", path.display())))?,
            );
        }
    }
    let track = phase_track(df, at)?;
    Ok(Animated {
        part: pi,
        controls: df.controls.clone(),
        stages,
        combine: cf.combine,
        track,
    })
}

/// One fitted stage bound to the part's vertices in its region: the
/// region is chosen on `mesh` (the file's frame), the map placed with the
/// mesh (`placed`). `per_frame`: a chained stage after the first, evaluated
/// every frame.
#[allow(clippy::too_many_arguments)]
fn bind_stage(
    mesh: &Mesh,
    placed: &Mesh,
    placement: Placement,
    part: &Part,
    spec: &csrbf_edit::controls::ControlSpec,
    step: csrbf::FittedStage,
    name: Option<String>,
    per_frame: bool,
) -> std::result::Result<BoundStage, csrbf::Error> {
    let deformation = if placement.is_identity() {
        step.deformation
    } else {
        step.deformation.placed(placement.scale, placement.rotation)
    };
    {
        // The stage acts on the part's vertices that are also in its region,
        // each by its weight there (less than 1 in a falloff).
        let (region, weights): (Vec<u32>, Vec<f32>) = if spec.region == Region::All {
            (part.vertices.clone(), vec![1.0; part.vertices.len()])
        } else {
            let (sel, w) = spec
                .region
                .weights(&mesh.positions, &|n| mesh.part_vertices(n))?;
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
        let pts: Vec<Vec3> = region
            .iter()
            .map(|&v| placed.positions[v as usize])
            .collect();
        let binding = Binding::new(&deformation, &pts);
        let (vertices, displacement) = if per_frame {
            (region.clone(), Vec::new())
        } else {
            let displacement = binding.displacements(&deformation)?;
            // The phase in the file, except for a sweep's step, which moves
            // by its share of it (BoundStage::displacement_factor).
            let phase = if step.sweep.is_some() {
                1.0
            } else {
                spec.phase as f32
            };
            // Keep only the vertices that move: a frame then touches nothing else.
            region
                .iter()
                .zip(displacement)
                .zip(&weights)
                .filter(|((_, d), _)| *d != Vec3::ZERO)
                .map(|((&v, d), w)| (v, d * (phase * w)))
                .unzip()
        };
        // The overlay shows a sweep's controls once, from start to destination.
        let targets = match step.sweep {
            Some(s) if s.index > 0 => Vec::new(),
            _ => spec.targets.iter().map(|&t| placement.point(t)).collect(),
        };
        Ok(BoundStage {
            deformation,
            targets,
            vertices,
            binding,
            displacement,
            phase: spec.phase as f32,
            region,
            weights,
            name,
            sweep: step.sweep,
        })
    }
}
