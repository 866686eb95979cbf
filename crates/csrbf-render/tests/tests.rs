//! Real pictures on the system's adapter (lavapipe in CI).

use csrbf_render::{Camera, DrawMesh, DrawOptions, DrawPart, Light, Renderer, View};

use glam::{Vec2, Vec3};

/// The data of a quad the views borrow.
struct Quad {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    uvs: Vec<Vec2>,
    parts: Vec<DrawPart>,
}

impl Quad {
    fn new(color: [f32; 4]) -> Quad {
        Quad {
            positions: vec![
                Vec3::new(-1.0, -1.0, 0.0),
                Vec3::new(1.0, -1.0, 0.0),
                Vec3::new(1.0, 1.0, 0.0),
                Vec3::new(-1.0, 1.0, 0.0),
            ],
            normals: vec![Vec3::Z; 4],
            uvs: vec![],
            parts: vec![DrawPart {
                indices: vec![0, 1, 2, 0, 2, 3],
                color,
                texture: None,
                wireframe: false,
            }],
        }
    }

    fn mesh(&self) -> DrawMesh<'_> {
        DrawMesh {
            positions: &self.positions,
            normals: &self.normals,
            uvs: &self.uvs,
            parts: &self.parts,
            ..Default::default()
        }
    }
}

fn camera() -> Camera {
    Camera::perspective(Vec3::new(0.0, 0.0, 4.0), Vec3::ZERO, Vec3::Y, 45.0)
}

fn view(meshes: Vec<DrawMesh<'_>>) -> View<'_> {
    View {
        camera: camera(),
        lights: vec![Light {
            direction: Vec3::new(0.0, 0.0, -1.0),
            color: Vec3::ONE,
        }],
        background: [0.0, 0.0, 0.0],
        meshes,
        lines: vec![],
        overlay: vec![],
        options: DrawOptions::default(),
    }
}

#[test]
fn draws_a_lit_quad_on_the_background() {
    let mut r = Renderer::new(64, 48).expect("renderer (install mesa-vulkan-drivers)");
    let red = Quad::new([1.0, 0.0, 0.0, 1.0]);
    let img = r.render(&view(vec![red.mesh()])).expect("render");
    assert_eq!((img.width, img.height), (64, 48));
    let centre = img.pixel(32, 24);
    assert!(
        centre[0] > 200 && centre[1] < 40 && centre[2] < 40,
        "centre {centre:?}"
    );
    assert_eq!(img.pixel(0, 0), [0, 0, 0, 255]);
    // Depth test: a second quad in front, green, hides the red one.
    let mut green = Quad::new([0.0, 1.0, 0.0, 1.0]);
    for p in &mut green.positions {
        p.z = 1.0;
        *p *= 0.5;
    }
    let img = r
        .render(&view(vec![green.mesh(), red.mesh()]))
        .expect("render");
    let c = img.pixel(32, 24);
    assert!(c[1] > 200 && c[0] < 40, "centre {c:?}");
    assert!(img.to_png().expect("png").starts_with(b"\x89PNG"));
}

/// What the camera says is inside the quad is drawn, what it says is
/// outside is background: picking and drawing share one camera.
#[test]
fn the_camera_projects_where_the_renderer_draws() {
    let size = [96u32, 64u32];
    let mut r = Renderer::new(size[0], size[1]).expect("renderer");
    let quad = Quad::new([1.0, 1.0, 1.0, 1.0]);
    let img = r.render(&view(vec![quad.mesh()])).expect("render");
    let (lo, _) = camera()
        .project(Vec3::new(-1.0, 1.0, 0.0), size)
        .expect("corner");
    let (hi, _) = camera()
        .project(Vec3::new(1.0, -1.0, 0.0), size)
        .expect("corner");
    for (x, y) in [(2.0, 2.0), (-2.0, -2.0), (-2.0, 2.0), (2.0, -2.0)] {
        let inside = (lo + hi) * 0.5 + (hi - lo) * 0.5 * Vec2::new(x, y) * 0.4;
        let outside = (lo + hi) * 0.5 + (hi - lo) * 0.5 * Vec2::new(x, y) * 0.6;
        let lit = |p: Vec2| img.pixel(p.x as u32, p.y as u32)[0] > 100;
        assert!(lit(inside), "{inside} should be on the quad");
        assert!(!lit(outside), "{outside} should be background");
    }
    // And the ray through a lit pixel meets the quad's plane inside it.
    let ray = camera().ray(Vec2::new(20.5, 40.5), size);
    let t = -ray.origin.z / ray.dir.z;
    let p = ray.at(t);
    assert_eq!(
        img.pixel(20, 40)[0] > 100,
        p.x.abs() < 1.0 && p.y.abs() < 1.0
    );
}

/// An app's device, another colour format, and drawing without read-back.
#[test]
fn draws_on_a_given_device_into_a_given_texture() {
    let headless = Renderer::new(32, 24).expect("renderer");
    let (device, queue) = (headless.device().clone(), headless.queue().clone());
    let format = wgpu::TextureFormat::Bgra8UnormSrgb;
    let mut r = Renderer::on_device(device.clone(), queue, format, 32, 24, 4).expect("on device");
    assert_eq!(r.format(), format);
    let red = Quad::new([1.0, 0.0, 0.0, 1.0]);
    let target = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("app"),
        size: wgpu::Extent3d {
            width: 32,
            height: 24,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
        view_formats: &[],
    });
    r.draw_into(
        &view(vec![red.mesh()]),
        &target.create_view(&Default::default()),
    );
    // The same renderer still reads pictures back, BGRA turned into RGBA.
    let img = r.render(&view(vec![red.mesh()])).expect("render");
    let c = img.pixel(16, 12);
    assert!(c[0] > 200 && c[2] < 40, "centre {c:?}");
    r.resize(40, 20).expect("resize");
    assert_eq!(r.size(), (40, 20));
    let img = r.render(&view(vec![red.mesh()])).expect("render");
    assert_eq!((img.width, img.height), (40, 20));
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
    let mut q = Quad::new([1.0; 4]);
    q.uvs = vec![
        Vec2::new(0.0, 0.0),
        Vec2::new(1.0, 0.0),
        Vec2::new(1.0, 1.0),
        Vec2::new(0.0, 1.0),
    ];
    q.parts[0].texture = Some(tex);
    let img = r.render(&view(vec![q.mesh()])).expect("render");
    let (left, right) = (img.pixel(27, 24), img.pixel(38, 24));
    assert!(left[1] > 150 && left[2] < 100, "left {left:?}");
    assert!(right[2] > 150 && right[1] < 100, "right {right:?}");
    assert!(r.texture(2, 2, &[0; 4]).is_err());
    // Flat shading of a tilted quad: one colour across it.
    let mut q = Quad::new([1.0, 0.0, 0.0, 1.0]);
    for p in &mut q.positions {
        p.z = p.x * 0.5;
    }
    q.normals = vec![
        Vec3::new(0.3, 0.0, 1.0).normalize(),
        Vec3::Z,
        Vec3::Z,
        Vec3::new(-0.3, 0.0, 1.0).normalize(),
    ];
    let mut v = view(vec![q.mesh()]);
    v.options.flat = true;
    let img = r.render(&v).expect("render");
    let (a, b) = (img.pixel(24, 24), img.pixel(40, 24));
    assert!((a[0] as i32 - b[0] as i32).abs() <= 2, "{a:?} vs {b:?}");
}

/// The library's frame loop: a GIF of a demo scene, cancelled half way
/// (nothing left on disk), refused when it asks for too many frames.
#[test]
fn movies_render_cancel_cleanly_and_refuse_endless_ranges() {
    use csrbf_render::movie::{MovieOptions, render_movie};
    let dir = std::env::temp_dir().join(format!("csrbf-render-movie-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let demo = csrbf_anim::demos::demo("ball").expect("demo");
    let scene_path = demo.write(&dir, "ball").expect("write demo");
    let scene = csrbf_anim::Scene::load(&scene_path).expect("scene");
    let mut o = MovieOptions::of(&scene);
    o.size = [64, 48];
    o.to = 0.5;
    let gif = dir.join("m.gif");
    let mut seen = 0;
    let w = render_movie(&scene, &gif, o, &mut |done, total| {
        seen = done;
        assert_eq!(total, o.frames());
        true
    })
    .expect("movie");
    assert_eq!(
        (w.path.clone(), w.frames, seen),
        (gif.clone(), o.frames(), o.frames())
    );
    assert!(gif.is_file());
    // Cancelled after two frames: an error, and neither the movie nor a temporary file.
    let cancelled = dir.join("c.gif");
    let before: Vec<_> = std::fs::read_dir(&dir).expect("dir").collect();
    let e = render_movie(&scene, &cancelled, o, &mut |done, _| done < 2).expect_err("cancel");
    assert!(e.to_string().contains("cancelled"));
    assert!(!cancelled.exists());
    assert_eq!(std::fs::read_dir(&dir).expect("dir").count(), before.len());
    // A range of a billion seconds is refused before anything is drawn.
    o.to = 1e9;
    let e = render_movie(&scene, &dir.join("e.gif"), o, &mut |_, _| true).expect_err("endless");
    assert!(e.to_string().contains("more than the limit"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The Composer's scene camera as lines: seen through the camera itself,
/// its frame's corners are the picture's corners, for either projection.
#[test]
fn a_camera_drawn_as_lines_frames_its_own_picture() {
    let size = [400u32, 300];
    let aspect = size[0] as f32 / size[1] as f32;
    let pinhole = Camera::perspective(
        Vec3::new(1.0, 2.0, 8.0),
        Vec3::new(0.0, 0.5, 0.0),
        Vec3::Y,
        40.0,
    );
    let parallel = Camera {
        projection: csrbf_anim::Projection::Orthographic { height: 3.0 },
        ..pinhole
    };
    for cam in [pinhole, parallel] {
        let mut lines = Vec::new();
        csrbf_render::camera_lines(&cam, aspect, [1.0; 4], &mut lines);
        // Four edges from the eye, four around the frame, the up tick, the target line.
        assert_eq!(lines.len(), 10);
        let mut corners: Vec<Vec2> = (0..4)
            .map(|k| cam.project(lines[2 * k].b, size).expect("in front").0)
            .collect();
        corners.sort_by(|a, b| (a.x + 10.0 * a.y).total_cmp(&(b.x + 10.0 * b.y)));
        let want = [
            Vec2::new(0.0, 0.0),
            Vec2::new(400.0, 0.0),
            Vec2::new(0.0, 300.0),
            Vec2::new(400.0, 300.0),
        ];
        for (c, w) in corners.iter().zip(want) {
            assert!(c.distance(w) < 0.5, "{c} vs {w} ({:?})", cam.projection);
        }
        assert_eq!(lines[9].b, cam.target);
    }
}

/// Issue 42: a start's cross is 6 % of R, but never more than 1.5 % of the
/// model: with R = 3000 on a head 20 across it was drawn as lines across
/// the whole view.
#[test]
fn a_starts_marker_stays_small_beside_a_huge_radius() {
    let start = Vec3::new(1.0, 2.0, 3.0);
    let control = [(start, start, start + Vec3::X, 3000.0f32)];
    let mut lines = Vec::new();
    csrbf_render::control_lines(&control, 20.0, false, &mut lines);
    let cross = lines[0].a.distance(lines[0].b);
    assert!((cross - 2.0 * 0.3).abs() < 1e-5, "{cross}");
    // A radius small for the model keeps its 6 %.
    let mut lines = Vec::new();
    csrbf_render::control_lines(&[(start, start, start, 2.0)], 20.0, false, &mut lines);
    assert!((lines[0].a.distance(lines[0].b) - 2.0 * 0.12).abs() < 1e-5);
}
