//! glTF export: what arrives in the file (issue 24).

use std::path::PathBuf;

use serde_json::Value;

use crate::*;

/// A demo written into a fresh temporary folder, removed on drop.
struct DemoDir(PathBuf);

impl DemoDir {
    fn new(demo: &str, tag: &str) -> (DemoDir, PathBuf) {
        let d = std::env::temp_dir().join(format!("csrbf-export-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).expect("dir");
        let scene = demos::demo(demo)
            .expect("demo")
            .write(&d, demo)
            .expect("write demo");
        (DemoDir(d), scene)
    }
}

impl Drop for DemoDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// The JSON chunk of a GLB.
fn glb_json(glb: &[u8]) -> Value {
    let len = u32::from_le_bytes(glb[12..16].try_into().expect("4 bytes")) as usize;
    serde_json::from_slice(&glb[20..20 + len]).expect("GLB JSON")
}

/// Issue 24, item 1: the duck has UV seams (2277 UVs for 2108 vertices);
/// a texture on its part was silently dropped from the export.
#[test]
fn a_texture_on_a_mesh_with_uv_seams_is_exported() {
    let (d, scene) = DemoDir::new("fish", "seams");
    let img = image::RgbaImage::from_fn(8, 8, |x, y| {
        image::Rgba(if (x + y) % 2 == 0 {
            [250, 10, 10, 255]
        } else {
            [10, 10, 250, 255]
        })
    });
    img.save(d.0.join("checker.png")).expect("png");
    let mut file =
        SceneFile::parse(&std::fs::read_to_string(&scene).expect("read")).expect("parse");
    file.objects[0].parts[0].texture = Some("checker.png".into());
    std::fs::write(&scene, file.to_json()).expect("write");
    let s = Scene::load(&scene).expect("load");
    let rest = &s.objects[0].mesh;
    let n = rest.positions.len();
    let glb = export_gltf(&s, true);
    let doc = glb_json(&glb);
    assert_eq!(doc["images"].as_array().map(Vec::len), Some(1), "no image");
    let prim = &doc["meshes"][0]["primitives"][0];
    let tex = prim["attributes"]["TEXCOORD_0"].as_u64().expect("no UVs") as usize;
    let pos = prim["attributes"]["POSITION"].as_u64().expect("positions") as usize;
    let count = |a: usize| doc["accessors"][a]["count"].as_u64().unwrap_or(0) as usize;
    // The seams are split: more vertices than the mesh, one UV each, and
    // every morph target as long as the positions.
    assert!(count(pos) > n, "{} written for {n}", count(pos));
    assert_eq!(count(tex), count(pos));
    for t in prim["targets"].as_array().expect("targets") {
        assert_eq!(
            count(t["POSITION"].as_u64().expect("target") as usize),
            count(pos)
        );
    }
    let pbr = &doc["materials"][0]["pbrMetallicRoughness"];
    assert_eq!(pbr["baseColorTexture"]["index"], 0);

    // Read back: the image is the one given, every corner keeps its UV, and
    // each written vertex sits where its source vertex does.
    let back = csrbf_mesh::Mesh::from_bytes(&glb, csrbf_mesh::Format::Glb, "x.glb".as_ref())
        .expect("read back");
    let (_, bytes) = back
        .materials
        .iter()
        .find_map(|m| m.texture.as_ref())
        .expect("texture read back");
    assert_eq!(bytes, &std::fs::read(d.0.join("checker.png")).expect("png"));
    let uv = rest.uvs.as_ref().expect("duck UVs");
    let uv_back = back.uvs.as_ref().expect("UVs read back");
    let corner_uv = |t: &csrbf_mesh::TexCoords, k: usize| match &t.corners {
        Some(c) => t.values[c[k] as usize],
        None => t.values[back.faces.indices[k] as usize],
    };
    let tris: Vec<u32> = rest
        .faces
        .triangle_indices(&(0..rest.faces.len() as u32).collect::<Vec<_>>());
    assert_eq!(back.faces.indices.len(), tris.len());
    // Corner k of the rest mesh's fan triangles, in its own UVs.
    let starts: Vec<usize> = rest.faces.offsets.iter().map(|&o| o as usize).collect();
    let mut rest_corner_uv = Vec::new();
    for f in 0..rest.faces.len() {
        let local: Vec<usize> = (starts[f]..starts[f + 1]).collect();
        for tri in csrbf_mesh::fan(&local) {
            for c in tri {
                let t = uv
                    .corners
                    .as_ref()
                    .map_or(rest.faces.indices[c], |cs| cs[c]);
                rest_corner_uv.push(uv.values[t as usize]);
            }
        }
    }
    // The reader places the mesh where its node is at time 0.
    let node = &doc["nodes"][0];
    let f = |v: &Value, k: usize| v[k].as_f64().unwrap_or(0.0) as f32;
    let t = &node["translation"];
    let r = &node["rotation"];
    let shift = glam::Vec3::new(f(t, 0), f(t, 1), f(t, 2));
    let turn = glam::Quat::from_xyzw(f(r, 0), f(r, 1), f(r, 2), f(r, 3));
    for (k, &v) in tris.iter().enumerate() {
        let got = back.positions[back.faces.indices[k] as usize];
        let want = turn * rest.positions[v as usize] + shift;
        assert!((got - want).length() < 1e-4, "corner {k}: {got} vs {want}");
        assert!(
            (corner_uv(uv_back, k) - rest_corner_uv[k]).length() < 1e-6,
            "corner {k}'s UV"
        );
    }
}

/// Issue 24, item 4: the ball demo's box has colour alpha 0.3 and no
/// `alphaMode`, so readers drew it opaque; its wireframe look is said lost.
#[test]
fn see_through_parts_blend_and_a_wireframe_is_named_in_the_notes() {
    let (_d, scene) = DemoDir::new("ball", "alpha");
    let s = Scene::load(&scene).expect("load");
    let doc = glb_json(&export_gltf(&s, true));
    for (m, obj_part) in doc["materials"]
        .as_array()
        .expect("materials")
        .iter()
        .zip(s.objects.iter().flat_map(|o| &o.parts))
    {
        let blend = m["alphaMode"] == "BLEND";
        assert_eq!(blend, obj_part.color[3] < 1.0, "{m}");
    }
    assert!(
        doc["materials"]
            .as_array()
            .expect("materials")
            .iter()
            .any(|m| m["alphaMode"] == "BLEND")
    );
    let wire: Vec<_> = s
        .objects
        .iter()
        .flat_map(|o| &o.parts)
        .filter(|p| p.wireframe)
        .collect();
    assert!(!wire.is_empty(), "the ball demo draws the box's edges");
    let notes = export_notes(&s).join("\n");
    assert!(notes.contains("wireframe"), "{notes}");
}

/// Issue 24, item 5: morph targets were named after the control file's path
/// plus `#0`; Blender cut two files of one long folder to the same prefix.
#[test]
fn morph_targets_are_named_by_name_or_stem_short_and_unique() {
    let (d, scene) = DemoDir::new("fish", "names");
    let s = Scene::load(&scene).expect("load");
    let doc = glb_json(&export_gltf(&s, true));
    assert_eq!(
        doc["meshes"][0]["extras"]["targetNames"],
        serde_json::json!(["beak", "tail", "wings"])
    );
    // Two files in a long folder, one named in its file, one the same stem twice.
    let long = "a_very_long_folder_name_that_goes_on_and_on_for_quite_a_while_indeed";
    std::fs::create_dir_all(d.0.join(long).join("x")).expect("dir");
    let beak = std::fs::read_to_string(d.0.join("controls/beak.json")).expect("beak");
    let named = beak.replacen('{', "{\"name\": \"open beak\", ", 1);
    std::fs::write(d.0.join(long).join("expr_beak.json"), named).expect("write");
    std::fs::write(d.0.join(long).join("expr_tail.json"), &beak).expect("write");
    std::fs::write(d.0.join(long).join("x/expr_tail.json"), &beak).expect("write");
    let mut file =
        SceneFile::parse(&std::fs::read_to_string(&scene).expect("read")).expect("parse");
    let defs = &mut file.objects[0].parts[0].deformations;
    defs[0].controls = format!("{long}/expr_beak.json");
    defs[1].controls = format!("{long}/expr_tail.json");
    defs[2].controls = format!("{long}/x/expr_tail.json");
    std::fs::write(&scene, file.to_json()).expect("write");
    let s = Scene::load(&scene).expect("load");
    let doc = glb_json(&export_gltf(&s, true));
    assert_eq!(
        doc["meshes"][0]["extras"]["targetNames"],
        serde_json::json!(["open beak", "expr_tail", "expr_tail 2"])
    );
}

/// Issue 24, items 6 and 7: the scene's camera and lights arrive, and the
/// scene's fps and duration are in the asset's extras.
#[test]
fn the_camera_lights_and_timeline_are_exported() {
    let (_d, scene) = DemoDir::new("face", "view");
    let s = Scene::load(&scene).expect("load");
    let doc = glb_json(&export_gltf(&s, true));
    assert_eq!(doc["cameras"].as_array().map(Vec::len), Some(1));
    let nodes = doc["nodes"].as_array().expect("nodes");
    let cam = nodes
        .iter()
        .find(|n| n.get("camera").is_some())
        .expect("camera node");
    let eye: Vec<f64> = serde_json::from_value(cam["translation"].clone()).expect("eye");
    for (a, b) in eye.iter().zip(s.file.camera.eye) {
        assert!((a - b).abs() < 1e-4, "{eye:?}");
    }
    let lights = doc["extensions"]["KHR_lights_punctual"]["lights"]
        .as_array()
        .expect("lights");
    assert_eq!(lights.len(), s.file.lights.len().max(2));
    assert_eq!(
        doc["extensionsUsed"],
        serde_json::json!(["KHR_lights_punctual"])
    );
    // Every node is in the scene.
    assert_eq!(
        doc["scenes"][0]["nodes"].as_array().map(Vec::len),
        Some(nodes.len())
    );
    let extras = &doc["asset"]["extras"];
    assert_eq!(extras["fps"], s.file.fps);
    assert_eq!(extras["duration"], s.file.duration);
}

/// Issue 17: a sweep is one morph target per step, named `NAME step j/k`,
/// whose weights rise one after another; the frame the scene draws at a
/// phase between steps is what those targets give.
#[test]
fn a_sweep_exports_one_target_per_step_rising_in_turn() {
    let (d, scene) = DemoDir::new("fish", "sweep");
    let beak = std::fs::read_to_string(d.0.join("controls/beak.json")).expect("beak");
    let swept = beak.replacen('{', "{\"sweep\": {\"steps\": 4}, ", 1);
    std::fs::write(d.0.join("controls/beak.json"), swept).expect("write");
    let s = Scene::load(&scene).expect("load");
    let doc = glb_json(&export_gltf(&s, true));
    let names = doc["meshes"][0]["extras"]["targetNames"].clone();
    assert_eq!(
        names,
        serde_json::json!([
            "beak step 1/4",
            "beak step 2/4",
            "beak step 3/4",
            "beak step 4/4",
            "tail",
            "wings"
        ])
    );
    let notes = export_notes(&s);
    assert!(
        notes.iter().any(|n| n.contains("sweep of 4 steps")),
        "{notes:?}"
    );
    // The weights at a time: the track's phase p gives step j clamp(4p - j).
    let anim = &s.objects[0].deformations[0];
    let time = (0..200)
        .map(|k| k as f64 * s.file.duration / 200.0)
        .find(|&t| {
            let p = anim.track.phase(t) * anim.stages[0].phase as f64;
            (p * 4.0).fract() > 0.2 && p > 0.3 && p < 0.9
        })
        .expect("a time between steps");
    let p = (anim.track.phase(time) as f32) * anim.stages[0].phase;
    let want: Vec<f32> = (0..4)
        .map(|j| (4.0 * p - j as f32).clamp(0.0, 1.0))
        .collect();
    let got: Vec<f32> = anim
        .stages
        .iter()
        .map(|st| st.phase_at(anim.track.phase(time) as f32))
        .collect();
    for (g, w) in got.iter().zip(&want) {
        assert!((g - w).abs() < 1e-6, "{got:?} vs {want:?}");
    }
    // The targets summed with those weights are the frame (beak only).
    let only_beak = {
        let mut f = s.file.clone();
        f.objects[0].parts[0].deformations.truncate(1);
        std::fs::write(&scene, f.to_json()).expect("write");
        Scene::load(&scene).expect("load")
    };
    let frame = only_beak.frame(time);
    let rest = &only_beak.objects[0].mesh.positions;
    let targets = super::sweep_targets(rest, &only_beak.objects[0].deformations[0]);
    let (rot, shift) = only_beak.objects[0].transform(time);
    for (v, r) in rest.iter().enumerate() {
        let local = targets
            .iter()
            .zip(&want)
            .fold(*r, |x, (t, w)| x + t[v] * *w);
        let world = rot.as_quat() * local + shift.as_vec3();
        assert!(
            world.distance(frame.objects[0].positions[v]) < 1e-5,
            "vertex {v}"
        );
    }
}
