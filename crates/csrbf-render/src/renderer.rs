//! The wgpu renderer: draws meshes and lines into its own multisampled colour
//! and depth textures and reads the picture back. It needs no window; on a
//! machine without a GPU it runs on Mesa's software Vulkan driver (lavapipe).

use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec2, Vec3};
use wgpu::util::DeviceExt;

pub use csrbf_anim::Camera;

use crate::image::Image;
use crate::{RenderError, Result};

const COLOR: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;
const DEPTH: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
/// Multisampling used unless asked otherwise: smooth edges.
pub const DEFAULT_SAMPLES: u32 = 4;

/// A directional light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Light {
    /// Direction the light travels.
    pub direction: Vec3,
    /// Colour times intensity, linear RGB.
    pub color: Vec3,
}

/// Part of a mesh with one look.
#[derive(Clone, Debug, PartialEq)]
pub struct DrawPart {
    /// Triangles (vertex indices of the mesh).
    pub indices: Vec<u32>,
    /// Base colour, linear RGBA.
    pub color: [f32; 4],
    /// A texture made by [`Renderer::texture`].
    pub texture: Option<TextureId>,
    /// Draw this part's edges even when the view's wireframe is off.
    pub wireframe: bool,
}

/// A mesh to draw: per-vertex attributes and parts.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DrawMesh {
    /// Positions in world space.
    pub positions: Vec<Vec3>,
    /// Normals in world space.
    pub normals: Vec<Vec3>,
    /// Texture coordinates (zeros when empty).
    pub uvs: Vec<Vec2>,
    /// Vertex colours, linear RGBA (white when empty).
    pub colors: Vec<[f32; 4]>,
    /// Parts.
    pub parts: Vec<DrawPart>,
    /// Non-zero when the parts (indices, colours, textures) are the same as
    /// in the last picture that had this key at this place in the view: the
    /// renderer then keeps their GPU buffers. 0: always upload.
    pub key: u64,
}

/// A line segment with a colour (linear RGBA).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Line {
    /// One end.
    pub a: Vec3,
    /// The other.
    pub b: Vec3,
    /// Colour.
    pub color: [f32; 4],
}

/// How to draw.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub struct DrawOptions {
    /// Flat shading (one normal per triangle). Default false (smooth).
    pub flat: bool,
    /// Draw triangle edges over the surface. Default false.
    pub wireframe: bool,
    /// Ambient light. Default 0.22.
    pub ambient: f32,
}

impl Default for DrawOptions {
    fn default() -> Self {
        DrawOptions {
            flat: false,
            wireframe: false,
            ambient: 0.22,
        }
    }
}

/// Everything one picture shows.
#[derive(Clone, Debug, PartialEq)]
pub struct View {
    /// Camera.
    pub camera: Camera,
    /// Up to four lights.
    pub lights: Vec<Light>,
    /// Background, linear RGB.
    pub background: [f32; 3],
    /// Meshes.
    pub meshes: Vec<DrawMesh>,
    /// Lines drawn with depth test (wireframe, scenery).
    pub lines: Vec<Line>,
    /// Lines drawn on top of everything (control-vector overlay).
    pub overlay: Vec<Line>,
    /// Options.
    pub options: DrawOptions,
}

/// A texture uploaded to the renderer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct TextureId(usize);

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Vertex {
    pos: [f32; 3],
    normal: [f32; 3],
    uv: [f32; 2],
    color: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct LineVertex {
    pos: [f32; 3],
    color: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Globals {
    view_proj: [[f32; 4]; 4],
    eye: [f32; 4],
    light_dir: [[f32; 4]; 4],
    light_color: [[f32; 4]; 4],
    params: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct PartUniform {
    color: [f32; 4],
    flags: [f32; 4],
}

struct Targets {
    width: u32,
    height: u32,
    msaa: wgpu::TextureView,
    resolve: wgpu::Texture,
    resolve_view: wgpu::TextureView,
    depth: wgpu::TextureView,
    readback: wgpu::Buffer,
    padded_row: u32,
    samples: u32,
}

/// A headless renderer of a fixed picture size.
pub struct Renderer {
    device: wgpu::Device,
    queue: wgpu::Queue,
    adapter_name: String,
    mesh_pipeline: wgpu::RenderPipeline,
    line_pipeline: wgpu::RenderPipeline,
    wire_pipeline: wgpu::RenderPipeline,
    overlay_pipeline: wgpu::RenderPipeline,
    globals: wgpu::Buffer,
    globals_group: wgpu::BindGroup,
    part_layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    textures: Vec<wgpu::TextureView>,
    white: wgpu::TextureView,
    targets: Targets,
    samples: u32,
    cache: Vec<MeshSlot>,
}

/// GPU buffers of one mesh slot of a view, kept between pictures.
#[derive(Default)]
struct MeshSlot {
    key: u64,
    vb: Option<wgpu::Buffer>,
    vbytes: u64,
    parts: Vec<(wgpu::Buffer, u32, wgpu::BindGroup)>,
}

/// Edges of every part's triangles, for the wireframe.
fn wire_lines(m: &DrawMesh, all: bool, wire: &mut Vec<LineVertex>) {
    let n = m.positions.len();
    for p in m.parts.iter().filter(|p| all || p.wireframe) {
        for t in p.indices.chunks_exact(3) {
            if t.iter().any(|&i| i as usize >= n) {
                continue;
            }
            for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                for i in [a, b] {
                    wire.push(LineVertex {
                        pos: m.positions[i as usize].to_array(),
                        color: [0.05, 0.05, 0.08, 0.85],
                    });
                }
            }
        }
    }
}

impl Renderer {
    /// Largest side accepted, in pixels.
    pub const MAX_SIDE: u32 = 8192;

    /// A renderer for pictures of `width` x `height`. Picks the system's
    /// adapter (a GPU, or lavapipe on the CPU); `WGPU_BACKEND` can force one.
    pub fn new(width: u32, height: u32) -> Result<Renderer> {
        Renderer::with_samples(width, height, DEFAULT_SAMPLES)
    }

    /// A renderer with `samples` per pixel (1 or 4): 4 smooths edges, 1 is
    /// faster on a software rasteriser.
    pub fn with_samples(width: u32, height: u32, samples: u32) -> Result<Renderer> {
        check_size(width, height)?;
        let samples = if samples >= 4 { 4 } else { 1 };
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let adapter =
            pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions::default()))
                .map_err(|e| RenderError::NoAdapter(e.to_string()))?;
        let adapter_name = format!(
            "{} ({:?})",
            adapter.get_info().name,
            adapter.get_info().backend
        );
        let (device, queue) =
            pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor::default()))
                .map_err(|e| RenderError::NoAdapter(e.to_string()))?;
        let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("csrbf shader"),
            source: wgpu::ShaderSource::Wgsl(include_str!("shader.wgsl").into()),
        });
        let globals_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("globals"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            }],
        });
        let part_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("part"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: true },
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: false,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 2,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                    count: None,
                },
            ],
        });
        let mesh_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("mesh"),
            bind_group_layouts: &[Some(&globals_layout), Some(&part_layout)],
            immediate_size: 0,
        });
        let line_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("line"),
            bind_group_layouts: &[Some(&globals_layout)],
            immediate_size: 0,
        });
        let mesh_attrs = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x2, 3 => Float32x4];
        let line_attrs = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x4];
        let depth =
            |write: bool, compare: wgpu::CompareFunction, bias: i32| wgpu::DepthStencilState {
                format: DEPTH,
                depth_write_enabled: Some(write),
                depth_compare: Some(compare),
                stencil: wgpu::StencilState::default(),
                bias: wgpu::DepthBiasState {
                    constant: bias,
                    slope_scale: if bias != 0 { 1.0 } else { 0.0 },
                    clamp: 0.0,
                },
            };
        let blend = Some(wgpu::ColorTargetState {
            format: COLOR,
            blend: Some(wgpu::BlendState::ALPHA_BLENDING),
            write_mask: wgpu::ColorWrites::ALL,
        });
        let make = |label: &str,
                    layout: &wgpu::PipelineLayout,
                    vs: &str,
                    fs: &str,
                    buffers: &[Option<wgpu::VertexBufferLayout>],
                    topology: wgpu::PrimitiveTopology,
                    depth_state: wgpu::DepthStencilState| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(layout),
                vertex: wgpu::VertexState {
                    module: &shader,
                    entry_point: Some(vs),
                    compilation_options: Default::default(),
                    buffers,
                },
                primitive: wgpu::PrimitiveState {
                    topology,
                    cull_mode: None,
                    ..Default::default()
                },
                depth_stencil: Some(depth_state),
                multisample: wgpu::MultisampleState {
                    count: samples,
                    ..Default::default()
                },
                fragment: Some(wgpu::FragmentState {
                    module: &shader,
                    entry_point: Some(fs),
                    compilation_options: Default::default(),
                    targets: std::slice::from_ref(&blend),
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        let mesh_buffers = [Some(wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<Vertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &mesh_attrs,
        })];
        let line_buffers = [Some(wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<LineVertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &line_attrs,
        })];
        use wgpu::CompareFunction::{Always, LessEqual};
        use wgpu::PrimitiveTopology::{LineList, TriangleList};
        // The surface is pushed back a little so edges drawn on it win the depth test.
        let mesh_pipeline = make(
            "mesh",
            &mesh_layout,
            "vs_mesh",
            "fs_mesh",
            &mesh_buffers,
            TriangleList,
            depth(true, LessEqual, 2),
        );
        let line_pipeline = make(
            "lines",
            &line_layout,
            "vs_line",
            "fs_line",
            &line_buffers,
            LineList,
            depth(true, LessEqual, 0),
        );
        let wire_pipeline = make(
            "wire",
            &line_layout,
            "vs_line",
            "fs_line",
            &line_buffers,
            LineList,
            depth(false, LessEqual, 0),
        );
        let overlay_pipeline = make(
            "overlay",
            &line_layout,
            "vs_line",
            "fs_line",
            &line_buffers,
            LineList,
            depth(false, Always, 0),
        );
        let globals = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("globals"),
            size: std::mem::size_of::<Globals>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let globals_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("globals"),
            layout: &globals_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: globals.as_entire_binding(),
            }],
        });
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            address_mode_u: wgpu::AddressMode::Repeat,
            address_mode_v: wgpu::AddressMode::Repeat,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        let white = upload_texture(&device, &queue, 1, 1, &[255, 255, 255, 255]);
        let targets = make_targets(&device, width, height, samples);
        Ok(Renderer {
            device,
            queue,
            adapter_name,
            mesh_pipeline,
            line_pipeline,
            wire_pipeline,
            overlay_pipeline,
            globals,
            globals_group,
            part_layout,
            sampler,
            textures: Vec::new(),
            white,
            targets,
            samples,
            cache: Vec::new(),
        })
    }

    /// Picture width in pixels.
    pub fn width(&self) -> u32 {
        self.targets.width
    }

    /// Picture height in pixels.
    pub fn height(&self) -> u32 {
        self.targets.height
    }

    /// The adapter in use, e.g. "llvmpipe (LLVM 15.0.6, 256 bits) (Vulkan)".
    pub fn adapter(&self) -> &str {
        &self.adapter_name
    }

    /// Picture size.
    pub fn size(&self) -> (u32, u32) {
        (self.targets.width, self.targets.height)
    }

    /// Changes the picture size.
    pub fn resize(&mut self, width: u32, height: u32) -> Result<()> {
        check_size(width, height)?;
        self.targets = make_targets(&self.device, width, height, self.samples);
        Ok(())
    }

    /// Uploads an RGBA8 (sRGB) texture for [`DrawPart::texture`].
    pub fn texture(&mut self, width: u32, height: u32, rgba: &[u8]) -> Result<TextureId> {
        if width == 0
            || height == 0
            || rgba.len() != 4 * width as usize * height as usize
            || width > 16384
            || height > 16384
        {
            return Err(RenderError::BadTexture(format!(
                "{width} x {height} with {} bytes",
                rgba.len()
            )));
        }
        self.textures.push(upload_texture(
            &self.device,
            &self.queue,
            width,
            height,
            rgba,
        ));
        Ok(TextureId(self.textures.len() - 1))
    }

    /// Draws the view and reads the picture back.
    pub fn render(&mut self, view: &View) -> Result<Image> {
        let (w, h) = (self.targets.width, self.targets.height);
        let c = view.camera;
        let aspect = w as f32 / h as f32;
        let (near, far) = near_far(view);
        let vp: Mat4 = c.view_proj(aspect, near, far);
        let mut g = Globals {
            view_proj: vp.to_cols_array_2d(),
            eye: c.eye.extend(1.0).to_array(),
            light_dir: [[0.0; 4]; 4],
            light_color: [[0.0; 4]; 4],
            params: [
                view.lights.len().min(4) as f32,
                view.options.flat as u32 as f32,
                view.options.ambient,
                0.0,
            ],
        };
        for (k, l) in view.lights.iter().take(4).enumerate() {
            g.light_dir[k] = l.direction.extend(0.0).to_array();
            g.light_color[k] = l.color.extend(1.0).to_array();
        }
        self.queue
            .write_buffer(&self.globals, 0, bytemuck::bytes_of(&g));

        // Vertex data and one bind group per part.
        let mut wire: Vec<LineVertex> = Vec::new();
        for (slot, m) in view.meshes.iter().enumerate() {
            if self.cache.len() <= slot {
                self.cache.push(MeshSlot::default());
            }
            let mut cached = std::mem::take(&mut self.cache[slot]);
            self.upload_mesh(&mut cached, m);
            self.cache[slot] = cached;
            if view.options.wireframe || m.parts.iter().any(|p| p.wireframe) {
                wire_lines(m, view.options.wireframe, &mut wire);
            }
        }
        self.cache.truncate(view.meshes.len());
        let line_buf = |lines: &[Line]| -> Option<(wgpu::Buffer, u32)> {
            if lines.is_empty() {
                return None;
            }
            let v: Vec<LineVertex> = lines
                .iter()
                .flat_map(|l| {
                    [
                        LineVertex {
                            pos: l.a.to_array(),
                            color: l.color,
                        },
                        LineVertex {
                            pos: l.b.to_array(),
                            color: l.color,
                        },
                    ]
                })
                .collect();
            Some((
                self.device
                    .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                        label: Some("lines"),
                        contents: bytemuck::cast_slice(&v),
                        usage: wgpu::BufferUsages::VERTEX,
                    }),
                v.len() as u32,
            ))
        };
        let scenery = line_buf(&view.lines);
        let overlay = line_buf(&view.overlay);
        let wire_buf = (!wire.is_empty()).then(|| {
            (
                self.device
                    .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                        label: Some("wire"),
                        contents: bytemuck::cast_slice(&wire),
                        usage: wgpu::BufferUsages::VERTEX,
                    }),
                wire.len() as u32,
            )
        });

        let mut enc = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("frame"),
            });
        let multisampled = self.targets.samples > 1;
        {
            let bg = view.background;
            let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("frame"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: if multisampled {
                        &self.targets.msaa
                    } else {
                        &self.targets.resolve_view
                    },
                    depth_slice: None,
                    resolve_target: multisampled.then_some(&self.targets.resolve_view),
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color {
                            r: bg[0] as f64,
                            g: bg[1] as f64,
                            b: bg[2] as f64,
                            a: 1.0,
                        }),
                        store: if multisampled {
                            wgpu::StoreOp::Discard
                        } else {
                            wgpu::StoreOp::Store
                        },
                    },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &self.targets.depth,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(1.0),
                        store: wgpu::StoreOp::Discard,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_bind_group(0, &self.globals_group, &[]);
            pass.set_pipeline(&self.mesh_pipeline);
            for slot in &self.cache {
                let (Some(vb), parts) = (&slot.vb, &slot.parts) else {
                    continue;
                };
                pass.set_vertex_buffer(0, vb.slice(..slot.vbytes));
                for (ib, count, group) in parts {
                    pass.set_bind_group(1, group, &[]);
                    pass.set_index_buffer(ib.slice(..), wgpu::IndexFormat::Uint32);
                    pass.draw_indexed(0..*count, 0, 0..1);
                }
            }
            for (pipeline, buf) in [
                (&self.line_pipeline, &scenery),
                (&self.wire_pipeline, &wire_buf),
                (&self.overlay_pipeline, &overlay),
            ] {
                if let Some((b, n)) = buf {
                    pass.set_pipeline(pipeline);
                    pass.set_vertex_buffer(0, b.slice(..));
                    pass.draw(0..*n, 0..1);
                }
            }
        }
        let t = &self.targets;
        enc.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture: &t.resolve,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &t.readback,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(t.padded_row),
                    rows_per_image: Some(h),
                },
            },
            wgpu::Extent3d {
                width: w,
                height: h,
                depth_or_array_layers: 1,
            },
        );
        self.queue.submit([enc.finish()]);
        let slice = t.readback.slice(..);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| RenderError::Gpu(e.to_string()))?;
        rx.recv()
            .map_err(|e| RenderError::Gpu(e.to_string()))?
            .map_err(|e| RenderError::Gpu(e.to_string()))?;
        let mut rgba = Vec::with_capacity(4 * w as usize * h as usize);
        {
            let data = slice
                .get_mapped_range()
                .map_err(|e| RenderError::Gpu(format!("{e:?}")))?;
            for row in 0..h as usize {
                let s = row * t.padded_row as usize;
                rgba.extend_from_slice(&data[s..s + 4 * w as usize]);
            }
        }
        t.readback.unmap();
        Ok(Image {
            width: w,
            height: h,
            rgba,
        })
    }
}

impl Renderer {
    /// Writes a mesh's vertices into its slot; rebuilds the slot's index
    /// buffers and part bindings unless `m.key` says they are unchanged.
    fn upload_mesh(&self, slot: &mut MeshSlot, m: &DrawMesh) {
        let n = m.positions.len();
        let verts: Vec<Vertex> = (0..n)
            .map(|i| Vertex {
                pos: m.positions[i].to_array(),
                normal: m.normals.get(i).copied().unwrap_or(Vec3::Z).to_array(),
                uv: m.uvs.get(i).copied().unwrap_or(Vec2::ZERO).to_array(),
                color: m.colors.get(i).copied().unwrap_or([1.0; 4]),
            })
            .collect();
        if verts.is_empty() {
            slot.vb = None;
            slot.parts.clear();
            return;
        }
        let bytes: &[u8] = bytemuck::cast_slice(&verts);
        match &slot.vb {
            Some(vb) if vb.size() >= bytes.len() as u64 => self.queue.write_buffer(vb, 0, bytes),
            _ => {
                slot.vb = Some(
                    self.device
                        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                            label: Some("vertices"),
                            contents: bytes,
                            usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
                        }),
                );
            }
        }
        slot.vbytes = bytes.len() as u64;
        if m.key != 0 && slot.key == m.key {
            return;
        }
        slot.key = m.key;
        slot.parts.clear();
        for p in &m.parts {
            let idx: Vec<u32> = p
                .indices
                .iter()
                .copied()
                .filter(|&i| (i as usize) < n)
                .collect();
            if idx.len() < 3 {
                continue;
            }
            let ib = self
                .device
                .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("indices"),
                    contents: bytemuck::cast_slice(&idx[..idx.len() / 3 * 3]),
                    usage: wgpu::BufferUsages::INDEX,
                });
            let tex = p.texture.and_then(|t| self.textures.get(t.0));
            let u = PartUniform {
                color: p.color,
                flags: [tex.is_some() as u32 as f32, 0.0, 0.0, 0.0],
            };
            let ub = self
                .device
                .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("part"),
                    contents: bytemuck::bytes_of(&u),
                    usage: wgpu::BufferUsages::UNIFORM,
                });
            let group = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("part"),
                layout: &self.part_layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: ub.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::TextureView(tex.unwrap_or(&self.white)),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: wgpu::BindingResource::Sampler(&self.sampler),
                    },
                ],
            });
            slot.parts.push((ib, (idx.len() / 3 * 3) as u32, group));
        }
    }
}

fn check_size(width: u32, height: u32) -> Result<()> {
    if width == 0 || height == 0 || width > Renderer::MAX_SIDE || height > Renderer::MAX_SIDE {
        return Err(RenderError::BadSize { width, height });
    }
    Ok(())
}

/// Near and far planes that hold everything drawn.
fn near_far(view: &View) -> (f32, f32) {
    let eye = view.camera.eye;
    let mut far: f32 = 0.0;
    for m in &view.meshes {
        for p in &m.positions {
            far = far.max(p.distance(eye));
        }
    }
    for l in view.lines.iter().chain(&view.overlay) {
        far = far.max(l.a.distance(eye)).max(l.b.distance(eye));
    }
    let far = if far > 0.0 && far.is_finite() {
        far * 1.05
    } else {
        100.0
    };
    (far * 1e-3, far)
}

fn upload_texture(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    width: u32,
    height: u32,
    rgba: &[u8],
) -> wgpu::TextureView {
    let tex = device.create_texture_with_data(
        queue,
        &wgpu::TextureDescriptor {
            label: Some("texture"),
            size: wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba8UnormSrgb,
            usage: wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        },
        wgpu::util::TextureDataOrder::LayerMajor,
        rgba,
    );
    tex.create_view(&Default::default())
}

fn make_targets(device: &wgpu::Device, width: u32, height: u32, samples: u32) -> Targets {
    let size = wgpu::Extent3d {
        width,
        height,
        depth_or_array_layers: 1,
    };
    let tex = |label: &str, format, samples, usage| {
        device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size,
            mip_level_count: 1,
            sample_count: samples,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage,
            view_formats: &[],
        })
    };
    let msaa = tex(
        "msaa",
        COLOR,
        samples,
        wgpu::TextureUsages::RENDER_ATTACHMENT,
    )
    .create_view(&Default::default());
    let resolve = tex(
        "resolve",
        COLOR,
        1,
        wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
    );
    let resolve_view = resolve.create_view(&Default::default());
    let depth = tex(
        "depth",
        DEPTH,
        samples,
        wgpu::TextureUsages::RENDER_ATTACHMENT,
    )
    .create_view(&Default::default());
    let padded_row = (4 * width).div_ceil(256) * 256;
    let readback = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size: padded_row as u64 * height as u64,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    Targets {
        width,
        height,
        msaa,
        resolve,
        resolve_view,
        depth,
        readback,
        padded_row,
        samples,
    }
}
