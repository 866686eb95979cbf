//! Reading a picture back: a single-sample texture the pass resolves into,
//! copied into a mappable buffer with rows padded to 256 bytes.

use crate::image::Image;
use crate::{RenderError, Result};

/// The texture a headless picture is drawn into and the buffer it is read through.
pub(super) struct Readback {
    texture: wgpu::Texture,
    pub(super) view: wgpu::TextureView,
    buffer: wgpu::Buffer,
    padded_row: u32,
    width: u32,
    height: u32,
}

impl Readback {
    pub(super) fn new(
        device: &wgpu::Device,
        format: wgpu::TextureFormat,
        width: u32,
        height: u32,
    ) -> Readback {
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("picture"),
            size: wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let view = texture.create_view(&Default::default());
        let padded_row = (4 * width).div_ceil(256) * 256;
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size: padded_row as u64 * height as u64,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Readback {
            texture,
            view,
            buffer,
            padded_row,
            width,
            height,
        }
    }

    /// Records the copy of the picture into the buffer.
    pub(super) fn copy(&self, enc: &mut wgpu::CommandEncoder) {
        enc.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture: &self.texture,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &self.buffer,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(self.padded_row),
                    rows_per_image: Some(self.height),
                },
            },
            wgpu::Extent3d {
                width: self.width,
                height: self.height,
                depth_or_array_layers: 1,
            },
        );
    }

    /// Waits for the copy and returns the picture (RGBA8, rows from the top;
    /// a BGRA target is swizzled back to RGBA).
    pub(super) fn read(&self, device: &wgpu::Device) -> Result<Image> {
        let (w, h) = (self.width, self.height);
        let slice = self.buffer.slice(..);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        device
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
                let s = row * self.padded_row as usize;
                rgba.extend_from_slice(&data[s..s + 4 * w as usize]);
            }
        }
        self.buffer.unmap();
        if matches!(
            self.texture.format(),
            wgpu::TextureFormat::Bgra8Unorm | wgpu::TextureFormat::Bgra8UnormSrgb
        ) {
            for px in rgba.chunks_exact_mut(4) {
                px.swap(0, 2);
            }
        }
        Ok(Image {
            width: w,
            height: h,
            rgba,
        })
    }
}
