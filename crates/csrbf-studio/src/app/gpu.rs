//! The viewport on the GPU: `csrbf-render` draws the model into a texture of
//! the viewport's size (with its own depth buffer: egui's pass has none), and
//! a full-screen triangle copies that texture into egui's pass.
//!
//! Everything the drawing needs travels in a [`ViewportPaint`] (shared
//! arrays, no copies); the GPU objects live in egui's callback resources.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use csrbf::glam::Vec3;
use csrbf_anim::{Camera, Frame, Scene};
use csrbf_render::{
    DrawOptions, Line, Renderer, SceneOptions, SceneRenderer, View, default_lights,
};
use eframe::egui;
use eframe::egui_wgpu::{self, CallbackResources, CallbackTrait, ScreenDescriptor};
use eframe::wgpu;

/// The colour format the model is drawn in (sRGB, as the CLI's pictures).
const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;

pub use crate::preview::BIG_MESH_TRIANGLES;

/// How many frames [`Screen::frame_cost`] looks back on.
const RECENT_FRAMES: usize = 4;

/// What the window and the GPU give both rooms: the render state, the
/// viewport's size and place, the last frame's time.
pub(super) struct Screen {
    pub(super) gpu: Option<eframe::egui_wgpu::RenderState>,
    /// The app's own part of the last frame (its update: layout, edits,
    /// the paint callbacks queued).
    pub(super) frame_time: Duration,
    /// When the last frame began, and the time from the frame before it to
    /// that one: the whole frame as the person sees it (the app, the
    /// rasteriser, the present) while frames follow each other.
    pub(super) frame_start: Option<std::time::Instant>,
    pub(super) frame_interval: Option<Duration>,
    /// The last few whole frames, newest last ([`Screen::frame_cost`]).
    pub(super) recent_frames: Vec<Duration>,
    /// How long this frame waited for the preview's worker (a drag step
    /// drawn in the frame that sent it).
    pub(super) waited: Duration,
    /// `CSRBF_STUDIO_TRACE` set: each frame's times on stderr.
    pub(super) trace: bool,
    /// The viewport's size in physical pixels, and where it is on screen.
    pub(super) viewport: ([u32; 2], egui::Rect, f32),
    /// Whether wgpu runs on the CPU (lavapipe, llvmpipe).
    pub(super) software: bool,
    /// To wake the window from other threads.
    pub(super) ctx: egui::Context,
}

/// The next id of a mesh for the GPU side (ids are never reused: a new one
/// makes the GPU side prepare the mesh's parts again).
static NEXT_MESH_ID: AtomicU64 = AtomicU64::new(1);

/// Runs `f` with the next mesh id, which it advances by the ids it takes
/// (the UI thread alone hands ids out).
pub(super) fn with_mesh_ids<R>(f: impl FnOnce(&mut u64) -> R) -> R {
    let mut next = NEXT_MESH_ID.load(Ordering::Relaxed);
    let r = f(&mut next);
    NEXT_MESH_ID.store(next, Ordering::Relaxed);
    r
}

/// A new mesh id.
pub(super) fn new_mesh_id() -> u64 {
    with_mesh_ids(|next| {
        *next += 1;
        *next - 1
    })
}

impl Screen {
    /// A frame begins: the time since the one before is the whole frame
    /// (kept only below a second: a longer gap is an idle window).
    pub(super) fn frame_begins(&mut self, now: std::time::Instant) {
        self.frame_interval = self
            .frame_start
            .map(|t| now - t)
            .filter(|d| *d < Duration::from_secs(1));
        self.frame_start = Some(now);
        if let Some(d) = self.frame_interval {
            if self.recent_frames.len() == RECENT_FRAMES {
                self.recent_frames.remove(0);
            }
            self.recent_frames.push(d);
        }
    }

    /// What a frame costs on this machine: the shortest of the last
    /// [`RECENT_FRAMES`] whole frames (a longer one is the window waiting
    /// for input; egui draws at least two frames back to back for each
    /// pointer move), None until that many were timed.
    pub(super) fn frame_cost(&self) -> Option<Duration> {
        (self.recent_frames.len() == RECENT_FRAMES)
            .then(|| self.recent_frames.iter().copied().min())
            .flatten()
    }

    /// With `CSRBF_STUDIO_TRACE` set, one line on stderr for the frame now
    /// ending: the whole frame before it, the app's part of this one, the
    /// wait for the worker in it, the CPU time of the last viewport picture
    /// (upload, commands, submission), and the worker's time on the frame
    /// shown. What the whole frame has beyond these is egui's drawing, the
    /// rasteriser and the present.
    pub(super) fn trace(&self, worker: Option<Duration>) {
        if !self.trace {
            return;
        }
        let ms = |d: Duration| d.as_secs_f64() * 1e3;
        let prepared = self.gpu.as_ref().and_then(|g| {
            g.renderer
                .read()
                .callback_resources
                .get::<ViewportGpu>()
                .map(|v| (v.prepared, v.light, v.drawn_size))
        });
        eprintln!(
            "trace: frame {:.1} ms, app {:.1} ms (waited {:.1} ms for the worker), viewport draw {:.1} ms ({}{}), worker {:.1} ms",
            self.frame_interval.map_or(0.0, ms),
            ms(self.frame_time),
            ms(self.waited),
            prepared.map_or(0.0, |p| ms(p.0)),
            prepared.map_or(String::new(), |p| format!("{}x{}", p.2[0], p.2[1])),
            if prepared.is_some_and(|p| p.1) {
                ", stand-in"
            } else {
                ""
            },
            worker.map_or(0.0, ms),
        );
    }

    /// The status bar's frame figure: the whole frame and the app's part
    /// of it ("frame 41 ms (app 3.0 ms)"), or the app's part alone while
    /// the window is idle.
    pub(super) fn frame_text(&self) -> String {
        let ms = |d: Duration| d.as_secs_f64() * 1e3;
        match self.frame_interval {
            Some(whole) => format!(
                "frame {:.0} ms (app {:.1} ms)",
                ms(whole),
                ms(self.frame_time)
            ),
            None => format!("app {:.1} ms a frame", ms(self.frame_time)),
        }
    }
}

/// A mesh newly opened: the GPU side prepares its parts once.
pub struct NewMesh {
    /// Identifies the mesh (changes on each open).
    pub id: u64,
    /// The scene `csrbf render` would make of it (parts, colours, textures).
    pub scene: Mutex<Option<Scene>>,
    /// Samples per pixel: 4 on a GPU, 1 on a software rasteriser (4x costs
    /// it three times the frame: 31 against 11 ms for the head at 1280x800)
    /// or for a big mesh.
    pub samples: u32,
}

/// One picture of the viewport.
pub struct ViewportPaint {
    /// Size in physical pixels.
    pub size: [u32; 2],
    /// The mesh drawn (its parts prepared once from [`NewMesh::scene`]).
    pub mesh: Arc<NewMesh>,
    /// Positions drawn.
    pub positions: Arc<Vec<Vec3>>,
    /// A light copy to draw instead (a big mesh moving); `positions` and
    /// `normals` are then its vertices'.
    pub stand_in: Option<Arc<csrbf_mesh::StandIn>>,
    /// Their normals.
    pub normals: Arc<Vec<Vec3>>,
    /// The camera.
    pub camera: Camera,
    /// Lines drawn with the depth test (flipped faces).
    pub lines: Vec<Line>,
    /// Lines drawn over everything (controls, the gizmo, the ghost).
    pub overlay: Vec<Line>,
    /// Shading.
    pub options: DrawOptions,
    /// Background, linear RGB.
    pub background: [f32; 3],
}

/// Whose scene renderer: each room keeps its own.
#[derive(Clone, Copy)]
enum Room {
    Picker = 0,
    Composer = 1,
}

/// The GPU objects of the viewport, kept between frames.
struct ViewportGpu {
    blit: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    /// The scene renderer of each room (the Picker's mesh, the Composer's
    /// scene) with the id it was made for: each keeps its own, so a room
    /// drawn again finds its parts prepared (the Picker's mesh is handed to
    /// the GPU side once).
    scenes: [Option<(u64, SceneRenderer)>; 2],
    target: Option<([u32; 2], wgpu::TextureView, wgpu::BindGroup)>,
    error: Option<String>,
    /// The CPU time of the last picture's preparation (the upload, the
    /// commands, their submission), for `CSRBF_STUDIO_TRACE`.
    prepared: Duration,
    /// Whether that picture was of a stand-in, and its size, for the same.
    light: bool,
    drawn_size: [u32; 2],
    /// What the Composer's picture in `target` shows (see
    /// [`ScenePaint::stamp`]): the same stamp is not drawn again.
    drawn: Option<u64>,
    /// The blit copies the picture's sRGB bytes as they are (egui's target
    /// is not sRGB).
    raw: bool,
}

/// Sets up the blit pipeline in egui's renderer (once, when the app starts).
pub fn install(state: &egui_wgpu::RenderState) {
    let device = &state.device;
    // egui's own target is usually not sRGB (it blends in gamma space):
    // then the blit reads the picture's sRGB bytes as they are, through a
    // plain view of the texture, with no decode and encode per pixel.
    let raw = !state.target_format.is_srgb();
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("viewport blit"),
        source: wgpu::ShaderSource::Wgsl(BLIT.into()),
    });
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("viewport blit"),
        entries: &[wgpu::BindGroupLayoutEntry {
            binding: 0,
            visibility: wgpu::ShaderStages::FRAGMENT,
            ty: wgpu::BindingType::Texture {
                sample_type: wgpu::TextureSampleType::Float { filterable: false },
                view_dimension: wgpu::TextureViewDimension::D2,
                multisampled: false,
            },
            count: None,
        }],
    });
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("viewport blit"),
        bind_group_layouts: &[Some(&layout)],
        immediate_size: 0,
    });
    let blit = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("viewport blit"),
        layout: Some(&pipeline_layout),
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some("vs"),
            compilation_options: Default::default(),
            buffers: &[],
        },
        fragment: Some(wgpu::FragmentState {
            module: &module,
            entry_point: Some("fs"),
            compilation_options: Default::default(),
            targets: &[Some(wgpu::ColorTargetState {
                format: state.target_format,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            })],
        }),
        primitive: wgpu::PrimitiveState::default(),
        depth_stencil: None,
        multisample: wgpu::MultisampleState::default(),
        multiview_mask: None,
        cache: None,
    });
    state
        .renderer
        .write()
        .callback_resources
        .insert(ViewportGpu {
            blit,
            layout,
            scenes: [None, None],
            target: None,
            error: None,
            drawn: None,
            prepared: Duration::ZERO,
            light: false,
            drawn_size: [0, 0],
            raw,
        });
}

const BLIT: &str = r#"
struct Out { @builtin(position) pos: vec4<f32>, @location(0) uv: vec2<f32> };
@vertex fn vs(@builtin(vertex_index) i: u32) -> Out {
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    var o: Out;
    o.pos = vec4<f32>(uv * vec2<f32>(2.0, -2.0) + vec2<f32>(-1.0, 1.0), 0.0, 1.0);
    o.uv = uv;
    return o;
}
@group(0) @binding(0) var tex: texture_2d<f32>;
@fragment fn fs(o: Out) -> @location(0) vec4<f32> {
    // The texture has the viewport's size: a load per pixel, no filtering
    // (cheaper on a software rasteriser).
    let size = vec2<f32>(textureDimensions(tex));
    let texel = min(vec2<i32>(o.uv * size), vec2<i32>(size) - vec2<i32>(1, 1));
    // Bytes as they are: sRGB-encoded for a target that is not sRGB, else
    // decoded to linear by the sRGB view (and encoded again by the target).
    let c = textureLoad(tex, texel, 0);
    return vec4<f32>(c.rgb, 1.0);
}
"#;

impl CallbackTrait for ViewportPaint {
    fn prepare(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        _screen: &ScreenDescriptor,
        _encoder: &mut wgpu::CommandEncoder,
        resources: &mut CallbackResources,
    ) -> Vec<wgpu::CommandBuffer> {
        let Some(gpu) = resources.get_mut::<ViewportGpu>() else {
            return Vec::new();
        };
        let started = std::time::Instant::now();
        if let Err(e) = self.draw(gpu, device, queue) {
            gpu.error = Some(e.to_string());
        }
        gpu.prepared = started.elapsed();
        gpu.light = self.stand_in.is_some();
        gpu.drawn_size = self.size;
        Vec::new()
    }

    fn paint(
        &self,
        _info: egui::PaintCallbackInfo,
        pass: &mut wgpu::RenderPass<'static>,
        resources: &CallbackResources,
    ) {
        if let Some(gpu) = resources.get::<ViewportGpu>() {
            gpu.blit(self.size, pass);
        }
    }
}

impl ViewportGpu {
    /// The scene renderer of `room` for `id`, made by `make` on a renderer
    /// of this device when `id` is new (None: nothing to draw yet), sized to
    /// `size`.
    fn scene_renderer(
        &mut self,
        (room, id): (Room, u64),
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        samples: u32,
        size: [u32; 2],
        make: impl FnOnce(Renderer) -> Option<csrbf_render::Result<SceneRenderer>>,
    ) -> csrbf_render::Result<Option<&mut SceneRenderer>> {
        let [w, h] = size;
        let slot = &mut self.scenes[room as usize];
        if slot.as_ref().map(|(k, _)| *k) != Some(id) {
            let renderer =
                Renderer::on_device(device.clone(), queue.clone(), FORMAT, w, h, samples)?;
            match make(renderer) {
                Some(r) => *slot = Some((id, r?)),
                None => return Ok(None),
            }
        }
        let Some((_, scene)) = slot.as_mut() else {
            return Ok(None);
        };
        scene.renderer_mut().resize(w, h)?;
        Ok(Some(scene))
    }

    /// The texture the viewport is drawn into, of `size`.
    fn target(&mut self, device: &wgpu::Device, size: [u32; 2]) -> wgpu::TextureView {
        if let Some((s, view, _)) = &self.target
            && *s == size
        {
            return view.clone();
        }
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("viewport"),
            size: wgpu::Extent3d {
                width: size[0],
                height: size[1],
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[wgpu::TextureFormat::Rgba8Unorm],
        });
        let view = texture.create_view(&Default::default());
        let read = if self.raw {
            texture.create_view(&wgpu::TextureViewDescriptor {
                format: Some(wgpu::TextureFormat::Rgba8Unorm),
                ..Default::default()
            })
        } else {
            view.clone()
        };
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("viewport"),
            layout: &self.layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::TextureView(&read),
            }],
        });
        self.target = Some((size, view.clone(), group));
        view
    }

    /// Copies the drawn texture into egui's pass.
    fn blit(&self, size: [u32; 2], pass: &mut wgpu::RenderPass<'static>) {
        if let Some((s, _, group)) = &self.target
            && *s == size
        {
            pass.set_pipeline(&self.blit);
            pass.set_bind_group(0, group, &[]);
            pass.draw(0..3, 0..1);
        }
    }
}

impl ViewportPaint {
    fn draw(
        &self,
        gpu: &mut ViewportGpu,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
    ) -> csrbf_render::Result<()> {
        let target = gpu.target(device, self.size);
        // The Picker draws over the Composer's last picture.
        gpu.drawn = None;
        let made = gpu.scene_renderer(
            (Room::Picker, self.mesh.id),
            device,
            queue,
            self.mesh.samples,
            self.size,
            |renderer| {
                let taken = self.mesh.scene.lock().ok().and_then(|mut s| s.take())?;
                Some(SceneRenderer::on_renderer(&taken, renderer))
            },
        )?;
        let Some(scene) = made else {
            return Ok(());
        };
        let view = View {
            camera: self.camera,
            lights: default_lights(self.camera),
            background: self.background,
            meshes: Vec::new(),
            lines: self.lines.clone(),
            overlay: self.overlay.clone(),
            options: self.options,
        };
        match &self.stand_in {
            Some(light) => scene.draw_stand_in_into(
                &view,
                0,
                &self.positions,
                &self.normals,
                &light.indices,
                &target,
            ),
            None => scene.draw_object_into(&view, 0, &self.positions, &self.normals, &target),
        }
        gpu.error = None;
        Ok(())
    }
}

/// A stand-in at one frame: its triangles, its vertices' positions and
/// normals.
pub type StandInFrame = (Arc<csrbf_mesh::StandIn>, Vec<Vec3>, Vec<Vec3>);

/// One picture of the Composer's viewport: a frame of the scene.
pub struct ScenePaint {
    /// Size in physical pixels.
    pub size: [u32; 2],
    /// Identifies the GPU preparation of `scene`: parts and textures are
    /// prepared once per id (a new id when objects, parts or looks change;
    /// the same while only keys do).
    pub id: u64,
    /// Samples per pixel (see [`NewMesh::samples`]).
    pub samples: u32,
    /// The scene (its camera, lights and background are drawn).
    pub scene: Arc<Scene>,
    /// The frame drawn.
    pub frame: Arc<Frame>,
    /// Camera and shading (the scene's own lights and background).
    pub options: SceneOptions,
    /// Lines among the meshes (trajectories).
    pub lines: Vec<Line>,
    /// Lines over everything (keys, the camera, gizmos).
    pub overlay: Vec<Line>,
    /// Objects left out.
    pub hidden: Vec<bool>,
    /// Objects drawn by a lighter stand-in (big meshes while the scene
    /// plays): its triangles, and its vertices' positions and normals.
    pub stand_ins: Vec<Option<StandInFrame>>,
    /// Identifies what this picture shows (scene, frame, camera, lines):
    /// when it equals the last one drawn, the texture is shown again
    /// without drawing (a window repainted for its panels, a progress bar).
    pub stamp: u64,
}

impl CallbackTrait for ScenePaint {
    fn prepare(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        _screen: &ScreenDescriptor,
        _encoder: &mut wgpu::CommandEncoder,
        resources: &mut CallbackResources,
    ) -> Vec<wgpu::CommandBuffer> {
        let Some(gpu) = resources.get_mut::<ViewportGpu>() else {
            return Vec::new();
        };
        let target = gpu.target(device, self.size);
        let key = self.stamp
            ^ self.id.rotate_left(17)
            ^ ((self.size[0] as u64) << 32 | self.size[1] as u64);
        let room = &gpu.scenes[Room::Composer as usize];
        if gpu.drawn == Some(key) && room.as_ref().is_some_and(|(id, _)| *id == self.id) {
            return Vec::new();
        }
        let s = &self.scene;
        let made = gpu.scene_renderer(
            (Room::Composer, self.id),
            device,
            queue,
            self.samples,
            self.size,
            |r| Some(SceneRenderer::on_renderer(s, r)),
        );
        match made {
            Ok(Some(r)) => {
                let stand_ins: Vec<_> = self
                    .stand_ins
                    .iter()
                    .map(|s| {
                        s.as_ref().map(|(light, p, n)| csrbf_render::StandInDraw {
                            positions: p,
                            normals: n,
                            indices: &light.indices,
                        })
                    })
                    .collect();
                r.draw_frame_into(
                    s,
                    &self.frame,
                    self.options,
                    &self.lines,
                    &self.overlay,
                    &self.hidden,
                    &stand_ins,
                    &target,
                );
                gpu.error = None;
                gpu.drawn = Some(key);
            }
            Ok(None) => {}
            Err(e) => gpu.error = Some(e.to_string()),
        }
        Vec::new()
    }

    fn paint(
        &self,
        _info: egui::PaintCallbackInfo,
        pass: &mut wgpu::RenderPass<'static>,
        resources: &CallbackResources,
    ) {
        if let Some(gpu) = resources.get::<ViewportGpu>() {
            gpu.blit(self.size, pass);
        }
    }
}

/// The last error the GPU side met, if any (shown in the status bar).
pub fn last_error(state: &egui_wgpu::RenderState) -> Option<String> {
    state
        .renderer
        .read()
        .callback_resources
        .get::<ViewportGpu>()
        .and_then(|g| g.error.clone())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Instant;

    /// A screen without a GPU, no frame timed yet.
    fn screen() -> Screen {
        Screen {
            gpu: None,
            frame_time: Duration::ZERO,
            frame_start: None,
            frame_interval: None,
            recent_frames: Vec::new(),
            waited: Duration::ZERO,
            trace: false,
            viewport: ([1, 1], egui::Rect::NOTHING, 1.0),
            software: true,
            ctx: egui::Context::default(),
        }
    }

    #[test]
    fn the_frame_figure_is_the_whole_frame_while_frames_follow_each_other() {
        let mut s = screen();
        s.frame_time = Duration::from_millis(3);
        let t0 = Instant::now();
        s.frame_begins(t0);
        assert_eq!(s.frame_text(), "app 3.0 ms a frame");
        s.frame_begins(t0 + Duration::from_millis(270));
        assert_eq!(s.frame_text(), "frame 270 ms (app 3.0 ms)");
        // After an idle second the window was waiting, not drawing.
        s.frame_begins(t0 + Duration::from_secs(5));
        assert_eq!(s.frame_text(), "app 3.0 ms a frame");
    }

    #[test]
    fn a_frame_costs_the_shortest_of_the_last_few() {
        let mut s = screen();
        let mut t = Instant::now();
        // A pointer held still for 600 ms, then frames 40 ms apart.
        for gap in [600, 40, 40] {
            s.frame_begins(t);
            t += Duration::from_millis(gap);
        }
        s.frame_begins(t);
        assert_eq!(s.frame_cost(), None, "four frames not timed yet");
        t += Duration::from_millis(600);
        s.frame_begins(t);
        assert_eq!(
            s.frame_cost(),
            Some(Duration::from_millis(40)),
            "quick frames"
        );
        // Only slow frames: slow.
        for _ in 0..4 {
            t += Duration::from_millis(110);
            s.frame_begins(t);
        }
        assert_eq!(s.frame_cost(), Some(Duration::from_millis(110)));
    }
}
