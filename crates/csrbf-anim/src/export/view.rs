//! The scene's camera and lights as glTF nodes (a perspective camera and
//! `KHR_lights_punctual` directional lights). The scene format keeps both
//! still, so they are not animated.

use glam::{Mat3, Quat, Vec3};
use serde_json::{Value, json};

use crate::camera::{Camera, default_lights};
use crate::file::SceneFile;

/// The extension glTF lights live in.
pub const LIGHTS_EXTENSION: &str = "KHR_lights_punctual";

/// Camera and light nodes to add to the scene, with the document parts they use.
pub struct ViewNodes {
    /// Nodes: the camera's first, then one per light.
    pub nodes: Vec<Value>,
    /// The `cameras` array.
    pub cameras: Vec<Value>,
    /// The extension's `lights` array.
    pub lights: Vec<Value>,
}

fn v3(a: [f64; 3]) -> Vec3 {
    Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32)
}

/// The camera as `csrbf animate` looks through it (glTF cameras look along
/// their node's -Z with +Y up), and the scene's lights (or, when it lists
/// none, the two `csrbf animate` lights it with), each pointing its node's
/// -Z along the light's direction.
pub fn view_nodes(file: &SceneFile) -> ViewNodes {
    let c = &file.camera;
    let camera = Camera::perspective(v3(c.eye), v3(c.target), v3(c.up), c.fov as f32);
    let fwd = (camera.target - camera.eye).normalize_or(Vec3::NEG_Z);
    let right = fwd.cross(camera.up).normalize_or(Vec3::X);
    let up = right.cross(fwd);
    let rotation = Quat::from_mat3(&Mat3::from_cols(right, up, -fwd)).normalize();
    let distance = (camera.target - camera.eye).length().max(1e-6);
    let [w, h] = file.size;
    let cameras = vec![json!({
        "name": "camera",
        "type": "perspective",
        "perspective": {
            "yfov": (c.fov as f32).to_radians(),
            "aspectRatio": w.max(1) as f32 / h.max(1) as f32,
            "znear": distance * 1e-3,
        }
    })];
    let mut nodes = vec![json!({
        "name": "camera", "camera": 0,
        "translation": camera.eye.to_array(), "rotation": rotation.to_array(),
    })];
    let given: Vec<(Vec3, [f32; 3], f32)> = file
        .lights
        .iter()
        .map(|l| (v3(l.direction), l.color, l.intensity))
        .collect();
    let lit = if given.is_empty() {
        default_lights(&camera)
            .into_iter()
            .map(|(d, grey)| (d, [1.0; 3], grey))
            .collect()
    } else {
        given
    };
    let mut lights = Vec::new();
    for (k, (direction, color, intensity)) in lit.into_iter().enumerate() {
        let dir = direction.normalize_or(Vec3::NEG_Z);
        let rotation = Quat::from_rotation_arc(Vec3::NEG_Z, dir).normalize();
        // glTF colours are in [0, 1]: a brighter one moves into the intensity.
        let peak = color.iter().fold(1.0f32, |m, &c| m.max(c));
        let color = color.map(|c| c.max(0.0) / peak);
        let intensity = intensity * peak;
        lights.push(json!({
            "name": format!("light {}", k + 1), "type": "directional",
            "color": color, "intensity": intensity,
        }));
        nodes.push(json!({
            "name": format!("light {}", k + 1), "rotation": rotation.to_array(),
            "extensions": { LIGHTS_EXTENSION: { "light": k } },
        }));
    }
    ViewNodes {
        nodes,
        cameras,
        lights,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_camera_node_looks_at_the_target_and_lights_point_their_way() {
        let mut file = crate::demos::demo("face").expect("face").scene;
        file.lights = vec![crate::file::LightFile {
            direction: [1.0, -1.0, -1.0],
            color: [1.0, 0.5, 0.25],
            intensity: 0.9,
        }];
        let v = view_nodes(&file);
        let q = |n: &Value| {
            let r: Vec<f32> = serde_json::from_value(n["rotation"].clone()).expect("rotation");
            Quat::from_xyzw(r[0], r[1], r[2], r[3])
        };
        let c = &file.camera;
        let want = (v3(c.target) - v3(c.eye)).normalize();
        assert!((q(&v.nodes[0]) * Vec3::NEG_Z - want).length() < 1e-5);
        assert!((q(&v.nodes[0]) * Vec3::Y).dot(v3(c.up)) > 0.0, "upright");
        let light = Vec3::new(1.0, -1.0, -1.0).normalize();
        assert!((q(&v.nodes[1]) * Vec3::NEG_Z - light).length() < 1e-5);
        assert_eq!(v.lights[0]["color"], json!([1.0, 0.5, 0.25]));
        // No lights: the two csrbf draws with.
        file.lights.clear();
        assert_eq!(view_nodes(&file).lights.len(), 2);
    }
}
