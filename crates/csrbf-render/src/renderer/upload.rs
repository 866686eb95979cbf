//! Uploading: vertices and parts of each mesh slot (kept between pictures),
//! wireframe and overlay lines, and the per-picture constants.

use glam::{Mat4, Vec2, Vec3};
use wgpu::util::DeviceExt;

use super::{DrawMesh, Globals, Line, LineVertex, PartUniform, Renderer, Vertex, View};

/// GPU buffers of one mesh slot of a view, kept between pictures.
#[derive(Default)]
pub(super) struct MeshSlot {
    pub(super) key: u64,
    pub(super) vb: Option<wgpu::Buffer>,
    pub(super) vbytes: u64,
    pub(super) parts: Vec<(wgpu::Buffer, u32, wgpu::BindGroup)>,
}

/// Edges of every part's triangles, for the wireframe.
pub(super) fn wire_lines(m: &DrawMesh, all: bool, wire: &mut Vec<LineVertex>) {
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

/// Line vertices of `lines`, in a new vertex buffer (None when empty).
pub(super) fn line_buffer(device: &wgpu::Device, lines: &[Line]) -> Option<(wgpu::Buffer, u32)> {
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
    vertex_buffer(device, "lines", &v)
}

/// A vertex buffer of line vertices (None when empty).
pub(super) fn vertex_buffer(
    device: &wgpu::Device,
    label: &str,
    v: &[LineVertex],
) -> Option<(wgpu::Buffer, u32)> {
    (!v.is_empty()).then(|| {
        (
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: bytemuck::cast_slice(v),
                usage: wgpu::BufferUsages::VERTEX,
            }),
            v.len() as u32,
        )
    })
}

/// The per-picture constants: camera, lights, shading.
pub(super) fn globals(view: &View, width: u32, height: u32) -> Globals {
    let c = view.camera;
    let aspect = width as f32 / height as f32;
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
    g
}

/// Near and far planes that hold everything drawn.
fn near_far(view: &View) -> (f32, f32) {
    let eye = view.camera.eye;
    let mut far: f32 = 0.0;
    for m in &view.meshes {
        for p in m.positions {
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

impl Renderer {
    /// Writes a mesh's vertices into its slot; rebuilds the slot's index
    /// buffers and part bindings unless `m.key` says they are unchanged.
    pub(super) fn upload_mesh(&self, slot: &mut MeshSlot, m: &DrawMesh) {
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
        for p in m.parts {
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
                layout: &self.pipes.part_layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: ub.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::TextureView(
                            tex.unwrap_or(&self.pipes.white),
                        ),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: wgpu::BindingResource::Sampler(&self.pipes.sampler),
                    },
                ],
            });
            slot.parts.push((ib, (idx.len() / 3 * 3) as u32, group));
        }
    }
}
