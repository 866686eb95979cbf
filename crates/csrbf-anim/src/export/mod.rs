//! glTF 2.0 export of a scene: meshes with their parts' materials and
//! textures (vertices split at UV seams), node translation and rotation
//! sampled from the trajectories and orientation keys, every deformation
//! stage as a named morph target whose weight follows its phase track, the
//! scene's camera and lights, and its fps and duration in the asset's
//! extras. Contact deformations, rebuilt every frame, have no morph-target
//! form and are left out (the objects still move).

mod names;
#[cfg(test)]
mod tests;
mod view;

use names::target_names;

use csrbf_mesh::formats::gltf::{Builder, package, split_uv_seams};
use glam::Vec3;
use serde_json::{Value, json};

use csrbf::Combine;

use crate::scene::Scene;

/// What [`export_gltf`] cannot represent exactly, in words, for the user.
pub fn export_notes(scene: &Scene) -> Vec<String> {
    let mut notes = Vec::new();
    for obj in &scene.objects {
        for anim in &obj.deformations {
            if is_one_sweep(anim) {
                notes.push(format!(
                    "{}: {}: a fold-free sweep of {} steps, exported as one morph target per step whose weights rise one after another (exact at every phase)",
                    obj.name,
                    anim.controls,
                    anim.stages.len()
                ));
            }
            if exported_whole(anim) {
                notes.push(format!(
                    "{}: {}: its {} deformations are chained; glTF morph targets add, so the chain is exported as one morph target (the whole chain at full phase) weighted by its phase track: exact at phases 0 and 1, a straight blend between (\"combine\": \"add\" exports exactly)",
                    obj.name,
                    anim.controls,
                    anim.stages.len()
                ));
            }
        }
        let has_uvs = obj.mesh.uvs.is_some();
        for p in &obj.parts {
            if p.texture.is_some() && !has_uvs {
                notes.push(format!(
                    "{}: {}: the mesh has no UVs, so its texture is left out",
                    obj.name, p.name
                ));
            }
            if p.wireframe {
                notes.push(format!(
                    "{}: {}: glTF has no wireframe look; the part is exported as a surface",
                    obj.name, p.name
                ));
            }
        }
        if obj.contact.is_some() {
            notes.push(format!(
                "{}: its contact deformation is rebuilt every frame and has no morph-target form; it is left out (the objects still move)",
                obj.name
            ));
        }
    }
    notes
}

/// Whether a deformation is exported as one morph target (a chain of
/// several, which morph targets cannot add up to) rather than one per stage.
fn exported_whole(anim: &crate::scene::Animated) -> bool {
    anim.combine == Combine::Chain && anim.stages.len() > 1 && !is_one_sweep(anim)
}

/// Whether a control file is one fold-free sweep: exported as one morph
/// target per step, whose weights rise one after another. Exact at every
/// phase: step j moves each vertex straight from where the steps before it
/// left it, by its weight times its target.
fn is_one_sweep(anim: &crate::scene::Animated) -> bool {
    let k = anim.stages.len();
    k > 1
        && anim.stages.iter().enumerate().all(|(j, s)| {
            s.sweep
                .is_some_and(|s| s.index as usize == j && s.count as usize == k)
        })
}

/// Each step's move of every vertex of a sweep at full phase (the steps
/// before it in full): its morph targets.
fn sweep_targets(rest: &[Vec3], anim: &crate::scene::Animated) -> Vec<Vec<Vec3>> {
    let mut x = rest.to_vec();
    anim.stages
        .iter()
        .map(|st| {
            let pts: Vec<Vec3> = st.region.iter().map(|&v| x[v as usize]).collect();
            let d = st.deformation.displacements_f32(&pts);
            let mut full = vec![Vec3::ZERO; rest.len()];
            for ((&v, d), w) in st.region.iter().zip(d).zip(&st.weights) {
                full[v as usize] = d * *w;
                x[v as usize] += d * *w;
            }
            full
        })
        .collect()
}

/// A morph target's weight over time: its file's phase track, or a sweep's
/// step's share of it.
struct Weight<'a> {
    track: &'a crate::track::PhaseTrack,
    step: Option<&'a crate::scene::BoundStage>,
}

impl Weight<'_> {
    fn at(&self, time: f64) -> f32 {
        let t = self.track.phase(time) as f32;
        self.step.map_or(t, |s| s.phase_at(t))
    }
}

/// The scene as glTF: binary `.glb` or `.gltf` JSON with an embedded buffer.
pub fn export_gltf(scene: &Scene, glb: bool) -> Vec<u8> {
    let mut b = Builder::default();
    let (mut nodes, mut meshes, mut materials, mut images, mut textures) =
        (vec![], vec![], vec![], vec![], vec![]);
    let fps = scene.file.fps;
    let frames = scene.frame_count();
    let times: Vec<f32> = (0..frames)
        .map(|k| (k as f64 / fps).min(scene.file.duration) as f32)
        .collect();
    let mut samplers = Vec::new();
    let mut channels = Vec::new();
    let input = b.animation_floats(&times, 1, "SCALAR", true);

    for (oi, obj) in scene.objects.iter().enumerate() {
        let n = obj.mesh.positions.len();
        // glTF keeps one UV per vertex: a mesh with UV seams is written with
        // its seam vertices split (as `csrbf deform --out x.glb` writes it),
        // every per-vertex attribute and morph target copied to the splits.
        let split = split_uv_seams(&obj.mesh);
        let source: Vec<u32> = split
            .as_ref()
            .map_or_else(|| (0..n as u32).collect(), |s| s.source.clone());
        let written = |per_vertex: &[Vec3]| -> Vec<f32> {
            source
                .iter()
                .flat_map(|&v| per_vertex[v as usize].to_array())
                .collect()
        };
        let pos = written(&obj.mesh.positions);
        let mut attributes = json!({ "POSITION": b.floats(&pos, 3, "VEC3", true) });
        // The rest mesh's own normals where it has them: recomputed on a
        // mesh read split at UV seams, they would differ across the seams.
        let nrm = match &obj.mesh.normals {
            Some(own) if own.len() == n => written(own),
            _ => {
                let mut m = obj.mesh.clone();
                m.recompute_normals();
                written(m.normals.as_deref().unwrap_or(&obj.mesh.positions[..]))
            }
        };
        attributes["NORMAL"] = json!(b.floats(&nrm, 3, "VEC3", false));
        let uvs = match &split {
            Some(s) => Some(s.uvs.clone()),
            None => obj
                .mesh
                .uvs
                .as_ref()
                .and_then(|u| u.per_vertex(&obj.mesh.faces, n)),
        };
        if let Some(uv) = &uvs {
            // glTF's texture origin is the top left.
            let t: Vec<f32> = uv.iter().flat_map(|v| [v.x, 1.0 - v.y]).collect();
            attributes["TEXCOORD_0"] = json!(b.floats(&t, 2, "VEC2", false));
        }
        // One morph target per deformation stage.
        let mut targets = Vec::new();
        let names = target_names(&obj.deformations, exported_whole);
        let mut tracks = Vec::new();
        for anim in &obj.deformations {
            if is_one_sweep(anim) {
                for (st, full) in anim
                    .stages
                    .iter()
                    .zip(sweep_targets(&obj.mesh.positions, anim))
                {
                    let d = written(&full);
                    targets.push(json!({ "POSITION": b.floats(&d, 3, "VEC3", true) }));
                    tracks.push(Weight {
                        track: &anim.track,
                        step: Some(st),
                    });
                }
                continue;
            }
            if exported_whole(anim) {
                // A chain is not a sum of targets: one target, the whole
                // chain at full phase (see `export_notes`).
                let full = Scene::chained_displacement(&obj.mesh.positions, anim);
                let d = written(&full);
                targets.push(json!({ "POSITION": b.floats(&d, 3, "VEC3", true) }));
                tracks.push(Weight {
                    track: &anim.track,
                    step: None,
                });
                continue;
            }
            for st in &anim.stages {
                let mut full = vec![Vec3::ZERO; n];
                for (&v, dv) in st.vertices.iter().zip(&st.displacement) {
                    full[v as usize] = *dv;
                }
                let d = written(&full);
                targets.push(json!({ "POSITION": b.floats(&d, 3, "VEC3", true) }));
                tracks.push(Weight {
                    track: &anim.track,
                    step: None,
                });
            }
        }
        let mut primitives = Vec::new();
        for p in &obj.parts {
            let idx = match &split {
                Some(s) => s.triangle_indices(&obj.mesh.faces, &p.faces),
                None => obj.mesh.faces.triangle_indices(&p.faces),
            };
            if idx.is_empty() {
                continue;
            }
            let mut pbr = json!({ "baseColorFactor": p.color, "metallicFactor": 0.0, "roughnessFactor": 0.7 });
            if let (Some(t), true) = (&p.texture, uvs.is_some()) {
                let view = b.view(&t.encoded, None);
                images.push(json!({ "bufferView": view, "mimeType": t.mime }));
                textures.push(json!({ "source": images.len() - 1, "sampler": 0 }));
                pbr["baseColorTexture"] = json!({ "index": textures.len() - 1 });
            }
            let mut material = json!({ "name": format!("{}/{}", obj.name, p.name), "pbrMetallicRoughness": pbr, "doubleSided": true });
            let see_through = p.color[3] < 1.0
                || (uvs.is_some()
                    && p.texture
                        .as_ref()
                        .is_some_and(|t| t.rgba.chunks_exact(4).any(|px| px[3] < 255)));
            if see_through {
                material["alphaMode"] = json!("BLEND");
            }
            materials.push(material);
            let mut prim = json!({ "attributes": attributes.clone(), "indices": b.indices(&idx), "material": materials.len() - 1, "mode": 4 });
            if !targets.is_empty() {
                prim["targets"] = json!(targets.clone());
            }
            primitives.push(prim);
        }
        let mut mesh = json!({ "name": obj.name, "primitives": primitives });
        if !targets.is_empty() {
            mesh["weights"] = json!(tracks.iter().map(|t| t.at(0.0)).collect::<Vec<_>>());
            mesh["extras"] = json!({ "targetNames": names });
        }
        meshes.push(mesh);
        let (rot0, shift0) = obj.transform(0.0);
        nodes.push(json!({
            "name": obj.name, "mesh": oi,
            "translation": shift0.as_vec3().to_array(), "rotation": rot0.as_quat().normalize().to_array(),
        }));

        // Rigid motion, sampled.
        if obj.trajectory.keys().len() > 1 || obj.orientation.keys().len() > 1 {
            let mut tr = Vec::with_capacity(3 * frames);
            let mut ro = Vec::with_capacity(4 * frames);
            for &t in &times {
                let (r, s) = obj.transform(t as f64);
                tr.extend_from_slice(&s.as_vec3().to_array());
                ro.extend_from_slice(&r.as_quat().normalize().to_array());
            }
            for (path, data, width, ty) in
                [("translation", tr, 3, "VEC3"), ("rotation", ro, 4, "VEC4")]
            {
                let output = b.animation_floats(&data, width, ty, false);
                samplers
                    .push(json!({ "input": input, "output": output, "interpolation": "LINEAR" }));
                channels.push(json!({ "sampler": samplers.len() - 1, "target": { "node": oi, "path": path } }));
            }
        }
        // Morph weights follow the phase tracks.
        if !tracks.is_empty() {
            let w: Vec<f32> = times
                .iter()
                .flat_map(|&t| tracks.iter().map(move |tr| tr.at(t as f64)))
                .collect();
            let output = b.animation_floats(&w, 1, "SCALAR", false);
            samplers.push(json!({ "input": input, "output": output, "interpolation": "LINEAR" }));
            channels.push(json!({ "sampler": samplers.len() - 1, "target": { "node": oi, "path": "weights" } }));
        }
    }
    let view = view::view_nodes(&scene.file);
    nodes.extend(view.nodes);
    // glTF has no frame rate: the scene's timing, for tools that look (in the
    // asset's extras, and the scene's, which Blender's importer can keep as
    // custom properties).
    let timing = json!({ "fps": fps, "duration": scene.file.duration, "frames": frames });
    let mut doc = json!({
        "asset": { "version": "2.0", "generator": "csrbf", "extras": timing },
        "scene": 0,
        "scenes": [{ "nodes": (0..nodes.len()).collect::<Vec<_>>(), "extras": timing }],
        "nodes": nodes,
        "meshes": meshes,
        "materials": materials,
        "cameras": view.cameras,
    });
    if !view.lights.is_empty() {
        doc["extensionsUsed"] = json!([view::LIGHTS_EXTENSION]);
        doc["extensions"] = json!({ view::LIGHTS_EXTENSION: { "lights": view.lights } });
    }
    if !channels.is_empty() {
        doc["animations"] =
            json!([{ "name": "scene", "samplers": samplers, "channels": channels }]);
    }
    if !images.is_empty() {
        doc["images"] = json!(images);
        doc["textures"] = json!(textures);
        doc["samplers"] = json!([{ "magFilter": 9729, "minFilter": 9729 }]);
    }
    doc["bufferViews"] = Value::Array(b.views);
    doc["accessors"] = Value::Array(b.accessors);
    package(doc, b.bin, glb)
}
