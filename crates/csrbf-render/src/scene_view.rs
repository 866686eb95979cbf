//! Pictures of `csrbf-anim` scenes: the one path from a scene frame to a
//! [`View`], shared by stills, movies and (later) the studio's viewport.

use csrbf_anim::{Frame, Scene};
use glam::{Vec2, Vec3};

use crate::{
    Camera, DrawMesh, DrawOptions, DrawPart, Image, Light, Line, Renderer, Result, TextureId,
};

/// How control vectors are drawn over the picture.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Overlay {
    /// Not at all (default).
    #[default]
    Off,
    /// Starts, arrows to where they are at this phase and to their
    /// destinations, and the support sphere of up to 16 moving ones.
    Full,
    /// Starts and arrows only: for files with many vectors.
    Arrows,
}

impl std::str::FromStr for Overlay {
    type Err = String;
    fn from_str(s: &str) -> Result<Overlay, String> {
        match s {
            "full" => Ok(Overlay::Full),
            "arrows" => Ok(Overlay::Arrows),
            "off" => Ok(Overlay::Off),
            _ => Err(format!(
                "unknown overlay {s:?}: expected full, arrows or off"
            )),
        }
    }
}

/// What to draw besides the surfaces.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[non_exhaustive]
pub struct SceneOptions {
    /// Shading and wireframe.
    pub draw: DrawOptions,
    /// Control vectors over the picture.
    pub overlay: Overlay,
    /// An axis gizmo (X red, Y green, Z blue) in the lower left corner.
    pub gizmo: bool,
    /// Look through this camera instead of the scene's (the studio's
    /// viewport). Default none.
    pub camera: Option<Camera>,
}

/// Static per-object data prepared once: UVs, colours, triangles and
/// textures of each part.
struct Prepared {
    uvs: Vec<Vec2>,
    colors: Vec<[f32; 4]>,
    parts: Vec<DrawPart>,
}

/// A lighter copy of an object to draw instead of it: triangles over a
/// subset of its vertices (e.g. from `csrbf_mesh::cluster_triangles`), with
/// their positions and normals at this frame.
#[derive(Clone, Copy, Debug)]
pub struct StandInDraw<'a> {
    /// Positions of the stand-in's vertices, world space.
    pub positions: &'a [Vec3],
    /// Their normals.
    pub normals: &'a [Vec3],
    /// Triangles, three indices into `positions` each.
    pub indices: &'a [u32],
}

/// A renderer bound to one scene: textures uploaded and parts triangulated once.
pub struct SceneRenderer {
    renderer: Renderer,
    prepared: Vec<Prepared>,
    /// Cache key of the first object's parts (the others follow).
    key: u64,
}

impl SceneRenderer {
    /// Prepares `scene` for pictures of `width` x `height`.
    pub fn new(scene: &Scene, width: u32, height: u32) -> Result<SceneRenderer> {
        SceneRenderer::with_samples(scene, width, height, crate::renderer::DEFAULT_SAMPLES)
    }

    /// Prepares `scene` with `samples` per pixel (1 or 4).
    pub fn with_samples(
        scene: &Scene,
        width: u32,
        height: u32,
        samples: u32,
    ) -> Result<SceneRenderer> {
        SceneRenderer::on_renderer(scene, Renderer::with_samples(width, height, samples)?)
    }

    /// Prepares `scene` for a renderer the caller made (on its own device:
    /// the studio's viewport, see [`Renderer::on_device`]).
    pub fn on_renderer(scene: &Scene, mut renderer: Renderer) -> Result<SceneRenderer> {
        let mut prepared = Vec::new();
        for obj in &scene.objects {
            let n = obj.mesh.positions.len();
            let uvs = obj
                .mesh
                .uvs
                .as_ref()
                .and_then(|u| u.per_vertex(&obj.mesh.faces, n))
                .unwrap_or_default();
            let colors = obj.mesh.colors.clone().unwrap_or_default();
            let mut parts = Vec::new();
            for p in &obj.parts {
                let texture: Option<TextureId> = match &p.texture {
                    Some(t) => Some(renderer.texture(t.width, t.height, &t.rgba)?),
                    None => None,
                };
                let indices = obj.mesh.faces.triangle_indices(&p.faces);
                parts.push(DrawPart {
                    indices,
                    color: p.color,
                    texture,
                    wireframe: p.wireframe,
                });
            }
            prepared.push(Prepared { uvs, colors, parts });
        }
        static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);
        let key = NEXT.fetch_add(1 << 20, std::sync::atomic::Ordering::Relaxed);
        Ok(SceneRenderer {
            renderer,
            prepared,
            key,
        })
    }

    /// The renderer underneath.
    pub fn renderer(&self) -> &Renderer {
        &self.renderer
    }

    /// The renderer underneath, to change its size or draw with it.
    pub fn renderer_mut(&mut self) -> &mut Renderer {
        &mut self.renderer
    }

    /// Draws `view` with object `object` of the scene at `positions` and
    /// `normals` as its only mesh (whatever meshes `view` had are replaced)
    /// into a texture view the caller owns: the studio's viewport.
    pub fn draw_object_into(
        &mut self,
        view: &View,
        object: usize,
        positions: &[Vec3],
        normals: &[Vec3],
        target: &wgpu::TextureView,
    ) {
        let meshes = self
            .prepared
            .get(object)
            .map(|prep| DrawMesh {
                key: self.key + object as u64,
                positions,
                normals,
                uvs: &prep.uvs,
                colors: &prep.colors,
                parts: &prep.parts,
            })
            .into_iter()
            .collect();
        self.renderer.draw_into(&view.with_meshes(meshes), target);
    }

    /// [`SceneRenderer::draw_object_into`] with a lighter stand-in of the
    /// object: the triangles `indices` over `positions` and `normals` (a
    /// subset of its vertices, e.g. from `csrbf_mesh::cluster_triangles`),
    /// in the colour of its first part, for the frames of a drag on a big
    /// mesh. The indices are uploaded once and kept while the same number
    /// of them is given.
    pub fn draw_stand_in_into(
        &mut self,
        view: &View,
        object: usize,
        positions: &[Vec3],
        normals: &[Vec3],
        indices: &[u32],
        target: &wgpu::TextureView,
    ) {
        if self.prepared.get(object).is_none() {
            return;
        }
        let parts = self.stand_in_part(object, indices);
        let s = StandInDraw {
            positions,
            normals,
            indices,
        };
        let mesh = stand_in_mesh(self.key, object, &s, &parts);
        self.renderer
            .draw_into(&view.with_meshes(vec![mesh]), target);
    }

    /// A stand-in's one part: its triangles in the colour of the object's
    /// first part.
    fn stand_in_part(&self, object: usize, indices: &[u32]) -> [DrawPart; 1] {
        let color = self
            .prepared
            .get(object)
            .and_then(|p| p.parts.first())
            .map_or([0.8; 4], |p| p.color);
        [DrawPart {
            indices: indices.to_vec(),
            color,
            texture: None,
            wireframe: false,
        }]
    }

    /// Draws one frame of the scene and reads it back.
    pub fn render(&mut self, scene: &Scene, frame: &Frame, options: SceneOptions) -> Result<Image> {
        let view = view_of(
            &self.prepared,
            self.key,
            self.renderer.size(),
            scene,
            frame,
            options,
        );
        self.renderer.render(&view)
    }

    /// Draws one frame of the scene into a texture view the caller owns (of
    /// the renderer's format and size), without reading it back: the
    /// interactive path.
    pub fn draw_into(
        &mut self,
        scene: &Scene,
        frame: &Frame,
        options: SceneOptions,
        target: &wgpu::TextureView,
    ) {
        let view = view_of(
            &self.prepared,
            self.key,
            self.renderer.size(),
            scene,
            frame,
            options,
        );
        self.renderer.draw_into(&view, target);
    }

    /// [`SceneRenderer::draw_into`] with lines of the caller's: `lines`
    /// depth-tested among the meshes (trajectories), `overlay` over
    /// everything (keys, gizmos), object `k` left out where `hidden[k]`, and
    /// drawn by `stand_ins[k]` instead where it has one (a big mesh while
    /// the scene plays): the Composer's viewport.
    #[allow(clippy::too_many_arguments)]
    pub fn draw_frame_into(
        &mut self,
        scene: &Scene,
        frame: &Frame,
        options: SceneOptions,
        lines: &[Line],
        overlay: &[Line],
        hidden: &[bool],
        stand_ins: &[Option<StandInDraw>],
        target: &wgpu::TextureView,
    ) {
        let parts: Vec<Option<[DrawPart; 1]>> = stand_ins
            .iter()
            .enumerate()
            .map(|(k, s)| Some(self.stand_in_part(k, s.as_ref()?.indices)))
            .collect();
        let mut view = view_of(
            &self.prepared,
            self.key,
            self.renderer.size(),
            scene,
            frame,
            options,
        );
        for (k, (s, p)) in stand_ins.iter().zip(&parts).enumerate() {
            if let (Some(s), Some(p), Some(m)) = (s, p, view.meshes.get_mut(k)) {
                *m = stand_in_mesh(self.key, k, s, p);
            }
        }
        if hidden.iter().any(|&h| h) {
            let mut k = 0;
            view.meshes.retain(|_| {
                k += 1;
                !hidden.get(k - 1).copied().unwrap_or(false)
            });
        }
        view.lines.extend_from_slice(lines);
        view.overlay.extend_from_slice(overlay);
        self.renderer.draw_into(&view, target);
    }

    /// The view of one frame: camera, lights, meshes (borrowed from the frame
    /// and from what was prepared) and overlay.
    pub fn view<'a>(&'a self, scene: &Scene, frame: &'a Frame, options: SceneOptions) -> View<'a> {
        view_of(
            &self.prepared,
            self.key,
            self.renderer.size(),
            scene,
            frame,
            options,
        )
    }
}

/// The mesh of object `object`'s stand-in `s`, drawn with `parts`.
fn stand_in_mesh<'a>(
    key: u64,
    object: usize,
    s: &StandInDraw<'a>,
    parts: &'a [DrawPart],
) -> DrawMesh<'a> {
    DrawMesh {
        // Its own key: switching between it and the full mesh uploads the
        // other's indices once.
        key: (key + object as u64) ^ (1 << 62) ^ s.indices.len() as u64,
        positions: s.positions,
        normals: s.normals,
        uvs: &[],
        colors: &[],
        parts,
    }
}

fn view_of<'a>(
    prepared: &'a [Prepared],
    key: u64,
    size: (u32, u32),
    scene: &Scene,
    frame: &'a Frame,
    options: SceneOptions,
) -> View<'a> {
    let f = &scene.file;
    let v3 = |a: [f64; 3]| Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32);
    let camera = options.camera.unwrap_or_else(|| {
        Camera::perspective(
            v3(f.camera.eye),
            v3(f.camera.target),
            v3(f.camera.up),
            f.camera.fov as f32,
        )
    });
    let mut lights: Vec<Light> = f
        .lights
        .iter()
        .map(|l| Light {
            direction: v3(l.direction),
            color: Vec3::from_array(l.color) * l.intensity,
        })
        .collect();
    if lights.is_empty() {
        lights = default_lights(camera);
    }
    let mut meshes = Vec::new();
    let mut overlay = Vec::new();
    for (k, (obj, prep)) in frame.objects.iter().zip(prepared).enumerate() {
        meshes.push(DrawMesh {
            key: key + k as u64,
            positions: &obj.positions,
            normals: &obj.normals,
            uvs: &prep.uvs,
            colors: &prep.colors,
            parts: &prep.parts,
        });
        if options.overlay != Overlay::Off {
            let model = bounds_diagonal(&obj.positions);
            control_lines(
                &obj.controls,
                model,
                options.overlay == Overlay::Full,
                &mut overlay,
            );
        }
    }
    if options.gizmo {
        axis_gizmo(&camera, [size.0, size.1], &mut overlay);
    }
    View {
        camera,
        lights,
        background: f.background,
        meshes,
        lines: Vec::new(),
        overlay,
        options: options.draw,
    }
}

pub use crate::View;

/// A key light from the upper left of the camera and a weaker fill from the
/// right ([`csrbf_anim::camera::default_lights`], which `csrbf export` writes too).
pub fn default_lights(camera: Camera) -> Vec<Light> {
    csrbf_anim::camera::default_lights(&camera)
        .into_iter()
        .map(|(direction, grey)| Light {
            direction,
            color: Vec3::splat(grey),
        })
        .collect()
}

/// Three short axes (X red, Y green, Z blue) seen from the camera, in the
/// lower left corner of a picture of `size` (35 pixels long, less on small
/// pictures).
pub fn axis_gizmo(camera: &Camera, size: [u32; 2], out: &mut Vec<Line>) {
    let margin = (size[0].min(size[1]) as f32 * 0.15).clamp(12.0, 50.0);
    let corner = Vec2::new(margin, size[1] as f32 - margin);
    let ray = camera.ray(corner, size);
    // A point a short way in front of the eye; the axes' length there covers
    // about 40 pixels.
    let dist = (camera.target - camera.eye).length() * 0.5;
    let origin = ray.at(dist);
    let Some((p0, _)) = camera.project(origin, size) else {
        return;
    };
    let (right, _, _) = camera.basis();
    let Some((p1, _)) = camera.project(origin + right * dist * 0.01, size) else {
        return;
    };
    let per_unit = (p1 - p0).length() / (dist * 0.01);
    if !(per_unit > 0.0 && per_unit.is_finite()) {
        return;
    }
    let len = margin * 0.7 / per_unit;
    for (axis, color) in [
        (Vec3::X, [0.95, 0.25, 0.2, 1.0]),
        (Vec3::Y, [0.3, 0.85, 0.3, 1.0]),
        (Vec3::Z, [0.3, 0.5, 1.0, 1.0]),
    ] {
        out.push(Line {
            a: origin,
            b: origin + axis * len,
            color,
        });
    }
}

/// Overlay lines for control vectors (start, current, destination, R) on a
/// model of diagonal `model` (the start's cross is 6 % of the least R, at
/// most 1.5 % of the model: a radius far larger than the model does not
/// draw it across the view); `spheres`: also the support spheres of up to
/// 16 moving ones.
pub fn control_lines(
    controls: &[(Vec3, Vec3, Vec3, f32)],
    model: f32,
    spheres: bool,
    out: &mut Vec<Line>,
) {
    const START: [f32; 4] = [1.0, 1.0, 1.0, 1.0];
    const NOW: [f32; 4] = [1.0, 0.55, 0.1, 1.0];
    const GOAL: [f32; 4] = [1.0, 0.85, 0.3, 0.45];
    const SUPPORT: [f32; 4] = [0.35, 0.7, 1.0, 0.35];
    let least = controls.iter().map(|c| c.3).fold(f32::INFINITY, f32::min) * 0.06;
    let size = if model > 0.0 && model.is_finite() {
        least.min(0.015 * model)
    } else {
        least
    };
    let (spheres_on, mut drawn) = (spheres, 0);
    for &(s, now, goal, r) in controls {
        let k = if size.is_finite() { size } else { 0.01 };
        for axis in [Vec3::X, Vec3::Y, Vec3::Z] {
            out.push(Line {
                a: s - axis * k,
                b: s + axis * k,
                color: START,
            });
        }
        out.push(Line {
            a: s,
            b: goal,
            color: GOAL,
        });
        out.push(Line {
            a: s,
            b: now,
            color: NOW,
        });
        // Support spheres of moving controls only (anchors would hide the model).
        if spheres_on && drawn < 16 && goal.distance(s) > 1e-6 * r {
            drawn += 1;
            sphere_lines(s, r, SUPPORT, out);
        }
    }
}

/// A camera as lines, for a view from elsewhere (the Composer's scene
/// camera): its frustum out to a quarter of the way to its target, the
/// frame of a picture of `aspect` (width / height) there, a tick above it
/// for up, and a faint line to the target.
pub fn camera_lines(camera: &Camera, aspect: f32, color: [f32; 4], out: &mut Vec<Line>) {
    let (right, up, forward) = camera.basis();
    let d = (camera.target - camera.eye).length() * 0.25;
    // Half the frame's height there, and where its edges start: the eye of
    // a pinhole, a rectangle as large as the frame for parallel rays.
    let (h, spread) = match camera.projection {
        csrbf_anim::Projection::Perspective { fov } => (d * (fov.to_radians() * 0.5).tan(), 0.0),
        csrbf_anim::Projection::Orthographic { height } => (height * 0.5, 1.0),
    };
    let w = h * aspect;
    let centre = camera.eye + forward * d;
    let offsets = [
        right * w + up * h,
        -right * w + up * h,
        -right * w - up * h,
        right * w - up * h,
    ];
    for k in 0..4 {
        let corner = centre + offsets[k];
        out.push(Line {
            a: camera.eye + offsets[k] * spread,
            b: corner,
            color,
        });
        out.push(Line {
            a: corner,
            b: centre + offsets[(k + 1) % 4],
            color,
        });
    }
    out.push(Line {
        a: centre + up * h,
        b: centre + up * h * 1.4,
        color,
    });
    out.push(Line {
        a: camera.eye,
        b: camera.target,
        color: [color[0], color[1], color[2], color[3] * 0.35],
    });
}

/// A circle of `radius` about `centre` in the plane of the unit vectors `u`
/// and `v`, as `segments` lines.
pub fn circle_lines(
    centre: Vec3,
    (u, v): (Vec3, Vec3),
    radius: f32,
    segments: usize,
    color: [f32; 4],
    out: &mut Vec<Line>,
) {
    let at = |j: usize| {
        let a = j as f32 / segments as f32 * std::f32::consts::TAU;
        centre + (u * a.cos() + v * a.sin()) * radius
    };
    for j in 0..segments {
        out.push(Line {
            a: at(j),
            b: at(j + 1),
            color,
        });
    }
}

/// A sphere drawn as its three great circles in the axis planes.
pub fn sphere_lines(centre: Vec3, radius: f32, color: [f32; 4], out: &mut Vec<Line>) {
    for plane in [(Vec3::X, Vec3::Y), (Vec3::Y, Vec3::Z), (Vec3::Z, Vec3::X)] {
        circle_lines(centre, plane, radius, 32, color, out);
    }
}

/// The diagonal of the points' bounding box (0 for none).
fn bounds_diagonal(points: &[Vec3]) -> f32 {
    let (lo, hi) = points
        .iter()
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), p| {
            (a.min(*p), b.max(*p))
        });
    if points.is_empty() {
        0.0
    } else {
        (hi - lo).length()
    }
}
