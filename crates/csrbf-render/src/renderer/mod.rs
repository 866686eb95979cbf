//! The wgpu renderer, split by operation: `setup` (device, pipelines,
//! targets), `upload` (meshes, lines, per-picture constants), `draw` (the
//! render pass) and `readback` (a picture back into memory).
//!
//! Headless ([`Renderer::new`]) it picks the system's adapter: a GPU, or
//! Mesa's lavapipe on the CPU, and [`Renderer::render`] reads each picture
//! back. An interactive app builds it on its own device and queue
//! ([`Renderer::on_device`]) and draws into a texture of its own with
//! [`Renderer::draw_into`], with no read-back.

use bytemuck::{Pod, Zeroable};
use glam::{Vec2, Vec3};

pub use csrbf_anim::Camera;

use crate::image::Image;
use crate::{RenderError, Result};

mod draw;
mod readback;
mod setup;
mod upload;

/// The colour format of headless pictures.
pub(crate) const COLOR: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;
pub(crate) const DEPTH: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
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

/// A mesh to draw: per-vertex attributes and parts, borrowed from whoever
/// holds them (a scene frame, the studio's document): nothing is copied but
/// into GPU buffers.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DrawMesh<'a> {
    /// Positions in world space.
    pub positions: &'a [Vec3],
    /// Normals in world space.
    pub normals: &'a [Vec3],
    /// Texture coordinates (zeros when empty).
    pub uvs: &'a [Vec2],
    /// Vertex colours, linear RGBA (white when empty).
    pub colors: &'a [[f32; 4]],
    /// Parts.
    pub parts: &'a [DrawPart],
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

/// Everything one picture shows; meshes are borrowed.
#[derive(Clone, Debug, PartialEq)]
pub struct View<'a> {
    /// Camera.
    pub camera: Camera,
    /// Up to four lights.
    pub lights: Vec<Light>,
    /// Background, linear RGB.
    pub background: [f32; 3],
    /// Meshes.
    pub meshes: Vec<DrawMesh<'a>>,
    /// Lines drawn with depth test (wireframe, scenery).
    pub lines: Vec<Line>,
    /// Lines drawn on top of everything (control-vector overlay).
    pub overlay: Vec<Line>,
    /// Options.
    pub options: DrawOptions,
}

impl View<'_> {
    /// The same view (camera, lights, lines, options) over other meshes.
    pub fn with_meshes<'b>(&self, meshes: Vec<DrawMesh<'b>>) -> View<'b> {
        View {
            camera: self.camera,
            lights: self.lights.clone(),
            background: self.background,
            meshes,
            lines: self.lines.clone(),
            overlay: self.overlay.clone(),
            options: self.options,
        }
    }
}

/// A texture uploaded to the renderer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct TextureId(pub(crate) usize);

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

/// A renderer of a fixed picture size (see [`Renderer::resize`]).
pub struct Renderer {
    device: wgpu::Device,
    queue: wgpu::Queue,
    adapter_name: String,
    pipes: setup::Pipelines,
    textures: Vec<wgpu::TextureView>,
    targets: setup::Targets,
    readback: Option<readback::Readback>,
    samples: u32,
    cache: Vec<upload::MeshSlot>,
}

impl Renderer {
    /// Largest side accepted, in pixels.
    pub const MAX_SIDE: u32 = csrbf_anim::MAX_SIDE;

    /// A renderer for pictures of `width` x `height`. Picks the system's
    /// adapter (a GPU, or lavapipe on the CPU); `WGPU_BACKEND` can force one.
    pub fn new(width: u32, height: u32) -> Result<Renderer> {
        Renderer::with_samples(width, height, DEFAULT_SAMPLES)
    }

    /// A renderer with `samples` per pixel (1 or 4): 4 smooths edges, 1 is
    /// faster on a software rasteriser.
    pub fn with_samples(width: u32, height: u32, samples: u32) -> Result<Renderer> {
        check_size(width, height)?;
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let adapter =
            pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions::default()))
                .map_err(|e| RenderError::NoAdapter(e.to_string()))?;
        let info = adapter.get_info();
        let (device, queue) =
            pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor::default()))
                .map_err(|e| RenderError::NoAdapter(e.to_string()))?;
        let mut r = Renderer::on_device(device, queue, COLOR, width, height, samples)?;
        r.adapter_name = format!("{} ({:?})", info.name, info.backend);
        Ok(r)
    }

    /// A renderer on a device and queue the caller owns (an eframe app's),
    /// drawing into textures of `format` (an sRGB format keeps colours as in
    /// headless pictures) of `width` x `height`, with `samples` per pixel
    /// (1 or 4).
    pub fn on_device(
        device: wgpu::Device,
        queue: wgpu::Queue,
        format: wgpu::TextureFormat,
        width: u32,
        height: u32,
        samples: u32,
    ) -> Result<Renderer> {
        check_size(width, height)?;
        let samples = if samples >= 4 { 4 } else { 1 };
        let pipes = setup::Pipelines::new(&device, &queue, format, samples);
        let targets = setup::Targets::new(&device, format, width, height, samples);
        Ok(Renderer {
            device,
            queue,
            adapter_name: "the caller's device".into(),
            pipes,
            textures: Vec::new(),
            targets,
            readback: None,
            samples,
            cache: Vec::new(),
        })
    }

    /// The adapter in use, e.g. "llvmpipe (LLVM 15.0.6, 256 bits) (Vulkan)".
    pub fn adapter(&self) -> &str {
        &self.adapter_name
    }

    /// Picture size.
    pub fn size(&self) -> (u32, u32) {
        (self.targets.width, self.targets.height)
    }

    /// The colour format it draws in.
    pub fn format(&self) -> wgpu::TextureFormat {
        self.pipes.format
    }

    /// The device it draws with.
    pub fn device(&self) -> &wgpu::Device {
        &self.device
    }

    /// The queue it submits to.
    pub fn queue(&self) -> &wgpu::Queue {
        &self.queue
    }

    /// Changes the picture size.
    pub fn resize(&mut self, width: u32, height: u32) -> Result<()> {
        check_size(width, height)?;
        if (width, height) != self.size() {
            self.targets =
                setup::Targets::new(&self.device, self.pipes.format, width, height, self.samples);
            self.readback = None;
        }
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
        self.textures.push(setup::upload_texture(
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
        let (w, h) = self.size();
        let rb = match self.readback.take() {
            Some(rb) => rb,
            None => readback::Readback::new(&self.device, self.pipes.format, w, h),
        };
        let mut enc = self.encode(view, &rb.view);
        rb.copy(&mut enc);
        self.queue.submit([enc.finish()]);
        let img = rb.read(&self.device);
        self.readback = Some(rb);
        img
    }

    /// Draws the view into `target`, a texture view of [`Renderer::format`]
    /// and [`Renderer::size`] that the caller owns, and submits the work;
    /// nothing is read back (the interactive path).
    pub fn draw_into(&mut self, view: &View, target: &wgpu::TextureView) {
        let enc = self.encode(view, target);
        self.queue.submit([enc.finish()]);
    }
}

fn check_size(width: u32, height: u32) -> Result<()> {
    if width == 0 || height == 0 || width > Renderer::MAX_SIDE || height > Renderer::MAX_SIDE {
        return Err(RenderError::BadSize { width, height });
    }
    Ok(())
}
