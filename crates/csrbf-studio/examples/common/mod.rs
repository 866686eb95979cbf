//! What the studio's examples share: medians, milliseconds, and a texture
//! to draw into.

use std::time::Duration;

use csrbf_render::SceneRenderer;

/// The middle value (the upper one of an even count).
pub fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Milliseconds.
pub fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

/// A texture of the picture's size to draw into (not every example draws).
#[allow(dead_code)]
pub fn target(sr: &SceneRenderer) -> wgpu::TextureView {
    let r = sr.renderer();
    let (w, h) = r.size();
    r.device()
        .create_texture(&wgpu::TextureDescriptor {
            label: Some("bench target"),
            size: wgpu::Extent3d {
                width: w,
                height: h,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: r.format(),
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        })
        .create_view(&Default::default())
}
