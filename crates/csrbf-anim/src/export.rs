//! glTF 2.0 export of a scene: meshes with their parts' materials and
//! textures, node translation and rotation sampled from the trajectories and
//! orientation keys, and every deformation stage as a morph target whose
//! weight follows its phase track. Contact deformations, rebuilt every frame,
//! have no morph-target form and are left out (the objects still move).

use csrbf_mesh::formats::gltf::{Builder, package};
use serde_json::{Value, json};

use csrbf::Combine;

use crate::scene::Scene;

/// What [`export_gltf`] cannot represent exactly, in words, for the user.
pub fn export_notes(scene: &Scene) -> Vec<String> {
    let mut notes = Vec::new();
    for obj in &scene.objects {
        for anim in &obj.deformations {
            if anim.combine == Combine::Chain && anim.stages.len() > 1 {
                notes.push(format!(
                    "{}: {}: its {} deformations are chained; glTF morph targets add, so the chain is exported as one morph target (the whole chain at full phase) weighted by its phase track: exact at phases 0 and 1, a straight blend between (\"combine\": \"add\" exports exactly)",
                    obj.name,
                    anim.controls,
                    anim.stages.len()
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
        let pos: Vec<f32> = obj
            .mesh
            .positions
            .iter()
            .flat_map(|p| p.to_array())
            .collect();
        let mut attributes = json!({ "POSITION": b.floats(&pos, 3, "VEC3", true) });
        let mut m = obj.mesh.clone();
        m.recompute_normals();
        let nrm: Vec<f32> = m
            .normals
            .unwrap_or_default()
            .iter()
            .flat_map(|p| p.to_array())
            .collect();
        attributes["NORMAL"] = json!(b.floats(&nrm, 3, "VEC3", false));
        let uvs = obj
            .mesh
            .uvs
            .as_ref()
            .and_then(|u| u.per_vertex(&obj.mesh.faces, n));
        if let Some(uv) = &uvs {
            // glTF's texture origin is the top left.
            let t: Vec<f32> = uv.iter().flat_map(|v| [v.x, 1.0 - v.y]).collect();
            attributes["TEXCOORD_0"] = json!(b.floats(&t, 2, "VEC2", false));
        }
        // One morph target per deformation stage.
        let mut targets = Vec::new();
        let mut target_names = Vec::new();
        let mut tracks = Vec::new();
        for anim in &obj.deformations {
            if anim.combine == Combine::Chain && anim.stages.len() > 1 {
                // A chain is not a sum of targets: one target, the whole
                // chain at full phase (see `export_notes`).
                let full = Scene::chained_displacement(&obj.mesh.positions, anim);
                let d: Vec<f32> = full.iter().flat_map(|v| v.to_array()).collect();
                targets.push(json!({ "POSITION": b.floats(&d, 3, "VEC3", true) }));
                target_names.push(anim.controls.clone());
                tracks.push(&anim.track);
                continue;
            }
            for (si, st) in anim.stages.iter().enumerate() {
                let mut d = vec![0.0f32; 3 * n];
                for (&v, dv) in st.vertices.iter().zip(&st.displacement) {
                    d[3 * v as usize..3 * v as usize + 3].copy_from_slice(&dv.to_array());
                }
                targets.push(json!({ "POSITION": b.floats(&d, 3, "VEC3", true) }));
                target_names.push(format!("{}#{si}", anim.controls));
                tracks.push(&anim.track);
            }
        }
        let mut primitives = Vec::new();
        for p in &obj.parts {
            let idx = obj.mesh.faces.triangle_indices(&p.faces);
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
            materials.push(json!({ "name": format!("{}/{}", obj.name, p.name), "pbrMetallicRoughness": pbr, "doubleSided": true }));
            let mut prim = json!({ "attributes": attributes.clone(), "indices": b.indices(&idx), "material": materials.len() - 1, "mode": 4 });
            if !targets.is_empty() {
                prim["targets"] = json!(targets.clone());
            }
            primitives.push(prim);
        }
        let mut mesh = json!({ "name": obj.name, "primitives": primitives });
        if !targets.is_empty() {
            mesh["weights"] = json!(tracks.iter().map(|t| t.phase(0.0)).collect::<Vec<_>>());
            mesh["extras"] = json!({ "targetNames": target_names });
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
                .flat_map(|&t| tracks.iter().map(move |tr| tr.phase(t as f64) as f32))
                .collect();
            let output = b.animation_floats(&w, 1, "SCALAR", false);
            samplers.push(json!({ "input": input, "output": output, "interpolation": "LINEAR" }));
            channels.push(json!({ "sampler": samplers.len() - 1, "target": { "node": oi, "path": "weights" } }));
        }
    }
    let mut doc = json!({
        "asset": { "version": "2.0", "generator": "csrbf" },
        "scene": 0,
        "scenes": [{ "nodes": (0..nodes.len()).collect::<Vec<_>>() }],
        "nodes": nodes,
        "meshes": meshes,
        "materials": materials,
    });
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
