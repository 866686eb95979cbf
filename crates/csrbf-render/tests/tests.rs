//! Real pictures on the system's adapter (lavapipe in CI).

use csrbf_render::{Camera, DrawMesh, DrawOptions, DrawPart, Light, Renderer, View};

use glam::Vec3;

fn quad_view() -> View {
    let positions = vec![
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(-1.0, 1.0, 0.0),
    ];
    View {
        camera: Camera::perspective(Vec3::new(0.0, 0.0, 4.0), Vec3::ZERO, Vec3::Y, 45.0),
        lights: vec![Light {
            direction: Vec3::new(0.0, 0.0, -1.0),
            color: Vec3::ONE,
        }],
        background: [0.0, 0.0, 0.0],
        meshes: vec![DrawMesh {
            normals: vec![Vec3::Z; 4],
            positions,
            parts: vec![DrawPart {
                indices: vec![0, 1, 2, 0, 2, 3],
                color: [1.0, 0.0, 0.0, 1.0],
                texture: None,
                wireframe: false,
            }],
            ..Default::default()
        }],
        lines: vec![],
        overlay: vec![],
        options: DrawOptions::default(),
    }
}

#[test]
fn draws_a_lit_quad_on_the_background() {
    let mut r = Renderer::new(64, 48).expect("renderer (install mesa-vulkan-drivers)");
    let img = r.render(&quad_view()).expect("render");
    assert_eq!((img.width, img.height), (64, 48));
    let centre = img.pixel(32, 24);
    assert!(
        centre[0] > 200 && centre[1] < 40 && centre[2] < 40,
        "centre {centre:?}"
    );
    assert_eq!(img.pixel(0, 0), [0, 0, 0, 255]);
    // Depth test: a second quad in front, green, hides the red one.
    let mut v = quad_view();
    let mut front = v.meshes[0].clone();
    for p in &mut front.positions {
        p.z = 1.0;
        *p *= 0.5;
    }
    front.parts[0].color = [0.0, 1.0, 0.0, 1.0];
    v.meshes.insert(0, front);
    let img = r.render(&v).expect("render");
    let c = img.pixel(32, 24);
    assert!(c[1] > 200 && c[0] < 40, "centre {c:?}");
    assert!(img.to_png().expect("png").starts_with(b"\x89PNG"));
}

#[test]
fn bad_sizes_are_refused() {
    for (w, h) in [(0, 10), (10, 0), (100_000, 10)] {
        let e = Renderer::new(w, h)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(e.contains("not valid"), "{e}");
    }
}

#[test]
fn textures_and_flat_shading_reach_the_picture() {
    let mut r = Renderer::new(64, 48).expect("renderer");
    // A 4 x 1 texture: left half green, right half blue.
    let tex = r
        .texture(
            4,
            1,
            &[
                0, 255, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255, 0, 0, 255, 255,
            ],
        )
        .expect("texture");
    let mut v = quad_view();
    v.meshes[0].uvs = vec![
        glam::Vec2::new(0.0, 0.0),
        glam::Vec2::new(1.0, 0.0),
        glam::Vec2::new(1.0, 1.0),
        glam::Vec2::new(0.0, 1.0),
    ];
    v.meshes[0].parts[0].color = [1.0; 4];
    v.meshes[0].parts[0].texture = Some(tex);
    let img = r.render(&v).expect("render");
    let (left, right) = (img.pixel(27, 24), img.pixel(38, 24));
    assert!(left[1] > 150 && left[2] < 100, "left {left:?}");
    assert!(right[2] > 150 && right[1] < 100, "right {right:?}");
    assert!(r.texture(2, 2, &[0; 4]).is_err());
    // Flat shading of a tilted quad: one colour across it.
    let mut v = quad_view();
    for p in &mut v.meshes[0].positions {
        p.z = p.x * 0.5;
    }
    v.meshes[0].normals = vec![
        Vec3::new(0.3, 0.0, 1.0).normalize(),
        Vec3::Z,
        Vec3::Z,
        Vec3::new(-0.3, 0.0, 1.0).normalize(),
    ];
    v.options.flat = true;
    let img = r.render(&v).expect("render");
    let (a, b) = (img.pixel(24, 24), img.pixel(40, 24));
    assert!((a[0] as i32 - b[0] as i32).abs() <= 2, "{a:?} vs {b:?}");
}
