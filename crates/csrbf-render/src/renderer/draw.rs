//! Drawing: one render pass of the surfaces, then scenery lines, the
//! wireframe and the overlay, into a colour target (through the
//! multisampled one when there is one).

use super::upload::{MeshSlot, globals, line_buffer, vertex_buffer, wire_lines};
use super::{LineVertex, Renderer, View};

impl Renderer {
    /// Uploads what the view needs and records its pass into `color`.
    pub(super) fn encode(
        &mut self,
        view: &View,
        color: &wgpu::TextureView,
    ) -> wgpu::CommandEncoder {
        let (w, h) = self.size();
        let g = globals(view, w, h);
        self.queue
            .write_buffer(&self.pipes.globals, 0, bytemuck::bytes_of(&g));

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
        let scenery = line_buffer(&self.device, &view.lines);
        let overlay = line_buffer(&self.device, &view.overlay);
        let wire_buf = vertex_buffer(&self.device, "wire", &wire);

        let mut enc = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("frame"),
            });
        {
            let bg = view.background;
            let (target, resolve) = match &self.targets.msaa {
                Some(msaa) => (msaa, Some(color)),
                None => (color, None),
            };
            let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("frame"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: target,
                    depth_slice: None,
                    resolve_target: resolve,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color {
                            r: bg[0] as f64,
                            g: bg[1] as f64,
                            b: bg[2] as f64,
                            a: 1.0,
                        }),
                        store: if resolve.is_some() {
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
            pass.set_bind_group(0, &self.pipes.globals_group, &[]);
            pass.set_pipeline(&self.pipes.mesh_pipeline);
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
                (&self.pipes.line_pipeline, &scenery),
                (&self.pipes.wire_pipeline, &wire_buf),
                (&self.pipes.overlay_pipeline, &overlay),
            ] {
                if let Some((b, n)) = buf {
                    pass.set_pipeline(pipeline);
                    pass.set_vertex_buffer(0, b.slice(..));
                    pass.draw(0..*n, 0..1);
                }
            }
        }
        enc
    }
}
